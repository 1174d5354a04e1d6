"""What an effect declares: its scene keys, parameter slots, per-body columns and terms.

A declaration imports no Taichi, so the scene, the schema and the run-file readers built
from it work where Taichi is not installed; the terms are ``@ti.func``s in
:mod:`melange_ti.physics.terms` (``terms/NAME.py``), imported when a kernel first asks.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..columns import Column


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


@dataclass(frozen=True)
class Quantity:
    """A named value an effect gives at every output event (``held``: an energy it holds,
    part of ``E``; a diagnostic of that name): units, meaning, and the run-file format
    version that first holds it."""

    name: str
    units: str
    doc: str
    since: int = 1


@dataclass(frozen=True)
class Effect:
    """One physical term a scene may name in ``scene.effects``.

    ``keys``: its ``[physics]`` keys (accepted whether or not the scene names the effect, so
    a scene can switch an effect on and off without editing values); ``params``: its slots
    in ``par`` (each with the ``source`` key it is filled from); ``body_columns``: its
    per-iceberg columns in ``b`` (a ``ledger`` column with an ``output`` name is summed into
    that diagnostic and checkpointed; marked ``budget``, it is booked in the energy budget);
    ``terms``: which of :data:`TERMS` it has, each a ``@ti.func`` of that name in
    ``melange_ti/physics/terms/NAME.py`` (read as ``effect.force`` etc.; ``None`` when absent):

    ``force(a, i) -> ti.Vector([f_x, f_z, tau])``
                                               body force and torque on iceberg i
    ``torque``                                 True if ``force`` has a torque component
    ``horizontal``                             True if ``force`` has a horizontal component
                                               (only then does the kick touch ``VX``)
    ``added_inertia(a, i) -> ti.Vector([m_a, I_a])``
                                               mass and moment of inertia added to the
                                               iceberg's own (the water it carries)
    ``damp(a, i, m, inertia)``                 applied to the velocities after the forces;
                                               ``m``, ``inertia``: the iceberg's with any
                                               added inertia
    ``post_drift(a, i)``                       after the position update
    ``potential(a, i) -> U``                   its potential energy of iceberg i

    ``beyond_paper``: the effect is not in the paper's model; its columns go after the
    paper's (a line of their own), so a scene that does not name it keeps the paper's row.

    A term is compiled into the kernels only when the scene names the effect
    (``ti.static``), so an effect not named costs nothing.
    """

    name: str
    doc: str
    keys: tuple[Key, ...] = ()
    params: tuple[Column, ...] = ()
    body_columns: tuple[Column, ...] = ()
    terms: tuple[str, ...] = ()
    torque: bool = False
    horizontal: bool = False
    beyond_paper: bool = False
    held: tuple[Quantity, ...] = ()

    def __post_init__(self):
        unknown = set(self.terms) - set(TERMS)
        if unknown:
            raise ValueError(f"effect {self.name}: unknown terms {sorted(unknown)} (known: {', '.join(TERMS)})")

    def on(self, fx) -> bool:
        """Whether the frozen effect set ``fx`` names this effect (use inside ``ti.static``)."""
        return bool(getattr(fx, self.name))

    def term(self, which: str) -> Callable | None:
        """The ``@ti.func`` ``which`` of this effect (imports Taichi), or ``None``."""
        if which not in self.terms:
            return None
        return getattr(importlib.import_module(f"melange_ti.physics.terms.{self.name}"), which)

    force = property(lambda self: self.term("force"))
    added_inertia = property(lambda self: self.term("added_inertia"))
    damp = property(lambda self: self.term("damp"))
    post_drift = property(lambda self: self.term("post_drift"))
    potential = property(lambda self: self.term("potential"))


TERMS = ("force", "added_inertia", "damp", "post_drift", "potential")
