"""What an effect declares: its scene keys, parameter slots, per-body columns and terms."""

from __future__ import annotations

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


@dataclass(frozen=True)
class Effect:
    """One physical term a scene may name in ``scene.effects``.

    ``keys``: its ``[physics]`` keys (accepted whether or not the scene names the effect, so
    a scene can switch an effect on and off without editing values); ``params``: its slots
    in ``par`` (each with the ``source`` key it is filled from); ``body_columns``: its
    per-iceberg columns in ``b`` (a ``ledger`` column with an ``output`` name is summed into
    that diagnostic, checkpointed and booked in the energy budget); and its terms, each a
    ``@ti.func`` or ``None``:

    ``force(a, i) -> ti.Vector([f_z, tau])``  body force and torque on iceberg i
    ``torque``                                 True if ``force`` has a torque component
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
    force: Callable | None = None
    torque: bool = False
    added_inertia: Callable | None = None
    damp: Callable | None = None
    post_drift: Callable | None = None
    potential: Callable | None = None
    beyond_paper: bool = False

    def on(self, fx) -> bool:
        """Whether the frozen effect set ``fx`` names this effect (use inside ``ti.static``)."""
        return bool(getattr(fx, self.name))
