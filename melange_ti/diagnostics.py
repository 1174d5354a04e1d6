"""Diagnostics: the scalar time series of a run (:data:`FIELDS`, each with its computation),
and pure numpy functions of the state (docs/model.md, docs/output.md)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from .physics.data.schema import ACCUMULATORS, BODIES, ENERGY_LEDGERS, E
from .physics.effects import REGISTRY


class Event(NamedTuple):
    """What the diagnostics of one output event are computed from: the state the step before
    it left (``sample``, ``totals``) and, for the kinetic energy at the step time, the sample
    the next step leaves (``after``: its ``half_kick``, :meth:`kinetic`)."""

    t: float  # time of the event
    sample: dict[str, np.ndarray]  # Model.sample(): state, per-body ledgers, kinetic, potential, (N,)
    totals: Any  # Model.Totals of the same instant (run-wide ledgers and the impulse count)
    previous: Any  # totals at the previous diagnostic: t, impulses, wall_impulse, impulse_sum
    x0_max: float  # max_i x_i(0)
    after: dict[str, np.ndarray]  # Model.sample() one step later (its half_kick)

    def rate(self, name: str) -> float:
        """Change of the run-wide total ``name`` per unit time since the previous diagnostic."""
        span = self.t - self.previous.t
        return (getattr(self.totals, name) - getattr(self.previous, name)) / span if span > 0 else 0.0

    def kinetic(self) -> float:
        """The kinetic energy at the step time: ``0.5 m v0 . v1`` summed, ``v0`` the velocities
        the step before left (half a kick before the step time), ``v1`` those after the next
        step's forces' kick (half a kick after it): the sample's kinetic energy plus the next
        step's ``half_kick`` (docs/model.md, "What the budget promises")."""
        ke = float(np.sum(self.sample["kinetic"], dtype=np.float64))
        return ke + float(np.sum(self.after["half_kick"], dtype=np.float64))


class Field(NamedTuple):
    """One diagnostic: name, dtype, units, meaning, how it is computed from an :class:`Event`,
    and the run-file format version that first holds it (``since``: plotting reads older
    files without it, so adding a field with the next version breaks no older file)."""

    name: str
    dtype: str
    units: str
    long_name: str
    compute: Callable[[Event], float]
    since: int = 1
    owner: str | None = None  # the effect whose diagnostic it is: in a run file only when the scene names it


def _ledger_fields() -> tuple[Field, ...]:
    """Every energy ledger of the schema (:data:`schema.ENERGY_LEDGERS`: per-body ledgers
    summed over the icebergs, then the run-wide ones): a ledger column added by an effect
    appears here with no other edit."""
    cols = {c.output: c for t in (BODIES, ACCUMULATORS) for c in t.columns if c.output}
    per_body = set(BODIES.outputs("ledger"))

    def field(name: str) -> Field:
        if name in per_body:
            compute = lambda e: float(np.sum(e.sample[name]))  # noqa: E731
        else:
            compute = lambda e: getattr(e.totals, name)  # noqa: E731
        # drag_dissipated is the paper's (SPEC): every run holds it, form_drag books into it too
        owner = cols[name].owner if cols[name].owner != "drag" else None
        return Field(name, "f8", cols[name].units, cols[name].doc, compute, cols[name].since, owner)

    return tuple(field(name) for name in ENERGY_LEDGERS)


def _held_fields() -> tuple[Field, ...]:
    """Every energy an effect holds (its declaration's ``held``), part of ``E``: the value the
    effect's sample gives; without the effect, the declaration's ``without`` (0)."""

    def field(q, owner: str) -> Field:
        key = q.at_step or q.name  # read from the positions: the sample's own instant
        return Field(q.name, "f8", q.units, q.doc, lambda e: float(e.sample.get(key, q.without(e.sample))), q.since, owner)

    return tuple(field(q, eff.name) for eff in REGISTRY for q in eff.held)


def _report_fields() -> tuple[Field, ...]:
    """Every diagnostic an effect reports beyond energies (its declaration's ``reports``), a
    count: the value its sample gives; without the effect, the declaration's ``without``
    (``fragments``: the icebergs, each its own piece; any other 0)."""

    def field(q, owner: str) -> Field:
        return Field(q.name, "i8", q.units, q.doc, lambda e: int(e.sample.get(q.name, q.without(e.sample))), q.since, owner)

    return tuple(field(q, eff.name) for eff in REGISTRY for q in eff.reports)


HELD: tuple[str, ...] = tuple(q.name for eff in REGISTRY for q in eff.held)  # energies part of E beyond the icebergs'

