"""Coulomb friction (effect ``friction``): oblique impacts in the stick and the slip regimes
against the analytic impulses, the energy it removes booked, momentum kept, the budget
closed, the kernel forms bit for bit, and a scene without it unchanged.

For one contact with normal ``n`` (from j to i), tangent ``t = (-n_z, n_x)`` and arms ``r``:
after the normal impulse ``J_n``, the tangential relative velocity ``v_t`` meets
``K_t = 1/m_i + 1/m_j + (r_i x t)^2/I_i + (r_j x t)^2/I_j``; the friction impulse is
``J_t = clamp(-v_t / K_t, -mu J_n, mu J_n)``: it stops the sliding (stick) when
``|v_t| <= mu J_n K_t``, else it is ``-mu J_n sign(v_t)`` (slip). It removes
``-J_t (v_t + J_t K_t / 2)`` of kinetic energy: ``v_t^2 / (2 K_t)`` when sticking,
``mu J_n (|v_t| - mu J_n K_t / 2)`` when slipping.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from melange_ti import scene as scene_mod
from melange_ti.model import Model
from melange_ti.physics.schema import ENERGY_LEDGERS
from melange_ti.scene import DENSITY_RATIO

from .scenes import KERNEL_FORMS, initial, make_scene

R = DENSITY_RATIO
MU = 0.3
WALL_X = -50.0
DISCS = 16  # k = 4 per face: a disc at each face centre, so an upright block meets the wall centrally
W, H = 1.0, 1.4
MASS = R * W * H
INERTIA = MASS * (W * W + H * H) / 12.0


def kinetic(s, idx, mass, inertia):
    return sum(0.5 * mass[q] * (s["vx"][q] ** 2 + s["vz"][q] ** 2) + 0.5 * inertia[q] * s["omega"][q] ** 2 for q in idx)


def first_impulse(m, steps=40):
    """Step one at a time until some velocity changes: (state before, after, totals before, after)."""
    for _ in range(steps):
        b, tb = m.state(), m.totals()
        m.advance(1)
        a, ta = m.state(), m.totals()
        if ta.impulses > tb.impulses:
            return b, a, tb, ta
    raise AssertionError(f"no impulse within {steps} steps")


def wall_model(restitution, friction):
    """One upright block near the wall: effects collisions, wall (and friction), no gravity."""
    effects = ["collisions", "wall"] + (["friction"] if friction is not None else [])
    physics = {"restitution": restitution, "density_ratio": R, "wall_x": WALL_X}
    if friction is not None:
        physics["friction"] = friction
    sc = make_scene(effects, [{"x": WALL_X + 2.0, "z": 3.0, "width": W, "thickness": H}], physics, contacts={"discs": DISCS})
    return Model(sc), sc


def approach_wall(sc, vz):
    """The block moving into the wall at v_x = -1 with v_z, half a step's approach away."""
    s = initial(sc)
    s["vx"][0], s["vz"][0] = -1.0, vz
    r = sc.icebergs().width[0] / 2  # the discs' union is tangent to the face
    s["x"][0] = WALL_X + r + 0.5 * sc.time.dt
    return s


def analytic_wall(e, vz, rx):
    """J_n, J_t and the friction's dissipation for a central impact (r_z = 0) at v_x = -1."""
    jn = (1 + e) * MASS * 1.0
    kt = 1 / MASS + rx * rx / INERTIA
    jt = min(max(-vz / kt, -MU * jn), MU * jn)
    return jn, jt, -jt * (vz + 0.5 * jt * kt), kt


