"""The schema: every array the model keeps, column by column, and the namespaces to index them.

The model's data are a few packed Taichi ndarrays (a struct cannot be an ndarray element in
Taichi 1.7, and fields would recompile per allocation; packed ndarrays compile once per
effect set and precision). Each is described here by a :class:`Table`: its columns in order,
each with a role, units, a description and, for ``bodies``, the 64-byte cache line it lives
on. From a table come

- its **namespace**, a class of integer constants, so kernels write ``a.b[i, Body.VX]`` and
  ``a.par[Param.DT]`` (a class attribute compiles to the same constant as a bare integer);
- the lists the rest of the code derives from the roles: the state a snapshot writes, the
  constants in ``/icebergs``, the ledgers that the diagnostics sum and the checkpoints keep.

Roles:

``state``     evolves every step; written in every snapshot and checkpoint
``constant``  fixed per iceberg or per run (``constant`` columns with an ``output`` name are
              written to ``/icebergs``)
``cache``     a function of the state kept for speed (cos and sin of the tilt)
``scratch``   meaningful only inside one step; never written
``ledger``    cumulative since t = 0 (energy removed by an effect, impulse sums); summed
              into a diagnostic and kept in checkpoints
``counter``   an integer count or flag (``contacts`` is a ledger of impulses applied)
``config``    an integer setting of the run (N, discs per face, ...)
``reading``   what the last step left for the diagnostics to read (the forces' half kick);
              sampled, never checkpointed: the step after a resume writes it afresh

Effects (:mod:`melange_ti.physics.effects`) add their own columns (parameters, per-body
ledgers, scratch) when they are registered; a new ledger column is then checkpointed and
written to the diagnostics with no other edit.

Index spaces do not mix: indexing an array with another array's namespace is caught by
``tests/physics/test_schema.py``, which reads every kernel module and checks that each
subscript's column comes from the namespace of the array it indexes (Taichi would compile
``a.cd[s, i, Body.VX]`` silently; distinct Python types cannot survive into a kernel).
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

from ...geometry import MAX_VERTICES
from ..effects import OWNERS, REGISTRY
from .columns import Column, E, Table


class Body:
    """Columns of ``b`` (bodies): filled by :mod:`.schema`."""


class BodyInt:
    """Columns of ``bi`` (body_ints)."""


class Contact:
    """Columns of ``cd`` (contacts)."""


class ListPose:
    """Columns of ``nr`` (list_poses)."""


class Cell:
    """Columns of ``cells``."""


class Param:
    """Slots of ``par`` (params)."""


class Scratch:
    """Slots of ``scr`` (scratch)."""


class Config:
    """Slots of ``cfg`` (config)."""


class Counter:
    """Slots of ``cnt`` (counters)."""


class Acc:
    """Slots of ``acc`` (accumulators)."""


LINE_COLUMNS = 8  # 64-byte cache line of f64 columns


def _bodies(effect_columns: tuple[Column, ...], beyond: tuple[Column, ...] = ()) -> Table:
    """The per-iceberg row, grouped into cache lines by the phases that read it together (at
    large N the sweeps are bound by memory traffic). Line 2 holds the cold columns and the
    effects' own; more effect columns than fit open line 3."""
    line0 = (
        Column("X", "state", "w", "centre of mass, horizontal (seaward +)", "x"),
        Column("Z", "state", "w", "centre of mass, vertical (up +)", "z"),
        Column("VX", "state", "w / sqrt(w/g)", "velocity, horizontal", "vx"),
        Column("VZ", "state", "w / sqrt(w/g)", "velocity, vertical", "vz"),
        Column("OM", "state", "rad / sqrt(w/g)", "angular velocity (counter-clockwise +)", "omega"),
        Column("INV_MASS", "constant", "1 / (rho_w w^2)", "1 / mass, rounded once in the model's precision"),
        Column("SHIFT_X", "scratch", "w", "correction: push so far this step, x (before it: KICK_VX)"),
        Column("SHIFT_Z", "scratch", "w", "correction: push so far this step, z (before it: KICK_VZ)"),
    )
    line1 = (
        Column("COS", "cache", "1", "cos(theta), set at the drift"),
        Column("SIN", "cache", "1", "sin(theta), set at the drift"),
        Column("WIDTH", "constant", "w", "width, along the body u axis (a polygon: its extent along u)", "width"),
        Column("THICK", "constant", "w", "thickness, along the body v axis (a polygon: its extent along v)", "thickness"),
        Column("RADIUS", "constant", "w", "radius of the collision discs"),
        Column("BOUND", "constant", "w", "bounding radius, half the diagonal (a polygon: its farthest corner)"),
        Column("MOTION", "scratch", "w", "broad phase: how far it moves at its current velocities"),
        Column(
            "HALF_KICK",
            "reading",
            E,
            "the last step's forces' half kick: dt/2 times the power of the forces its kick applied at the "
            "velocities before it (kinetic_energy reads the kinetic energy at the step time with it)",
            "half_kick",
        ),
    )
    line2 = [
        Column("TH", "state", "rad", "tilt, counter-clockwise, 0 upright; continuous (not wrapped)", "theta"),
        Column(
            "MASS",
            "constant",
            "rho_w w^2",
            "mass, density_ratio * width * thickness (a polygon: density_ratio * its area)",
            "mass",
        ),
        Column(
            "INERTIA",
            "constant",
            "rho_w w^4",
            "moment of inertia, mass (w^2 + h^2) / 12 (a polygon: from its corners)",
            "inertia",
        ),
        *effect_columns,
        Column(
            "POT_START",
            "scratch",
            E,
            "correction: potential energy before the body's first push (before it: KICK_OM; "
            "with islands, then its change, islands.correction_energy)",
        ),
    ]
    # the effects beyond the paper start a line of their own: a scene that names none of
    # them allocates the paper's three lines only (Model), so they cost it nothing
    spare = 0
    while beyond and (3 * LINE_COLUMNS - len(line0) - len(line1) - len(line2)) > 0:
        spare += 1
        line2.append(Column(f"SPARE_{spare}", "scratch", "1", "unused: keeps the effects beyond the paper on their own line"))
    # cache lines follow from the position (8 f64 columns a line)
    # a polygon's outline (any scene with a [[iceberg]] given by vertices; Effects.vertices > 0):
    # last, so a scene of rectangles allocates none of it
    outline = (
        Column("CORNERS", "constant", "1", "polygons: the outline's number of corners", owner="vertices"),
        Column("AXIS", "constant", "rad", "polygons: the principal axis nearest v, from v (capsize angle)", owner="vertices"),
        *(
            Column(f"{axis}{k}", "constant", "w", f"polygons: corner {k}'s body-frame {axis.lower()}", owner="vertices")
            for k in range(MAX_VERTICES)
            for axis in ("U", "V")
        ),
        # the collision discs (geometry.polygon_discs): the outline moved inwards by the radius,
        # and how many discs each edge holds from its inset corner
        *(
            Column(f"I{axis}{k}", "constant", "w", f"polygons: inset corner {k}'s body-frame {axis.lower()}", owner="vertices")
            for k in range(MAX_VERTICES)
            for axis in ("U", "V")
        ),
        *(Column(f"NDISC{k}", "constant", "1", f"polygons: discs on edge {k}", owner="vertices") for k in range(MAX_VERTICES)),
    )
    cols = [dataclasses.replace(c, line=k // LINE_COLUMNS) for k, c in enumerate((*line0, *line1, *line2, *beyond, *outline))]
    width = -(-len(cols) // LINE_COLUMNS) * LINE_COLUMNS
    return Table(
        "bodies",
        "b",
        "real",
        "(N, Body.SIZE)",
        "one row per iceberg: state, constants, cached tilt, per-step scratch, per-body ledgers",
        tuple(cols),
        Body,
        width,
    )


BODY_INTS = Table(
    "body_ints",
    "bi",
    "i32",
    "(N, BodyInt.SIZE)",
    "per-iceberg integers of one step",
    (
        Column("CELL", "scratch", "1", "broad phase: the cell of the body's centre"),
        Column("NCONTACT", "scratch", "1", "contacts of the body with partners j > i (slots used)"),
        Column("WALL_ON", "scratch", "1", "1 if the body has a wall contact this step"),
        Column("SORTED", "scratch", "1", "broad phase: bodies in cell order (indexed by slot, not body)"),
        Column("PUSHED", "scratch", "1", "correction: the last sweep that moved the body (-1: none)"),
        Column("NEXT_ENTRY", "scratch", "1", "candidate lists: the entry a new partner takes (round robin)"),
        Column("ISLAND", "scratch", "1", "islands: the body's root (lowest index of its island)"),
        Column("ISLAND_NUM", "scratch", "1", "islands: at a root, its island's number (islands by root ascending)"),
        Column(
            "ISLAND_START",
            "scratch",
            "1",
            "islands: indexed by island number, where its bodies start in ISLAND_ORDER; groups (islands off): "
            "indexed by group, its first body (groups.split)",
        ),
        Column("ISLAND_ORDER", "scratch", "1", "islands: bodies grouped by island, ascending within (indexed by position)"),
        Column("ISLAND_END", "scratch", "1", "device islands: one past the island's highest body (indexed by island number)"),
        Column("COLOUR_TOP", "scratch", "1", "colouring: the highest priority of the body's uncoloured contacts this round"),
        Column("COLOUR_USED", "scratch", "1", "colouring: the colours of every contact the body is in (bit k: colour k)"),
        Column("COLOUR_OWN", "scratch", "1", "colouring: the colours of the contacts it keeps (wall, partners j > i)"),
    ),
    BodyInt,
)

CONTACTS = Table(
    "contacts",
    "cd",
    "real",
    "(slots, N, Contact.SIZE)",
    "body i's contacts with partners j > i at [s, i], sorted by j (partner in cp[s, i]); slot-major, "
    "so a sweep over the bodies reads them as dense streams",
    (
        Column("PX", "scratch", "w", "contact point, x"),
        Column("PZ", "scratch", "w", "contact point, z"),
        Column("NX", "scratch", "1", "unit normal from j to i, x"),
        Column("NZ", "scratch", "1", "unit normal from j to i, z"),
        Column("GAP", "scratch", "w", "gap when found; the correction replaces it by the predicted end-of-step gap"),
        # islands solved side by side (islands.py): an impulse's terms, kept until added to
        # acc in the sequential order; the wall contact's at slot Config.SLOTS
        Column("DEF_COLLISION", "scratch", E, "islands: the impulse's own dissipation, until booked"),
        Column("DEF_OFFSET", "scratch", E, "islands: the impulse's half-kick offset, until booked"),
        Column("DEF_IMPULSE", "scratch", "rho_w w^2 sqrt(g w)", "islands: the impulse J (0: none or booked)"),
        # an effect's ledgers of the contact law (Effect.law_ledgers), allocated only when the
        # scene names it (contact_width)
        *(
            Column(f"DEF_{c.name}", "scratch", c.units, f"islands: the impulse's share of {c.output}, until booked", owner=e.name)
            for e in REGISTRY
            for c in e.law_ledgers
        ),
        # the contact's colour (forms/colours.py), allocated only when the passes are coloured
        Column("COLOUR", "scratch", "1", "coloured passes: the contact's colour (-1: not yet coloured)", owner="coloured"),
        # the normal impulse the contact has passed this step (effect crushing: at most F_c dt)
        Column("SPENT", "scratch", "rho_w w^2 sqrt(g w)", "crushing: its normal impulse so far this step", owner="crushing"),
    ),
    Contact,
)

LIST_POSES = Table(
    "list_poses",
    "nr",
    "real",
    "(N, ENTRIES, ListPose.SIZE)",
    "the pose of the pair (i, j) when i's candidate list for j was made",
    (
        Column("TU", "scratch", "w", "i's centre in j's frame, u"),
        Column("TV", "scratch", "w", "i's centre in j's frame, v"),
        Column("C", "scratch", "1", "cos of j's tilt relative to i"),
        Column("S", "scratch", "1", "sin of j's tilt relative to i"),
        Column("KEEP", "scratch", "w", "the distance within which disc pairs were kept (touch + skin)"),
    ),
    ListPose,
)

CELLS = Table(
    "cells",
    "cells",
    "i32",
    "(ncells + 1, Cell.SIZE)",
    "counting-sort cell list of the broad phase",
    (
        Column("COUNT", "scratch", "1", "bodies in the cell"),
        Column("START", "scratch", "1", "first slot of the cell in BodyInt.SORTED"),
        Column("FILL", "scratch", "1", "next free slot while filling"),
    ),
    Cell,
)

SCRATCH = Table(
    "scratch",
    "scr",
    "real",
    "(Scratch.SIZE,)",
    "run-wide reals of one step",
    (
        Column("SPEED_MAX", "scratch", "w / sqrt(w/g)", "fastest point of any body"),
        Column("REACH_MAX", "scratch", "w", "largest reach of any body"),
    ),
    Scratch,
)

CONFIG = Table(
    "config",
    "cfg",
    "i64",
    "(Config.SIZE,)",
    "integer settings of the run, fixed when the model is built",
    (
        Column("N", "config", "1", "icebergs"),
        Column("K", "config", "1", "discs per face (contacts.discs / 4)"),
        Column("SLOTS", "config", "1", "contact slots per iceberg (contacts.max_partners)"),
        Column("PASSES", "config", "1", "impulse passes per step (contacts.contact_passes)"),
        Column("NCELLS", "config", "1", "cells of the broad phase (a power of 2)"),
        Column("DISCS", "config", "1", "discs per iceberg"),
        Column("LISTS", "config", "1", "1 if the narrow phase keeps candidate lists"),
        Column("GROUPS", "config", "1", "parallel form without islands: contiguous groups the sequential passes split into"),
        Column("ID_BITS", "config", "1", "coloured passes: bits of a contact's number, i (SLOTS + 1) + slot"),
        *(dataclasses.replace(c, owner=e.name) for e in REGISTRY for c in e.config),
        # the owners' rows stacked in one table, a.own (registry order; docs/architecture.md)
        *(
            Column(f"{e.name.upper()}_{what}", "config", "1", f"{e.name}: {doc} in the owners' table a.own", owner=e.name)
            for e in OWNERS
            for what, doc in (("ROW0", "its first row"), ("ROWS", "its rows"))
        ),
    ),
    Config,
)

COUNTERS = Table(
    "counters",
    "cnt",
    "i64",
    "(Counter.SIZE,)",
    "integer counters and flags",
    (
        Column("IMPULSES", "counter", "1", "impulses applied since t = 0 (per interval: the diagnostic contacts)", "contacts"),
        Column("OVERFLOW", "counter", "1", "1 if a body had more partners than slots"),
        Column("AGAIN", "counter", "1", "after an impulse pass: 2 detect again, 1 pass again, 0 done"),
        Column("ISLANDS", "counter", "1", "islands of the last detection (parallel form)"),
        Column(
            "CHANGED", "counter", "1", "device islands, colouring, coloured correction: 1 if the last round changed something"
        ),
        Column("COLOURS", "counter", "1", "coloured passes: colours of the last colouring (the overflow colour's included)"),
        Column("COLOUR", "counter", "1", "coloured passes: the colour the next launch solves"),
        Column("SLOTS_USED", "counter", "1", "colouring: the most contact slots a body uses (the device's flattened loop)"),
        Column("SWEEP", "counter", "1", "coloured correction: the sweep under way"),
        Column("PUSHES", "counter", "1", "coloured correction: pushes in the sweep under way"),
    ),
    Counter,
)

ACCUMULATORS = Table(
    "accumulators",
    "acc",
    "f64",
    "(Acc.SIZE,)",
    "run-wide cumulative sums since t = 0, in f64 whatever the precision",
    (
        Column(
            "COLLISION",
            "ledger",
            E,
            "energy removed by impulses, 0.5 (1 - e^2) vn^2 / K each",
            "collision_dissipated",
            budget=True,
        ),
        Column(
            "CORRECTION",
            "ledger",
            E,
            "energy removed by overlap corrections (minus the potential energy they add)",
            "correction_work",
            budget=True,
        ),
        Column(
            "OFFSET",
            "ledger",
            E,
            "energy the impulses remove beyond their own dissipation because they act half a kick after the "
            "time the energy is taken at, J dv_kick / 2 each, dv_kick the forces' kick's change of the pair's "
            "normal velocity (not the dampers') less the bonds' (bond_offset_work books theirs), with waves "
            "plus (K - 2i) dt F_w / m at the i-th step of a wave step (-> 0 as dt -> 0)",
            "impulse_offset_work",
            budget=True,
            since=3,
        ),
        Column("WALL_IMPULSE", "ledger", "rho_w w^2 sqrt(g w)", "sum of impulses from the wall", "wall_impulse"),
        Column("IMPULSE", "ledger", "rho_w w^2 sqrt(g w)", "sum of all impulses", "impulse_sum"),
        *(dataclasses.replace(c, owner=e.name) for e in REGISTRY for c in (*e.law_ledgers, *e.run_ledgers)),
    ),
    Acc,
)

BASE_PARAMS = (
    Column("DT", "constant", "sqrt(w/g)", "time step", source="time.dt"),
    Column("RESTITUTION", "constant", "1", "coefficient of restitution", source="physics.restitution"),
    Column("WATER", "constant", "w", "sea surface height", source="physics.water_level"),
    Column("BOUND_MAX", "constant", "w", "largest bounding radius"),
    Column("EPS", "constant", "1", "machine epsilon of the model's precision"),
    # the hydrostatic moments' divisors, read at run time: a device's compiler turns x / 6.0
    # into x * (1/6), not correctly rounded (docs/devices.md); x / y rounds as on the CPU
    Column("SIX", "constant", "1", "6, the divisor of a segment's first moments"),
    Column("TWELVE", "constant", "1", "12, the divisor of a segment's second moments"),
    Column("SUBSTEPS", "constant", "1", "n, the drift's sub-steps the named effects ask for (1: none; Effect.substeps)"),
)


def _params(effect_params: tuple[Column, ...]) -> Table:
    return Table("params", "par", "real", "(Param.SIZE,)", "run-time parameters", (*BASE_PARAMS, *effect_params), Param)


class Arrays(NamedTuple):
    """The model's ndarrays, in the order every kernel takes them (see :class:`Table`).

    ``nl`` (N, narrow.list_width(k), i32): candidate lists; see :mod:`..step.narrow`. ``own``: the
    owners' table, the rows of every named effect that owns one stacked in the registry's
    order (``Effect.table``, each indexed with its namespace from its first row,
    :func:`own_rows`; one row of one column in a model without such an effect). Every field defaults to ``None``, for
    kernels that take a few arrays (``Arrays(cfg=cfg, own=own)``)."""

    b: object = None
    bi: object = None
    cd: object = None
    cp: object = None
    nl: object = None
    nr: object = None
    cells: object = None
    par: object = None
    scr: object = None
    cfg: object = None
    cnt: object = None
    acc: object = None
    red: object = None  # (blocks, device.RED_WIDTH), f64: partial sums of the device's parallel parts (physics/forms/device.py)
    own: object = None  # (rows, widest table), real: the owners' rows stacked (own_rows)
    fx: object = None  # the effect set (Effects): what a term asks of it at compile time (the outline's corners)

    def ndarrays(self) -> tuple:
        """The arrays alone, in the order the kernels take them (without ``fx``)."""
        return tuple(self)[:-1]


def _build():
    def owned(e):
        return tuple(dataclasses.replace(c, owner=e.name) for c in e.body_columns)

    body_cols = tuple(c for e in REGISTRY if not e.beyond_paper for c in owned(e))
    beyond = tuple(c for e in REGISTRY if e.beyond_paper for c in owned(e))
    param_cols = tuple(c for e in REGISTRY for c in e.params)
    return _bodies(body_cols, beyond), _params(param_cols)


BODIES, PARAMS = _build()

# Scratch shared in time: from the kick to the last impulse pass, the columns the correction
# uses later hold the kick's change of the velocities, which the contact law's energy
# booking reads (:func:`..step.impulses.resolve`); the correction zeroes or overwrites them first.
Body.KICK_VX = Body.SHIFT_X
Body.KICK_VZ = Body.SHIFT_Z
Body.KICK_OM = Body.POT_START
# the effects' own tables (``a.own``) after the model's
TABLES = (
    BODIES,
    BODY_INTS,
    CONTACTS,
    LIST_POSES,
    CELLS,
    PARAMS,
    SCRATCH,
    CONFIG,
    COUNTERS,
    ACCUMULATORS,
    *(e.table for e in OWNERS),
)

NAMESPACES = {t.namespace.__name__: t for t in TABLES}


def body_width(fx) -> int:
    """Columns of ``b`` a model with the effect set ``fx`` allocates: the model's own and
    those of the effects it names, in whole cache lines."""
    used = [k for k, c in enumerate(BODIES.columns) if c.owner is None or getattr(fx, c.owner)]
    return -(-(max(used) + 1) // LINE_COLUMNS) * LINE_COLUMNS


def contact_width(fx) -> int:
    """Columns of ``cd`` a model with the effect set ``fx`` allocates: an effect's own (its
    ``owner``, the last ones) only when the scene names it."""
    return max(k for k, c in enumerate(CONTACTS.columns) if c.owner is None or getattr(fx, c.owner)) + 1


def allocated(column: Column, fx) -> bool:
    """Whether a model with the effect set ``fx`` has ``column`` of ``b`` (every column of the
    model and of the named effects lies below :func:`body_width` by construction)."""
    return BODIES.index(column.name) < body_width(fx)


def law_ledgers(fx) -> tuple[tuple[int, int], ...]:
    """The contact law's energy ledgers in a model of ``fx``, as ``(Acc column, Contact column
    of its deferred term)``: the law's own (its dissipation, the half-kick offset), then
    each named effect's ``law_ledgers`` in the registry's order. Every form books them
    through this one list (:func:`..step.impulses.resolve`, :func:`..step.impulses.book_one`,
    :func:`..forms.device.impulse_sums`)."""
    own = ((Acc.COLLISION, Contact.DEF_COLLISION), (Acc.OFFSET, Contact.DEF_OFFSET))
    named = tuple(
        (ACCUMULATORS.index(c.name), CONTACTS.index(f"DEF_{c.name}"))
        for e in REGISTRY
        if getattr(fx, e.name)
        for c in e.law_ledgers
    )
    return own + named


# the most ledgers the contact law books in any effect set (the device's block sums' width)
MAX_LAW_LEDGERS = 2 + sum(len(e.law_ledgers) for e in REGISTRY)

# What the rest of the code derives from the roles.
STATE_NAMES = ("x", "z", "theta", "vx", "vz", "omega")  # the file's order (docs/output.md)
assert sorted(BODIES.outputs("state")) == sorted(STATE_NAMES)
CONSTANTS = tuple(BODIES.outputs("constant"))  # /icebergs: width, thickness, mass, inertia
BODY_LEDGERS = BODIES.outputs("ledger")  # per-body ledgers, summed into a diagnostic
# an effect's per-body state with no output name: carried from step to step (checkpoints keep it)
BODY_CARRIED = {c.name: k for k, c in enumerate(BODIES.columns) if c.role == "state" and not c.output}
ACC_LEDGERS = ACCUMULATORS.outputs("ledger")
# energy ledgers close the budget: E(0) - E(t) = their sum (marked ``budget`` in the tables)
ENERGY_LEDGERS = tuple(c.output for t in (BODIES, ACCUMULATORS) for c in t.columns if c.budget)


def own_rows(effect) -> tuple[int, int]:
    """The ``cfg`` slots of an owning effect's first row and row count in the owners' stacked
    table (``a.own``): its kernels read its rows from the one, as many as the other."""
    return getattr(Config, f"{effect.name.upper()}_ROW0"), getattr(Config, f"{effect.name.upper()}_ROWS")
