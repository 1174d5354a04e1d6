"""Ledgers that keep their digits (issue 49, point 3).

A damping term books the kinetic energy it removes. Written ``1/2 m v^2 (1 - keep^2)`` for a
decay ``keep = 1 / (1 + x)`` (``x = c dt``, 1e-4 at the paper's drag and step), the factor
``1 - keep^2`` loses ``eps / 2x`` of its digits, the same every step: drag_dissipated was 3e-4
off in f32 on the CPU and on the device alike (1.8e-4 here, at ``x = 1e-5``, and 5.8e-13 in
f64, both past the bound below). Booked as ``m (v - v') . (v + v') / 2`` from
the velocities the step stores, each step's term is right to a few ulps, and the ledger is
the energy those velocities lost, up to its own sum's rounding: at most ``(N + 8) u`` of it
after N steps (each addition rounds by at most ``u`` of the running sum, below the last;
each term by at most 8 ``u``), ``u`` the precision's unit roundoff.
"""

from __future__ import annotations

import numpy as np
import pytest

from melange_ti.model import Model
from melange_ti.scene import loads

STEPS = 1000
DRAG = 0.001  # x = c dt = 1e-5: the factor 1 - keep^2 kept 1e-3 of its digits in f32, 1e-11 in f64


def drifting(precision: str) -> str:
    """One block in the air, drag alone: it coasts and slows (no force, no contact)."""
    return (
        f'[scene]\neffects = ["drag"]\nprecision = "{precision}"\n[physics]\ndrag = {DRAG}\nangular_drag = {2 * DRAG}\n'
        "[time]\ndt = 0.01\nduration = 10.0\n[[iceberg]]\nx = 0.0\nz = 5.0\nvx = 1.0\nvz = -0.5\nomega = 0.3\n"
    )


def replayed(precision: str, mass: float, inertia: float) -> tuple[float, float]:
    """The step's own arithmetic in numpy, in the model's precision: ``keep = 1 / (1 + c dt)``,
    ``v' = v keep``; returns what the stored velocities lost, summed exactly (in f64), and the
    final ``vx``."""
    real = np.float64 if precision == "f64" else np.float32
    dt = real(0.01)
    keep_lin = real(1.0) / (real(1.0) + real(DRAG) * dt)
    keep_ang = real(1.0) / (real(1.0) + real(2 * DRAG) * dt)
    v = np.array([1.0, -0.5], dtype=real)
    om = real(0.3)
    lost = 0.0
    for _ in range(STEPS):
        nv, nom = v * keep_lin, om * keep_ang
        lost += 0.5 * mass * float(np.sum(v.astype(np.float64) ** 2 - nv.astype(np.float64) ** 2))
        lost += 0.5 * inertia * (float(om) ** 2 - float(nom) ** 2)
        v, om = nv, nom
    return lost, float(v[0])


def within_its_sum(booked: float, lost: float, precision: str) -> bool:
    """The bound of the module docstring: ``(N + 8) u`` of what was lost."""
    u = float(np.finfo(np.float64 if precision == "f64" else np.float32).eps) / 2
    return abs(booked - lost) <= (STEPS + 8) * u * lost


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_drag_books_the_energy_the_stored_velocities_lost(precision):
    import melange_ti.runtime as rt

    real = np.float64 if precision == "f64" else np.float32
    rt.init("cpu", precision=precision)
    m = Model(loads(drifting(precision)), mode="serial")
    mass, inertia = (float(real(m.constants()[k][0])) for k in ("mass", "inertia"))
    m.advance(STEPS)
    booked = float(np.sum(m.sample()["drag_dissipated"]))
    lost, vx = replayed(precision, mass, inertia)
    assert m.state()["vx"][0] == vx  # the same velocities, bit for bit
    assert within_its_sum(booked, lost, precision), (booked, lost, abs(booked - lost) / lost)
