"""One time step as a list of named stages, and the kernels that run it (Taichi).

The step is written once, as data (:data:`STEP`)::

    forces                                   kick: body forces, then damping   (forces.py)
    rounds, at most MAX_DETECT, if contacts:
        broad     (first round, and again     reach and cell list              (broad.py)
        narrow     when a body outran it)     contacts from the discs, wall    (narrow.py)
        islands                               parallel form: touching groups   (islands.py;
                                              islands off: cuts into groups, groups.py)
        impulses                              sequential impulse pass          (impulses.py)
        check                                 again? Counter.AGAIN             (impulses.py)
    drift                                    x += dt v, theta += dt omega      (forces.py)
    correction                   if contacts  sequential overlap correction    (correction.py)

and run in one of two forms that give the same bits:

- **serial** (:func:`steps_serial`): many whole steps in one kernel call, every loop serial
  (no launch cost: the form for small N on the CPU);
- **parallel**: each stage's parts launched as kernels (:func:`run_part`), their outer loop
  parallel (over bodies, or over islands for the impulse pass and the correction's sweeps:
  :mod:`.islands`; with islands off, over contiguous groups of bodies: :mod:`.groups`),
  except the parts that must be sequential (``sequential``: the cell
  scan, finding the islands, adding the energy terms to the run-wide sums in order). :class:`melange_ti.model.Model` walks
  :data:`STEP` and can time every stage (:meth:`Model.profile`, like Box2D's profile).

Kernels take the model's ndarrays (:class:`.schema.Arrays`) and the frozen effect set ``fx``
as a template, so they compile once per effect set and precision and serve every model of
any size; parameters such as ``dt`` are read at run time from ``par``. Every term is guarded
by ``ti.static``: an effect the scene does not name is not compiled, and a part it does not
need is not launched.
"""

from collections.abc import Callable
from dataclasses import dataclass

import taichi as ti

from . import broad, correction, device, forces, groups, impulses, islands, narrow, waves
from .schema import BODIES, Arrays, Counter, allocated

MAX_DETECT = 16  # rounds of (detection,) impulse pass and check per step


def always(fx) -> bool:
    return True


def contacts(fx) -> bool:
    return bool(fx.collisions or fx.wall)


def collisions(fx) -> bool:
    return bool(fx.collisions)


def has_waves(fx) -> bool:
    return bool(fx.waves)


@dataclass(frozen=True)
class Part:
    """One kernel of the parallel form: ``func(fx, a)``; ``sequential`` parts run on one
    thread (their order is the physics); ``needs(fx)``: launched only when true; ``repeat``:
    launched again while it sets ``Counter.CHANGED``."""

    func: Callable
    sequential: bool = False
    needs: Callable = always
    repeat: bool = False


@dataclass(frozen=True)
class Stage:
    """A named stage: ``serial(fx, a)`` is the whole stage with serial loops (inside the
    fused kernel); ``parallel`` its parts as kernels, in turn, ``contact_passes`` times if
    ``per_pass``; ``needs(fx)``: run only when true. Without islands
    (``Model(islands=False)``) the parallel form runs ``without_islands`` instead (once), and
    skips an ``islands_only`` stage; with groups (``Model(groups=G)``, G > 1: the sequential
    passes split into G contiguous groups, :mod:`.groups`) it runs ``groups`` where given
    (``per_pass`` as ``parallel``), the islands stage included. On a device (``Model(device_parts=True)``) it runs
    ``device`` instead of ``parallel``, where given: no part on one thread but a walk over
    block sums (:mod:`.device`)."""

    name: str
    serial: Callable
    parallel: tuple[Part, ...]
    needs: Callable = always
    kind: str = "stage"
    per_pass: bool = False
    without_islands: tuple[Part, ...] | None = None
    islands_only: bool = False
    device: tuple[Part, ...] | None = None
    groups: tuple[Part, ...] | None = None