FIELDS: tuple[Field, ...] = (
    Field(
        "capsized_fraction",
        "f8",
        "1",
        "fraction of icebergs capsized (tilted 45 degrees or more)",
        lambda e: capsized_fraction(e.sample["theta"], e.sample.get("axis")),
    ),
    Field(
        "leading_edge",
        "f8",
        "w",
        "leading edge: how far the front (the foremost iceberg centre) has advanced since t = 0",
        lambda e: leading_edge(e.sample["x"], e.x0_max),
    ),
    Field(
        "kinetic_energy",
        "f8",
        E,
        "kinetic energy, summed over icebergs, at the step time (0.5 m v0 . v1, the velocities half a kick before and after it)",
        lambda e: e.kinetic(),
    ),
    Field(
        "potential_energy",
        "f8",
        E,
        "potential energy (gravity and buoyancy), summed over icebergs",
        lambda e: float(np.sum(e.sample["potential"])),
    ),
    *_held_fields(),
    *_ledger_fields(),
    Field(
        "contacts",
        "i8",
        "1",
        "impulses applied since the previous diagnostic",
        lambda e: e.totals.impulses - e.previous.impulses,
        since=3,
    ),
    Field(
        "wall_force",
        "f8",
        "rho_w g w^2",
        "mean horizontal force on the wall since the previous diagnostic",
        lambda e: e.rate("wall_impulse"),
        since=3,
    ),
    Field(
        "impulse_rate",
        "f8",
        "rho_w g w^2",
        "sum of impulses per unit time since the previous diagnostic",
        lambda e: e.rate("impulse_sum"),
        since=3,
    ),
    *_report_fields(),
)
NAMES: tuple[str, ...] = tuple(f.name for f in FIELDS)


# The run-file format from which a run holds only the diagnostics of the effects its scene
# names (io.hdf5.FORMAT_VERSION 7); older files hold every one, 0 for an effect not named
OWN_DIAGNOSTICS_SINCE = 7


def fields(effects: Any = None) -> tuple[Field, ...]:
    """The diagnostics of a run whose scene names ``effects`` (an ``Effects``, or anything
    with a true attribute per effect named; ``None``: every one): the model's own and those
    of the effects named ("simulate only the effects a scene calls for")."""
    return tuple(f for f in FIELDS if effects is None or f.owner is None or getattr(effects, f.owner))


def row(event: Event, chosen: tuple[Field, ...] = FIELDS) -> dict[str, float]:
    """The diagnostics ``chosen`` (default: every one) of one event, ``time`` first."""
    return {"time": event.t, **{f.name: f.compute(event) for f in chosen}}


def required(format_version: int, effects: Any = None) -> tuple[str, ...]:
    """The diagnostics every run file of ``format_version`` holds (``time`` first); from
    :data:`OWN_DIAGNOSTICS_SINCE` on, only those of its scene's ``effects`` (given: else
    every one)."""
    chosen = fields(effects) if format_version >= OWN_DIAGNOSTICS_SINCE else FIELDS
    return ("time", *(f.name for f in chosen if f.since <= format_version))


def capsize_angle(theta: np.ndarray, axis: np.ndarray | None = None) -> np.ndarray:
    """``phi = |theta|`` folded into [0, pi/2]: the long axis' distance from vertical. For a
    polygon, ``axis`` (``/icebergs/axis``, :func:`melange_ti.geometry.principal_axis`): the
    angle from the body's v axis to the principal axis of its area nearest it, so ``phi`` is
    that axis' distance from vertical (``None`` or 0: a rectangle's, v itself)."""
    if axis is not None:
        theta = theta + axis
    m = np.mod(np.abs(theta), np.pi)
    return np.minimum(m, np.pi - m)


def capsized(theta: np.ndarray, axis: np.ndarray | None = None) -> np.ndarray:
    """Boolean mask of icebergs with ``phi >= pi/4``."""
    return capsize_angle(theta, axis) >= np.pi / 4


def capsized_fraction(theta: np.ndarray, axis: np.ndarray | None = None) -> float:
    return float(np.mean(capsized(theta, axis))) if theta.size else 0.0


def leading_edge(x: np.ndarray, x0_max: float) -> float:
    """``max_i x_i(t) - max_i x_i(0)``."""
    return float(np.max(x) - x0_max)


def capsize_energy(density_ratio: float, width: float, thickness: float) -> float:
    """Potential energy released by one capsize, upright to flat: ``0.5 r (1-r) w h (h-w)``."""
    r = density_ratio
    return 0.5 * r * (1 - r) * width * thickness * (thickness - width)


def critical_aspect(density_ratio: float) -> float:
    """Thickness/width above which upright is unstable: ``1/sqrt(6 r (1-r))``."""
    return 1.0 / np.sqrt(6 * density_ratio * (1 - density_ratio))


def roll_period(density_ratio: float, width: float, thickness: float) -> float:
    """Small-amplitude roll period of a stable upright rectangle (no added mass)."""
    d = density_ratio * thickness
    gm = d / 2 + width**2 / (12 * d) - thickness / 2
    return 2 * np.pi / np.sqrt(12 * gm / (width**2 + thickness**2))


def heave_period(density_ratio: float, thickness: float) -> float:
    """Small-amplitude heave period ``2 pi sqrt(draft / g)``."""
    return 2 * np.pi * np.sqrt(density_ratio * thickness)
