"""What an effect declares: its scene keys, parameter slots, per-body columns and terms.

A declaration is data: it imports no Taichi and none of its effect's kernels or host code,
so the scene, the schema and the run-file readers built from it work where Taichi is not
installed, and the package's imports run one way (docs/architecture.md, "Floors"). The
terms are ``@ti.func``s in :mod:`melange_ti.physics.effects.terms` (``terms/NAME.py``; an
effect that owns state: its package's ``kernels.py``), linked to the effect by name from
above (:mod:`melange_ti.physics.step.terms`); its host side (``host.py``) likewise
(:mod:`melange_ti.physics.effects.hosts`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..data.columns import Column, Table

# A stress in the model's unit rho_w g w: such a [physics] key may also be given in Pa, as the
# same name with PA_SUFFIX, converted with scene.width_m (pascals); an energy per unit area (a
# fracture energy) in rho_w g w^2 likewise in J/m^2 with JM2_SUFFIX; both forms of one key are
# refused together (melange_ti.scene.core)
STRESS = "rho_w g w"
PA_SUFFIX = "_pa"
ENERGY_PER_AREA = "rho_w g w^2"
JM2_SUFFIX = "_jm2"
RHO_W_SI = 1025.0  # kg m^-3
G_SI = 9.81  # m s^-2


def pascals(width_m: float) -> float:
    """The model's stress unit ``rho_w g w`` in Pa for icebergs ``width_m`` metres wide."""
    return RHO_W_SI * G_SI * width_m


def joules_per_m2(width_m: float) -> float:
    """The model's energy per unit area ``rho_w g w^2`` in J/m^2 for icebergs ``width_m`` wide."""
    return pascals(width_m) * width_m


# the model's units a [physics] key may be given in SI instead: units -> (suffix, SI unit, SI per model unit)
SI_TWINS = {STRESS: (PA_SUFFIX, "Pa", pascals), ENERGY_PER_AREA: (JM2_SUFFIX, "J/m^2", joules_per_m2)}


@dataclass(frozen=True)
class Key:
    """A scene key under ``[physics]``: its default, units, meaning and the check its value
    must pass (``rule``, said in words by ``accepts``)."""

    name: str
    default: Any
    units: str
    doc: str
    rule: Callable[[Any], bool] | None = None
    accepts: str = ""
    required: bool = False  # a key of an array of tables ([[NAME]]) that has no default

    @classmethod
    def nonnegative(cls, name: str, default: Any, units: str, doc: str) -> Key:
        """A key whose value must be ``>= 0`` (a rate, a coefficient, a gap)."""
        return cls(name, default, units, doc, _nonnegative, "must be >= 0")

    @classmethod
    def positive(cls, name: str, default: Any, units: str, doc: str) -> Key:
        """A key whose value must be ``> 0`` (a length, a spacing)."""
        return cls(name, default, units, doc, _positive, "must be > 0")


def _nonnegative(v) -> bool:
    return v >= 0.0


def _positive(v) -> bool:
    return v > 0.0


def _zero(sample: dict) -> float:
    return 0.0


@dataclass(frozen=True)
class Quantity:
    """A named value an effect gives at every output event (``held``: an energy it holds,
    part of ``E``; a diagnostic of that name): units, meaning, the run-file format version
    that first holds it, and its value in a run without the effect (``without``, from the
    output event's sample; 0 unless given). ``at_step``: for a held energy, the key of the
    effect's sample that holds it as the run's diagnostic reads it, at the step time from the
    positions alone (docs/model.md, "What the budget promises"), where that is not ``name``."""

    name: str
    units: str
    doc: str
    since: int = 1
    without: Callable[[dict], float] = _zero
    at_step: str = ""


