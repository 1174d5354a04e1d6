"""Contacts: detection against brute force, the impulse law, rest, and hard cases (SPEC 2).

The disc layout comes from the numpy reference (:mod:`melange_ti.geometry`), so that the
contact geometry is checked independently of the Taichi code.

Bounds used for the hard cases (documented, not tuned to pass):

* interpenetration: no disc of one iceberg may overlap a disc of another by more than one
  disc radius (the smallest in the scene). A disc centre inside the other body's inset
  rectangle counts as ``r_i + r_j`` plus its depth (deeper than any disc overlap). One radius
  is the depth of the scallops between neighbouring discs on a face: deeper than that, the
  merged disc-pair normal no longer reliably points out of the other body.
* energy: ``E(t) - E(0) <= 1e-3 * sum(mass)`` (units g w), the scale of the integrator's own
  O(dt) energy error at dt = 0.01 (test_analytic measures <= 5e-4 per body). Collisions,
  drag and corrections only remove energy.
* no tunnelling: icebergs in a floating row keep their order along x.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from melange_ti import scene as scene_mod
from melange_ti.energy import total_energy
from melange_ti.geometry import disc_local
from melange_ti.model import Model
from melange_ti.physics.data.schema import STATE_NAMES as STATE  # noqa: E402
from melange_ti.scene import DENSITY_RATIO

from .scenes import initial, make_scene

FULL = ["gravity", "buoyancy", "drag", "collisions", "wall"]
R = DENSITY_RATIO


class Geometry:
    """Disc geometry of a model's icebergs."""

    def __init__(self, m: Model, sc):
        c = m.constants()
        self.w, self.h = c["width"], c["thickness"]
        self.discs = sc.contacts.discs
        local, self.r = disc_local(self.w, self.h, self.discs, sc.contacts.disc_spacing)
        self.n = len(self.w)
        self.local = list(local)
        self.bound = 0.5 * np.hypot(self.w, self.h)

    def world(self, s, i):
        c, sn = math.cos(s["theta"][i]), math.sin(s["theta"][i])
        loc = self.local[i]
        return np.stack([s["x"][i] + loc[:, 0] * c - loc[:, 1] * sn, s["z"][i] + loc[:, 0] * sn + loc[:, 1] * c], 1)

    def pair_gap(self, s, i, j):
        d = np.linalg.norm(self.world(s, i)[:, None] - self.world(s, j)[None], axis=2)
        return d.min() - self.r[i] - self.r[j]

    def penetration(self, s):
        """Largest disc overlap between two icebergs (see the module docstring); -inf if none."""
        worst = -np.inf
        pts = [self.world(s, i) for i in range(self.n)]
        for j in range(self.n):
            dx, dz = s["x"] - s["x"][j], s["z"] - s["z"][j]
            near = np.flatnonzero(np.hypot(dx, dz) < self.bound + self.bound[j])
            c, sn = math.cos(s["theta"][j]), math.sin(s["theta"][j])
            iu, iv = 0.5 * self.w[j] - self.r[j], 0.5 * self.h[j] - self.r[j]
            for i in near:
                if i == j:
                    continue
                dd = np.linalg.norm(pts[i][:, None] - pts[j][None], axis=2)
                pen = (self.r[i] + self.r[j] - dd).max()
                e = pts[i] - (s["x"][j], s["z"][j])
                lu, lv = e[:, 0] * c + e[:, 1] * sn, -e[:, 0] * sn + e[:, 1] * c
                inside = np.minimum(iu - np.abs(lu), iv - np.abs(lv)).max()
                if inside > 0:
                    pen = max(pen, self.r[i] + self.r[j] + inside)
                worst = max(worst, pen)
        return worst

    def wall_penetration(self, s, wall_x):
        return max((wall_x - (self.world(s, i)[:, 0] - self.r[i])).max() for i in range(self.n))


def copy(s):
    return {k: np.array(v, dtype=float) for k, v in s.items()}


# ---------------------------------------------------------------- broad + narrow phase
N_PROP = 12
WALL_PROP = -3.0


def _has_spacing():
    import dataclasses

    return "disc_spacing" in {f.name for f in dataclasses.fields(scene_mod.Contacts)}


DETECTION_POOL = ((1, 8, 2.0), (2, 28, 1.5), (3, 12, 1.0), (4, 16, 2.0))  # seed, discs, disc spacing


