"""Coulomb friction (effect ``friction``): oblique impacts in the stick and the slide regimes
against the analytic impulses, at central and off-centre contacts, the energy it removes
booked, momentum kept, the budget closed, the kernel forms bit for bit, and a scene without
it unchanged.

The law (docs/model.md, "Contacts"): at a contact with normal ``n`` (from j to i) and tangent
``t = (-n_z, n_x)`` the relative velocity ``u = (v_n, v_t)`` of the contact point changes by
``K J`` under the impulse ``J = (J_n, J_t)``, ``K`` the point's 2x2 effective-mass matrix. The
impulse gives ``v_n' = -e v_n``; it sticks (``v_t' = 0``) when that impulse lies in the cone
``|J_t| <= mu J_n``, else it slides on the cone's edge on the stick impulse's side. At a central
contact ``K_nt = 0`` and this is ``J_n = -(1 + e) v_n / K_nn``,
``J_t = clamp(-v_t / K_tt, -mu J_n, mu J_n)``; off centre ``K_nt`` couples the two (the law is
written again in numpy in :func:`melange_ti.testing.coulomb_impulse`).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from melange_ti import scene as scene_mod
from melange_ti.model import Model
from melange_ti.physics.data.schema import ENERGY_LEDGERS
from melange_ti.scene import DENSITY_RATIO
from melange_ti.testing import (
    contact_matrix,
    contacts_seen,
    corner_x,
    coulomb_impulse,
    first_impulse,
    impact_gain,
    kept_restitution,
    kinetic,
    newton_coulomb,
)

from .scenes import KERNEL_FORMS, initial, make_scene

R = DENSITY_RATIO
MU = 0.3
WALL_X = -50.0
DISCS = 16  # k = 4 per face: a disc at each face centre, so an upright block meets the wall centrally
W, H = 1.0, 1.4
MASS = R * W * H
INERTIA = MASS * (W * W + H * H) / 12.0


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
    """mu = 0 gives the frictionless impulses and ledgers to the bit, centrally and at a tilted
    block's corner (e = 0.3: values whose roundings differ between the two ways of writing the
    impact's dissipation); a scene without the effect allocates no deferred friction column and
    books nothing."""
    for tilt in (0.0, 0.4):
        runs = {}
        for friction in (None, 0.0):
            m, sc = wall_model(0.3, friction)
            s = approach_wall(sc, 0.7)
            s["theta"][0], s["vx"][0] = tilt, -1.1
            s["x"][0] = WALL_X + corner_x(W, H, tilt) + 0.02
            m.set_state(s)
            m.advance(20)
            runs[friction] = (m.state(), m.totals(), m.arrays.cd.shape[-1])
        (s0, t0, w0), (s1, t1, w1) = runs[None], runs[0.0]
        for k in s0:
            assert np.array_equal(s0[k], s1[k]), k
        assert t0.impulses > 0 and t0.friction_dissipated == 0.0 and t1 == t0, (tilt, t0, t1)
        assert w1 == w0 + 1


def pair_model(friction=MU, restitution=0.5):
    """Two blocks side by side (mass ratios 1 and 10), far apart from each other and from the wall."""
    light = {1: (1.0, 1.4), 10: (0.2, 0.7)}
    bergs = []
    for k, ratio in enumerate((1, 10)):
        wl, hl = light[ratio]
        x, z = 137.0 + 100.0 * k, -40.0 + 25.0 * k
        bergs.append({"x": x, "z": z, "width": W, "thickness": H})
        bergs.append({"x": x + 0.5 + wl / 2 + 0.01, "z": z, "width": wl, "thickness": hl})
    physics = {"restitution": restitution, "density_ratio": R, "friction": friction}
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


def point_velocity(s, q, r):
    return np.array([s["vx"][q] - s["omega"][q] * r[1], s["vz"][q] + s["omega"][q] * r[0]])


def impulse_against_the_law(m, b, a, e, moving):
    """The contact of the step's first impulse (the one touching a body of ``moving``) against
    the analytic law at its point and normal as the impulse pass met them: every velocity
    change, the restitution, the regime. Returns ``(regime, J_n, J_t, v_n, v_t, v_n', v_t', K)``."""
    k = m.constants()
    mass, inertia = k["mass"], k["inertia"]
    (c,) = [c for c in contacts_seen(m) if c.i in moving or c.j in moving]
    i, j, n = c.i, c.j, c.n
    t = np.array([-n[1], n[0]])
    ri = c.p - np.array([b["x"][i], b["z"][i]])  # the pass acts at the start-of-step positions
    arms = [(ri, mass[i], inertia[i])]
    u, u_after = point_velocity(b, i, ri), point_velocity(a, i, ri)
    if j >= 0:
        rj = c.p - np.array([b["x"][j], b["z"][j]])
        arms.append((rj, mass[j], inertia[j]))
        u, u_after = u - point_velocity(b, j, rj), u_after - point_velocity(a, j, rj)
    kk = contact_matrix(n, arms)
    jn, jt, regime = coulomb_impulse(kk, u @ n, u @ t, e, MU)
    p = jn * n + jt * t
    scale = jn * (1 + abs(jt) / jn)
    for q, sign, r in [(i, 1.0, ri)] + ([(j, -1.0, rj)] if j >= 0 else []):
        dv = np.array([a["vx"][q] - b["vx"][q], a["vz"][q] - b["vz"][q]])
        np.testing.assert_allclose(mass[q] * dv, sign * p, rtol=0, atol=1e-12 * scale, err_msg=f"body {q}: impulse")
        spin = inertia[q] * (a["omega"][q] - b["omega"][q])
        np.testing.assert_allclose(
            spin, sign * (r[0] * p[1] - r[1] * p[0]), rtol=0, atol=1e-12 * scale, err_msg=f"body {q}: spin"
        )
    kept = kept_restitution(kk, u @ n, u @ t, e, MU)  # e, unless Newton's law would create energy
    assert u_after @ n == pytest.approx(-kept * (u @ n), rel=1e-11), "v_n' = -e' v_n in both regimes"
    if regime == "stick":
        assert abs(u_after @ t) < 1e-11 * np.abs(u).max()
    else:
        assert abs(jt) == pytest.approx(MU * jn, rel=1e-14) and (u_after @ t) * jt <= 0, "slides against the friction"
    return regime, jn, jt, u @ n, u @ t, u_after @ n, u_after @ t, kk


def booked_exactly(b, a, tb, ta, idx, mass, inertia, jn, jt, vn, vt, vn_after, vt_after):
    """Each ledger is its impulse's work at its direction's mean velocity, and they sum to the
    kinetic energy lost."""
    collision = ta.collision_dissipated - tb.collision_dissipated
    rubbed = ta.friction_dissipated - tb.friction_dissipated
    lost = kinetic(b, idx, mass, inertia) - kinetic(a, idx, mass, inertia)
    scale = jn * np.abs([vn, vt]).max()
    assert collision == pytest.approx(-0.5 * jn * (vn + vn_after), rel=0, abs=1e-12 * scale)
    assert rubbed == pytest.approx(-0.5 * jt * (vt + vt_after), rel=0, abs=1e-12 * scale)
    assert lost == pytest.approx(collision + rubbed, rel=0, abs=1e-12 * scale)
    return lost


@pytest.mark.parametrize("e", [0.5, 1.0])
def test_tilted_block_into_the_wall_off_centre(e):
    """A block tilted 0.4 rad meets the wall with its corner (arm ~(-0.7, 0.4): K_nt is not
    small), moving in at v_x = -1 while sliding at nine speeds either way: every impulse is the
    coupled law's, both regimes occur, v_n' = -e v_n in each, and the ledgers book it exactly.
    (The uncoupled law, a normal impulse and then a clamped tangential one each with its own
    K, misses v_n' by up to 60% here.)"""
    m, sc = wall_model(e, MU)
    k = m.constants()
    regimes = set()
    for vz in (-4.0, -1.5, -0.6, -0.2, 0.0, 0.2, 0.6, 1.5, 4.0):
        s = initial(sc)
        s["theta"][0], s["vx"][0], s["vz"][0] = 0.4, -1.0, vz
        s["x"][0] = WALL_X + corner_x(W, H, 0.4) + 0.02
        m.set_state(s)
        b, a, tb, ta = first_impulse(m)
        regime, jn, jt, vn, vt, vn_after, vt_after, kk = impulse_against_the_law(m, b, a, e, moving={0})
        assert abs(kk[0, 1]) > 0.2 * kk[0, 0], f"an off-centre contact: K = {kk}"
        booked_exactly(b, a, tb, ta, (0,), k["mass"], k["inertia"], jn, jt, vn, vt, vn_after, vt_after)
        regimes.add((regime, np.sign(jt)))
    assert {("stick", 1.0), ("stick", -1.0), ("slide", 1.0), ("slide", -1.0)} <= regimes, regimes


@pytest.mark.parametrize("ratio", [1, 10])
def test_tilted_pair_off_centre_conserves_momentum(ratio):
    """A tilted block's corner into an upright block's face (mass ratios 1 and 10), closing at
    relative speed 2 while sliding past at five speeds: the impulse is the coupled law's at the
    contact the narrow phase found, equal and opposite (momentum and angular momentum kept),
    and the energy booked exactly."""
    m, sc = pair_model()
    k = m.constants()
    mass, inertia = k["mass"], k["inertia"]
    i, j = (0, 1) if ratio == 1 else (2, 3)
    wj, hj = k["width"][j], k["thickness"][j]
    regimes = set()
    for slide in (-3.0, -0.4, 0.1, 0.5, 3.0):
        s = initial(sc)
        s["theta"][j] = 0.4
        s["x"][j] = s["x"][i] + 0.5 * W + corner_x(wj, hj, 0.4) + 0.02
        # in the centre-of-mass frame, so that neither body leaves the step faster than it came
        # (a body that outruns its search is detected again, and the contact read after the step
        # would not be the one the impulse met)
        share = mass[j] / (mass[i] + mass[j])
        s["vx"][i], s["vx"][j] = 2.0 * share, -2.0 * (1.0 - share)
        s["vz"][i], s["vz"][j] = slide * share, -slide * (1.0 - share)
        m.set_state(s)
        b, a, tb, ta = first_impulse(m)
        regime, jn, jt, vn, vt, vn_after, vt_after, kk = impulse_against_the_law(m, b, a, 0.5, moving={i, j})
        assert abs(kk[0, 1]) > 0.05 * kk[0, 0], f"an off-centre contact: K = {kk}"
        lost = booked_exactly(b, a, tb, ta, (i, j), mass, inertia, jn, jt, vn, vt, vn_after, vt_after)
        assert lost > 0
        momentum = [sum(mass[q] * (s_[v][q]) for q in (i, j)) for s_ in (b, a) for v in ("vx", "vz")]
        assert momentum[0] == pytest.approx(momentum[2], abs=1e-13 * mass[i]) and momentum[1] == pytest.approx(
            momentum[3], abs=1e-13 * mass[i]
        )
        spin = [
            sum(mass[q] * (b["x"][q] * s_["vz"][q] - b["z"][q] * s_["vx"][q]) + inertia[q] * s_["omega"][q] for q in (i, j))
            for s_ in (b, a)
        ]
        assert spin[1] == pytest.approx(spin[0], abs=1e-12 * mass[i] * 250)
        regimes.add(regime)
    assert regimes == {"stick", "slide"}, regimes


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


# ----------------------------------------------------------------------------- no impact creates energy
TRIANGLE = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.8]])


