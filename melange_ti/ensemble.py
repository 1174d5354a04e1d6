"""``melange-ti ensemble``: seeds x swept parameter values on a Dask cluster (docs/cli.md).

Plan, validate, then run:

1. ``--set KEY=V1,V2,...`` lists are swept (Cartesian product over all listed keys, in the
   order given), a value without a top-level comma is a plain override; seeds are 1..K.
   Keys can move together instead: ``--set K1,K2=V1,V2,...`` gives the listed keys each
   value at once, and ``--zip K1,K2`` pairs the i-th values of their own ``--set`` lists
   (of equal length); a group is one factor of the product (:func:`plan`).
   Every run's scene (overrides plus ``time.seed``) is validated before anything starts, and
   existing files in DIR are classified: finished (the file's ``complete`` attribute) -> skipped;
   unfinished with a checkpoint -> resumed; unfinished without one (or unreadable) ->
   overwritten. A file holding a *different* scene's results is refused up front.
   Input problems raise :class:`~melange_ti.scene.SceneError` or
   :class:`~melange_ti.errors.RunError` (one line, exit status 2), and no file is written.
2. ``DIR/ensemble.json`` lists every run (file, seed, overrides); it is rewritten at the
   end with each run's status.
3. The runs go to Dask workers: a ``LocalCluster`` of spawned single-threaded worker
   processes, or an existing cluster (``--scheduler``, connected before anything is
   written: one that does not answer within :data:`CONNECT_SECONDS` is a RunError, and DIR
   is left as it was). A task receives the scene *text*,
   the overrides and the absolute output path (remote workers need DIR on a shared file
   system, but not the scene file), initialises Taichi in its own process with one thread
   and runs :class:`~melange_ti.simulation.Simulation`. Output is bit-identical to
   ``melange-ti run`` of the same scene and seed (results do not depend on thread count).
4. A failed run does not stop the others: each failure is printed as one line at the end
   and the exit status is 3; otherwise 0.
5. However the command ends (done, an error, Ctrl-C, SIGTERM), the local cluster is shut
   down and its worker processes are gone (:class:`_Stopping`, :func:`_reap`); Ctrl-C exits
   with 130 and SIGTERM with 143, the manifest rewritten, the finished runs kept and the
   unfinished ones left to resume from their checkpoints.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import itertools
import json
import logging
import math
import os
import re
import signal
import sys
import threading
import time as wallclock
import traceback
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import scene as scn
from .version import __version__

MANIFEST = "ensemble.json"
EXIT_OK, EXIT_FAILED = 0, 3
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143  # 128 + SIGINT, 128 + SIGTERM, as a shell reports them
SEED_KEY = "time.seed"
CONNECT_SECONDS = 5  # --scheduler: how long to wait for it (Dask's default: 30 s)


# ---------------------------------------------------------------------------- planning
@dataclass(frozen=True)
class Axis:
    """One ``--set`` key and its values (one value: a plain override).

    ``together``: the keys (in ``--set`` order, this one among them) whose i-th values go
    into one run, from ``--set K1,K2=...`` or ``--zip K1,K2``; empty when the key varies on
    its own (every combination with the other keys)."""

    key: str
    values: tuple
    texts: tuple[str, ...]
    together: tuple[str, ...] = ()

    @property
    def swept(self) -> bool:
        return len(self.values) > 1


@dataclass
class RunSpec:
    """One run of the ensemble."""

    file: str  # file name inside DIR
    seed: int
    overrides: list[tuple[str, Any]]  # every --set override, in order (without time.seed)
    swept: list[tuple[str, Any]]  # the swept subset (names the file)
    action: str = "fresh"  # fresh | overwrite | resume | skip
    status: str = "pending"  # pending | complete | skipped | failed
    error: str | None = None
    trace: str | None = None  # worker traceback of a failed run (manifest only)
    summary: dict = field(default_factory=dict)

    def describe(self) -> str:
        parts = [f"seed {self.seed}"] + [f"{k}={_json_value(v)}" for k, v in self.swept]
        return f"{self.file} ({', '.join(parts)})"


def split_values(text: str) -> list[str]:
    """Split ``text`` at commas outside brackets, braces and quotes.

    ``"12,28,60"`` -> three values; ``'["gravity", "drag"]'`` and ``'"a,b"'`` -> one value;
    ``'["gravity"],["gravity","drag"]'`` -> two list values.
    """
    parts, depth, quote, start, i = [], 0, None, 0, 0
    while i < len(text):
        ch = text[i]
        if quote is not None:
            if ch == "\\" and quote == '"':
                i += 1
            elif ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth = max(0, depth - 1)
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
        i += 1
    parts.append(text[start:])
    return [p.strip() for p in parts]


def parse_sweep(items: list[str] | None, zips: list[str] | None = None) -> list[Axis]:
    """``--set`` and ``--zip`` -> one :class:`Axis` per key, in ``--set`` order.

    ``"contacts.discs=12,28"``: a key and its values (one value: a plain override).
    ``"physics.tensile_strength,physics.shear_strength=0.1,0.2"``: the listed keys take each
    value together. ``zips`` (``--zip K1,K2,...``): keys given with ``--set`` lists of equal
    length whose i-th values go together. Every other swept key varies on its own.
    """
    axes: list[Axis] = []
    seen: set[str] = set()
    groups: list[tuple[str, tuple[str, ...]]] = []  # (what the user wrote, keys moving together)
    given = []  # (what the user wrote, its keys, values and their texts)
    for item in items or []:
        if "=" not in item:
            raise scn.SceneError(f"--set {item!r}: expected SECTION.KEY=VALUE or SECTION.KEY=V1,V2,...")
        head, text = item.split("=", 1)
        keys = [k.strip() for k in head.split(",")]
        if any(not k for k in keys):
            raise scn.SceneError(f"--set {item!r}: empty key in {head.strip()!r} (keys that move together: K1,K2=V1,V2,...)")
        for key in keys:
            if key == SEED_KEY:
                raise scn.SceneError(f"--set {item!r}: {SEED_KEY} is set by --seeds (runs use seeds 1..K)")
            if key in seen:
                raise scn.SceneError(f"--set {item!r}: {key} is given more than once (list its values in one --set)")
            seen.add(key)
        texts = split_values(text.strip())
        if len(texts) > 1 and any(t == "" for t in texts):
            raise scn.SceneError(f"--set {item!r}: empty value in the list")
        values = tuple(scn.parse_value(t) for t in texts)
        given.append((f"--set {item!r}", keys, values, texts))
        axes.extend(Axis(key, values, tuple(texts)) for key in keys)
        if len(keys) > 1:
            groups.append((f"--set {item!r}", tuple(keys)))
    by_key = {a.key: a for a in axes}
    for item in zips or []:
        where = f"--zip {item!r}"
        keys = [k.strip() for k in item.split(",")]
        if len(keys) < 2 or any(not k for k in keys):
            raise scn.SceneError(
                f"{where}: name two or more keys given with --set, e.g. --zip physics.tensile_strength,physics.shear_strength"
            )
        for i, key in enumerate(keys):
            if key in keys[:i]:
                raise scn.SceneError(f"{where}: {key} is named twice")
            if key not in by_key:
                hint = " (the seeds are --seeds)" if key == SEED_KEY else f" (give its values with --set {key}=V1,V2,...)"
                raise scn.SceneError(f"{where}: {key} is not given with --set{hint}")
            other = next((g for _, g in groups if key in g), None)
            if other is not None:
                raise scn.SceneError(
                    f"{where}: {key} already moves with {', '.join(k for k in other if k != key)} (a key is in one group)"
                )
        counts = [len(by_key[k].values) for k in keys]
        if len(set(counts)) > 1:
            sizes = ", ".join(f"{k} has {n} value{'s' if n != 1 else ''}" for k, n in zip(keys, counts, strict=True))
            raise scn.SceneError(f"{where}: {sizes}; keys that move together need lists of equal length")
        rows = list(zip(*(by_key[k].values for k in keys), strict=True))
        labels = [
            ", ".join(f"{k}={t}" for k, t in zip(keys, row, strict=True))
            for row in zip(*(by_key[k].texts for k in keys), strict=True)
        ]
        _distinct(where, rows, labels)
        groups.append((where, tuple(keys)))
    zipped = {k for where, g in groups if where.startswith("--zip") for k in g}
    for where, keys, values, texts in given:  # a key in a --zip may repeat a value (its rows differ)
        if not zipped.intersection(keys):
            _distinct(where, [(v,) for v in values], texts)
    order = {a.key: i for i, a in enumerate(axes)}
    together = {k: tuple(sorted(g, key=order.__getitem__)) for _, g in groups for k in g}
    return [Axis(a.key, a.values, a.texts, together.get(a.key, ())) for a in axes]


def _distinct(where: str, rows: list[tuple], labels: list[str]) -> None:
    """Refuse a value (or a row of values moving together) listed twice."""
    for a in range(len(rows)):
        for b in range(a):
            if all(_same(x, y) for x, y in zip(rows[a], rows[b], strict=True)):
                what = f"value {labels[a]}" if len(rows[a]) == 1 else f"row {a + 1} ({labels[a]})"
                raise scn.SceneError(f"{where}: {what} is listed twice")


def _same(a: Any, b: Any) -> bool:
    return type(a) is type(b) and a == b


def _json_value(v: Any) -> str:
    return json.dumps(v, default=str)


def _token(v: Any) -> str:
    """A value as a file-name fragment (before sanitising)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, list):
        return "+".join(_token(x) for x in v) or "empty"
    return str(v)