@pytest.fixture(scope="module")
def detection_models():
    """Models of 12 icebergs each, assorted sizes (0.3-2 wide, aspect up to 3 or what the
    disc count allows), different disc counts and spacings; hypothesis picks one per example."""
    out = []
    for seed, discs, spacing in DETECTION_POOL:
        if not _has_spacing():
            spacing = 2.0
        rng = np.random.default_rng(seed)
        amax = min(3.0, ((discs // 4) * spacing + 2.0) / 2.0)
        w = rng.uniform(0.3, 2.0, N_PROP)
        h = w * np.exp(rng.uniform(-math.log(amax), math.log(amax), N_PROP))
        bergs = [{"x": 10.0 * k, "z": 0.0, "width": w[k], "thickness": h[k]} for k in range(N_PROP)]
        contacts = {"discs": discs, "max_partners": 64}
        if _has_spacing():
            contacts["disc_spacing"] = spacing
        sc = make_scene(["collisions", "wall"], bergs, {"wall_x": WALL_PROP}, contacts=contacts)
        m = Model(sc)
        out.append((m, sc, Geometry(m, sc)))
    return out


def brute_force(geo: Geometry, s, dt, tol, restitution=0.5):
    """Pairs (i < j) with some disc pair closer than r_i + r_j + reach_i + reach_j, and wall
    bodies with a disc closer than r + reach to the wall. ``reach = dt (speed + (1 + e) vmax)``
    with ``speed = |v| + |omega| half-diagonal`` and ``vmax`` the largest speed: room for
    what one impulse can add. ``maybe``: within ``tol`` of the
    threshold (round-off decides; not asserted either way). Symmetric overlaps whose disc
    normals cancel must still be found (the model falls back to the centre line)."""
    speed = np.hypot(s["vx"], s["vz"]) + np.abs(s["omega"]) * geo.bound
    reach = dt * (speed + (1.0 + restitution) * speed.max())
    pts = [geo.world(s, i) for i in range(geo.n)]
    sure, maybe = set(), set()
    for i in range(geo.n):
        for j in range(i + 1, geo.n):
            diff = pts[i][:, None] - pts[j][None]
            dist = np.linalg.norm(diff, axis=2)
            d = dist - geo.r[i] - geo.r[j] - reach[i] - reach[j]
            if d.min() < -tol:
                sure.add((i, j))
            elif d.min() <= tol:
                maybe.add((i, j))
    wall_sure, wall_maybe = set(), set()
    for i in range(geo.n):
        g = (pts[i][:, 0] - geo.r[i] - WALL_PROP - reach[i]).min()
        if g < -tol:
            wall_sure.add(i)
        elif g <= tol:
            wall_maybe.add(i)
    return sure, maybe, wall_sure, wall_maybe


coord = st.floats(-1.0, 1.0, allow_nan=False)


@st.composite
def layouts(draw, moving):
    which = draw(st.integers(0, len(DETECTION_POOL) - 1))
    spread = draw(st.floats(0.3, 8.0))
    ox = draw(st.one_of(st.floats(-1000.0, 1000.0), st.floats(-8.0, 8.0)))
    oz = draw(st.floats(-1000.0, 1000.0))
    n = N_PROP
    u = np.array(draw(st.lists(coord, min_size=n, max_size=n)))
    v = np.array(draw(st.lists(coord, min_size=n, max_size=n)))
    theta = np.array(draw(st.lists(st.floats(-7.0, 7.0), min_size=n, max_size=n)))
    if moving:
        vel = np.array(draw(st.lists(st.floats(-30.0, 30.0), min_size=3 * n, max_size=3 * n))).reshape(3, n)
    else:
        vel = np.zeros((3, n))
    state = {"x": ox + spread * u, "z": oz + spread * v, "theta": theta, "vx": vel[0], "vz": vel[1], "omega": vel[2]}
    return which, state


def _check_detection(detection_models, which, state):
    m, sc, geo = detection_models[which]
    m.set_state(state)
    pairs, wall = m.contact_pairs()
    scale = 1.0 + max(np.abs(state["x"]).max(), np.abs(state["z"]).max())
    sure, maybe, wall_sure, wall_maybe = brute_force(geo, state, sc.time.dt, 1e-10 * scale)
    got = set(pairs)
    assert len(got) == len(pairs), f"duplicate pairs: {pairs}"
    assert pairs == sorted(pairs) and all(i < j for i, j in pairs), f"pairs not in (i, j) order: {pairs}"
    assert not sure - got, f"missed pairs {sorted(sure - got)}"
    assert not got - sure - maybe, f"spurious pairs {sorted(got - sure - maybe)}"
    assert not wall_sure - set(wall), f"missed wall contacts {sorted(wall_sure - set(wall))}"
    assert not set(wall) - wall_sure - wall_maybe, f"spurious wall contacts {sorted(set(wall) - wall_sure - wall_maybe)}"
    return len(sure)


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(layouts(moving=False))
def test_detection_matches_brute_force_at_rest(detection_models, case):
    """Zero velocities (reach 0): contacts are exactly the overlapping disc pairs."""
    _check_detection(detection_models, *case)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(layouts(moving=True))
def test_detection_matches_brute_force_moving(detection_models, case):
    """Speculative contacts: disc gaps below reach_i + reach_j (see brute_force)."""
    _check_detection(detection_models, *case)


def test_detection_finds_dense_contacts(detection_models):
    """Guard for the property tests: a packed layout has many contacts (the check is not vacuous)."""
    m, sc, geo = detection_models[0]
    rng = np.random.default_rng(0)
    state = {"x": rng.uniform(-2, 2, N_PROP) - 500.25, "z": rng.uniform(-2, 2, N_PROP) - 77.5}
    state["theta"] = rng.uniform(-3, 3, N_PROP)
    state.update(vx=np.zeros(N_PROP), vz=np.zeros(N_PROP), omega=np.zeros(N_PROP))
    assert _check_detection(detection_models, 0, state) >= 10


# ---------------------------------------------------------------- two-body impulses
LIGHT = {1: (1.0, 1.4), 10: (0.2, 0.7), 100: (0.1, 0.14)}  # mass ratios against a 1 x 1.4 block
WALL_X = -50.0
DISCS_PAIR = 16  # k = 4 per face: a disc sits at each face centre, so head-on is exactly central


@pytest.fixture(scope="module", params=[0.5, 1.0], ids=["e0.5", "e1.0"])
def pair_model(request):
    """Three independent pairs (mass ratios 1, 10, 100) far from the origin, and one iceberg
    near the wall; effects collisions + wall only (no gravity or buoyancy)."""
    e = request.param
    bergs = []
    for k, ratio in enumerate((1, 10, 100)):
        wl, hl = LIGHT[ratio]
        x, z = 137.0 + 100.0 * k, -40.0 + 25.0 * k
        bergs.append({"x": x, "z": z, "width": 1.0, "thickness": 1.4})
        bergs.append({"x": x + 0.5 + wl / 2 + 0.05, "z": z, "width": wl, "thickness": hl})
    bergs.append({"x": WALL_X + 2.0, "z": 3.0, "width": 1.0, "thickness": 1.4})
    physics = {"restitution": e, "density_ratio": R, "wall_x": WALL_X}
    sc = make_scene(["collisions", "wall"], bergs, physics, contacts={"discs": DISCS_PAIR})
    m = Model(sc)
    return m, sc, e, Geometry(m, sc)


def setup_pairs(m, sc, geo, offset, spin, tilt, vz=(0.0, 0.0)):
    """Pairs approaching at relative speed 2, placed at a disc gap of half a step's approach."""
    s = initial(sc)
    dt = sc.time.dt
    for k in range(3):
        i, j = 2 * k, 2 * k + 1
        s["z"][j] += offset * (1.0, 0.4, 0.1)[k]
        s["theta"][i], s["theta"][j] = -0.5 * tilt, tilt
        s["vx"][i], s["vx"][j] = 1.0, -1.0
        s["vz"][i], s["vz"][j] = vz
        s["omega"][i], s["omega"][j] = spin
        for _ in range(60):  # slide j along x until the disc gap is 0.5 * 2 * dt
            g = geo.pair_gap(s, i, j) - dt
            s["x"][j] -= g
            if abs(g) < 1e-14:
                break
    w = 6
    s["theta"][w], s["omega"][w], s["vx"][w], s["vz"][w] = tilt, spin[0], -1.0, vz[0]
    for _ in range(60):
        g = geo.wall_penetration(s, WALL_X) + 0.5 * dt
        s["x"][w] += g
        if abs(g) < 1e-14:
            break
    return s


def kinetic(k, s, idx):
    return sum(0.5 * k["mass"][q] * (s["vx"][q] ** 2 + s["vz"][q] ** 2) + 0.5 * k["inertia"][q] * s["omega"][q] ** 2 for q in idx)


def angular_momentum(k, s, idx):
    """About the origin: sum m (x v_z - z v_x) + I omega."""
    return sum(k["mass"][q] * (s["x"][q] * s["vz"][q] - s["z"][q] * s["vx"][q]) + k["inertia"][q] * s["omega"][q] for q in idx)


def normal_speed(s, i, j, n, a1, a2):
    """v_rel . n at the contact, with (omega x r) . n = omega (r x n) and arms a = r x n."""
    return (s["vx"][i] - s["vx"][j]) * n[0] + (s["vz"][i] - s["vz"][j]) * n[1] + s["omega"][i] * a1 - s["omega"][j] * a2


def check_impulse_steps(m, sc, e, state, steps=40):
    """Step one at a time; every velocity change must be one SPEC impulse. Returns the
    number of impulses seen per pair and on the wall."""
    k = m.constants()
    dt = sc.time.dt
    m.set_state(state)
    seen = [0, 0, 0, 0]
    pushes = [0, 0, 0]
    for _ in range(steps):
        b, tb = m.state(), m.totals()
        m.advance(1)
        a, ta = m.state(), m.totals()
        n_imp = 0
        lost = 0.0
        for p in range(3):
            i, j = 2 * p, 2 * p + 1
            dv1 = np.array([a["vx"][i] - b["vx"][i], a["vz"][i] - b["vz"][i]])
            dv2 = np.array([a["vx"][j] - b["vx"][j], a["vz"][j] - b["vz"][j]])
            # drift with the new velocity; anything else is an overlap correction (counted)
            for q in (i, j):
                if abs(a["x"][q] - b["x"][q] - dt * a["vx"][q]) + abs(a["z"][q] - b["z"][q] - dt * a["vz"][q]) > 1e-12:
                    pushes[p] += 1
            if not (np.any(dv1) or np.any(dv2) or a["omega"][i] != b["omega"][i]):
                continue
            n_imp += 1
            seen[p] += 1
            m1, m2, i1, i2 = k["mass"][i], k["mass"][j], k["inertia"][i], k["inertia"][j]
            scale_p = m1 * math.hypot(b["vx"][i], b["vz"][i]) + m2 * math.hypot(b["vx"][j], b["vz"][j])
            # equal and opposite impulses: linear momentum to round-off
            assert np.all(np.abs(m1 * dv1 + m2 * dv2) < 1e-13 * scale_p), (p, m1 * dv1 + m2 * dv2)
            # angular momentum about the origin (pairs sit ~100-300 widths away) to round-off,
            # across the impulse (applied at the start-of-step positions, before the drift)
            lscale = sum(k["mass"][q] * math.hypot(b["x"][q], b["z"][q]) * math.hypot(b["vx"][q], b["vz"][q]) for q in (i, j))
            mid = {**a, "x": b["x"], "z": b["z"]}
            dl = angular_momentum(k, mid, (i, j)) - angular_momentum(k, b, (i, j))
            assert abs(dl) < 1e-12 * lscale, f"pair {p}: angular momentum changed by {dl} (scale {lscale})"
            # the impulse J n (J > 0) and the arms r x n seen through the velocity changes
            jn = m1 * np.linalg.norm(dv1)
            n = dv1 / np.linalg.norm(dv1)
            a1 = (a["omega"][i] - b["omega"][i]) * i1 / jn
            a2 = -(a["omega"][j] - b["omega"][j]) * i2 / jn
            # the arms belong to one contact point: (r2 - r1) x n = (x1 - x2) x n
            lever = (b["x"][i] - b["x"][j]) * n[1] - (b["z"][i] - b["z"][j]) * n[0]
            assert abs((a2 - a1) - lever) < 1e-9 * (1 + abs(lever)), (p, a2 - a1, lever)
            v0, v1 = normal_speed(b, i, j, n, a1, a2), normal_speed(a, i, j, n, a1, a2)
            assert v0 < 0, f"pair {p}: impulse on a separating contact (v_n = {v0})"
            np.testing.assert_allclose(v1, -e * v0, rtol=1e-9, atol=1e-12, err_msg=f"pair {p}: restitution")
            kk = 1 / m1 + 1 / m2 + a1 * a1 / i1 + a2 * a2 / i2
            expect = 0.5 * (1 - e * e) * v0 * v0 / kk
            de = kinetic(k, b, (i, j)) - kinetic(k, a, (i, j))
            np.testing.assert_allclose(de, expect, rtol=1e-9, atol=1e-13, err_msg=f"pair {p}: energy lost")
            lost += de
        w = 6
        dvx = a["vx"][w] - b["vx"][w]
        if dvx != 0.0 or a["omega"][w] != b["omega"][w] or a["vz"][w] != b["vz"][w]:
            n_imp += 1
            seen[3] += 1
            mw, iw = k["mass"][w], k["inertia"][w]
            assert a["vz"][w] == b["vz"][w], "the wall's normal is horizontal"
            jn = mw * dvx
            assert jn > 0
            arm = (a["omega"][w] - b["omega"][w]) * iw / jn
            v0, v1 = b["vx"][w] + b["omega"][w] * arm, a["vx"][w] + a["omega"][w] * arm
            assert v0 < 0
            np.testing.assert_allclose(v1, -e * v0, rtol=1e-9, atol=1e-12, err_msg="wall restitution")
            expect = 0.5 * (1 - e * e) * v0 * v0 / (1 / mw + arm * arm / iw)
            de = kinetic(k, b, (w,)) - kinetic(k, a, (w,))
            np.testing.assert_allclose(de, expect, rtol=1e-9, atol=1e-13, err_msg="wall energy lost")
            np.testing.assert_allclose(ta.wall_impulse - tb.wall_impulse, jn, rtol=1e-12)
            lost += de
        assert ta.impulses - tb.impulses == n_imp, f"{ta.impulses - tb.impulses} impulses counted, {n_imp} seen"
        np.testing.assert_allclose(ta.collision_dissipated - tb.collision_dissipated, lost, rtol=1e-9, atol=1e-13)
        if e == 1.0:
            assert abs(ta.collision_dissipated - tb.collision_dissipated) < 1e-13
    return seen, pushes


@pytest.mark.parametrize(
    "offset,spin,tilt",
    [(0.35, (0.0, 0.0), 0.0), (0.35, (0.5, -1.0), 0.0), (0.4, (0.5, -1.0), 0.2), (-0.3, (-2.0, 3.0), -0.3)],
    ids=["eccentric", "eccentric-spin", "eccentric-spin-tilt", "spin-tilt-below"],
)
def test_two_body_impulse_law(pair_model, offset, spin, tilt):
    """Mass ratios 1, 10, 100, eccentric, spinning: momentum and angular momentum conserved,
    v_n' = -e v_n, energy lost = collision_dissipated = 0.5 (1 - e^2) v_n^2 / K; wall too."""
    m, sc, e, geo = pair_model
    s = setup_pairs(m, sc, geo, offset, spin, tilt, vz=(0.1, -0.2))
    seen, pushes = check_impulse_steps(m, sc, e, s)
    assert all(c >= 1 for c in seen), f"impulses per pair/wall: {seen}"


def test_head_on_textbook(pair_model):
    """Head-on, no spin: v1' = ((m1 - e m2) u1 + (1 + e) m2 u2) / (m1 + m2), no spin, no v_z;
    the wall returns -e u."""
    m, sc, e, geo = pair_model
    k = m.constants()
    s = setup_pairs(m, sc, geo, 0.0, (0.0, 0.0), 0.0)
    seen, pushes = check_impulse_steps(m, sc, e, s, steps=1)
    assert seen == [1, 1, 1, 1] and pushes == [0, 0, 0], (seen, pushes)  # all touch in the first step
    m.set_state(s)
    m.advance(30)
    a = m.state()
    assert m.totals().impulses > 0
    for p in range(3):
        i, j = 2 * p, 2 * p + 1
        m1, m2 = k["mass"][i], k["mass"][j]
        u1, u2 = s["vx"][i], s["vx"][j]
        v1 = ((m1 - e * m2) * u1 + (1 + e) * m2 * u2) / (m1 + m2)
        v2 = ((m2 - e * m1) * u2 + (1 + e) * m1 * u1) / (m1 + m2)
        np.testing.assert_allclose([a["vx"][i], a["vx"][j]], [v1, v2], rtol=1e-12, err_msg=f"mass ratio {m1 / m2:.3g}")
        for q in (i, j):
            assert abs(a["vz"][q]) < 1e-12 and abs(a["omega"][q]) * geo.bound[q] < 1e-12, (q, a["vz"][q], a["omega"][q])
    np.testing.assert_allclose(a["vx"][6], e * 1.0, rtol=1e-12)
    assert abs(a["omega"][6]) < 1e-12 and a["vz"][6] == 0.0
    if e == 1.0:
        assert kinetic(k, a, range(geo.n)) == pytest.approx(kinetic(k, s, range(geo.n)), rel=1e-13)


def test_symmetric_equal_blocks(pair_model):
    """Equal blocks at +-u, head-on: they leave at -+e u with no spin (mass ratio 1 pair)."""
    m, sc, e, geo = pair_model
    s = setup_pairs(m, sc, geo, 0.0, (0.0, 0.0), 0.0)
    m.set_state(s)
    m.advance(30)
    a = m.state()
    np.testing.assert_allclose([a["vx"][0], a["vx"][1]], [-e, e], rtol=1e-12)
    assert abs(a["omega"][0]) < 1e-13 and abs(a["omega"][1]) < 1e-13
    assert abs(a["vz"][0]) < 1e-13 and abs(a["vz"][1]) < 1e-13


# ---------------------------------------------------------------- rest
def test_floating_row_stays_at_rest():
    """Paper geometry (gap 0.1 from the wall and between icebergs), no tilt: nothing moves."""
    sc = scene_mod.load(None, overrides=[("shelf.count", 30), ("shelf.tilt", 0.0)])
    m = Model(sc)
    s0 = initial(sc)
    vmax = 0.0
    for _ in range(10):
        m.advance(100)
        s = m.state()
        vmax = max(vmax, max(np.abs(s[k]).max() for k in ("vx", "vz", "omega")))
    assert vmax < 1e-12, f"max velocity {vmax}"
    for key in ("x", "z", "theta"):
        np.testing.assert_allclose(s[key], s0[key], rtol=0, atol=1e-11)
    t = m.totals()
    assert t.impulses == 0 and t.collision_dissipated == 0.0 and t.correction_work == 0.0 and t.wall_impulse == 0.0
    assert m.contact_pairs() == ([], [])


# ---------------------------------------------------------------- hard cases
def run_hard(m, sc, state, steps, every, order=True, depth=1.0):
    """Advance, checking finiteness, interpenetration, wall penetration, energy and order.

    ``depth``: the interpenetration bound in disc radii (README: 1 up to a third of a width
    per step, 1.5 at one width per step).

    Runs to the end and then reports every violated bound with its worst value and the
    first step it was exceeded (so a failure describes the whole run)."""
    geo = Geometry(m, sc)
    k = m.constants()
    m.set_state(state)
    s = m.sample()
    e0 = total_energy(s)
    bounds = {
        "interpenetration": depth * geo.r.min(),
        "wall penetration": depth * geo.r.min(),
        "energy rise": 1e-3 * k["mass"].sum(),
    }
    worst = {key: -np.inf for key in bounds}
    first = {}
    order0 = np.argsort(s["x"], kind="stable")
    swapped = None
    for step in range(every, steps + 1, every):
        m.advance(every)
        s = m.sample()
        for key in STATE:
            assert np.all(np.isfinite(s[key])), f"non-finite {key} at step {step}"
        now = {
            "interpenetration": geo.penetration(s),
            "wall penetration": geo.wall_penetration(s, sc.physics.wall_x) if sc.effects.wall else -np.inf,
            "energy rise": total_energy(s) - e0,
        }
        for key, value in now.items():
            worst[key] = max(worst[key], value)
            if value > bounds[key] and key not in first:
                first[key] = step
        if order and swapped is None and not np.array_equal(np.argsort(s["x"], kind="stable"), order0):
            swapped = step
    problems = [f"{key}: max {worst[key]:.4g} > {bounds[key]:.4g} (first at step {first[key]})" for key in first]
    if swapped is not None:
        problems.append(f"icebergs passed through each other (x order changed at step {swapped})")
    assert not problems, "; ".join(problems)
    return worst, m.totals()


@pytest.mark.parametrize("discs", [8, 12])
def test_tall_thin_icebergs_packed(discs):
    """Aspect 3 (0.5 x 1.5; 8 discs is the minimum), 30 icebergs 0.01 apart, upright with
    small random spins: they capsize into each other. Stable, finite, bounded overlap."""
    w, h, gap, n = 0.5, 1.5, 0.01, 30
    rng = np.random.default_rng(3)
    bergs = [
        {"x": 0.1 + w / 2 + q * (w + gap), "z": -R * h + h / 2, "omega": rng.uniform(-0.1, 0.1), "width": w, "thickness": h}
        for q in range(n)
    ]
    sc = make_scene(FULL, bergs, {"density_ratio": R, "restitution": 0.5}, contacts={"discs": discs})
    m = Model(sc)
    worst, tot = run_hard(m, sc, initial(sc), 3000, 20, order=False)
    s = m.state()
    from melange_ti.diagnostics import capsized_fraction

    assert tot.impulses > 1000 and capsized_fraction(s["theta"]) > 0, "the test needs capsizes and contacts"


@pytest.fixture(scope="module")
def packed_row():
    gap, n, h = 0.01, 20, 1.4
    bergs = [{"x": gap + 0.5 + q * (1 + gap), "z": -R * h + h / 2, "width": 1.0, "thickness": h} for q in range(n)]
    bergs.append({"x": bergs[-1]["x"] + 1.0 + 0.05, "z": -R * h + h / 2, "width": 1.0, "thickness": h})
    sc = make_scene(FULL, bergs, {"density_ratio": R, "restitution": 0.5}, contacts={"discs": 28})
    return Model(sc), sc


@pytest.mark.parametrize(("speed", "depth"), [(10.0, 1.0), (30.0, 1.0), (100.0, 1.5)])
def test_fast_iceberg_into_packed_row(packed_row, speed, depth):
    """One iceberg at 1.1, 3.4 or 11 disc radii per step into a packed row of 20 (gaps 0.01)
    against the wall: it must not tunnel, nor drive others through each other, and overlaps
    stay within the documented bound (one disc radius; 1.5 at one width per step)."""
    m, sc = packed_row
    s = initial(sc)
    s["vx"][-1] = -speed
    run_hard(m, sc, s, 200, 1, depth=depth)


@pytest.mark.parametrize("speed", [1.0, 5.0])
def test_row_driven_into_wall(speed):
    """The paper row (20 icebergs, gaps 0.1) pushed into the wall at `speed`."""
    sc = scene_mod.load(None, overrides=[("shelf.count", 20), ("shelf.tilt", 0.0)])
    m = Model(sc)
    s = initial(sc)
    s["vx"][:] = -speed
    run_hard(m, sc, s, 1000, 5)


# ---------------------------------------------------------------- candidate lists
def _contacts_now(m):
    """Contacts the next step would use, with their raw data: pairs, wall bodies, and each
    body's slots (partner, point, normal, gap) as bytes."""
    pairs, wall = m.contact_pairs()
    from melange_ti.physics.data.schema import BodyInt

    nc = m.arrays.bi.to_numpy()[:, BodyInt.NCONTACT]
    cd, cp = m.arrays.cd.to_numpy(), m.arrays.cp.to_numpy()
    slots = [(cp[: nc[i], i].tobytes(), cd[: nc[i], i].tobytes()) for i in range(m.n)]
    return pairs, wall, slots


@st.composite
def moved_layouts(draw):
    which, state = draw(layouts(moving=True))
    n = N_PROP
    scale = draw(st.sampled_from([0.0, 1e-6, 1e-3, 0.02, 0.1, 0.5]))
    d = np.array(draw(st.lists(coord, min_size=3 * n, max_size=3 * n))).reshape(3, n) * scale
    moved = copy(state)
    moved["x"] = moved["x"] + d[0]
    moved["z"] = moved["z"] + d[1]
    moved["theta"] = moved["theta"] + d[2]
    return which, state, moved


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(moved_layouts())
def test_candidate_lists_give_the_searched_contacts(detection_models, case):
    """The narrow phase keeps, per body pair, the disc pairs found within touching distance
    plus a skin, and later visits only those while the pair has not moved too far. After any
    move (none, tiny, within the skin, far beyond it) the contacts must be bit-for-bit those
    of a fresh search."""
    which, before, after = case
    m = detection_models[which][0]
    assert m.lists, "this model keeps no candidate lists: the comparison would be vacuous"
    m.set_state(before)
    m.contact_pairs()  # lists made at `before`
    m.set_state(after)
    warm = _contacts_now(m)
    m.clear_candidate_lists()
    cold = _contacts_now(m)
    assert warm[:2] == cold[:2]
    assert warm[2] == cold[2], "contact data differ between the kept lists and a fresh search"


def _packed_row(discs=28, n=20):
    bergs = [{"x": 0.6 + k * 1.0, "z": -R * 1.4 + 0.7, "width": 1.0, "thickness": 1.4} for k in range(n)]
    sc = make_scene(FULL, bergs, contacts={"discs": discs})
    rng = np.random.default_rng(3)
    s = initial(sc)
    s["theta"] = rng.uniform(-0.01, 0.01, n)
    return sc, s, rng


@pytest.mark.parametrize("discs", [12, 28, 60])
def test_candidate_lists_are_kept_and_exact(discs):
    """A packed row, its lists made, then moved a little (well within the skin): the lists
    are reused (their recorded poses do not change) and give the searched contacts exactly;
    moved a lot, they are remade (poses change) and are exact again."""
    from melange_ti.physics.step.narrow import ENTRIES

    sc, s, rng = _packed_row(discs)
    m = Model(sc)
    assert m.lists
    m.set_state(s)
    first = _contacts_now(m)
    assert len(first[0]) >= 15  # the row touches along its length: not vacuous
    poses = m.arrays.nr.to_numpy().copy()
    used = m.arrays.nl.to_numpy()[:, :ENTRIES] >= 0

    small = copy(s)
    small["x"] = small["x"] + rng.uniform(-1e-4, 1e-4, s["x"].size)
    small["theta"] = small["theta"] + rng.uniform(-1e-5, 1e-5, s["x"].size)
    small["vx"] = rng.uniform(-0.01, 0.01, s["x"].size)
    m.set_state(small)
    warm = _contacts_now(m)
    kept = np.all(m.arrays.nr.to_numpy() == poses, axis=2) & used
    assert kept.sum() >= 15, "lists were not reused after a tiny move"
    m.clear_candidate_lists()
    assert warm == _contacts_now(m)

    m.set_state(small)
    _contacts_now(m)  # lists at `small`
    poses = m.arrays.nr.to_numpy().copy()
    used = m.arrays.nl.to_numpy()[:, :ENTRIES] >= 0
    big = copy(small)
    big["theta"] = big["theta"] + np.where(np.arange(big["x"].size) % 2 == 0, 0.05, -0.05)
    big["x"] = big["x"] + np.arange(big["x"].size) * 0.02
    m.set_state(big)
    warm = _contacts_now(m)
    remade = ~np.all(m.arrays.nr.to_numpy() == poses, axis=2) & used
    assert remade.sum() >= 15, "lists were not remade after a large move"
    m.clear_candidate_lists()
    assert warm == _contacts_now(m)


def test_broad_phase_reach_is_exact():
    """The broad phase keeps only each body's motion and the fastest speed; every reach is
    ``motion + dt (1 + e) v_max`` where it is read, and the largest reach comes from the
    fastest speed alone (both monotone in floating point). Against numpy, exactly, with
    random velocities over more bodies than one chunk of the parallel maximum (1,000 > 256)
    and the fastest body in the last, partial chunk."""
    from melange_ti.physics.data.schema import Body, Param, Scratch
    from melange_ti.physics.step import broad

    sc = scene_mod.load(None, overrides=[("shelf.count", 1000)])
    m = Model(sc, mode="parallel", islands=False)
    rng = np.random.default_rng(7)
    s = m.state()
    s["vx"], s["vz"], s["omega"] = rng.normal(0, 0.1, (3, 1000))
    s["vx"][990] = 3.0
    m.set_state(s)
    m.contact_pairs()  # the broad and narrow phases, parallel form
    b, par, scr = m.arrays.b.to_numpy(), m.arrays.par.to_numpy(), m.arrays.scr.to_numpy()
    speed = np.sqrt(b[:, Body.VX] ** 2 + b[:, Body.VZ] ** 2) + np.abs(b[:, Body.OM]) * b[:, Body.BOUND]
    dt = par[Param.DT]
    motion = dt * speed
    reach = motion + dt * (1.0 + par[Param.RESTITUTION]) * speed.max()
    assert broad.CHUNK < 1000 and np.argmax(speed) == 990
    assert np.array_equal(b[:, Body.MOTION], motion)
    assert scr[Scratch.SPEED_MAX] == speed.max()
    assert scr[Scratch.REACH_MAX] == reach.max()