def _sweep_impacts(m, sc, place, e, cases, moving):
    """Each case placed (``place(state, case)``), stepped to its first impulse: the kinetic
    energy it removes (no force acts: the step's change is the impulses'), the restitution it
    kept against :func:`kept_restitution`, and what Newton's law with the cone would have given
    the same contact (its gain > 0: a case today's law fails). Returns (lost, Newton's gain, scale)."""
    k = m.constants()
    out = []
    for case in cases:
        s = initial(sc)
        place(s, case)
        m.set_state(s)
        b, a, tb, ta = first_impulse(m)
        lost = kinetic(b, moving, k["mass"], k["inertia"]) - kinetic(a, moving, k["mass"], k["inertia"])
        regime, jn, jt, vn, vt, vn_after, vt_after, kk = impulse_against_the_law(m, b, a, e, moving=set(moving))
        booked_exactly(b, a, tb, ta, moving, k["mass"], k["inertia"], jn, jt, vn, vt, vn_after, vt_after)
        newton = impact_gain(kk, vn, vt, *newton_coulomb(kk, vn, vt, e, MU)[:2])
        out.append((lost, newton, 0.5 * (vn * vn + vt * vt) / kk[0, 0]))
    return out


@pytest.mark.parametrize("e", [0.5, 0.85, 0.9, 1.0])
def test_no_impact_of_a_rectangle_or_a_polygon_on_the_wall_creates_energy(e):
    """Issue 49: Newton's restitution with Coulomb's cone gained up to 16.6% of the kinetic
    energy at e = 1 (a 1 x 1.4 block's corner into the wall, mu = 0.3). Swept over tilts (the
    worst K_nt among them) and sliding speeds either way, a rectangle's and a triangle's
    corner: no impact gains kinetic energy, every impulse is the law's at the restitution it
    keeps (e, or the largest e' that creates none), the ledgers book it exactly; and at
    e >= 0.85 the sweep holds impacts where Newton's law would have gained (today's law failed
    them)."""
    tilts = (0.15, 0.4, 0.7, 1.0, 1.3)
    speeds = (-3.0, -1.0, -0.3, 0.0, 0.3, 1.0, 3.0)
    results = []
    m, sc = wall_model(e, MU)

    def block(s, case):
        theta, vz = case
        s["theta"][0], s["vx"][0], s["vz"][0] = theta, -1.0, vz
        s["x"][0] = WALL_X + corner_x(W, H, theta) + 0.02

    results += _sweep_impacts(m, sc, block, e, [(t, v) for t in tilts for v in speeds], (0,))
    physics = {"restitution": e, "density_ratio": R, "wall_x": WALL_X, "friction": MU}
    tri = make_scene(["collisions", "wall", "friction"], [{"x": WALL_X + 2.0, "z": 3.0, "vertices": TRIANGLE.tolist()}], physics)
    mt = Model(tri)
    body = np.stack([mt.constants()["corner_u"][0], mt.constants()["corner_v"][0]], 1)[: int(mt.constants()["corners"][0])]

    def triangle(s, case):
        theta, vz = case
        c, sn = np.cos(theta), np.sin(theta)
        s["theta"][0], s["vx"][0], s["vz"][0] = theta, -1.0, vz
        s["x"][0] = WALL_X - float(np.min(body[:, 0] * c - body[:, 1] * sn)) + 0.02

    results += _sweep_impacts(mt, tri, triangle, e, [(t, v) for t in (0.3, 1.1, 2.0, 2.9, 4.0, 5.2) for v in speeds], (0,))
    lost, newton, scale = (np.array(x) for x in zip(*results, strict=True))
    assert np.all(lost >= -1e-12 * scale), f"an impact created {np.max(-lost / scale):.3g} of its scale"
    if e >= 0.85:
        assert np.any(newton > 1e-6 * scale), "the sweep must hold impacts Newton's law makes gain energy"
    gained = newton > 1e-9 * scale
    assert np.all(lost[gained] <= 1e-9 * scale[gained]), "where Newton's law gains, the kept restitution's gains nothing"