def _sanitize(text: str, limit: int = 40) -> str:
    """Only ``[A-Za-z0-9.+-]``: no path separators, and ``_``/``=`` stay unambiguous."""
    out = re.sub(r"[^A-Za-z0-9.+-]+", "-", text).strip("-.")
    if not out:
        out = "x"
    if len(out) > limit:
        out = out[: limit - 7] + "~" + hashlib.sha1(text.encode()).hexdigest()[:6]
    return out


def _labels(axes: list[Axis]) -> dict[str, tuple[str, list[str]]]:
    """For each swept key: its label in file names and one token per value (one token per
    distinct value: a key moving with others may repeat a value)."""
    swept = [a for a in axes if a.swept]
    leaves = [a.key.split(".")[-1] for a in swept]
    out = {}
    for axis, leaf in zip(swept, leaves, strict=True):
        label = _sanitize(leaf if leaves.count(leaf) == 1 else axis.key)
        tokens = [_sanitize(_token(v)) for v in axis.values]
        n = len(tokens)
        if any(tokens[a] == tokens[b] and not _same(axis.values[a], axis.values[b]) for a in range(n) for b in range(a)):
            digests = [hashlib.sha1(_json_value(v).encode()).hexdigest()[:6] for v in axis.values]
            tokens = [f"{t}~{d}" for t, d in zip(tokens, digests, strict=True)]
        out[axis.key] = (label, tokens)
    return out