@pytest.mark.parametrize("e", [0.5, 1.0])
@pytest.mark.parametrize("regime", ["stick", "slip"])
def test_wall_impact_stick_and_slip_against_the_analytic_impulses(e, regime):
    m, sc = wall_model(e, MU)
    rx_guess = -(W / 2 + 0.5 * sc.time.dt)
    threshold = MU * (1 + e) * MASS * (1 / MASS + rx_guess**2 / INERTIA)  # |v_t| where slip begins
    vz = (0.5 if regime == "stick" else 3.0) * threshold
    m.set_state(approach_wall(sc, vz))
    b, a, tb, ta = first_impulse(m)
    # the impulse acts at the start-of-step position: arms from it; the wall's point is at x = WALL_X
    rx = WALL_X - b["x"][0]
    jn_seen = MASS * (a["vx"][0] - b["vx"][0])
    jt_seen = MASS * (a["vz"][0] - b["vz"][0])
    rz = (rx * jt_seen - INERTIA * (a["omega"][0] - b["omega"][0])) / jn_seen
    assert abs(rz) < 1e-12, f"an upright block meets the wall centrally (r_z = {rz})"
    jn, jt, rubbed, kt = analytic_wall(e, vz, rx)
    np.testing.assert_allclose(jn_seen, jn, rtol=1e-12, err_msg="normal impulse")
    np.testing.assert_allclose(jt_seen, jt, rtol=1e-12, err_msg="friction impulse")
    vt_after = a["vz"][0] + a["omega"][0] * rx
    if regime == "stick":
        assert abs(jt) < MU * jn
        assert abs(vt_after) < 1e-12 * abs(vz), f"sticks: v_t' = {vt_after}"
    else:
        assert jt == pytest.approx(-MU * jn, rel=1e-15), "slips at the Coulomb limit"
        assert vt_after > 0 and vt_after == pytest.approx(vz + jt * kt, rel=1e-12)
    np.testing.assert_allclose(a["vx"][0], e, rtol=1e-12, err_msg="restitution unchanged by friction")
    lost = kinetic(b, (0,), [MASS], [INERTIA]) - kinetic(a, (0,), [MASS], [INERTIA])
    np.testing.assert_allclose(ta.friction_dissipated - tb.friction_dissipated, rubbed, rtol=1e-12)
    np.testing.assert_allclose(lost, ta.collision_dissipated - tb.collision_dissipated + rubbed, rtol=1e-12)
    np.testing.assert_allclose(ta.wall_impulse - tb.wall_impulse, jn, rtol=1e-12)


def test_zero_friction_is_frictionless_and_no_effect_costs_no_column():
    """mu = 0 gives the frictionless velocities; a scene without the effect allocates no
    deferred friction column and books nothing."""
    runs = {}
    for friction in (None, 0.0):
        m, sc = wall_model(0.5, friction)
        m.set_state(approach_wall(sc, 0.7))
        m.advance(20)
        runs[friction] = (m.state(), m.totals(), m.arrays.cd.shape[-1])
    (s0, t0, w0), (s1, t1, w1) = runs[None], runs[0.0]
    for k in s0:
        assert np.array_equal(s0[k], s1[k]), k
    assert t0.impulses > 0 and t0.friction_dissipated == 0.0 and t1 == t0
    assert w1 == w0 + 1


def pair_model(friction=MU):
    """Two blocks side by side (mass ratios 1 and 10), far apart from each other and from the wall."""
    light = {1: (1.0, 1.4), 10: (0.2, 0.7)}
    bergs = []
    for k, ratio in enumerate((1, 10)):
        wl, hl = light[ratio]
        x, z = 137.0 + 100.0 * k, -40.0 + 25.0 * k
        bergs.append({"x": x, "z": z, "width": W, "thickness": H})
        bergs.append({"x": x + 0.5 + wl / 2 + 0.01, "z": z, "width": wl, "thickness": hl})
    physics = {"restitution": 0.5, "density_ratio": R, "friction": friction}
    sc = make_scene(["collisions", "friction"], bergs, physics, contacts={"discs": DISCS})
    return Model(sc), sc