@dataclass(frozen=True)
class Rounds:
    """Stages repeated until the last of ``solve`` (the check) says done (``Counter.AGAIN``
    0), at most ``limit`` times: ``detect`` runs in the first round and again after a round
    whose check found a body faster than the reach it was searched with (``AGAIN`` 2)."""

    detect: tuple[Stage, ...]
    solve: tuple[Stage, ...]
    limit: int
    needs: Callable = always
    kind: str = "rounds"


@ti.func
def forces_stage(fx: ti.template(), a: ti.template()):
    for i in range(a.b.shape[0]):
        forces.kick(fx, a, i)


@ti.func
def drift_stage(fx: ti.template(), a: ti.template()):
    for i in range(a.b.shape[0]):
        forces.drift(fx, a, i)


FORCES = Stage("forces", forces_stage, (Part(forces_stage),))
BROAD = Stage(
    "broad",
    broad.broad_serial,
    (
        Part(broad.motion_all),
        Part(broad.bin_count, needs=collisions),
        Part(broad.bin_scan, sequential=True, needs=collisions),
        Part(broad.bin_fill, needs=collisions),
    ),
    device=(
        Part(broad.motion_all),
        Part(broad.bin_count, needs=collisions),
        Part(device.cell_sums, needs=collisions),
        Part(device.cell_scan_blocks, sequential=True, needs=collisions),
        Part(device.cell_starts, needs=collisions),
        Part(broad.bin_fill, needs=collisions),
    ),
)
NARROW = Stage("narrow", narrow.narrow_stage, (Part(narrow.narrow_stage),))


@ti.func
def nothing(fx: ti.template(), a: ti.template()):
    pass


# the serial form solves everything in one sequential pass and needs no islands
ISLANDS = Stage(
    "islands",
    nothing,
    (Part(islands.label, sequential=True),),
    islands_only=True,
    groups=(Part(groups.split, sequential=True),),
    device=(
        Part(device.label_start),
        Part(device.label_round, repeat=True),
        Part(device.root_sums),
        Part(device.root_scan_blocks, sequential=True),
        Part(device.number_roots),
        Part(device.island_ends),
    ),
)
IMPULSES = Stage(
    "impulses",
    impulses.impulse_pass,
    (Part(islands.impulse_islands), Part(impulses.book, sequential=True)),
    per_pass=True,
    without_islands=(Part(impulses.impulse_pass, sequential=True),),
    groups=(Part(groups.impulse_groups), Part(groups.book_later, sequential=True)),
    device=(Part(device.impulse_spans), Part(device.impulse_sums), Part(device.impulse_total, sequential=True)),
)
CHECK = Stage("check", impulses.check, (Part(impulses.check),))
DRIFT = Stage("drift", drift_stage, (Part(drift_stage),))
# the correction's parts: prepare each body and its contacts' gaps (parallel), the sweeps
# (per island in parallel, or all bodies in one sequential loop), each moved body's change
# of potential energy (parallel), their sum in body order (sequential)
CORRECTION = Stage(
    "correction",
    correction.correction_pass,
    (
        Part(correction.prepare_all),
        Part(islands.correct_islands),
        Part(correction.energy_all),
        Part(correction.book, sequential=True),
    ),
    needs=contacts,
    without_islands=(
        Part(correction.prepare_all),
        Part(correction.sweeps_eager, sequential=True),
        Part(correction.energy_all),
        Part(correction.book, sequential=True),
    ),
    groups=(
        Part(correction.prepare_all),
        Part(groups.correct_groups),
        Part(correction.energy_all),
        Part(correction.book, sequential=True),
    ),
    device=(
        Part(correction.prepare_all),
        Part(device.correct_spans),
        Part(correction.energy_all),
        Part(device.correction_sums),
        Part(device.correction_total, sequential=True),
    ),
)