def dimensions(axes: list[Axis]) -> list[list[Axis]]:
    """The axes grouped into what the product runs over: a key on its own, or the keys
    moving together; each at its first key's place in ``--set`` order."""
    dims, placed = [], set()
    for a in axes:
        if a.key not in placed:
            dim = [b for b in axes if b.key in a.together] if a.together else [a]
            placed.update(b.key for b in dim)
            dims.append(dim)
    return dims


def plan(axes: list[Axis], seeds: int) -> list[RunSpec]:
    """Every combination of the swept keys (keys moving together take their i-th values in
    one run), outermost first in ``--set`` order, then the seeds. A file is named by every
    swept key's value in ``--set`` order, then the seed."""
    labels = _labels(axes)
    dims = dimensions(axes)
    runs = []
    for combo in itertools.product(*(range(len(dim[0].values)) for dim in dims)):
        at = {a.key: k for dim, k in zip(dims, combo, strict=True) for a in dim}
        overrides = [(a.key, a.values[at[a.key]]) for a in axes]
        swept = [(a.key, a.values[at[a.key]]) for a in axes if a.swept]
        stem = "_".join(f"{labels[a.key][0]}={labels[a.key][1][at[a.key]]}" for a in axes if a.swept)
        for seed in range(1, seeds + 1):
            name = f"{stem}_seed{seed}.h5" if stem else f"seed{seed}.h5"
            runs.append(RunSpec(file=name, seed=seed, overrides=overrides, swept=swept))
    if len({r.file for r in runs}) != len(runs):  # cannot happen with the labels above; never overwrite a twin
        raise scn.SceneError("--set: the swept values do not give distinct file names")
    return runs


def describe(axes: list[Axis], seeds: int, most: int = 6) -> str:
    """The plan in a few words: ``contacts.discs = 12, 28 x seeds 1-8``; keys moving together
    as ``a = b = 0.1, 0.2`` (the same values) or ``(a, b) = (1, 2), (3, 4)``; a long list cut
    after ``most`` values."""

    def listed(items: list[str]) -> str:
        if len(items) > most:
            items = [*items[: most - 1], "...", items[-1], f"({len(items)} values)"]
            return ", ".join(items[:-1]) + " " + items[-1]
        return ", ".join(items)

    parts = []
    for dim in dimensions(axes):
        if not dim[0].swept:
            continue
        if len(dim) == 1:
            parts.append(f"{dim[0].key} = {listed(list(dim[0].texts))}")
        elif all(all(_same(a.values[i], dim[0].values[i]) for a in dim) for i in range(len(dim[0].values))):
            parts.append(f"{' = '.join(a.key for a in dim)} = {listed(list(dim[0].texts))}")
        else:
            rows = [f"({', '.join(row)})" for row in zip(*(a.texts for a in dim), strict=True)]
            parts.append(f"({', '.join(a.key for a in dim)}) = {listed(rows)}")
    parts.append("seed 1" if seeds == 1 else f"seeds 1-{seeds}")
    return " x ".join(parts)


