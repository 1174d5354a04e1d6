"""Ice crushing at contacts (beyond the paper): a contact's force is bounded by what the ice
can carry before it crushes.

A rigid contact (the paper's, :mod:`.collisions`) delivers its impulse within one step, so the
force it puts into elastic ice (bonds) is bounded only by the ice's stiffness. Real ice fails
in compression at the contact: a crushing pressure ``p_c`` (ice's pressure-area relation,
ISO 19906) over a contact ``h_c`` high bounds the force per unit length along the front at
``F_c = p_c h_c``. With this
effect each contact (one per touching pair, or an iceberg and the wall) passes at most
``F_c dt`` of normal impulse per step, ``F_c = crushing_pressure * crushing_height``: the
contact law's impulse (restitution, with friction its tangential part too) is scaled down to
that, so the rest of the momentum goes over the following steps, while the pair keeps
closing and the ice at the contact crushes (the overlap correction keeps the crushed overlap,
up to one disc radius). The normal work ``-J_n (v_n + J_n K / 2)`` of each scaled impulse goes
to ``collision_dissipated``, the crushing's (with friction, its tangential part's to
``friction_dissipated``). An impact slow enough to be stopped within one step
by ``F_c`` takes the rigid law's impulse to the bit; only the correction differs (it keeps an
overlap up to a disc radius), so a run whose correction pushes nothing is the rigid law's.
Derived and validated in docs/model.md ("Crushing") and docs/validation.md ("Impacts into
elastic ice").
"""

from ..data.columns import Column
from .base import STRESS, Effect, Key

EFFECT = Effect(
    name="crushing",
    doc="beyond the paper: ice crushing at contacts, each contact's force at most crushing_pressure * "
    "crushing_height (the impulse spread over the steps it takes); its work booked in collision_dissipated",
    keys=(
        Key.positive(
            "crushing_pressure",
            2.0,
            STRESS,
            "p_c, the mean pressure at which ice crushes over a contact (1.4 MPa at w = 70 m, within the 1-3 MPa of "
            "ice's pressure-area curves at tens of square metres; or give crushing_pressure_pa in Pa; used with the "
            "crushing effect)",
        ),
        Key.positive(
            "crushing_height",
            0.1,
            "w",
            "h_c, the height of ice a contact crushes over: a contact's force is at most crushing_pressure * "
            "crushing_height per unit length along the front (used with the crushing effect)",
        ),
    ),
    params=(
        Column("CRUSH_PRESSURE", "constant", STRESS, "crushing pressure p_c", source="physics.crushing_pressure"),
        Column("CRUSH_HEIGHT", "constant", "w", "height a contact crushes over, h_c", source="physics.crushing_height"),
    ),
    beyond_paper=True,
    requires=("collisions", "wall"),
    requires_doc="crushing acts at contacts",
)