@dataclass(frozen=True)
class Dataset:
    """A variable an effect writes to the run file: ``path`` in the file (``snapshots/eta``:
    one row per snapshot, after ``time``; another group's, e.g. ``waves/x``: written once
    when the file is made, or, ``updated``, rewritten with every snapshot: the state of the
    last one), its dimensions after ``time`` (``("wave_cell",)``: dimensions its effect
    declares, or ``iceberg``; a dimension an effect declares is a variable at the file's
    root with its index, as ``iceberg``), ``dtype`` (``""``: the run's precision), units
    and meaning; ``coordinate``: the name under which :func:`melange_ti.open_run` attaches it
    to every group with its dimension (``wave_x``), or ``""``."""

    path: str
    dims: tuple[str, ...]
    units: str
    doc: str
    coordinate: str = ""
    updated: bool = False  # in a group other than snapshots: rewritten with every snapshot (not written once)
    dtype: str = ""  # numpy dtype in the file ("": the run's precision)

    @property
    def group(self) -> str:
        return self.path.split("/")[0]

    @property
    def name(self) -> str:
        return self.path.split("/")[1]


@dataclass(frozen=True)
class Effect:
    """One physical term a scene may name in ``scene.effects``.

    ``keys``: its ``[physics]`` keys (accepted whether or not the scene names the effect, so
    a scene can switch an effect on and off without editing values); ``params``: its slots
    in ``par`` (each with the ``source`` key it is filled from); ``body_columns``: its
    per-iceberg columns in ``b`` (a ``ledger`` column with an ``output`` name is summed into
    that diagnostic and checkpointed; marked ``budget``, it is booked in the energy budget);
    ``terms``: which of :data:`TERMS` it has, each a ``@ti.func`` of that name in
    ``melange_ti/physics/effects/terms/NAME.py`` (read by :func:`melange_ti.physics.step.terms.term`):

    ``force(a, i) -> ti.Vector([f_x, f_z, tau])``
                                               body force and torque on iceberg i
    ``torque``                                 True if ``force`` has a torque component
    ``horizontal``                             True if ``force`` has a horizontal component
                                               (only then does the kick touch ``VX``)
    ``own_offset``                             True if the effect books itself what every change
                                               of velocity after the kick, impulses included, does
                                               to its energy as the step keeps it (the bonds'
                                               ``bond_offset_work``): the impulses' half-kick
                                               offset then leaves its force's kick out
    ``offset_kick(a, i) -> ti.Vector([f_x, f_z, tau])``
                                               the force whose ``dt / m`` the impulses'
                                               half-kick offset adds to this step's kick of
                                               the velocities (``KICK_VX``, ...), for a force
                                               that kicks less often than every step (the
                                               waves': the slow kick's offset over its step)
    ``added_inertia(a, i) -> ti.Vector([m_a, I_a])``
                                               mass and moment of inertia added to the
                                               iceberg's own (the water it carries)
    ``after_kick(a, i)``                       right after the forces changed the velocities,
                                               before any damping
    ``damp(a, i, m, inertia)``                 applied to the velocities after the forces;
                                               ``m``, ``inertia``: the iceberg's with any
                                               added inertia
    ``pre_drift(a, i)``                        before the position update, the step's velocities final
    ``post_drift(a, i)``                       after the position update (after its sub-steps)
    ``substep_update(fx, a)``                  with ``substeps``: the effect's forces again at
                                               the sub-step's positions (a loop of its own,
                                               not per iceberg); ``force`` then gives them
    ``substep_damp(a, i, m, inertia)``         with ``substeps``: applied after each sub-step's
                                               kick of ``force`` (its damping)
    ``DRIFT_SUM`` (a tuple, not a function)    with ``substeps``: the iceberg row's three
                                               columns (x, z, angle) in which its
                                               ``pre_drift`` and ``substep_damp`` sum the
                                               velocities the sub-steps drifted with; the
                                               overlap correction predicts a contact's gap
                                               from them (``step.correction.drift_sum``)
    ``potential(a, i) -> U``                   its potential energy of iceberg i
    ``joined(a, i, j) -> ti.i32``              1 if the pair (i, j) has no contact (the effect
                                               holds it: an intact bond); ``joined_wall(a, i)``
                                               the same for the wall
    ``kept(a, i, j) -> ti.i32``                1 if the pair (i, j) touches through contacts
                                               but the effect holds its overlap (a bond
                                               beside a crevasse's walls): the overlap
                                               correction leaves it
    ``impulse(fx, a, i, j, rx1, rz1, rx2, rz2, nx, nz, vn, e, K_nn, m1, I1, c1n, m2, I2, c2n, kick_vn, room)
       -> (J_n, ti.Vector(ledger terms))``     the contact law's impulse (at most one named
                                               effect has it; without, the frictionless law
                                               of :func:`..step.impulses.resolve`), applied to the
                                               pair; the terms of the law's ledgers, the
                                               law's own then its ``law_ledgers``; with
                                               crushing, ``J_n`` at most ``room``

    ``beyond_paper``: the effect is not in the paper's model; its columns go after the
    paper's (a line of their own), so a scene that does not name it keeps the paper's row.

    An effect may own state beyond the icebergs' rows (the waves' grid), declared here:

    ``table``        its own table (a :class:`Table`, with its own namespace): its rows in the
                     model's owners' table ``a.own``, stacked with those of every other named
                     effect that owns one, in the registry's order; its kernels read its first
                     row and row count from ``cfg`` (:func:`..data.schema.own_rows`)
    ``rows_first``   its kernels index its rows from 0 (the waves' grid): it must be the first
                     effect that owns a table in the registry (checked at import), so its rows
                     start the stacked table whatever else the scene names
    ``config``       its integer settings in ``cfg`` (filled by its ``State``)
    ``run_ledgers``  its run-wide ledgers in ``acc`` (f64; a ``budget`` one is booked in the
                     energy budget, with its diagnostic, file variable and checkpoint)
    ``law_ledgers``  run-wide ledgers the contact law books per impulse (its ``impulse``
                     term returns their terms after the law's own): each also gets a
                     deferred column in the contacts (``DEF_NAME``), and every form books
                     them through one path (:func:`melange_ti.physics.data.schema.law_ledgers`)
    ``held``         the energies it holds (:class:`Quantity`), part of ``E``: a diagnostic
                     each, summed by :func:`melange_ti.energy.total_energy`
    ``datasets``     the variables it writes to the run file (:class:`Dataset`)
    ``dims``         the file dimensions it declares, ``{name: meaning}``
    ``check``        ``check(physics, dt) -> (key, value, accepts) | None``: the scene checks
                     its keys need beyond each key's own (called when a scene names it)
    ``tables``       the arrays of tables it reads from a scene, ``((name, keys, doc), ...)``:
                     ``[[name]]`` entries, each key checked as a scene key's
                     (``Scene.tables``); accepted whether or not the scene names it
    ``reports``      diagnostics it gives beyond energies (:class:`Quantity`; its sample
                     gives each, 0 in a run without it)
    ``requires``     effects of which the scene must name at least one with it, and
    ``requires_doc`` why (the refusal's words)
    ``joins``        it joins the cells of an iceberg given as ``cells = [nx, nz]`` across
                     their shared faces (a scene with cells must name such an effect)
    ``substeps``     the scene key of the sub-steps its stiff forces ask of the drift (``n``,
                     an integer >= 1): the step's drift is ``n`` sub-steps of ``dt / n``,
                     between which its ``substep_update`` and the kick of its ``force`` (times
                     ``dt``: an effect that sub-steps gives ``dt / n`` of a step's share,
                     its force over ``n``) and ``substep_damp`` run; every other force, the
                     contacts and the correction once a step (:class:`..step.parts.Substeps`);
                     compiled only when a scene asks for more than one (``Effects.substepped``)

    Its kernels and host code are linked to it by name from the floors above (a declaration
    imports neither): its Taichi side, the module of its terms and ``STAGES``
    (``((anchor, Stage), ...)``, each stage run after the step's stage ``anchor``:
    :data:`melange_ti.physics.stages.STEP`), in :mod:`melange_ti.physics.step.terms`; an
    effect that owns a table, its host side (a :class:`State`, made by the model only when
    the scene names the effect) and any check that needs the initial state
    (``check_start(scene, icebergs) -> (key, value, accepts) | None``), in
    :mod:`melange_ti.physics.effects.hosts`.

    A term is compiled into the kernels only when the scene names the effect
    (``ti.static``), so an effect not named costs nothing; an effect's table, datasets,
    checkpoint entry and stages exist only in a model of a scene that names it.
    """

    name: str
    doc: str
    keys: tuple[Key, ...] = ()
    params: tuple[Column, ...] = ()
    body_columns: tuple[Column, ...] = ()
    terms: tuple[str, ...] = ()
    torque: bool = False
    horizontal: bool = False
    own_offset: bool = False
    beyond_paper: bool = False
    table: Table | None = None
    rows_first: bool = False
    config: tuple[Column, ...] = ()
    run_ledgers: tuple[Column, ...] = ()
    law_ledgers: tuple[Column, ...] = ()
    held: tuple[Quantity, ...] = ()
    datasets: tuple[Dataset, ...] = ()
    dims: tuple[tuple[str, str], ...] = ()
    check: Callable | None = None
    tables: tuple[tuple[str, tuple[Key, ...], str], ...] = ()
    reports: tuple[Quantity, ...] = ()
    requires: tuple[str, ...] = ()
    requires_doc: str = ""
    joins: bool = False
    substeps: str = ""

    def __post_init__(self):
        unknown = set(self.terms) - set(TERMS)
        if unknown:
            raise ValueError(f"effect {self.name}: unknown terms {sorted(unknown)} (known: {', '.join(TERMS)})")
        if self.law_ledgers and "impulse" not in self.terms:
            raise ValueError(f"effect {self.name}: law_ledgers are booked from its impulse term, which it lacks")
        own_dims = {name for name, _ in self.dims}
        # over its own dimensions, and the icebergs': the writer knows the effect is named from
        # its State's dimensions, so an effect that writes any dataset declares one
        for d in self.datasets:
            if not d.dims or not own_dims or not set(d.dims) <= own_dims | {"iceberg"}:
                raise ValueError(f"effect {self.name}: dataset {d.path} must lie over dimensions it declares {sorted(own_dims)}")

    def on(self, fx) -> bool:
        """Whether the frozen effect set ``fx`` names this effect (use inside ``ti.static``)."""
        return bool(getattr(fx, self.name))