def _scene_text(path: str | None) -> str:
    if path is None:
        return scn.bundled_scene_text("paper")
    p = Path(path)
    try:
        return p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise scn.SceneError(f"scene file {str(p)!r}: not found") from None
    except (IsADirectoryError, PermissionError, UnicodeDecodeError) as exc:
        raise scn.SceneError(f"scene file {str(p)!r}: cannot be read ({exc.__class__.__name__})") from None


def validate(text: str, runs: list[RunSpec], label: str | None) -> dict[str, str]:
    """Build every run's scene (raises SceneError naming the run); returns file -> resolved TOML."""
    resolved = {}
    for r in runs:
        try:
            sc = scn.loads(text, [*r.overrides, (SEED_KEY, r.seed)])
        except scn.SceneError as exc:
            where = f"{label}: " if label else ""
            combo = ", ".join(f"{k}={_json_value(v)}" for k, v in r.swept)
            raise scn.SceneError(f"{where}{exc}" + (f" (in the run with {combo})" if combo else "")) from None
        resolved[r.file] = sc.to_toml()
    first: dict[tuple[str, int], RunSpec] = {}
    for r in runs:  # e.g. 1 and 1.0 for a float key: two files of one scene
        twin = first.setdefault((resolved[r.file], r.seed), r)
        if twin is not r:
            raise scn.SceneError(f"--set: runs {twin.describe()} and {r.describe()} are the same scene; list each value once")
    return resolved


def classify(out_dir: Path, runs: list[RunSpec], resolved: dict[str, str]) -> None:
    """Decide each run's action from what DIR holds; refuse files of a different scene."""
    from .errors import RunError
    from .io.checkpoint import checkpoint_path
    from .io.hdf5 import run_status

    for r in runs:
        path = out_dir / r.file
        ckpt = checkpoint_path(path).exists()
        if not path.exists() and not path.is_symlink():
            r.action = "fresh"
            continue
        state = run_status(path)
        if state is None:  # unreadable (or a directory): cannot be resumed
            r.action = "overwrite"
            continue
        toml, complete = state
        if (complete or ckpt) and toml != resolved[r.file]:
            raise RunError(f"{path}: holds a run of a different scene (or --set values); remove it or use another --out")
        r.action = "skip" if complete else ("resume" if ckpt else "overwrite")


def _last_diagnostics(path: Path) -> dict:
    """Final time, capsized fraction and leading edge recorded in a finished file."""
    from .io.hdf5 import last_row

    return last_row(path, ("capsized_fraction", "leading_edge"))


def write_manifest(out_dir: Path, runs: list[RunSpec], axes: list[Axis], scene_path: str | None, seeds: int, name: str) -> None:
    # "together": the keys whose i-th values went into one run (absent when every swept key varied on its own)
    together = [[a.key for a in dim] for dim in dimensions(axes) if len(dim) > 1 and dim[0].swept]
    doc = {
        "melange_ti_version": __version__,
        "scene": None if scene_path is None else str(Path(scene_path).resolve()),
        "scene_name": name,
        "seeds": list(range(1, seeds + 1)),
        "sweep": {a.key: list(a.values) for a in axes if a.swept},
        **({"together": together} if together else {}),
        "overrides": {a.key: a.values[0] for a in axes if not a.swept},
        "runs": [
            {
                "file": r.file,
                "seed": r.seed,
                "overrides": dict(r.overrides),
                "status": r.status,
                **({"error": r.error} if r.error else {}),
                **({"traceback": r.trace} if r.trace else {}),
                **({"summary": r.summary} if r.summary else {}),
            }
            for r in runs
        ],
    }
    tmp = out_dir / (MANIFEST + ".tmp")
    tmp.write_text(json.dumps(doc, indent=2, default=str) + "\n", encoding="utf-8")
    os.replace(tmp, out_dir / MANIFEST)


# ---------------------------------------------------------------------------- worker side
_PROCESS_LOCK = threading.Lock()  # one Taichi runtime per process: one run at a time


