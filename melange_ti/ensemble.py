"""``melange-ti ensemble``: seeds x swept parameter values on a Dask cluster (docs/cli.md).

Plan, validate, then run:

1. ``--set KEY=V1,V2,...`` lists are swept (Cartesian product over all listed keys, in the
   order given), a value without a top-level comma is a plain override; seeds are 1..K.
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
import sys
import threading
import time as wallclock
import traceback
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import __version__
from . import scene as scn

MANIFEST = "ensemble.json"
EXIT_OK, EXIT_FAILED = 0, 3
SEED_KEY = "time.seed"
CONNECT_SECONDS = 5  # --scheduler: how long to wait for it (Dask's default: 30 s)


# ---------------------------------------------------------------------------- planning
@dataclass(frozen=True)
class Axis:
    """One ``--set`` key and its values (one value: a plain override)."""

    key: str
    values: tuple
    texts: tuple[str, ...]

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


def parse_sweep(items: list[str] | None) -> list[Axis]:
    """``["contacts.discs=12,28", "time.dt=0.005"]`` -> one :class:`Axis` per key."""
    axes: list[Axis] = []
    seen: set[str] = set()
    for item in items or []:
        if "=" not in item:
            raise scn.SceneError(f"--set {item!r}: expected SECTION.KEY=VALUE or SECTION.KEY=V1,V2,...")
        key, text = item.split("=", 1)
        key = key.strip()
        if key == SEED_KEY:
            raise scn.SceneError(f"--set {item!r}: {SEED_KEY} is set by --seeds (runs use seeds 1..K)")
        if key in seen:
            raise scn.SceneError(f"--set {item!r}: {key} is given more than once (list its values in one --set)")
        seen.add(key)
        texts = split_values(text.strip())
        if len(texts) > 1 and any(t == "" for t in texts):
            raise scn.SceneError(f"--set {item!r}: empty value in the list")
        values = tuple(scn.parse_value(t) for t in texts)
        for a in range(len(values)):
            for b in range(a):
                if _same(values[a], values[b]):
                    raise scn.SceneError(f"--set {item!r}: value {texts[a]} is listed twice")
        axes.append(Axis(key, values, tuple(texts)))
    return axes


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
    """For each swept key: its label in file names and one token per value (unique)."""
    swept = [a for a in axes if a.swept]
    leaves = [a.key.split(".")[-1] for a in swept]
    out = {}
    for axis, leaf in zip(swept, leaves, strict=True):
        label = _sanitize(leaf if leaves.count(leaf) == 1 else axis.key)
        tokens = [_sanitize(_token(v)) for v in axis.values]
        if len(set(tokens)) < len(tokens):  # distinct values, same sanitised text
            digests = [hashlib.sha1(_json_value(v).encode()).hexdigest()[:6] for v in axis.values]
            tokens = [f"{t}~{d}" for t, d in zip(tokens, digests, strict=True)]
        out[axis.key] = (label, tokens)
    return out


def plan(axes: list[Axis], seeds: int) -> list[RunSpec]:
    """Every (swept values, seed) combination, swept keys outermost in --set order."""
    labels = _labels(axes)
    choices = [list(enumerate(a.values)) for a in axes]
    runs = []
    for combo in itertools.product(*choices):
        overrides = [(a.key, v) for a, (_, v) in zip(axes, combo, strict=True)]
        swept = [(a.key, v) for a, (_, v) in zip(axes, combo, strict=True) if a.swept]
        stem = "_".join(f"{labels[a.key][0]}={labels[a.key][1][k]}" for a, (k, _) in zip(axes, combo, strict=True) if a.swept)
        for seed in range(1, seeds + 1):
            name = f"{stem}_seed{seed}.h5" if stem else f"seed{seed}.h5"
            runs.append(RunSpec(file=name, seed=seed, overrides=overrides, swept=swept))
    if len({r.file for r in runs}) != len(runs):  # cannot happen with the labels above; never overwrite a twin
        raise scn.SceneError("--set: the swept values do not give distinct file names")
    return runs


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
    doc = {
        "melange_ti_version": __version__,
        "scene": None if scene_path is None else str(Path(scene_path).resolve()),
        "scene_name": name,
        "seeds": list(range(1, seeds + 1)),
        "sweep": {a.key: list(a.values) for a in axes if a.swept},
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
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            # Dask's warnings are noise here: an interrupt's shutdown ("Worker process still
            # alive after 4.0 seconds, killing", a cancelled task), an event loop blocked while a
            # kernel holds the GIL. Failures are reported per run, and Dask's errors still print.
            silence_logs=logging.ERROR,
            preload=["melange_ti.ensemble"],  # dask_setup: the workers leave Ctrl-C to the client
            # No import banner; never Taichi's print buffer (see run_one).
            env={"ENABLE_TAICHI_HEADER_PRINT": "0", "TI_ENABLE_PYBUF": "0"},
        )
        try:
            client = Client(cluster)
            try:
                yield client, f"{workers} local worker{'s' if workers != 1 else ''}"
            finally:
                client.close()
        finally:
            cluster.close()


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
    """The ``ensemble`` subcommand; returns the exit status (0, or 3 if any run failed)."""
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
    axes = parse_sweep(args.set)
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
                    + f" into {out_dir}, on {args.scheduler or f'{workers} local worker' + ('s' if workers != 1 else '')}; "
                    "an estimate of the time follows the first run",
                    file=sys.stderr,
                    flush=True,
                )
                if args.scheduler:
                    workers = max(1, len(client.scheduler_info().get("workers", {})))
                else:
                    client, where = stack.enter_context(_cluster(None, workers))
                _run_all(client, text, out_dir, todo, workers, args.arch)
    except KeyboardInterrupt:
        logging.disable(logging.NOTSET)
        if (out_dir / MANIFEST).exists():
            write_manifest(out_dir, runs, axes, args.scene, args.seeds, name)
        print("melange-ti: interrupted; run the same command again to resume the unfinished runs", file=sys.stderr)
        return 130
    write_manifest(out_dir, runs, axes, args.scene, args.seeds, name)
    report(runs, out_dir, where, wallclock.perf_counter() - t0)
    return EXIT_FAILED if any(r.status == "failed" for r in runs) else EXIT_OK