TERMS = (
    "force",
    "offset_kick",
    "added_inertia",
    "after_kick",
    "damp",
    "pre_drift",
    "post_drift",
    "substep_update",
    "substep_damp",
    "potential",
    "impulse",
    "joined",
    "joined_wall",
    "kept",
)


class State:
    """The host side of an effect that owns state, made by the model of a scene that names
    the effect (linked in :mod:`.hosts`; Oceananigans' ``materialize_free_surface``: a scene without
    the effect has none). numpy only; the model moves the arrays.

    ``rows``: rows of its table (``Effect.table``); the methods below return what the model
    fills, writes and reads, each from the table's rows as numpy (``rows_`` below: the
    table's content, fetched by the model or copied inside a fused launch: the same bits)."""

    rows: int = 1
    model: Any = None  # the model it belongs to (set by the model)
    first_row: int = 0  # its first row in the owners' table a.own (set by the model)

    def params(self) -> dict[str, float]:
        """Values of its parameter slots that no scene key gives (``{column name: value}``)."""
        return {}

    def config(self) -> dict[str, int]:
        """Values of its ``config`` slots."""
        return {}

    def initial(self) -> Any:
        """Its table's content at t = 0 (numpy, ``(rows, table.size)``)."""
        raise NotImplementedError

    def dims(self) -> dict[str, int]:
        """The length of each file dimension it declares."""
        return {}

    def constants(self) -> dict[str, Any]:
        """Its datasets written once (``{path: array}``)."""
        return {}

    def bodies(self, rows) -> None:
        """Fill its per-iceberg columns in ``rows`` (the bodies' table at t = 0, numpy)."""

    def sample(self, rows_, bodies) -> dict[str, Any]:
        """Its snapshot and updated datasets (by name), held energies and reports at an
        output event, from its table's rows and ``bodies``: the icebergs' sample of the
        same instant (``x``, ``z``, ``theta``, ...)."""
        return {}

    def refresh(self) -> None:
        """After the host set part of its table (a script, a test): recompute what the step
        keeps from it, with a kernel of its own on ``self.model.arrays`` (a checkpoint
        restores the whole table, caches included)."""