def _ensure_taichi(precision: str, arch: str = "cpu") -> None:
    """Taichi for this worker process: ``arch`` (on the CPU one thread), the scene's precision.

    ``runtime.init`` does nothing when called again with the same settings, so a worker
    that runs many tasks initialises Taichi once (again only if the precision changes).
    """
    from . import runtime

    with contextlib.redirect_stdout(io.StringIO()):  # "[Taichi] Starting on arch=x64" (taichi is imported)
        runtime.init(arch, threads=1 if arch == "cpu" else None, precision=precision)


def run_one(text: str, overrides: list[tuple[str, Any]], seed: int, out: str, action: str, arch: str = "cpu") -> dict:
    """Dask task: one run into ``out`` (``action``: fresh | overwrite | resume).

    Returns ``{"ok": True, **summary}``, or ``{"ok": False, "error": line, "traceback": text}``
    for a run that raised: a failed run is a result, not a Dask error, so the worker logs
    no traceback and the client prints one line per failure.
    """
    try:
        return {"ok": True, **_run_one(text, overrides, seed, out, action, arch)}
    except Exception as exc:
        return {"ok": False, "error": _error_line(exc), "traceback": traceback.format_exc()}


def _run_one(text: str, overrides: list[tuple[str, Any]], seed: int, out: str, action: str, arch: str = "cpu") -> dict:
    with _PROCESS_LOCK:
        # Imported with the real stdout: Taichi decides at import whether to wrap every
        # kernel call in a print-buffer flush (10x slower here) if sys.stdout looks wrapped.
        from .io.checkpoint import checkpoint_path
        from .simulation import Simulation

        sc = scn.loads(text, [*overrides, (SEED_KEY, seed)])
        _ensure_taichi(sc.precision, arch)
        path = Path(out)
        if action == "overwrite":
            stale = checkpoint_path(path)
            if stale.exists():  # never resume later from another file's checkpoint
                stale.unlink()
        sim = Simulation(
            sc, path, overwrite=action == "overwrite", resume=action == "resume", arch=arch, progress=False, announce=False
        )
        s = sim.run()
        return {
            "time": s.time,
            "steps": s.steps,
            "wall_seconds": s.wall_seconds,
            "steps_per_second": s.steps_per_second,
            "capsized_fraction": s.capsized_fraction,
            "leading_edge": s.leading_edge,
            "energy_released": s.energy_released,
            "dissipated": s.dissipated,
            "energy_residual": s.energy_residual,
            "resumed": action == "resume",
            "worker_pid": os.getpid(),
        }


# ---------------------------------------------------------------------------- client side
def _error_line(exc: BaseException) -> str:
    from .errors import ArchError, ContactOverflow, NumericalError, RunError
    from .io.hdf5 import OutputError

    text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    if isinstance(exc, (scn.SceneError, RunError, ArchError, NumericalError, ContactOverflow, OutputError)):
        return text or exc.__class__.__name__
    return f"{exc.__class__.__name__}: {text}" if text else exc.__class__.__name__


def dask_setup(worker) -> None:
    """Dask's preload hook, run in each local worker process as it starts: SIGINT ignored.
    Ctrl-C at a terminal reaches every process of its group; a worker interrupted in the
    middle of its own shutdown races its nanny's and both log tracebacks. The client alone
    handles it (it closes the cluster; a run stopped there resumes from its checkpoint)."""
    import signal

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


# ---------------------------------------------------------------------------- stopping
class Terminated(KeyboardInterrupt):
    """SIGTERM: the ensemble stops as after Ctrl-C (its cluster shut down, the manifest
    written, the finished runs kept, the unfinished ones left to resume), with status 143."""


