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
    substeps, n - 1 times, if an effect      its forces at the new positions;
      sub-steps (n sub-steps of dt / n)      their kick, then x += dt/n v      (forces.py)
      then once                              what follows the position update
    correction                   if contacts  sequential overlap correction    (correction.py)

and run in one of two forms that give the same bits:

- **serial** (:func:`steps_serial`): many whole steps in one kernel call, every loop serial
  (no launch cost: the form for small N on the CPU);
- **parallel**: each stage's parts launched as kernels (:func:`run_part`), their outer loop
  parallel (over bodies, or over islands for the impulse pass and the correction's sweeps:
  :mod:`.forms.islands`; with islands off, over contiguous groups of bodies: :mod:`.forms.groups`),
  except the parts that must be sequential (``sequential``: the cell
  scan, finding the islands, adding the energy terms to the run-wide sums in order). :class:`melange_ti.model.Model` walks
  :data:`STEP` and can time every stage (:meth:`Model.profile`, like Box2D's profile).

Kernels take the model's ndarrays (:class:`.data.schema.Arrays`) and the frozen effect set ``fx``
as a template, so they compile once per effect set and precision and serve every model of
any size; parameters such as ``dt`` are read at run time from ``par``. Every term is guarded
by ``ti.static``: an effect the scene does not name is not compiled, and a part it does not
need is not launched.
"""

from dataclasses import replace

import taichi as ti

from .data.schema import ACCUMULATORS, BODIES, COUNTERS, Arrays, Counter, Param, allocated
from .effects import REGISTRY, SUBSTEPPED
from .forms import colours, device, groups, islands
from .step import broad, correction, forces, impulses, narrow, terms
from .step.parts import Part, Rounds, Stage, Substeps, always, collisions, contacts  # noqa: F401  (the step's vocabulary)

MAX_DETECT = 16  # rounds of (detection,) impulse pass and check per step


@ti.func
def forces_stage(fx: ti.template(), a: ti.template()):
    for i in range(a.b.shape[0]):
        forces.kick(fx, a, i)


@ti.func
def drift_stage(fx: ti.template(), a: ti.template()):
    for i in range(a.b.shape[0]):
        forces.drift(fx, a, i)


@ti.func
def substep_stage(fx: ti.template(), a: ti.template()):
    for i in range(a.b.shape[0]):
        forces.substep(fx, a, i)


@ti.func
def post_drift_stage(fx: ti.template(), a: ti.template()):
    for i in range(a.b.shape[0]):
        forces.post_drift(fx, a, i)


def substepping(fx) -> bool:
    """A named effect sub-steps the drift more than once (``fx.substepped``, set by the model)."""
    return bool(fx.substepped)


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
    coloured=(Part(colours.colour_start, recolour=True), Part(colours.colour_round, repeat=True)),
    coloured_device=(Part(colours.colour_start, recolour=True), Part(colours.colour_round_flat, repeat=True)),
    coloured_serial=colours.colour_serial,
)
IMPULSES = Stage(
    "impulses",
    impulses.impulse_pass,
    (Part(islands.impulse_islands), Part(impulses.book, sequential=True)),
    per_pass=True,
    without_islands=(Part(impulses.impulse_pass, sequential=True),),
    groups=(Part(groups.impulse_groups), Part(groups.book_later, sequential=True)),
    device=(Part(device.impulse_spans), Part(device.impulse_sums), Part(device.impulse_total, sequential=True)),
    coloured=(Part(colours.impulse_colour, per_colour=True), Part(impulses.book, sequential=True)),
    coloured_device=(
        Part(colours.impulse_colour, per_colour=True),
        Part(device.impulse_sums),
        Part(device.impulse_total, sequential=True),
    ),
    coloured_serial=colours.impulse_colours_serial,
)
CHECK = Stage("check", impulses.check, (Part(impulses.check),))
DRIFT = Stage("drift", drift_stage, (Part(drift_stage),))
# the coloured correction's parts before its energy is summed (on the CPU in body order, on
# a device in blocks)
COLOURED_SWEEPS = (
    Part(correction.prepare_all),
    Part(colours.correct_first, sequential=True),
    Part(colours.correct_colour, per_colour=True, repeat=True, limit=correction.MAX_CORRECT),
    Part(correction.energy_all),
)
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
    coloured=(*COLOURED_SWEEPS, Part(correction.book, sequential=True)),
    coloured_device=(*COLOURED_SWEEPS, Part(device.correction_sums), Part(device.correction_total, sequential=True)),
    coloured_serial=colours.correction_serial,
)


def _with_effects(base: tuple) -> tuple:
    """``base`` with every effect's own stages (``(anchor, Stage)``: :func:`.step.terms.stages`)
    after the stage they name (``"start"``: before the first), in the registry's order; each
    runs only when the scene names its effect."""
    step = list(base)
    for effect in REGISTRY:
        for anchor, stage in terms.stages(effect):
            if anchor == "start":  # before the step's first stage
                at = -1
                while at + 1 < len(step) and getattr(step[at + 1], "owner", None) is not None:
                    at += 1
                step.insert(at + 1, stage_of(effect, stage))
                continue
            at = next(k for k, part in enumerate(step) if getattr(part, "name", None) == anchor)
            while at + 1 < len(step) and getattr(step[at + 1], "owner", None) is not None:
                at += 1  # after the stages other effects put there before
            step.insert(at + 1, stage_of(effect, stage))
    return tuple(step)


def stage_of(effect, stage: Stage) -> Stage:
    """``stage``, run only when the scene names ``effect``."""
    return replace(stage, needs=lambda fx: effect.on(fx) and stage.needs(fx), owner=effect.name)


# the drift's sub-steps: each sub-stepped effect's forces at the new positions (its own loop),
# then every iceberg's kick and x += dt/n v; after the last, what follows the position update
SUBSTEPS = Substeps(
    tuple(
        stage_of(
            e,
            Stage(
                f"{e.name}_substep", terms.term(e, "substep_update"), (Part(terms.term(e, "substep_update")),), needs=substepping
            ),
        )
        for e in SUBSTEPPED
    )
    + (Stage("substep", substep_stage, (Part(substep_stage),), needs=substepping),),
    (Stage("post_drift", post_drift_stage, (Part(post_drift_stage),), needs=substepping),),
    needs=substepping,
)

STEP = _with_effects(
    (
        FORCES,
        Rounds((BROAD, NARROW, ISLANDS), (IMPULSES, CHECK), MAX_DETECT, needs=contacts),
        DRIFT,
        SUBSTEPS,
        CORRECTION,
    )
)


# every stage once, in the order STEP runs them
def _stages_of(part) -> tuple:
    if part.kind == "stage":
        return (part,)
    if part.kind == "substeps":
        return (*part.loop, *part.after)
    return (*part.detect, *part.solve)


STAGES = tuple(s for part in STEP for s in _stages_of(part))
STAGE_NAMES = tuple(s.name for s in STAGES)


# ---------------------------------------------------------------- the serial form
def serial_of(fx, stage: Stage):
    """The stage's serial form for the effect set ``fx`` (its coloured one with coloured passes)."""
    return stage.coloured_serial if fx.coloured and stage.coloured_serial is not None else stage.serial


@ti.func
def one_step(fx: ti.template(), a: ti.template()):
    """:data:`STEP` with serial loops (``Body.COS``, ``Body.SIN`` valid on entry)."""
    for part in ti.static(STEP):
        if ti.static(part.needs(fx)):
            if ti.static(part.kind == "stage"):
                ti.static(serial_of(fx, part))(fx, a)
            elif ti.static(part.kind == "substeps"):
                for _sub in range(ti.cast(a.par[Param.SUBSTEPS], ti.i32) - 1):
                    for st in ti.static(part.loop):
                        if ti.static(st.needs(fx)):
                            ti.static(serial_of(fx, st))(fx, a)
                for st in ti.static(part.after):
                    ti.static(serial_of(fx, st))(fx, a)
            else:
                redetect = 1
                for _round in range(part.limit):
                    if redetect:
                        for st in ti.static(part.detect):
                            ti.static(serial_of(fx, st))(fx, a)
                    for st in ti.static(part.solve):
                        ti.static(serial_of(fx, st))(fx, a)
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
    own: arr,
):
    """``steps`` whole steps in one call, every loop serial (small N: no launch costs)."""
    a = ti.static(Arrays(b, bi, cd, cp, nl, nr, cells, par, scr, cfg, cnt, acc, red, own, fx))
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
    own: arr,
):
    """One part of a stage; its outer loop over bodies is parallel unless it is sequential."""
    a = ti.static(Arrays(b, bi, cd, cp, nl, nr, cells, par, scr, cfg, cnt, acc, red, own, fx))
    if ti.static(part.sequential):
        ti.loop_config(serialize=True)
        for _ in range(1):
            part.func(fx, a)
    else:
        part.func(fx, a)


