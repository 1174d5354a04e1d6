"""The effects a scene may name (``scene.effects``): one module each, listed in :data:`REGISTRY`.

Each module declares an :class:`~.base.Effect`: its ``[physics]`` keys and their checks, its
parameter slots, its per-iceberg columns (an energy ledger among them), which ``@ti.func``
terms it has and where (its ``kernels``: ``terms/NAME.py``, imported by name when a kernel
is compiled: this package imports no Taichi), and what state it owns (the waves: a package
of their own, ``waves/``). From the registry come the scene's keys and validation
(:mod:`melange_ti.scene`), the parameter fill and the owned state (:mod:`melange_ti.model`),
the schema's columns (:mod:`..data.schema`), the step's stages, the run file, the
diagnostics and the energy budget. To add an effect: write its declaration here and its
kernels, add it to :data:`REGISTRY`, and describe it in the docs (docs/architecture.md).

The order is the order in which forces are summed, and so part of the results' bits.
"""

from dataclasses import make_dataclass

from . import added_mass, bonds, buoyancy, collisions, crushing, drag, form_drag, friction, gravity, wall, waves
from .base import Dataset, Effect, Key, Quantity, State

REGISTRY: tuple[Effect, ...] = (
    gravity.EFFECT,
    buoyancy.EFFECT,
    drag.EFFECT,
    form_drag.EFFECT,
    added_mass.EFFECT,
    collisions.EFFECT,
    wall.EFFECT,
    friction.EFFECT,
    crushing.EFFECT,
    waves.EFFECT,
    bonds.EFFECT,
)
NAMES: tuple[str, ...] = tuple(e.name for e in REGISTRY)
PAPER_EFFECTS: tuple[str, ...] = tuple(e.name for e in REGISTRY if not e.beyond_paper)  # a scene's default
BY_NAME = {e.name: e for e in REGISTRY}
FORCES = tuple(e for e in REGISTRY if "force" in e.terms)
DAMPERS = tuple(e for e in REGISTRY if "damp" in e.terms)
OFFSET_KICK = tuple(e for e in REGISTRY if "offset_kick" in e.terms)
AFTER_KICK = tuple(e for e in REGISTRY if "after_kick" in e.terms)
ADDED = tuple(e for e in REGISTRY if "added_inertia" in e.terms)
PRE_DRIFT = tuple(e for e in REGISTRY if "pre_drift" in e.terms)
POST_DRIFT = tuple(e for e in REGISTRY if "post_drift" in e.terms)
SUBSTEPPED = tuple(e for e in REGISTRY if e.substeps)  # effects whose forces the drift sub-steps (bonds)
POTENTIALS = tuple(e for e in REGISTRY if "potential" in e.terms)
IMPULSE_LAW = tuple(e for e in REGISTRY if "impulse" in e.terms)  # effects that replace the contact law's impulse
JOINED = tuple(e for e in REGISTRY if "joined" in e.terms)  # effects that hold a pair's contact (bonds)
JOINED_WALL = tuple(e for e in REGISTRY if "joined_wall" in e.terms)
KEPT = tuple(e for e in REGISTRY if "kept" in e.terms)  # effects that hold a touching pair's overlap (bonds)
OWNERS = tuple(e for e in REGISTRY if e.table is not None)  # effects that own a table (``a.own``)
# an owner whose kernels index its rows from 0 (``rows_first``) must come first among them: its
# rows then start the stacked table whatever else a scene names


def clashes(effects) -> list[str]:
    """File dimensions and dataset paths that more than one of ``effects`` declares: a scene may
    name them all together, and the run file has one of each name."""
    names = [n for e in effects for n, _ in e.dims] + [d.path for e in effects for d in e.datasets]
    return sorted({n for n in names if names.count(n) > 1})


if clashes(REGISTRY):
    raise ImportError(f"two effects declare the same file dimension or dataset: {clashes(REGISTRY)}")
if any(e.rows_first for e in OWNERS[1:]):
    raise ImportError(f"only the first effect that owns a table may index its rows from 0: {[e.name for e in OWNERS]}")


def _contacts(self) -> bool:
    """True when any contact (iceberg-iceberg or wall) is simulated."""
    return self.collisions or self.wall


def _names(self) -> list[str]:
    return [n for n in NAMES if getattr(self, n)]


def _owners(self) -> tuple[Effect, ...]:
    """The named effects that own a table, in the registry's order: their rows are stacked in
    that order in the model's one owners' table ``a.own`` (docs/architecture.md)."""
    return tuple(e for e in OWNERS if getattr(self, e.name))


def _named(self) -> tuple[Effect, ...]:
    """The named effects' declarations, in the registry's order."""
    return tuple(e for e in REGISTRY if getattr(self, e.name))


Effects = make_dataclass(
    "Effects",
    [*((n, bool, False) for n in NAMES), ("coloured", bool, False), ("vertices", int, 0), ("substepped", bool, False)],
    frozen=True,
    namespace={
        "contacts": property(_contacts),
        "owners": property(_owners),
        "owns": property(lambda self: bool(_owners(self))),
        "named": property(_named),
        "names": _names,
        "__doc__": "Which effects are compiled into the model, and ``coloured``: the contact passes run colour by "
        "colour (``contacts.order``, :mod:`..forms.colours`), not in body order; ``vertices``: the most corners of "
        "an outline when any iceberg is a polygon (``[[iceberg]] vertices``: the kernels then read every outline "
        "from its corners, :mod:`..shape.hydrostatics`), 0 when all are rectangles; ``substepped``: a named effect "
        "sub-steps the drift, more than once (``Effect.substeps``: the kernels then compile the sub-steps; with one "
        "sub-step the step is compiled as without them).",
    },
)
Effects.__module__ = __name__

__all__ = [
    "REGISTRY",
    "NAMES",
    "PAPER_EFFECTS",
    "BY_NAME",
    "Effect",
    "Effects",
    "Key",
    "FORCES",
    "DAMPERS",
    "OFFSET_KICK",
    "AFTER_KICK",
    "ADDED",
    "POST_DRIFT",
    "POTENTIALS",
    "OWNERS",
    "clashes",
    "JOINED",
    "JOINED_WALL",
    "KEPT",
    "IMPULSE_LAW",
    "Dataset",
    "Quantity",
    "State",
]
