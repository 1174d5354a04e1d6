"""The Simulation: run loop, scheduled outputs, guards and checkpoints; no physics here.

Like Oceananigans' ``Simulation``: the model advances in one call (no host transfer) to the
earliest next event of its outputs' schedules; at an event one packed transfer gives state,
ledgers and energies to every output that is due.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import math
import os
import sys
import time as wallclock
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import tomllib

from . import diagnostics as diag
from .energy import RESIDUAL_TRUSTED, budget_promise, budget_series, budget_verdict, runaway, total_energy, worst  # noqa: F401 (RESIDUAL_TRUSTED: as before)
from .errors import Interrupted, NumericalError, RunError
from .io import checkpoint
from .io.hdf5 import (
    COMPLETE_ATTR,
    FORMAT_VERSION,
    OUTLINE_DISCS,
    OUTLINE_DISCS_ATTR,
    SCENE_ATTR,
    OutputError,
    RunWriter,
    read_diagnostics,
    read_run,
    scene_text,
)
from .model import Model
from .physics.data.schema import BODIES
from .physics.effects import OWNERS
from .physics.stages import SAMPLE_NAMES
from .scene import Icebergs, Scene
from .version import __version__

# Output events between two writes of the model's state run in one launch (Simulation._batch):
# at most this many, and this many bytes of samples
BATCH_MAX = 64
BATCH_BYTES = 32 << 20
# A launch after the first two runs at most the steps this many wall seconds take at the pace of
# the launch before, so Ctrl-C acts within about a second even on a slow device (Simulation.run)
CHECK_SECONDS = 0.5

# How a message names the output, overwriting and resuming: the command line's flags, or
# the arguments of melange_ti.run (Simulation(interface=...))
SPELLINGS = {
    "cli": {"out": "--out", "overwrite": "--overwrite", "resume": "--resume"},
    "api": {"out": "out", "overwrite": "overwrite=True", "resume": "resume=True"},
}


# Run-file formats a resume continues: only this version's. Format 8 reads the energies at the
# step time, the formats before from the state a step leaves: one file mixing the two would
# show the difference as a jump in its budget
RESUMABLE = (FORMAT_VERSION,)

# The one scene key a resume may change: the end, before or after the run's (an extension)
EXTENDABLE = "time.duration"


def scene_changes(old: str, new: str) -> list[str]:
    """The keys (``section.key``; ``iceberg`` for the table list) whose values differ between
    two resolved scene texts (:meth:`Scene.to_toml`); a key one text lacks (written by a version
    before the key existed) counts at its default."""
    a, b, default = _flat(old), _flat(new), _default_keys()
    return sorted(k for k in a.keys() | b.keys() if a.get(k, default.get(k)) != b.get(k, default.get(k)))


def _flat(text: str) -> dict:
    out = {}
    for section, table in tomllib.loads(text).items():
        if isinstance(table, dict):
            out.update({f"{section}.{k}": v for k, v in table.items()})
        else:
            out[section] = table
    return out


@functools.cache
def _default_keys() -> dict:
    from . import scene as scn

    return _flat(scn.load(None).to_toml())


def _doc(text: str):
    """A field with its meaning (docs/api.md's RunSummary table is generated from these)."""
    return field(metadata={"doc": text})


@dataclass(frozen=True)
class RunSummary:
    """What :func:`melange_ti.run` returns (and ``melange-ti run`` prints): how the run went
    and its end state; energies in ``rho_w g w^3`` per unit length, times in ``sqrt(w/g)``."""

    path: Path = _doc("the run file written")
    steps: int = _doc("time steps taken by this call (after a resume: since the checkpoint)")
    wall_seconds: float = _doc("wall-clock seconds of the whole call, start-up included")
    startup_seconds: float = _doc(
        "wall-clock seconds of the first launch: compiling the kernels (or loading them from Taichi's cache) and its "
        "first `startup_steps` steps"
    )
    startup_steps: int = _doc("steps taken in the first launch (timed with the start-up)")
    steps_per_second: float = _doc(
        "stepping speed after the first launch, compiling excluded (NaN when the run was too short to have steps after it)"
    )
    compiled: bool = _doc(
        "true when the first launch compiled kernels, false when it loaded them all from Taichi's cache (as Taichi said: "
        "runtime.watch_compiling)"
    )
    time: float = _doc("simulated time reached")
    capsized_fraction: float = _doc("fraction of icebergs capsized (tilt past 45 degrees) at the end")
    leading_edge: float = _doc("how far the front moved, max x(t) - max x(0), in widths, at the end")
    energy_released: float = _doc("potential energy released, E_p(0) - E_p(t)")
    energy_lost: float = _doc("mechanical energy lost, E(0) - E(t), E = E_k + E_p")
    dissipated: float = _doc("what the energy ledgers booked (docs/output.md, the energy budget)")
    energy_residual: float = _doc("energy_lost - dissipated: the time integrator's error")
    backend: str = _doc('the Taichi backend that ran it ("x64", "arm64", "cuda", "vulkan", ...)')
    residual_largest: float = _doc(
        "the budget's residual of largest magnitude over the run's diagnostics (signed; what the budget's warning judges)"
    )
    residual_largest_time: float = _doc("the time of residual_largest")
    released_largest: float = _doc("the largest potential energy released at any diagnostic time")
    dissipated_largest: float = _doc("the largest energy the ledgers had booked at any diagnostic time")
    energy_largest: float = _doc("the largest |E| at any diagnostic time (the scale of rounding: energy.ROUNDING_SHARE)")
    dt: float = _doc("the time step, time.dt")
    precision: str = _doc("the model's precision, scene.precision (the scale of rounding: energy.ROUNDING_ULPS)")
    dt_accepted: float = _doc(
        "the largest time.dt the icebergs' hydrostatics accept, a share of the stability limit 2/omega of the stiffest "
        "heave (NaN without buoyancy: docs/model.md, 'The largest time step'; an effect's own limit may be smaller)"
    )

    def lines(self) -> list[str]:
        share = f"{self.energy_residual / self.energy_released:.2%} of released" if self.energy_released else "none released"
        how = "compiling the kernels" if self.compiled else "loading the kernels from Taichi's cache"
        rest = self.steps - self.startup_steps
        speed = (
            f"then {rest} steps at {self.steps_per_second:,.0f} steps/s"
            if math.isfinite(self.steps_per_second)
            else "no steps after it to time apart"
        )
        return [
            f"simulated t = {self.time:g} in {self.steps} steps, {self.wall_seconds:.1f} s wall: {self.startup_seconds:.1f} s "
            f"{how} with the first {self.startup_steps} steps, {speed}",
            f"capsized fraction {self.capsized_fraction:.3f}, leading edge {self.leading_edge:.3f} widths",
            f"energy: released (potential, E_p(0) - E_p(t)) {self.energy_released:.6g}; lost (E(0) - E(t)) "
            f"{self.energy_lost:.6g} = dissipated {self.dissipated:.6g} + residual {self.energy_residual:.3g} "
            f"({share})",
            budget_promise(
                self.residual_largest,
                self.released_largest,
                self.dissipated_largest,
                self.residual_largest_time,
                energy=self.energy_largest,
                precision=self.precision,
            ),
            *self._untrusted(),
            f"output: {self.path} (ran on Taichi's {self.backend} backend)",
        ]

    def _untrusted(self) -> list[str]:
        """A warning when the budget does not close: its largest residual over the run past
        :data:`melange_ti.energy.RESIDUAL_TRUSTED` of the largest energy released (or
        dissipated, where that is larger): :func:`melange_ti.energy.budget_verdict`."""
        verdict = budget_verdict(
            self.residual_largest,
            self.released_largest,
            self.dissipated_largest,
            self.residual_largest_time,
            dt=self.dt or None,
            accepted=self.dt_accepted,
            energy=self.energy_largest,
            precision=self.precision,
        )
        return [verdict] if verdict else []


def _utc_now() -> str:
    import datetime

    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


class _DeferredInterrupt:
    """Ctrl-C (SIGINT) during a run, turned into ``KeyboardInterrupt`` between two advances.

    Python raises ``KeyboardInterrupt`` wherever the main thread happens to be, and where
    that is a garbage-collection or weakref callback it is printed and dropped ("Exception
    ignored in ...") and the run goes on. This handler only records the signal; the run
    loop stops after its launch (about ``CHECK_SECONDS`` of stepping, any backend) and writes
    a checkpoint there (:meth:`Simulation._interrupted`). Installed only in the main thread, and not where
    SIGINT is ignored (e.g. under ``nohup``).
    """

    def __init__(self):
        import signal
        import threading

        self.requested = False
        self.installed = False
        self.previous = None
        if threading.current_thread() is threading.main_thread():
            current = signal.getsignal(signal.SIGINT)
            if current is not signal.SIG_IGN:
                self.previous = signal.signal(signal.SIGINT, self._record)
                self.installed = True

    def _record(self, signum, frame) -> None:
        self.requested = True

    def restore(self) -> None:
        if self.installed:
            import signal

            signal.signal(signal.SIGINT, self.previous if self.previous is not None else signal.SIG_DFL)
            self.installed = False


@dataclass(frozen=True)
class IterationInterval:
    """A schedule that fires every ``steps`` steps (Oceananigans' ``IterationInterval``).

    Output intervals are whole numbers of steps (``round(interval / dt)``), so output times
    are exactly ``step * dt``."""

    steps: int

    def __call__(self, step: int) -> bool:
        return step % self.steps == 0

    def next(self, step: int) -> int:
        """The first step after ``step`` at which the schedule fires."""
        return (step // self.steps + 1) * self.steps


@dataclass(frozen=True)
class PairedInterval:
    """The diagnostics' schedule: every ``steps`` steps, the times of the rows, and the step
    after each, whose state completes the row (the energy at the step time is read from the
    states two consecutive steps leave: docs/model.md, "What the budget promises")."""

    steps: int

    def __call__(self, step: int) -> bool:
        return step % self.steps == 0 or (step >= 1 and step % self.steps == 1)

    def on_grid(self, step: int) -> bool:
        """Whether a row is taken at ``step``."""
        return step % self.steps == 0

    def next(self, step: int) -> int:
        """The first step after ``step`` at which the schedule fires."""
        base = step // self.steps * self.steps
        return step + 1 if step == base else base + self.steps


@dataclass
class _Counters:
    """Cumulative totals at the previous diagnostic (rates are differences of these)."""

    t: float = 0.0
    impulses: int = 0
    wall_impulse: float = 0.0
    impulse_sum: float = 0.0

    def save(self) -> dict:
        return {"counters": np.array([self.t, self.wall_impulse, self.impulse_sum]), "counter_contacts": self.impulses}

    @classmethod
    def load(cls, ck: dict) -> _Counters:
        t, wall, imp = (float(v) for v in ck["counters"])
        return cls(t=t, impulses=int(ck["counter_contacts"]), wall_impulse=wall, impulse_sum=imp)


class Diagnostics:
    """The scalar time series (:data:`melange_ti.diagnostics.FIELDS`), also at the last step.

    A row at step ``j`` is written once step ``j + 1`` has run: its kinetic energy is read at
    the step time with that step's half kick (:meth:`diag.Event.kinetic`). Where the run
    stops at ``j`` (its end, a checkpoint, which ends a launch, an interrupt or an error) the
    row looks one step on instead (:meth:`Model.peek`), which changes nothing the run goes on
    from: the file then holds every row up to where the run stands. A snapshot ends its
    launch one step on instead (:meth:`Simulation._batch`)."""

    name = "diagnostics"
    at_end = True
    from_sample = True  # can run on a sample taken earlier in the same launch (Simulation._batch)

    def __init__(self, schedule: IterationInterval, effects=None):
        self.schedule = PairedInterval(schedule.steps)
        self.counters = _Counters()
        self.last: dict | None = None
        self.last_step = -1
        self.fields = diag.fields(effects)  # the model's own and those of the effects named
        self.names = tuple(f.name for f in self.fields)
        self.pending: tuple | None = None  # (step, t, sample, totals) of a row waiting for the next step's state
        self.before: _Counters | None = None  # the counters before the last row written (saved_counters)

    def write(self, sim: Simulation, step: int, t: float, s: dict) -> None:
        if self.pending is not None and step == self.pending[0] + 1:
            self._finish(sim, s)
        if self.schedule.on_grid(step) or step == sim.total:
            self.pending = (step, t, s, sim.totals)  # the totals fetched with the sample
            if step == sim.total or not all(o.from_sample for o in sim._due(step)):
                self.flush(sim)  # the launch stops here: the next step, looked at and undone

    def flush(self, sim: Simulation) -> None:
        """Write the pending row now: with the next step's sample where the launch took it
        (``sim.ahead``: a run stopped by an error amid a launch's samples), else with the next
        step looked at and undone (:meth:`Model.peek`) where the model stands at the row's
        step. Where neither can be had (the state the guard stops on, from which no step goes
        on; a launch that failed part way) the row is dropped rather than read another way:
        the file then ends at the row before."""
        if self.pending is None:
            return
        step = self.pending[0]
        after = None
        if sim.ahead is not None and sim.ahead[0] == step + 1:
            after = sim.ahead[1][0]
        elif sim.model_step == step:
            try:
                after = sim.model.peek(1)[0]
            except Exception:  # non-finite, contact slots overflowing
                after = None
        if after is None:
            self.pending = None
            return
        self._finish(sim, after)

    def take(self, step: int, t: float, sampled: tuple) -> None:
        """A resumed run's first row, at its checkpoint's step (``sampled``: the model's
        :meth:`Model.sample_with_totals` there), completed by the next step as any other."""
        self.pending = (step, t, *sampled)

    def _finish(self, sim: Simulation, after: dict) -> None:
        step, t, s, tot = self.pending
        self.pending = None
        c = self.counters
        row = diag.row(diag.Event(t, s, tot, c, sim.x0_max, after), self.fields)  # each field computed as declared
        self.before = dataclasses.replace(c)  # as a run resumed here, which forms this row again, needs them
        if self.schedule.on_grid(step):  # a row off the grid (at an end) leaves them: a run extended past it goes on as one run
            c.t, c.impulses, c.wall_impulse, c.impulse_sum = t, tot.impulses, tot.wall_impulse, tot.impulse_sum
        self.last, self.last_step = row, step
        sim.writer.diagnostic(row)

    def saved_counters(self, step: int) -> dict:
        """The counters a checkpoint at ``step`` keeps: those before the row at ``step``, when
        one was written there (a run resumed from it forms that row again)."""
        return (self.before if self.last_step == step else self.counters).save()


class Guard:
    """Stops a run whose state turned non-finite or whose energy ran away, keeping the file
    (a snapshot of the bad state is written first). Runs at every output event, after the
    diagnostics."""

    name = "guard"
    at_end = True
    from_sample = True  # can run on a sample taken earlier in the same launch (Simulation._batch)

    def __init__(self, diagnostics: Diagnostics):
        self.diagnostics = diagnostics
        self.schedule = None

    def write(self, sim: Simulation, step: int, t: float, s: dict) -> None:
        bad = runaway(s, total_energy(s), sim.e0, sim.total_mass)  # the energy of the state the step left
        if bad is not None:
            self.diagnostics.flush(sim)  # the row of this step, if it waits for the next
            sim.writer.snapshot(t, s)
            sim.writer.flush()
            raise NumericalError(f"step {step} (t = {t:g}): {bad}; output kept in {sim.out}")


class Snapshots:
    """The full state of every iceberg, also at the last step."""

    name = "snapshots"
    at_end = True
    from_sample = True  # writes the sample's state (Model.sample holds every dataset a snapshot has)
    ends_batch = True  # written as soon as it is reached: a batch stops here, or one step on (Simulation._batch)

    def __init__(self, schedule: IterationInterval):
        self.schedule = schedule

    def write(self, sim: Simulation, step: int, t: float, s: dict) -> None:
        sim.writer.snapshot(t, s)


# What an iceberg is made of besides its state (the fields of Icebergs that a step never
# changes): kept in every checkpoint, so that a resumed or extended run is built from the very
# bodies it began with (a polygon's corners, not the rectangle of its extents), with no
# [start] file to read again
SHAPE_FIELDS = tuple(f.name for f in dataclasses.fields(Icebergs) if f.name not in BODIES.outputs("state"))


def shape_of(bergs: Icebergs) -> dict[str, np.ndarray]:
    """The checkpoint's record of ``bergs``' shapes (:data:`SHAPE_FIELDS`; a field that is
    ``None``, e.g. no outline in a scene of rectangles, is left out)."""
    return {name: getattr(bergs, name) for name in SHAPE_FIELDS if getattr(bergs, name) is not None}


class Checkpoints:
    """Everything the next step depends on (:mod:`melange_ti.io.checkpoint`): the state and
    every ledger and counter the schema names, and the icebergs' sizes as the model was built
    from them, so a resumed run is bit-identical and needs no ``[start]`` file. Also at the
    last step, and kept: a finished run can then be extended to a later time."""

    name = "checkpoints"
    at_end = True
    from_sample = False  # reads the model itself (state, ledgers): a batch stops here (Simulation._batch)

    def __init__(self, schedule: IterationInterval, diagnostics: Diagnostics):
        self.schedule = schedule
        self.diagnostics = diagnostics

    def write(self, sim: Simulation, step: int, t: float, s: dict) -> None:
        sim.writer.flush()
        data = {
            SCENE_ATTR: sim.scene.to_toml(),
            "step": step,
            **{f"state_{k}": v for k, v in sim.model.state().items()},
            **{f"acc_{k}": v for k, v in sim.model.accumulators().items()},
            **self.diagnostics.saved_counters(step),
            **shape_of(sim.bergs),
            "x0_max": sim.x0_max,
            "e0": sim.e0,
            "p0": sim.p0,
        }
        try:
            checkpoint.save(sim.ckpt, data)
        except OSError as exc:
            raise OutputError(f"{sim.ckpt}: checkpoint write failed ({os.strerror(exc.errno) if exc.errno else exc})") from None


class Simulation:
    """Run ``scene`` into the HDF5 file ``out``.

    The simulation holds a list of outputs (:attr:`outputs`: diagnostics, the guard,
    snapshots, checkpoints), each with its own schedule; the model advances in one call to
    the earliest next event, where one packed transfer (:meth:`Model.sample`) feeds every
    output that is due, in list order. ``resume`` continues an interrupted run from its
    checkpoint so that the final file is bit-identical to an uninterrupted run.
    ``progress``: a bar on a terminal (``None``: when stderr is one). ``interface``
    (``"cli"`` or ``"api"``): whether messages name the command line's flags or
    :func:`melange_ti.run`'s arguments. ``announce``: without a progress bar, one line on
    stderr when the kernels are being compiled (not when loaded from the cache).
    """

    def __init__(
        self,
        scene: Scene,
        out: str | Path,
        overwrite: bool = False,
        resume: bool = False,
        arch: str = "cpu",
        progress: bool | None = None,
        mode: str = "auto",
        on_event: Callable[[int], None] | None = None,
        history: str | None = None,
        interface: str = "cli",
        announce: bool = True,
    ):
        self.scene = scene
        self.history = history or f"created by melange_ti {__version__} (Python API)"
        self.out = Path(out)
        self.ckpt = checkpoint.checkpoint_path(self.out)
        self.overwrite = overwrite
        self.resume = resume
        self.arch = arch
        self.progress = sys.stderr.isatty() if progress is None else progress
        self.mode = mode
        self.on_event = on_event
        self.say = SPELLINGS[interface]
        self.interface = interface
        self.announce = announce
        dt = scene.time.dt
        self.total = scene.time.steps

        def every(interval: float) -> IterationInterval:
            return IterationInterval(max(1, round(interval / dt)))

        diagnostics = Diagnostics(every(scene.output.diagnostic_interval), scene.effects)
        self.outputs = [
            diagnostics,
            Guard(diagnostics),
            Snapshots(every(scene.output.snapshot_interval)),
            Checkpoints(every(scene.output.checkpoint_interval), diagnostics),
        ]
        self.diagnostics = diagnostics
        self.checkpoints = self.outputs[-1]
        self.totals = None  # the model's Totals, fetched with each event's sample
        self._check_paths()
        self._ck = self._check_resume() if resume else None  # refused before anything is touched

    def _check_paths(self) -> None:
        out, say = self.out, self.say
        if self.resume:
            if not out.exists():
                raise RunError(f"{say['resume']}: {out} does not exist")
            return
        if out.is_dir():
            raise RunError(f"{say['out']} {out}: is a directory")
        if out.exists() and not self.overwrite:
            raise RunError(
                f"{say['out']} {out}: file exists (use {say['overwrite']} to replace it, {say['resume']} to continue it)"
            )
        parent = out.parent if str(out.parent) else Path(".")
        if not parent.is_dir():
            raise RunError(f"{say['out']} {out}: directory {parent} does not exist")

    # ------------------------------------------------------------------ run
    def run(self) -> RunSummary:
        import taichi as ti

        scene = self.scene
        dtype = np.float32 if scene.precision == "f32" else np.float64
        from . import runtime

        self.backend = runtime.init(self.arch, None, scene.precision)  # on demand; keeps an earlier init of the same kind
        ck = self._ck
        self.bergs = scene.icebergs() if ck is None or "width" not in ck else self._resumed_icebergs(ck)
        self.model = model = Model(scene, self.bergs, mode=self.mode)
        start_step = 0
        if self.resume:
            writer, start_step = self._reopen(model, dtype, ck)
        else:
            attrs = {
                "scene_name": scene.name,
                "history": f"{_utc_now()}: {self.history}",
                "width_m": scene.width_m,
                SCENE_ATTR: scene.to_toml(),
                "melange_ti_version": __version__,
                "taichi_version": ".".join(map(str, ti.__version__)),
                "arch": runtime.arch_family(self.backend),
                "taichi_arch": self.backend,
                "precision": scene.precision,
                "contact_order": model.order,
                "seed": scene.time.seed,
            }
            if self.ckpt.exists():  # an earlier run's, which a resume of this one must not take; first,
                try:  # so that a refusal here leaves the run file too
                    self.ckpt.unlink()
                except OSError as exc:
                    raise OutputError(f"{self.ckpt}: cannot remove an earlier run's checkpoint ({exc.strerror})") from None
            if self.out.exists():
                self.out.unlink()
            own = None
            if model.owned:  # every owning effect's dimensions and datasets written once
                own = {"dims": {}, "constants": {}}
                for state in model.owned.values():
                    own["dims"].update(state.dims())
                    own["constants"].update(state.constants())
            writer = RunWriter(self.out, attrs, model.constants(), dtype, own=own, diagnostics=self.diagnostics.names)
        self.writer = writer
        self.total_mass = float(model.constants()["mass"].sum())
        # the first launch compiles the kernels, or loads them from Taichi's offline cache: which
        # of the two happened is measured (runtime.watch_compiling), not foretold
        bar = None
        if self.progress:
            from tqdm import tqdm

            bar = tqdm(total=self.total, initial=start_step, unit="step", unit_scale=True, dynamic_ncols=True, leave=False)
            bar.set_description("compiling the kernels, or loading them from the cache")
        watch = contextlib.ExitStack()
        seen = watch.enter_context(runtime.watch_compiling())
        self.compiled = False
        t0 = wallclock.perf_counter()
        self.startup = None  # (seconds, steps) of the first launch
        step = start_step
        self.model_step = step  # where the model stands (Diagnostics.flush)
        self.ahead = None  # (step, sample) the launch took after the events being run, if any
        interrupt = _DeferredInterrupt()
        try:
            if not self.resume:
                self._events(0, first=True)
            elif step < self.total and self.diagnostics.schedule.on_grid(step):  # its row, formed again
                self.diagnostics.take(step, step * scene.time.dt, model.sample_with_totals())
            pace = None  # steps per wall second of the last launch
            while step < self.total:
                if interrupt.requested:
                    self._interrupted(step)
                stops = self._batch(step)
                cap = self._launch_cap(step, stops, pace)
                launched = wallclock.perf_counter()
                self.model_step, self.ahead = None, None  # until the launch returns: unknown
                if stops[0] - step > cap:  # a part of the way to the next event: no output
                    model.advance(cap)
                    stops, sampled = [step + cap], None
                else:
                    stops = [s for s in stops if s - step <= cap]
                    light = tuple(k for k, s in enumerate(stops) if self._completes_only(s))
                    sampled = model.advance_sampled([b - a for a, b in zip((step, *stops[:-1]), stops, strict=True)], light)
                self.model_step = stops[-1]  # where the model stands (its samples may be of earlier steps)
                if self.startup is not None:  # the first launch's pace is its compiling
                    pace = (stops[-1] - step) / max(wallclock.perf_counter() - launched, 1e-9)
                if self.startup is None:
                    self.startup = (wallclock.perf_counter() - t0, stops[-1] - step)
                    watch.close()
                    self._said_compiling(seen, bar)
                for k, (nxt, got) in enumerate(zip(stops, sampled or [None], strict=True)):
                    if bar is not None:
                        if step == start_step:
                            bar.set_description("running")
                        bar.update(nxt - step)
                    step = nxt
                    if got is not None:
                        # the launch's next sample, for a row an error would leave waiting
                        self.ahead = (stops[k + 1], sampled[k + 1]) if k + 1 < len(stops) else None
                        self._events(step, sampled=got)
        except OutputError:
            writer.close()
            if not self.resume and writer.snapshots_written == 0:
                # nothing was recorded: leave nothing behind
                self.out.unlink(missing_ok=True)
                self.ckpt.unlink(missing_ok=True)
            raise
        except BaseException:  # stopped part way (an exception from on_event, ...): the rows up to here
            try:
                self.diagnostics.flush(self)
            except Exception:
                pass
            raise
        finally:
            watch.close()
            interrupt.restore()
            if bar is not None:
                bar.close()
            writer.close(complete=step >= self.total)
        wall = wallclock.perf_counter() - t0
        return self._summary(step - start_step, wall)

    def _said_compiling(self, seen, bar) -> None:
        """After the first launch: whether it compiled kernels (measured), said on stderr when
        it did (a terminal's bar says it was preparing them meanwhile)."""
        self.compiled = seen.kernels > 0
        if self.compiled and self.announce and bar is None:
            print(
                f"melange-ti: compiled {seen.kernels} kernels in {seen.seconds:.1f} s (Taichi caches them: a later run of "
                "this kind loads them in about a second)",
                file=sys.stderr,
                flush=True,
            )

    def _launch_cap(self, step: int, stops: list[int], pace: float | None) -> int:
        """The most steps the next launch may take: ``CHECK_SECONDS`` at ``pace``, the steps
        per wall second of the launch before. The first two launches (the first compiles the
        kernels, or loads them: no pace) take one step each in the parallel form (a device,
        or many icebergs: perhaps a few steps per second) and up to two events in the serial
        form (the CPU: both of its kernels compile in the first, timed apart from the
        stepping). Launches of any length give the same bits (:meth:`Model.advance_sampled`)."""
        if pace is not None:
            return max(1, int(pace * CHECK_SECONDS))
        if self.model.mode != "serial":
            return 1
        return stops[min(1, len(stops) - 1)] - step

    def _interrupted(self, step: int) -> None:
        """Ctrl-C: a checkpoint where the run stands, then stop saying so."""
        t = step * self.scene.time.dt
        self.diagnostics.flush(self)  # a row waiting for the next step: written, as at an end
        self.checkpoints.write(self, step, t, None)
        if self.interface == "api":
            how = f"mt.run(scene, {str(self.out)!r}, resume=True)"
        else:
            how = f"melange-ti run --out {self.out} --resume"
        end = self.total * self.scene.time.dt
        raise Interrupted(
            f"interrupted at t = {t:g} of {end:g} (step {step} of {self.total}); {self.out} and its checkpoint "
            f"hold everything up to there: continue with {how}"
        )

    def _due(self, step: int) -> list:
        """The outputs due at ``step``, in list order; those without a schedule (the guard)
        whenever any other is due, but for a step that only completes a diagnostic row."""
        final = step == self.total
        due = [o for o in self.outputs if o.schedule is not None and (o.at_end if final else o.schedule(step))]
        if due == [self.diagnostics] and not final and not self.diagnostics.schedule.on_grid(step):
            return due  # the step after a row: its sample only completes the row (half_kick)
        return [o for o in self.outputs if o in due or (due and o.schedule is None)]

    def _completes_only(self, step: int) -> bool:
        """Whether the one output due at ``step`` is the diagnostics completing the row of the
        step before (:meth:`_due` leaves the guard out only there): its sample needs the
        icebergs' columns alone (Model.sample_with_totals, ``owners=False``)."""
        return self._due(step) == [self.diagnostics]

    def _batch(self, step: int) -> list[int]:
        """The event steps after ``step`` that one launch can run through
        (:meth:`Model.advance_sampled`): up to the first where an output that needs the
        model itself is due (a checkpoint: ``from_sample`` false) or the end, or where a
        snapshot is due (``ends_batch``: the file holds it as soon as the run reaches it), at
        most ``BATCH_MAX`` events and ``BATCH_BYTES`` of samples. A batch that ends at a
        snapshot with a diagnostic row there runs one step on, to the step that completes
        the row, rather than look at it and undo it (:meth:`Model.peek`)."""
        per_event = 8 * self.model.n * len(SAMPLE_NAMES)
        if self.model.owned:  # and a copy of the owners' table per event
            per_event += 8 * int(np.prod(self.model.arrays.own.shape))
        cap = max(1, min(BATCH_MAX, BATCH_BYTES // per_event))
        stops = []
        while len(stops) < cap and step < self.total:
            step = min(min(o.schedule.next(step) for o in self.outputs if o.schedule is not None), self.total)
            stops.append(step)
            due = self._due(step)
            if not all(o.from_sample for o in due):
                break
            if any(getattr(o, "ends_batch", False) for o in due):
                if self.diagnostics in due and step < self.total and self.diagnostics.schedule.on_grid(step):
                    stops.append(step + 1)  # the follower of the row at the snapshot (a schedule's own stop)
                break
        return stops

    def _events(self, step: int, first: bool = False, sampled: tuple | None = None) -> None:
        """Run the outputs due at ``step`` on the sample taken there (``sampled``: taken by
        :meth:`Model.advance_sampled`; else fetched now)."""
        due = self._due(step)
        if not due:
            return
        t = step * self.scene.time.dt
        s, self.totals = sampled if sampled is not None else self.model.sample_with_totals()
        if first:
            self.x0_max = float(np.max(s["x"]))
            self.p0 = float(np.sum(s["potential"]))
            self.e0 = total_energy(s)
        for output in due:
            output.write(self, step, t, s)
        if self.on_event is not None:
            self.on_event(step)

    def _checkpoint(self) -> dict:
        if not self.ckpt.exists():
            raise RunError(
                f"{self.say['resume']}: no checkpoint {self.ckpt} (the run never started, its file was moved without "
                f"it, or it finished under an earlier melange_ti, which kept none; use {self.say['overwrite']} to run it again)"
            )
        try:
            return checkpoint.load(self.ckpt)
        except ValueError as exc:
            raise RunError(f"--resume: checkpoint {self.ckpt} cannot be used: {exc}") from None

    def _check_resume(self) -> dict:
        """The checkpoint a resume continues from, checked before anything is touched: the
        file's format, and the scene of the file and of the checkpoint equal to this one but
        for ``time.duration``, which may move the end anywhere after the checkpoint: later
        than a finished run's end, it extends the run (docs/reliability.md)."""
        ck = self._checkpoint()
        data = read_run(self.out)
        version = int(data["attrs"].get("format_version", 1))
        if version not in RESUMABLE:
            raise RunError(
                f"--resume: {self.out} is in run-file format {version}, this melange_ti writes {FORMAT_VERSION}: "
                "continue the run with the version that began it, or start it again"
            )
        if int(ck["format_version"]) < 8 and "corners" in data["icebergs"]:  # its outlines were not kept
            raise RunError(
                f"--resume: checkpoint {self.ckpt} was written by an earlier melange_ti that kept no outlines, and "
                f"{self.out} holds polygons: continue the run with that version, or start it again"
            )
        for e in OWNERS:  # an owning effect's table that has gained a column since (format 9)
            held = np.asarray(ck[f"acc_{e.name}"]) if f"acc_{e.name}" in ck else None
            if held is not None and held.ndim == 2 and held.shape[1] != e.table.size:
                raise RunError(
                    f"--resume: checkpoint {self.ckpt} holds the {e.name} effect's table with {held.shape[1]} columns "
                    f"where this melange_ti has {e.table.size} (written by another version): continue the run with "
                    "that version, or start it again"
                )
        if "corners" in data["icebergs"] and data["attrs"].get(OUTLINE_DISCS_ATTR) != OUTLINE_DISCS:
            raise RunError(
                f"--resume: {self.out} holds polygons whose collision discs an earlier melange_ti laid out by another "
                "rule: continue the run with that version, or start it again"
            )
        text = self.scene.to_toml()
        stored = scene_text(self.out, data)
        for was in (str(ck[SCENE_ATTR]), stored):
            changed = [k for k in scene_changes(was, text) if k != EXTENDABLE]
            if changed:
                raise RunError(
                    f"--resume: {self.out} was made by a different scene (or --set values: {', '.join(changed)} differ); "
                    f"refusing to mix them (only {EXTENDABLE} may change, to move the end)"
                )
        step, dt = int(ck["step"]), self.scene.time.dt
        finished = bool(data["attrs"].get(COMPLETE_ATTR, False))
        # an end moved onto the checkpoint would lack the rows written at an end (stopped, or
        # an extension stopped on the way had dropped them): refused like an earlier one
        if step > self.total or (step == self.total and (finished or stored != text)):
            same = step == self.total and stored == text
            how = "nothing to resume" if same else f"{EXTENDABLE} = {self.scene.time.duration:g} is not later"
            raise RunError(
                f"{self.say['resume']}: {self.out} has run to t = {step * dt:g} (its checkpoint); {how}: a later "
                f"{EXTENDABLE} extends it"
            )
        self._extension = None
        if stored != text:  # the end moves: the file's scene and history say so
            old = tomllib.loads(stored)["time"]["duration"]
            line = f"{_utc_now()}: {EXTENDABLE} {old:g} -> {self.scene.time.duration:g} from t = {step * dt:g}: {self.history}"
            history = str(data["attrs"].get("history", ""))
            self._extension = {SCENE_ATTR: text, "history": f"{history}\n{line}" if history else line}
        return ck

    @staticmethod
    def _resumed_icebergs(ck: dict) -> Icebergs:
        """The icebergs the run was built from: every shape as first given (exact, whatever
        the precision: :func:`shape_of`), the state of the checkpoint (replaced by
        :meth:`_reopen` anyway)."""
        state = {k[6:]: np.asarray(ck[k], dtype=np.float64) for k in ck if k.startswith("state_")}
        return Icebergs(**state, **{name: ck[name] for name in SHAPE_FIELDS if name in ck})

    def _reopen(self, model: Model, dtype, ck: dict):
        step = int(ck["step"])
        model.set_state({k[6:]: ck[k] for k in ck if k.startswith("state_")})
        model.set_accumulators({k[4:]: ck[k] for k in ck if k.startswith("acc_")})
        self.diagnostics.counters = _Counters.load(ck)
        self.x0_max, self.e0, self.p0 = float(ck["x0_max"]), float(ck["e0"]), float(ck["p0"])
        # The file is cut to the last time on a snapshot or diagnostic grid at or before the
        # checkpoint: a row after it was written only because the run ended there, and a run
        # that goes on (extended) has none. A checkpoint at the end keeps them: nothing is left to run.
        # Each group is cut on its own grid: an end on the diagnostics' grid but not the snapshots'
        # keeps its diagnostic row and drops its snapshot. A diagnostic row at the checkpoint
        # itself is dropped too: the resumed run forms it again with the step it takes next
        # (Diagnostics.take), as a run that had gone on formed it.
        dt = self.scene.time.dt

        def kept(o) -> float:
            if step == self.total:
                return step * dt
            last = step - 1 if o.name == "diagnostics" else step
            return last // o.schedule.steps * o.schedule.steps * dt

        keep = {o.name: kept(o) for o in self.outputs if o.name in ("snapshots", "diagnostics")}
        writer = RunWriter(self.out, dtype=dtype, mode="r+", resume_time=keep, attrs=self._extension)
        # the diagnostics the file holds
        self.diagnostics.fields = tuple(f for f in diag.FIELDS if f.name in writer.diagnostic_names)
        return writer, step

    def _summary(self, steps: int, wall: float) -> RunSummary:
        row = self.diagnostics.last or {}
        budget = self._budget_series()
        lost = float(budget["energy"][0] - budget["energy"][-1]) if budget["energy"].size else 0.0
        dissipated = float(budget["dissipated"][-1]) if budget["dissipated"].size else 0.0
        first_wall, first_steps = self.startup or (wall, steps)
        return RunSummary(
            path=self.out,
            steps=steps,
            wall_seconds=wall,
            startup_seconds=first_wall,
            startup_steps=first_steps,
            steps_per_second=(steps - first_steps) / (wall - first_wall) if steps > first_steps else float("nan"),
            compiled=self.compiled,
            time=row.get("time", 0.0),
            capsized_fraction=row.get("capsized_fraction", float("nan")),
            leading_edge=row.get("leading_edge", float("nan")),
            energy_released=self.p0 - row.get("potential_energy", self.p0),
            energy_lost=lost,
            dissipated=dissipated,
            energy_residual=lost - dissipated,
            backend=self.backend,
            **self._budget_over_run(budget),
        )

    def _budget_series(self) -> dict[str, np.ndarray]:
        """The budget over the whole run, from the file's diagnostics (so a resumed run is
        judged from t = 0)."""
        try:
            return budget_series(read_diagnostics(self.out))
        except OutputError:
            return {k: np.zeros(0) for k in ("time", "released", "dissipated", "residual", "energy")}

    def _budget_over_run(self, b: dict[str, np.ndarray]) -> dict[str, float]:
        """The budget's largest residual over the whole run and what it is judged against."""
        from .scene.initial import DT_SAFETY, time_step_limit

        res = b["residual"]
        k = worst(res)
        limit = time_step_limit(self.scene, self.bergs)
        return {
            "residual_largest": float(res[k]) if res.size else 0.0,
            "residual_largest_time": float(b["time"][k]) if res.size else 0.0,
            "released_largest": float(np.nanmax(np.abs(b["released"]), initial=0.0)),
            "dissipated_largest": float(np.nanmax(np.abs(b["dissipated"]), initial=0.0)),
            "energy_largest": float(np.nanmax(np.abs(b["energy"]), initial=0.0)),
            "dt": float(self.scene.time.dt),
            "precision": self.scene.precision,
            "dt_accepted": DT_SAFETY * float(limit[0]) if limit is not None else float("nan"),
        }
