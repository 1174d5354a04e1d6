"""Added mass: the water set in motion by an accelerating iceberg (beyond the paper).

``m_a = C_a rho_w A_sub`` on translation and ``I_a = C_i rho_w J_sub`` on rotation, with
``A_sub`` the submerged area and ``J_sub`` its polar second moment about the centre of mass
(:func:`..shape.hydrostatics.wetted`), added to the iceberg's own mass and inertia where the
accelerations from body forces are computed (``v += dt F / (m + m_a)``), in the drags, and
in the contact law and the overlap correction (an impulse must set the carried water in
motion too; with it the impulse's exact dissipation ``0.5 (1 - e^2) vn^2 / K`` holds for the
kinetic energy of ice and water together). A floating block then heaves with period
``2 pi sqrt((1 + C_a) d / g)`` and rolls with ``2 pi sqrt((I + I_a) / (m g GM))``.

**Energy.** ``kinetic_energy`` includes the water's, ``0.5 m_a |v|^2 + 0.5 I_a omega^2``. The
added mass changes as the submerged part does, and with ``(m + m_a) dv/dt = F`` the total
energy then changes by ``0.5 (dm_a/dt) |v|^2 + 0.5 (dI_a/dt) omega^2``: energy this simple model
exchanges with the rest of the ocean. It is booked per step (after the drift, from the
change of ``m_a`` and ``I_a`` over the step) in ``added_mass_work``, so the budget
``E(0) - E(t) = drag + collisions + corrections + added_mass_work`` still closes.
"""

from ..data.columns import Column, E
from .base import Effect, Key

EFFECT = Effect(
    name="added_mass",
    doc="beyond the paper: the water's added mass C_a rho_w A_sub and added inertia C_i rho_w J_sub",
    keys=(
        Key.nonnegative("added_mass", 0.5, "1", "C_a, added-mass coefficient (used with the added_mass effect)"),
        Key.nonnegative("added_inertia", 0.5, "1", "C_i, added-inertia coefficient (used with the added_mass effect)"),
    ),
    params=(
        Column("ADDED_MASS", "constant", "1", "added-mass coefficient C_a", source="physics.added_mass"),
        Column("ADDED_INERTIA", "constant", "1", "added-inertia coefficient C_i", source="physics.added_inertia"),
    ),
    body_columns=(
        Column("ADDED_M", "scratch", "rho_w w^2", "added mass at this step's kick"),
        Column("ADDED_I", "scratch", "rho_w w^4", "added moment of inertia at this step's kick"),
        Column(
            "ADDED_WORK",
            "ledger",
            E,
            "energy the added mass exchanged with the ocean as it changed, -0.5 dm_a |v|^2 - 0.5 dI_a omega^2",
            "added_mass_work",
            budget=True,
            since=3,
        ),
    ),
    terms=("added_inertia", "post_drift"),
    beyond_paper=True,
)
