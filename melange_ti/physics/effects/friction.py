"""Coulomb friction at iceberg-iceberg and wall contacts (beyond the paper).

Each impulse of the contact law (:mod:`..impulses`) is followed, at the same contact, by a
tangential impulse along ``t = (-n_z, n_x)`` that opposes the tangential relative velocity
``v_t`` the normal impulse left, clamped by Coulomb's law to ``|J_t| <= mu J_n``:

``J_t = clamp(-v_t / K_t, -mu J_n, mu J_n)``,
``K_t = 1/m_i + 1/m_j + (r_i x t)^2 / I_i + (r_j x t)^2 / I_j``.

Unclamped, the contact sticks (``v_t' = 0``); clamped, it slips (``v_t' = v_t + J_t K_t``,
same sign as ``v_t``). Equal and opposite at one point, it conserves the pair's momentum and
angular momentum; the kinetic energy it removes, ``-J_t (v_t + J_t K_t / 2) >= 0``
(``0.5 v_t^2 / K_t`` when sticking), is booked in ``friction_dissipated``, and its half-kick
offset with the normal impulse's in ``impulse_offset_work``. The wall is a partner of
infinite mass. The order of the pass, and so its bits, is the contact law's.
"""

from ..columns import Column
from .base import Effect, Key

EFFECT = Effect(
    name="friction",
    doc="beyond the paper: Coulomb friction at iceberg-iceberg and wall contacts, |J_t| <= friction * J_n "
    "(stick or slip); booked in friction_dissipated",
    keys=(
        Key.nonnegative(
            "friction", 0.3, "1", "mu, Coulomb friction coefficient of ice on ice and on the wall (used with the friction effect)"
        ),
    ),
    params=(Column("FRICTION", "constant", "1", "Coulomb friction coefficient mu", source="physics.friction"),),
    beyond_paper=True,
)
