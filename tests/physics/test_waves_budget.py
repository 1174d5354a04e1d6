"""The energy budget over a capsize with waves: its largest residual over the run, not its
end point (docs/model.md, "Energy").

Symplectic Euler staggers each pair of the state: a step leaves the positions ``x_{n+1}``
with the velocities ``v_{n+1/2}`` their drift used, and the surface ``eta_{n+1}`` with the
potential ``phi_{n+1/2}``. The energy at the step time ``t_n`` takes the velocities and
``phi`` there, half a kick on: the mean of two consecutive steps' (exactly, without damping
or contacts). Taken so, the budget of the icebergs and the water closes to second order in
``dt``, with waves as without; taken from the stored state, as the run's diagnostics do, it
carries the stepping's half-kick offset (about ``dt / 2`` times the rate at which kinetic
and potential energy trade, 0.25% of a lone capsize's energy at its peak, with waves or
without), which oscillates and never accumulates.
"""

from __future__ import annotations

import numpy as np

from melange_ti.diagnostics import capsize_energy
from melange_ti.model import Model
from melange_ti.scene import DENSITY_RATIO as R

from .scenes import make_scene

THICK = 1.4  # aspect 1.4 > 1.33: capsizes
WAVES = {"water_depth": 6.0, "wave_dx": 0.25, "wave_end": 60.0, "wave_sponge": 15.0}


def capsize(dt: float) -> Model:
    """One block tilted 0.6 rad at its equilibrium height in waves: it capsizes by t ~ 6."""
    berg = {"x": 30.0, "z": -R * THICK + THICK / 2, "width": 1.0, "thickness": THICK, "theta": 0.6}
    return Model(make_scene(["gravity", "buoyancy", "waves"], [berg], WAVES, dt=dt), mode="serial")


def residuals(model: Model, duration: float, every: int = 20) -> tuple[np.ndarray, float]:
    """The budget's residual at the step time, ``E(0) - E(t) - wave_absorbed``, over the
    released energy, every ``every`` steps to ``duration``; and the waves' share at the end."""
    k = model.constants()
    mass, inertia = float(k["mass"][0]), float(k["inertia"][0])

    def grab():
        s, totals = model.sample_with_totals()
        w = model.effect("waves").surface()
        v = np.array([s["vx"][0], s["vz"][0], s["omega"][0]])
        return v, float(np.sum(s["potential"])), w, totals.wave_absorbed

    def energy(before, after) -> float:
        """At the step time of ``before``: its positions and surface, the mean of the two
        steps' velocities and potentials."""
        v = 0.5 * (before[0] + after[0])
        phi = 0.5 * (before[2]["phi"] + after[2]["phi"])
        g_phi = 0.5 * (before[2]["g_phi"] + after[2]["g_phi"])
        kinetic = 0.5 * mass * (v[0] ** 2 + v[1] ** 2) + 0.5 * inertia * v[2] ** 2
        eta = before[2]["eta"]
        return kinetic + before[1] + 0.5 * model.effect("waves").dx * (eta @ eta + phi @ g_phi)

    released = capsize_energy(R, 1.0, THICK)
    steps = round(duration / model.scene.time.dt)
    first = grab()
    model.advance(1)
    e0 = energy(first, grab())
    out = []
    for _ in range(every, steps + 1, every):
        model.advance(every - 1)
        before = grab()
        model.advance(1)
        after = grab()
        out.append((e0 - energy(before, after) - before[3]) / released)
    theta = float(model.state()["theta"][0])
    assert abs(theta) > 1.5, "the block must have capsized"
    return np.array(out), (model.effect("waves").energy() + model.totals().wave_absorbed) / released


def test_largest_residual_over_a_capsize_with_waves_is_within_a_thousandth():
    res, waves = residuals(capsize(0.01), 8.0)
    assert waves > 0.01  # the capsize made waves: the coupling carried energy
    assert np.max(np.abs(res)) <= 1e-3


def test_residual_over_a_capsize_with_waves_is_second_order_in_dt():
    """Halving ``dt`` quarters the largest residual (second order; a first-order coupling,
    e.g. the water's kick after its update, halves it): at most 0.35, between the two."""
    coarse, _ = residuals(capsize(0.01), 8.0)
    fine, _ = residuals(capsize(0.005), 8.0, every=40)
    assert np.max(np.abs(fine)) <= 0.35 * np.max(np.abs(coarse))