@pytest.mark.parametrize("ratio", [1, 10])
def test_no_impact_between_icebergs_creates_energy(ratio):
    """The same between two blocks, a tilted corner into an upright face (mass ratios 1 and
    10), at e = 1: momentum is kept as before and no impact gains kinetic energy."""
    m, sc = pair_model(restitution=1.0)
    k = m.constants()
    mass = k["mass"]
    i, j = (0, 1) if ratio == 1 else (2, 3)
    wj, hj = k["width"][j], k["thickness"][j]

    def place(s, case):
        theta, slide = case
        s["theta"][j] = theta
        s["x"][j] = s["x"][i] + 0.5 * W + corner_x(wj, hj, theta) + 0.02
        share = mass[j] / (mass[i] + mass[j])
        s["vx"][i], s["vx"][j] = 2.0 * share, -2.0 * (1.0 - share)
        s["vz"][i], s["vz"][j] = slide * share, -slide * (1.0 - share)

    cases = [(t, v) for t in (0.2, 0.4, 0.6) for v in np.linspace(-3.0, 3.0, 13)]
    lost, newton, scale = (np.array(x) for x in zip(*_sweep_impacts(m, sc, place, 1.0, cases, (i, j)), strict=True))
    assert np.all(lost >= -1e-12 * scale), lost / scale
    gained = newton > 1e-6 * scale
    assert gained.any(), "the sweep must hold impacts Newton's law makes gain energy"
    assert np.all(lost[gained] <= 1e-9 * scale[gained]), "where Newton's law gains, the kept restitution's gains nothing"
