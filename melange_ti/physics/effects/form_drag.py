"""Form drag: the water's quadratic pressure drag on the submerged part (beyond the paper).

Translation: ``F = -0.5 rho_w C_d P(v) |v| v``, with ``P(v)`` the submerged part's width
projected normal to ``v`` (per unit length into the page). Rotation: each wetted face element
``ds`` at arm ``r`` with outward normal ``n`` moves into the water at ``u_n = omega (r x n)``
and feels ``-0.5 rho_w C_d |u_n| u_n n ds``; summed, the torque is
``tau = -0.5 rho_w C_d omega |omega| R3`` with ``R3 = int_wetted |r x n|^3 ds``
(:func:`..shape.hydrostatics.wetted`), the quadratic analogue of a rotating plate's drag.

Both are applied after the body forces, implicitly in the speed:
``v <- v / (1 + k |v| dt)`` with ``k = 0.5 rho_w C_d P / m`` (and likewise omega with
``0.5 rho_w C_d R3 / I``), which never reverses a velocity and gives
``1/v_(n+1) = 1/v_n + k dt``: exactly the continuous decay ``v0 / (1 + k v0 t)`` at the
step times while ``P`` is constant. ``m`` and ``I`` include the water's added inertia when
``added_mass`` is on. The kinetic energy removed is booked in ``drag_dissipated``.
"""

from ..data.columns import Column
from .base import Effect, Key

EFFECT = Effect(
    name="form_drag",
    doc="beyond the paper: the water's quadratic pressure drag on the submerged part, "
    "F = -0.5 rho_w C_d P(v) |v| v and a matching torque; booked in drag_dissipated",
    keys=(
        Key.nonnegative(
            "form_drag", 1.0, "1", "C_d, pressure drag coefficient of the submerged part (used with the form_drag effect)"
        ),
    ),
    params=(Column("FORM_DRAG", "constant", "1", "pressure drag coefficient C_d", source="physics.form_drag"),),
    terms=("damp",),
    beyond_paper=True,
)