# the waves effect: phi's kick with the icebergs', and after they moved the grid's step
# (what they displaced, eta += dt G phi, the absorbing layer: every part parallel): physics/waves.py
WAVE_KICK = Stage("wave_kick", waves.kick_grid, (Part(waves.kick_grid),), needs=has_waves)
WAVES = Stage(
    "waves",
    waves.waves_serial,
    (Part(waves.update), Part(waves.sponge), Part(waves.pressure_surface)),
    needs=has_waves,
)

STEP = (
    FORCES,
    WAVE_KICK,
    Rounds((BROAD, NARROW, ISLANDS), (IMPULSES, CHECK), MAX_DETECT, needs=contacts),
    DRIFT,
    CORRECTION,
    WAVES,
)
# every stage once, in the order STEP runs them
STAGES = tuple(s for part in STEP for s in ((part,) if part.kind == "stage" else (*part.detect, *part.solve)))
STAGE_NAMES = tuple(s.name for s in STAGES)


# ---------------------------------------------------------------- the serial form
@ti.func
def one_step(fx: ti.template(), a: ti.template()):
    """:data:`STEP` with serial loops (``Body.COS``, ``Body.SIN`` valid on entry)."""
    for part in ti.static(STEP):
        if ti.static(part.needs(fx)):
            if ti.static(part.kind == "stage"):
                part.serial(fx, a)
            else:
                redetect = 1
                for _round in range(part.limit):
                    if redetect:
                        for st in ti.static(part.detect):
                            st.serial(fx, a)
                    for st in ti.static(part.solve):
                        st.serial(fx, a)
                    again = a.cnt[Counter.AGAIN]
                    redetect = ti.cast(again == 2, ti.i32)
                    if again == 0:
                        break


arr = ti.types.ndarray()


@ti.kernel
def steps_serial(
    fx: ti.template(),
    steps: ti.i32,
    b: arr,
    bi: arr,
    cd: arr,
    cp: arr,
    nl: arr,
    nr: arr,
    cells: arr,
    par: arr,
    scr: arr,
    cfg: arr,
    cnt: arr,
    acc: arr,
    red: arr,
    wv: arr,
):
    """``steps`` whole steps in one call, every loop serial (small N: no launch costs)."""
    a = ti.static(Arrays(b, bi, cd, cp, nl, nr, cells, par, scr, cfg, cnt, acc, red, wv))
    ti.loop_config(serialize=True)
    for _ in range(1):
        for i in range(b.shape[0]):
            forces.orient(a, i)  # the state may have been set from the host since the last call
        for _step in range(steps):
            one_step(fx, a)


# ---------------------------------------------------------------- the parallel form
@ti.kernel
def run_part(
    fx: ti.template(),
    part: ti.template(),
    b: arr,
    bi: arr,
    cd: arr,
    cp: arr,
    nl: arr,
    nr: arr,
    cells: arr,
    par: arr,
    scr: arr,
    cfg: arr,
    cnt: arr,
    acc: arr,
    red: arr,
    wv: arr,
):
    """One part of a stage; its outer loop over bodies is parallel unless it is sequential."""
    a = ti.static(Arrays(b, bi, cd, cp, nl, nr, cells, par, scr, cfg, cnt, acc, red, wv))
    if ti.static(part.sequential):
        ti.loop_config(serialize=True)
        for _ in range(1):
            part.func(fx, a)
    else:
        part.func(fx, a)


# ---------------------------------------------------------------- host-side helpers
@ti.kernel
def wave_refresh(cfg: arr, wv: arr):
    """``GPHI = G PHI`` and ``ETA_P = A ETA`` after the host set the wave grid (the step
    keeps them current); every loop parallel, as the step's (on a device a loop over the
    grid on one thread would stop at the driver's cap)."""
    a = ti.static(Arrays(None, None, None, None, None, None, None, None, None, cfg, None, None, None, wv))
    waves.refresh(a)


@ti.kernel
def orient_all(b: arr):
    a = ti.static(Arrays(b, None, None, None, None, None, None, None, None, None, None, None, None, None))
    for i in range(b.shape[0]):
        forces.orient(a, i)


