"""An impulse's offset is the forces' kick alone (docs/model.md, "What the budget promises").

The energy a step keeps is ``0.5 m v0 . (v0 + dt F / m) + U``. A change ``delta`` of the
velocities after the forces' kick (a damper, an impulse) changes it by the kinetic energy its
own ledger books plus ``dt/2 F . delta``, to first order. For an impulse ``J`` that is
``J . (dt F / m) / 2``: the forces' share of the kick. A damper acting between the kick and
the impulse (drag, a bond's dashpot) adds nothing to it: the dampers' and the impulse's
changes of the kinetic energy add up exactly in their own ledgers, so no cross term is left.
Booked with the damper's change counted in the kick (before), the impulse took
``J . delta_damper / 2`` too, and a bonded pair touching through contacts, whose stiff
dashpots kick hard, lost 13% of its energy to it (issue 50, crevasses).

Two checks: a block sliding into the wall with strong drag, where the forces have no
horizontal kick at all, so the budget closes to rounding; and a bonded pair driven into the
wall, whose dashpots ring after the impact, within the promise.
"""

from __future__ import annotations

import numpy as np
import pytest

import melange_ti as mt
from melange_ti.energy import RESIDUAL_PROMISED, budget_series
from melange_ti.io.hdf5 import read_run
from melange_ti.scene import DENSITY_RATIO, loads

R = DENSITY_RATIO


def slide_text(drag: float, restitution: float) -> str:
    """An upright 1 x 1 block floating at its draft (the forces balance: no kick), sliding at
    -1 into the wall 0.5 away, with linear drag ``drag``."""
    return (
        '[scene]\nname = "slide"\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall"]\n'
        f"[physics]\ndrag = {drag}\nangular_drag = {drag}\nrestitution = {restitution}\n"
        "[time]\ndt = 0.01\nduration = 6.0\n[output]\ndiagnostic_interval = 0.05\nsnapshot_interval = 1.0\n"
        f"[[iceberg]]\nx = 1.0\nz = {-R + 0.5}\ntheta = 0.0\nthickness = 1.0\nvx = -1.0\n"
    )


@pytest.mark.parametrize("restitution", [0.0, 0.5])
def test_a_damped_block_into_the_wall_closes_its_budget_to_rounding(tmp_path, restitution):
    """Drag 0.5 (fifty times the paper's): the block loses about half its kinetic energy to
    drag before it meets the wall, and at the wall an impulse of order its momentum. The
    forces' horizontal kick is zero, so every change of the energy is in the drag's and the
    collisions' ledgers: the residual stays within 1e-9 of the initial kinetic energy. Counting
    the drag's change of the velocity in the kick booked ``J dt c v / 2`` more, about 1e-3 of it."""
    out = tmp_path / "slide.h5"
    mt.run(loads(slide_text(0.5, restitution)), out, overwrite=True)
    d = read_run(out)["diagnostics"]
    assert d["collision_dissipated"][-1] > 0.05 and d["drag_dissipated"][-1] > 0.1  # both acted, and much
    assert d["contacts"].sum() > 0
    e0 = d["kinetic_energy"][0]
    residual = budget_series(d)["residual"]
    assert np.max(np.abs(residual)) <= 1e-9 * e0, np.max(np.abs(residual)) / e0


def test_a_bonded_pair_into_the_wall_keeps_the_promise(tmp_path):
    """Two 1 x 1 blocks bonded face to face (an unbreakable bond, its dashpot at the default
    damping), sliding at -1 into the wall: the impact sets the bond ringing, its dashpot kicks
    each step while the front block touches the wall again and again. The largest residual over
    the run stays within the promise of the largest energy dissipated."""
    text = (
        '[scene]\nname = "pair"\neffects = ["gravity", "buoyancy", "collisions", "wall", "bonds"]\n'
        "[physics]\nrestitution = 0.5\ntensile_strength = 1e6\nshear_strength = 1e6\n"
        "[time]\ndt = 0.002\nduration = 4.0\n[output]\ndiagnostic_interval = 0.01\nsnapshot_interval = 1.0\n"
        f"[[iceberg]]\nx = 0.7\nz = {-R + 0.5}\ntheta = 0.0\nthickness = 1.0\nvx = -1.0\n"
        f"[[iceberg]]\nx = 1.7\nz = {-R + 0.5}\ntheta = 0.0\nvx = -1.0\n[[bond]]\na = 0\nb = 1\n"
    )
    out = tmp_path / "pair.h5"
    mt.run(loads(text), out, overwrite=True)
    d = read_run(out)["diagnostics"]
    assert d["bonds_intact"][-1] == 1 and d["bond_damping_dissipated"][-1] > 0 and d["contacts"].sum() > 0
    b = budget_series(d)
    lost = np.max(np.abs(d["collision_dissipated"] + d["bond_damping_dissipated"]))
    assert np.max(np.abs(b["residual"])) <= RESIDUAL_PROMISED * lost, np.max(np.abs(b["residual"])) / lost