class _Stopping:
    """SIGINT and SIGTERM while ``melange-ti ensemble`` runs (handled in the main thread only).

    The first signal raises KeyboardInterrupt (SIGINT) or :class:`Terminated` (SIGTERM) in
    the main thread, and the cluster is shut down as the ``with`` blocks unwind. While the
    local cluster starts, a signal waits until it is up (one stopped half-started would leave
    its workers to themselves). A second signal while the first is handled does not wait for
    the shutdown: it kills this process's new child processes and exits at once."""

    def __init__(self) -> None:
        self.first: int | None = None  # the first signal received
        self.holding = False  # the local cluster is starting
        self.held: int | None = None  # the signal received meanwhile
        self.before: set[int] = set()  # child processes before the ensemble began

    @contextlib.contextmanager
    def installed(self):
        if threading.current_thread() is not threading.main_thread():  # signals go to the main thread
            yield
            return
        self.first, self.held, self.before = None, None, _descendants()
        previous = {sig: signal.signal(sig, self._handle) for sig in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
            self.first = self.held = None

    @contextlib.contextmanager
    def starting(self):
        """Hold a signal while the local cluster starts; raise it once the cluster is up."""
        self.holding = True
        try:
            yield
        finally:
            self.holding = False
        if self.held is not None:
            held, self.held = self.held, None
            raise _exception(held)

    def _handle(self, signum: int, frame) -> None:
        if self.first is not None:
            _reap(self.before, grace=0.0)
            print(
                f"melange-ti: {signal.Signals(signum).name} again: worker processes killed; "
                "run the same command again to resume the unfinished runs",
                file=sys.stderr,
                flush=True,
            )
            os._exit(_status(self.first))
        self.first = signum
        if self.holding:
            self.held = signum
            return
        raise _exception(signum)


def _exception(signum: int) -> KeyboardInterrupt:
    return Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def _status(signum: int) -> int:
    return EXIT_TERMINATED if signum == signal.SIGTERM else EXIT_INTERRUPTED


_STOPPING = _Stopping()


def _descendants() -> set[int]:
    import psutil

    return {p.pid for p in psutil.Process().children(recursive=True)}


def _reap(before: set[int], grace: float = 5.0) -> None:
    """Stop every process below this one that was not there in ``before`` (but Python's
    resource tracker, which ends with this process): SIGTERM, then SIGKILL after ``grace`` s.
    After the cluster's own shutdown this normally finds nothing."""
    import multiprocessing.resource_tracker

    import psutil

    tracker = getattr(multiprocessing.resource_tracker._resource_tracker, "_pid", None)
    left = []
    for p in psutil.Process().children(recursive=True):
        try:
            if p.pid not in before and p.pid != tracker and p.status() != psutil.STATUS_ZOMBIE:
                left.append(p)
        except psutil.NoSuchProcess:
            pass
    for how in ("terminate", "kill") if grace > 0 else ("kill",):
        for p in left:
            with contextlib.suppress(psutil.NoSuchProcess):
                getattr(p, how)()
        _, left = psutil.wait_procs(left, timeout=grace if grace > 0 else 1.0)
        if not left:
            return


def _reachable(scheduler: str) -> None:
    """Open and close a TCP connection to ``scheduler``: a refused port fails at once and a
    silent host within :data:`CONNECT_SECONDS`, where Dask's client retries for 30 s."""
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    scheme, loc = parse_address(scheduler)
    if scheme in ("tcp", "tls"):
        host, port = parse_host_port(loc, 8786)  # Dask's default scheduler port
        with socket.create_connection((host or "localhost", port), timeout=CONNECT_SECONDS):
            pass


@contextlib.contextmanager
def _cluster(scheduler: str | None, workers: int):
    """A connected Client: to ``scheduler``, or to a LocalCluster of spawned processes."""
    import dask
    from distributed import Client, LocalCluster

    from .errors import RunError

    # Read whenever a nanny (re)starts a worker process, so it must hold for the whole
    # lifetime: a forked child of a process that ran ti.init hangs (FACTS.md).
    with dask.config.set({"distributed.worker.multiprocessing-method": "spawn"}):
        assert dask.config.get("distributed.worker.multiprocessing-method") == "spawn"
        if scheduler:
            try:
                _reachable(scheduler)
                client = Client(scheduler, timeout=CONNECT_SECONDS)
            except Exception as exc:  # Dask raises anything from a peer that is not a scheduler
                raise RunError(f"--scheduler {scheduler}: cannot connect ({_error_line(exc)})") from None
            try:
                yield client, f"scheduler {scheduler}"
            finally:
                client.close()
            return
        before = _descendants()
        try:
            with contextlib.ExitStack() as stack:
                with _STOPPING.starting():  # a signal now stops the cluster once it is up
                    cluster = LocalCluster(
                        n_workers=workers,
                        threads_per_worker=1,
                        processes=True,
                        # the scheduler's HTTP server on a free port: Dask's 8787 is taken by a second
                        # ensemble running beside this one, and Dask then warns in the ensemble's output
                        dashboard_address=":0",
                        # Dask's warnings are noise here: an interrupt's shutdown ("Worker process still
                        # alive after 4.0 seconds, killing", a cancelled task), an event loop blocked while a
                        # kernel holds the GIL. Failures are reported per run, and Dask's errors still print.
                        silence_logs=logging.ERROR,
                        preload=["melange_ti.ensemble"],  # dask_setup: the workers leave Ctrl-C to the client
                        # No import banner; never Taichi's print buffer (see run_one).
                        env={"ENABLE_TAICHI_HEADER_PRINT": "0", "TI_ENABLE_PYBUF": "0"},
                    )
                    stack.callback(cluster.close)
                    client = Client(cluster)
                    stack.callback(client.close)
                yield client, f"{workers} local worker{'s' if workers != 1 else ''}"
        finally:
            # However the block ends (done, an error, Ctrl-C, SIGTERM), no worker outlives it:
            # the cluster's close stops its workers (killed after a few seconds); any left is killed here
            _reap(before)


def _run_all(client, text: str, out_dir: Path, todo: list[RunSpec], workers: int, arch: str = "cpu") -> None:
    from distributed import as_completed

    tag = uuid.uuid4().hex[:8]
    futures = {}
    for r in todo:
        args = (text, r.overrides, r.seed, str(out_dir / r.file), r.action, arch)
        fut = client.submit(run_one, *args, key=f"melange-ti-{r.file}-{tag}", pure=False, retries=0)
        futures[fut] = r
    bar = None
    if sys.stderr.isatty():
        from tqdm import tqdm

        bar = tqdm(total=len(todo), unit="run", dynamic_ncols=True, file=sys.stderr)
    done = 0
    failed = 0
    try:
        for fut in as_completed(futures):
            r = futures[fut]
            done += 1
            res = fut.result() if fut.status == "finished" else None
            if res is not None and res.pop("ok"):
                r.status, r.summary = "complete", res
                msg = f"[{done}/{len(todo)}] {r.file}: done in {res['wall_seconds']:.1f} s"
                if done == 1 and len(todo) > 1:
                    msg += "; " + estimate(res["wall_seconds"], len(todo) - 1, workers)
            else:
                if res is not None:  # the run raised inside the task
                    r.error, r.trace = res["error"], res["traceback"]
                else:  # the task itself failed: worker died (KilledWorker), not importable, ...
                    try:
                        exc = fut.exception()
                    except KeyboardInterrupt:  # Ctrl-C or SIGTERM (Terminated) just then: not this run's error
                        raise
                    except BaseException as cancelled:  # CancelledError when the cluster went away
                        exc = cancelled
                    r.error = _error_line(exc)
                r.status = "failed"
                failed += 1
                msg = f"[{done}/{len(todo)}] {r.file}: FAILED ({r.error})"
            if bar is not None:
                bar.set_postfix(failed=failed)
                bar.update(1)
                bar.write(msg, file=sys.stderr)
            else:
                print(msg, file=sys.stderr, flush=True)
    except KeyboardInterrupt:
        # Ctrl-C: what Dask logs while it shuts down (a nanny's traceback when its worker
        # went first, a cancelled task) is no news; main() says how to resume, and ends the quiet
        logging.disable(logging.CRITICAL)
        raise
    finally:
        if bar is not None:
            bar.close()
        for fut in futures:
            fut.cancel()


def estimate(first: float, left: int, workers: int) -> str:
    """The time the ``left`` runs should take on ``workers``, from the first run's ``first`` s.

    The first round's other runs started with the first one and end about when it did; the
    rest go ``workers`` at a time, ~``first`` s a round."""
    running = min(left, max(1, workers) - 1)
    rounds = math.ceil((left - running) / max(1, workers))
    if rounds == 0:
        return f"the other {left} started with it and should finish about now"
    total = rounds * first
    when = f"{total / 60:.0f} min" if total >= 120 else f"{total:.0f} s"
    now = f"{running} running now, then " if running else ""
    return f"the other {left} should take about {when} ({now}{rounds} round{'s' if rounds != 1 else ''} of ~{first:.0f} s)"


def _fmt(v: Any, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def report(runs: list[RunSpec], out_dir: Path, where: str, wall: float) -> None:
    ran = sum(r.status == "complete" for r in runs)
    skipped = sum(r.status == "skipped" for r in runs)
    failed = [r for r in runs if r.status == "failed"]
    width = max(len(r.file) for r in runs)
    print(f"ensemble: {len(runs)} runs in {out_dir}: {ran} ran, {skipped} already complete, {len(failed)} failed")
    for r in runs:
        s = r.summary
        if r.status == "failed":
            tail = "FAILED"
        else:
            if r.status == "skipped":
                note = "already complete"
            else:
                note = ("resumed, " if s.get("resumed") else "") + f"{s.get('wall_seconds', 0):.1f} s"
            tail = (
                f"t = {_fmt(s.get('time'), 'g')}, capsized fraction {_fmt(s.get('capsized_fraction'), '.3f')}, "
                f"leading edge {_fmt(s.get('leading_edge'), '.3f')} widths ({note})"
            )
        print(f"  {r.file:<{width}}  {tail}")
    print(f"total wall time {wall:.1f} s ({where})")
    for r in failed:
        print(f"melange-ti: error: run {r.describe()} failed: {r.error}", file=sys.stderr)


def main(args) -> int:
    """The ``ensemble`` subcommand; returns the exit status: 0, 3 if any run failed, 130 after
    Ctrl-C (SIGINT), 143 after SIGTERM (bad input raises: status 2). However it ends, its
    local cluster is shut down and no worker process is left running."""
    with _STOPPING.installed():
        try:
            return _main(args)
        except KeyboardInterrupt as exc:  # before anything was written, or after the manifest was
            return _stopped(exc)


def _stopped(exc: KeyboardInterrupt) -> int:
    """The one line after Ctrl-C or SIGTERM; the status."""
    logging.disable(logging.NOTSET)
    if isinstance(exc, Terminated):
        print(
            "melange-ti: terminated (SIGTERM); the cluster is shut down and the finished runs kept: "
            "run the same command again to resume the unfinished runs",
            file=sys.stderr,
        )
        return EXIT_TERMINATED
    print("melange-ti: interrupted; run the same command again to resume the unfinished runs", file=sys.stderr)
    return EXIT_INTERRUPTED


def _main(args) -> int:
    from .errors import RunError

    t0 = wallclock.perf_counter()
    if args.seeds < 1:
        raise scn.SceneError(f"--seeds = {args.seeds}: must be >= 1")
    if args.workers is not None and args.workers < 1:
        raise scn.SceneError(f"--workers = {args.workers}: must be >= 1")
    if args.workers is not None and args.scheduler:
        raise scn.SceneError("--workers sizes the local cluster; it cannot be combined with --scheduler")
    out_dir = Path(args.out).resolve()
    if out_dir.exists() and not out_dir.is_dir():
        raise RunError(f"--out {args.out}: exists and is not a directory")

    text = _scene_text(args.scene)
    axes = parse_sweep(args.set, getattr(args, "zip", None))
    runs = plan(axes, args.seeds)
    resolved = validate(text, runs, args.scene)
    name = scn.loads(text, [*runs[0].overrides, (SEED_KEY, 1)]).name
    if args.arch != "cpu":  # an unusable device is refused before anything starts
        from . import runtime

        for precision in sorted({scn.loads(text, [*r.overrides, (SEED_KEY, 1)]).precision for r in runs}):
            runtime.probe(args.arch, precision)
        if runtime.software_device(args.arch):
            print(f"melange-ti: note: --arch {args.arch}: {runtime.software_note(args.arch)}", file=sys.stderr)
    if out_dir.exists():
        classify(out_dir, runs, resolved)
    todo = [r for r in runs if r.action != "skip"]
    where = "nothing to run"
    try:
        with contextlib.ExitStack() as stack:
            if todo and args.scheduler:  # connected first: an unreachable scheduler leaves nothing behind
                client, where = stack.enter_context(_cluster(args.scheduler, 0))
            if not out_dir.exists():
                try:
                    out_dir.mkdir(parents=True)
                except OSError as exc:
                    raise RunError(f"--out {args.out}: cannot create directory ({_error_line(exc)})") from None
            for r in runs:
                if r.action == "skip":
                    r.status, r.summary = "skipped", _last_diagnostics(out_dir / r.file)
            write_manifest(out_dir, runs, axes, args.scene, args.seeds, name)
            if todo:
                workers = min(args.workers or os.cpu_count() or 1, len(todo))
                skipped = len(runs) - len(todo)
                print(
                    f"ensemble: {len(todo)} run{'s' if len(todo) != 1 else ''} to do"
                    + (f" ({skipped} already complete)" if skipped else "")
                    + f" into {out_dir}, on {args.scheduler or f'{workers} local worker' + ('s' if workers != 1 else '')}"
                    + f" ({describe(axes, args.seeds)}); an estimate of the time follows the first run",
                    file=sys.stderr,
                    flush=True,
                )
                if args.scheduler:
                    workers = max(1, len(client.scheduler_info().get("workers", {})))
                else:
                    client, where = stack.enter_context(_cluster(None, workers))
                _run_all(client, text, out_dir, todo, workers, args.arch)
    except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM: the cluster is closed by now
        if (out_dir / MANIFEST).exists():
            write_manifest(out_dir, runs, axes, args.scene, args.seeds, name)
        return _stopped(exc)
    write_manifest(out_dir, runs, axes, args.scene, args.seeds, name)
    report(runs, out_dir, where, wallclock.perf_counter() - t0)
    return EXIT_FAILED if any(r.status == "failed" for r in runs) else EXIT_OK