# What :func:`sample_all` writes per body, in order: the state and the per-body ledgers
# (their output names, from the schema), then the kinetic and potential energy.
_SAMPLED = [(c.output, k) for k, c in enumerate(BODIES.columns) if c.output and c.role in ("state", "ledger")]
SAMPLED_COLUMNS = tuple(k for _, k in _SAMPLED)


def _sampled(fx) -> tuple:
    """(position in the sample, column) of the sampled columns a model of ``fx`` has; the
    others (an effect not named) stay 0 in the sample."""
    return tuple((n, k) for n, k in enumerate(SAMPLED_COLUMNS) if allocated(BODIES.columns[k], fx))


def _sampled_positions(fx) -> tuple:
    return tuple(n for n, _ in _sampled(fx))


SAMPLE_NAMES = (*(name for name, _ in _SAMPLED), "kinetic", "potential")


@ti.func
def sample_into(fx: ti.template(), a: ti.template(), out: ti.template(), out_acc: ti.template(), out_cnt: ti.template(), k):
    """Sample ``k`` of ``out`` (K, N, :data:`SAMPLE_NAMES`) and copies of the run-wide
    accumulators and counters in row ``k`` of ``out_acc``, ``out_cnt``."""
    b = ti.static(a.b)
    for c in range(a.acc.shape[0]):
        out_acc[k, c] = a.acc[c]
    for c in range(a.cnt.shape[0]):
        out_cnt[k, c] = a.cnt[c]
    for i in range(b.shape[0]):
        forces.orient(a, i)
        # every element written, the columns of effects not named as 0: on a device an
        # output the kernel only writes is not copied there first, so an element left
        # alone would come back as whatever the device memory held
        for q in ti.static(range(len(SAMPLED_COLUMNS))):
            if ti.static(q in _sampled_positions(fx)):
                out[k, i, q] = b[i, SAMPLED_COLUMNS[q]]
            else:
                out[k, i, q] = 0.0
        out[k, i, ti.static(len(SAMPLED_COLUMNS))] = forces.kinetic_energy(fx, a, i)
        out[k, i, ti.static(len(SAMPLED_COLUMNS) + 1)] = forces.potential_energy(fx, a, i)


@ti.kernel
def sample_all(fx: ti.template(), b: arr, par: arr, acc: arr, cnt: arr, out: arr, out_acc: arr, out_cnt: arr):
    """Sample 0 of ``out`` (:func:`sample_into`): one launch, and no transfer where the
    outputs are the host's own numpy arrays (on the CPU Taichi writes them in place)."""
    a = ti.static(Arrays(b, None, None, None, None, None, None, par, None, None, cnt, acc, None, None))
    sample_into(fx, a, out, out_acc, out_cnt, 0)


@ti.kernel
def steps_serial_sampled(
    fx: ti.template(),
    segments: arr,
    b: arr,
    bi: arr,
    cd: arr,
    cp: arr,
    nl: arr,
    nr: arr,
    cells: arr,
    par: arr,
    scr: arr,
    cfg: arr,
    cnt: arr,
    acc: arr,
    red: arr,
    wv: arr,
    out: arr,
    out_acc: arr,
    out_cnt: arr,
):
    """:func:`steps_serial` for ``segments[0]`` steps, sample 0 (:func:`sample_into`), then
    ``segments[1]`` steps, sample 1, ...: a run's output events between two writes in one
    launch. The same bits as one call per segment (the tilts' cos and sin are the ones
    :func:`forces.orient` would give)."""
    a = ti.static(Arrays(b, bi, cd, cp, nl, nr, cells, par, scr, cfg, cnt, acc, red, wv))
    ti.loop_config(serialize=True)
    for _ in range(1):
        for i in range(b.shape[0]):
            forces.orient(a, i)
        for k in range(segments.shape[0]):
            for _step in range(segments[k]):
                one_step(fx, a)
            sample_into(fx, a, out, out_acc, out_cnt, k)