# ---------------------------------------------------------------- host-side helpers
@ti.kernel
def orient_all(b: arr):
    a = ti.static(Arrays(b=b))
    for i in range(b.shape[0]):
        forces.orient(a, i)


# What :func:`sample_all` writes per body, in order: the state and the per-body ledgers
# (their output names, from the schema), then the kinetic and potential energy.
_SAMPLED = [(c.output, k) for k, c in enumerate(BODIES.columns) if c.output and c.role in ("state", "ledger", "reading")]
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
    # constant indices, as the step's own: in a fused launch Taichi may keep a slot the step
    # writes at a constant index in a register across the loop, which a load at a variable
    # index would not see (docs/architecture.md: a Taichi hazard)
    for c in ti.static(range(ACCUMULATORS.size)):
        out_acc[k, c] = a.acc[c]
    for c in ti.static(range(COUNTERS.size)):
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
    a = ti.static(Arrays(b=b, par=par, cnt=cnt, acc=acc, fx=fx))
    sample_into(fx, a, out, out_acc, out_cnt, 0)


@ti.func
def copy_own(fx: ti.template(), a: ti.template(), out_own: ti.template(), k):
    """With effects that own a table, a copy of the owners' table in ``out_own[k]``: what
    their host sides sample (``State.sample``, each its rows) from, as from the table fetched
    after a launch."""
    if ti.static(fx.owns):
        for j in range(a.own.shape[0]):
            for c in range(a.own.shape[1]):
                out_own[k, j, c] = a.own[j, c]


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
    own: arr,
    out: arr,
    out_acc: arr,
    out_cnt: arr,
    out_own: arr,
):
    """:func:`steps_serial` for ``segments[0]`` steps, sample 0 (:func:`sample_into`, and
    :func:`copy_own`), then
    ``segments[1]`` steps, sample 1, ...: a run's output events between two writes in one
    launch. The same bits as one call per segment (the tilts' cos and sin are the ones
    :func:`forces.orient` would give)."""
    a = ti.static(Arrays(b, bi, cd, cp, nl, nr, cells, par, scr, cfg, cnt, acc, red, own, fx))
    ti.loop_config(serialize=True)
    for _ in range(1):
        for i in range(b.shape[0]):
            forces.orient(a, i)
        for k in range(segments.shape[0]):
            for _step in range(segments[k]):
                one_step(fx, a)
            sample_into(fx, a, out, out_acc, out_cnt, k)
            copy_own(fx, a, out_own, k)