@pytest.mark.parametrize("slide", [0.05, 2.0], ids=["stick", "slip"])
def test_pair_impact_conserves_momentum_and_books_the_energy(slide):
    """Blocks closing at relative speed 2 while sliding past each other: momentum and angular
    momentum conserved, J_t from the analytic law (arms read from the spins), energy lost =
    collision_dissipated + friction_dissipated."""
    m, sc = pair_model()
    k = m.constants()
    mass, inertia = k["mass"], k["inertia"]
    s = initial(sc)
    for p in range(2):
        i, j = 2 * p, 2 * p + 1
        s["vx"][i], s["vx"][j] = 1.0, -1.0
        s["vz"][i], s["vz"][j] = slide / 2, -slide / 2
    m.set_state(s)
    b, a, tb, ta = first_impulse(m)
    rubbed_total = 0.0
    lost_total = 0.0
    regimes = []
    for p in range(2):
        i, j = 2 * p, 2 * p + 1
        if a["vx"][i] == b["vx"][i]:
            continue
        dv1 = np.array([a["vx"][i] - b["vx"][i], a["vz"][i] - b["vz"][i]])
        dv2 = np.array([a["vx"][j] - b["vx"][j], a["vz"][j] - b["vz"][j]])
        scale = mass[i] * 2.0
        assert np.all(np.abs(mass[i] * dv1 + mass[j] * dv2) < 1e-13 * scale), "momentum"
        # angular momentum about the origin (150-250 widths away), at the start-of-step positions
        lb = sum(mass[q] * (b["x"][q] * b["vz"][q] - b["z"][q] * b["vx"][q]) + inertia[q] * b["omega"][q] for q in (i, j))
        la = sum(mass[q] * (b["x"][q] * a["vz"][q] - b["z"][q] * a["vx"][q]) + inertia[q] * a["omega"][q] for q in (i, j))
        assert abs(la - lb) < 1e-12 * scale * 250, f"angular momentum changed by {la - lb}"
        # side by side at one height: n = (-1, 0), t = (0, -1); J on i is (-J_n, -J_t)
        jn, jt = -mass[i] * dv1[0], -mass[i] * dv1[1]
        assert jn > 0
        r1x = -inertia[i] * (a["omega"][i] - b["omega"][i]) / jt
        r2x = inertia[j] * (a["omega"][j] - b["omega"][j]) / jt
        np.testing.assert_allclose(r1x - r2x, b["x"][j] - b["x"][i], rtol=1e-9, err_msg="one contact point")
        vt = -(b["vz"][i] + b["omega"][i] * r1x - b["vz"][j] - b["omega"][j] * r2x)
        kt = 1 / mass[i] + 1 / mass[j] + r1x**2 / inertia[i] + r2x**2 / inertia[j]
        expect = min(max(-vt / kt, -MU * jn), MU * jn)
        np.testing.assert_allclose(jt, expect, rtol=1e-9, err_msg=f"pair {p}: friction impulse")
        vt_after = -(a["vz"][i] + a["omega"][i] * r1x - a["vz"][j] - a["omega"][j] * r2x)
        if abs(expect) < MU * jn:
            regimes.append("stick")
            assert abs(vt_after) < 1e-9 * abs(vt)
        else:
            regimes.append("slip")
            assert np.sign(vt_after) == np.sign(vt) and abs(vt_after) < abs(vt)
        rubbed_total += -jt * (vt + 0.5 * jt * kt)
        lost_total += kinetic(b, (i, j), mass, inertia) - kinetic(a, (i, j), mass, inertia)
    assert regimes == ["stick" if slide < 1 else "slip"] * 2, regimes
    np.testing.assert_allclose(ta.friction_dissipated - tb.friction_dissipated, rubbed_total, rtol=1e-9)
    np.testing.assert_allclose(lost_total, ta.collision_dissipated - tb.collision_dissipated + rubbed_total, rtol=1e-9)


def capsizing_row(friction: float, count: int = 40) -> scene_mod.Scene:
    overrides = {
        "shelf.count": count,
        "shelf.tilt": 0.1,
        "time.duration": 150.0,
        "scene.effects": ["gravity", "buoyancy", "drag", "collisions", "wall", "friction"],
        "physics.friction": friction,
    }
    return scene_mod.load(None, overrides=list(overrides.items()))


def test_budget_closes_with_friction():
    """A packed, capsizing row with friction 0.3: the friction books energy, and
    E(0) - E(t) equals the ledgers to the integrator's error (as without friction)."""
    sc = capsizing_row(MU)
    m = Model(sc)
    s0 = m.sample()
    m.advance(round(sc.time.duration / sc.time.dt))
    s, tot = m.sample(), m.totals()
    ledgers = {name: float(s[name].sum()) if name in s else float(getattr(tot, name)) for name in ENERGY_LEDGERS}
    assert "friction_dissipated" in ledgers
    lost = (s0["kinetic"].sum() + s0["potential"].sum()) - (s["kinetic"].sum() + s["potential"].sum())
    released = s0["potential"].sum() - s["potential"].sum()
    assert tot.impulses > 1000 and released > 0.1
    assert ledgers["friction_dissipated"] > 0.01 * released, ledgers
    residual = lost - sum(ledgers.values())
    assert abs(residual) < 5e-4 * released, f"residual {residual / released:.4%} of released"
    without = residual + ledgers["friction_dissipated"]
    assert abs(without) > 20 * abs(residual), "leaving friction out of the budget must show"


def test_friction_is_bit_identical_across_kernel_forms():
    sc = capsizing_row(MU, count=30)
    results = []
    for mode, islands, groups in KERNEL_FORMS:
        m = Model(sc, mode=mode, islands=islands, groups=groups)
        m.advance(3000)
        results.append((m.state(), m.totals()))
    (s0, t0) = results[0]
    assert t0.friction_dissipated > 0
    for s, t in results[1:]:
        for k in s0:
            assert s0[k].tobytes() == s[k].tobytes(), k
        assert t == t0


def test_friction_key_is_checked():
    with pytest.raises(scene_mod.SceneError, match="physics.friction"):
        capsizing_row(-0.1)
    assert math.isclose(capsizing_row(0.45).physics.friction, 0.45)
    with pytest.raises(scene_mod.SceneError, match="friction acts at contacts"):
        scene_mod.load(None, overrides=[("scene.effects", ["gravity", "buoyancy", "friction"])])
    assert scene_mod.load(None, overrides=[("scene.effects", ["wall", "friction"])]).effects.friction
