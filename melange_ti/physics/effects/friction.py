"""Coulomb friction at iceberg-iceberg and wall contacts (beyond the paper).

With it the contact law (its ``impulse`` term, :func:`.terms.friction.impulse`) is Newton's restitution with Coulomb's
cone, one impulse ``J = J_n n + J_t t`` (``t = (-n_z, n_x)``) solved with the contact point's
2x2 effective-mass matrix ``K`` (``K_nt`` couples the directions at an off-centre contact):
``v_n' = -e v_n`` always; the contact sticks (``v_t' = 0``) when that impulse lies in the cone
``|J_t| <= mu J_n``, else it slides on the cone's edge, ``J_t = s mu J_n``,
``J_n = -(1 + e) v_n / (K_nn + s mu K_nt)``. Equal and opposite at one point, it conserves the
pair's momentum and angular momentum; each impulse's work at its direction's mean velocity is
booked, ``-J_n (v_n + v_n') / 2`` in ``collision_dissipated`` and ``-J_t (v_t + v_t') / 2`` in
``friction_dissipated`` (their sum is the kinetic energy lost), its half-kick offset in
``impulse_offset_work``. The wall is a partner of infinite mass. The order of the pass, and
so its bits, is the contact law's; ``mu = 0`` gives the frictionless impulse to the bit.
Derived in docs/model.md ("Contacts").
"""

from ..data.columns import Column, E
from .base import Effect, Key

EFFECT = Effect(
    name="friction",
    doc="beyond the paper: Coulomb friction at iceberg-iceberg and wall contacts, |J_t| <= friction * J_n "
    "(stick or slide, coupled with the restitution); booked in friction_dissipated",
    keys=(
        Key.nonnegative(
            "friction", 0.3, "1", "mu, Coulomb friction coefficient of ice on ice and on the wall (used with the friction effect)"
        ),
    ),
    params=(Column("FRICTION", "constant", "1", "Coulomb friction coefficient mu", source="physics.friction"),),
    beyond_paper=True,
    terms=("impulse",),
    law_ledgers=(
        Column(
            "FRICTION",
            "ledger",
            E,
            "energy removed by friction impulses, -J_t (v_t + J_t K_t / 2) each (0 without the friction effect)",
            "friction_dissipated",
            budget=True,
            since=4,
        ),
    ),
    requires=("collisions", "wall"),
    requires_doc="friction acts at contacts",
)
