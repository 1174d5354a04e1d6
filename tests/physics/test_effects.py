"""Each effect left out of a scene removes exactly its term (SPEC section 2).

Every test builds a model with all effects but one (or a single effect) and compares the
trajectory with the closed form of what remains. Comparisons are to round-off (rtol 1e-12):
the remaining terms are evaluated in numpy with the same recurrences as the time stepper
(semi-implicit Euler, drag as backward Euler v /= 1 + c dt).
"""

from __future__ import annotations

import math

import numpy as np

from melange_ti.energy import total_energy
from melange_ti.geometry import clipped_moments
from melange_ti.model import Model
from melange_ti.scene import DENSITY_RATIO

from .scenes import initial, make_scene

R = DENSITY_RATIO


PAPER = ("gravity", "buoyancy", "drag", "collisions", "wall")  # the paper's effects (test_water.py: the others)


def all_but(name):
    return [e for e in PAPER if e != name]


def z_eq(h, wl=0.0):
    return wl - R * h + 0.5 * h


# ---------------------------------------------------------------- buoyancy
def test_no_buoyancy_is_free_fall_with_drag():
    """Without buoyancy an iceberg in the water falls: v <- (v - g dt) / (1 + c dt)."""
    dt, c = 0.01, 0.3
    bergs = [{"x": 50.0, "z": z_eq(1.4), "vx": -0.4, "vz": 0.2}, {"x": 80.0, "z": 2.0, "theta": 0.3, "vx": 0.1}]
    sc = make_scene(all_but("buoyancy"), bergs, {"density_ratio": R, "drag": c, "angular_drag": 0.05}, dt=dt)
    m = Model(sc)
    s0 = initial(sc)
    n = 500
    m.advance(n)
    s = m.state()
    q = 1.0 / (1.0 + c * dt)
    vz, z = s0["vz"].copy(), s0["z"].copy()
    vx, x = s0["vx"].copy(), s0["x"].copy()
    for _ in range(n):
        vz = (vz - dt) * q
        z = z + dt * vz
        vx = vx * q
        x = x + dt * vx
    np.testing.assert_allclose(s["vz"], vz, rtol=1e-12)
    np.testing.assert_allclose(s["z"], z, rtol=1e-12)
    np.testing.assert_allclose(s["vx"], vx, rtol=1e-12)
    np.testing.assert_allclose(s["x"], x, rtol=1e-12)
    assert np.array_equal(s["theta"], s0["theta"]) and np.all(s["omega"] == 0.0)
    assert np.all(s["z"] < s0["z"] - 5.0)  # it really fell through the water line


def test_buoyancy_without_gravity_accelerates_up_by_area_over_mass():
    """Buoyancy only: dv_z = dt A / m and d omega = dt Sx / I for the clipped rectangle."""
    dt = 0.01
    rng = np.random.default_rng(4)
    bergs = []
    for k in range(8):
        w, h = rng.uniform(0.5, 2.0), rng.uniform(0.5, 2.0)
        z, theta = rng.uniform(-0.3, 0.3) * min(w, h), rng.uniform(-math.pi, math.pi)
        bergs.append({"x": 5.0 * k, "z": z, "theta": theta, "width": w, "thickness": h})
    bergs.append({"x": 60.0, "z": -5.0, "theta": 0.4})  # fully submerged
    bergs.append({"x": 70.0, "z": 5.0, "theta": 0.4})  # in the air
    sc = make_scene(["buoyancy"], bergs, {"density_ratio": R}, dt=dt)
    m = Model(sc)
    k = m.constants()
    s0 = initial(sc)
    m.advance(1)
    s = m.state()
    n = len(bergs)
    area = np.empty(n)
    sx = np.empty(n)
    for i in range(n):
        area[i], sx[i] = clipped_moments(s0["z"][i], s0["theta"][i], k["width"][i], k["thickness"][i])
    assert 0 < area[:8].min() and area[:8].max() < (k["width"] * k["thickness"])[:8].max()  # partly submerged
    np.testing.assert_allclose(s["vz"], dt * area / k["mass"], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(s["omega"], dt * sx / k["inertia"], rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(s["vz"][8], dt / R, rtol=1e-12)  # submerged: A / m = w h / (r w h)
    assert s["vz"][9] == 0.0 and s["omega"][9] == 0.0
    assert np.array_equal(s["vx"], s0["vx"])


# ---------------------------------------------------------------- drag
def test_only_drag_is_exponential_decay():
    """Drag only: nothing but v /= (1 + c dt) each step; v -> v0 exp(-c t) to first order."""
    dt, c, ca = 0.01, 0.2, 0.1
    bergs = [{"x": 0.0, "z": 3.0, "vx": 1.0, "vz": -2.0, "omega": 0.5}]
    sc = make_scene(["drag"], bergs, {"drag": c, "angular_drag": ca}, dt=dt)
    m = Model(sc)
    s0 = initial(sc)
    n = 2000
    m.advance(n)
    s = m.state()
    t = n * dt
    for key, rate in (("vx", c), ("vz", c), ("omega", ca)):
        np.testing.assert_allclose(s[key], s0[key] * (1 + rate * dt) ** -n, rtol=1e-12)
        rel = abs(s[key][0] / (s0[key][0] * math.exp(-rate * t)) - 1)
        assert rel < rate * rate * t * dt, f"{key}: {rel} vs first-order bound {rate * rate * t * dt}"
    q = 1.0 / (1.0 + c * dt)
    np.testing.assert_allclose(s["z"], s0["z"] + dt * s0["vz"] * q * (1 - q**n) / (1 - q), rtol=1e-12)  # no gravity


def test_no_drag_books_no_drag_work():
    """Without drag, drag_dissipated stays exactly 0 and a free iceberg keeps its velocity exactly."""
    dt = 0.01
    h = 1.4
    bergs = [{"x": 0.6 + 1.1 * k, "z": z_eq(h), "theta": 0.0, "omega": 0.05 * (-1) ** k} for k in range(6)]
    bergs.append({"x": 60.0, "z": z_eq(h), "vx": 0.7})  # alone, floating, moving sideways
    bergs.append({"x": 2.2 + 8.0, "z": z_eq(h), "vx": -3.0})  # runs into the row
    sc = make_scene(all_but("drag"), bergs, {"density_ratio": R, "restitution": 0.5, "drag": 0.5, "angular_drag": 0.5}, dt=dt)
    m = Model(sc)
    s0 = m.sample()
    m.advance(1500)
    s = m.sample()
    tot = m.totals()
    assert tot.impulses > 0, "the test needs collisions"
    assert np.all(s["drag_dissipated"] == 0.0), s["drag_dissipated"]
    assert s["vx"][6] == 0.7 and s["vz"][6] == 0.0 and s["omega"][6] == 0.0
    np.testing.assert_allclose(s["x"][6], 60.0 + 1500 * dt * 0.7, rtol=1e-12)
    # energy budget without drag: what is lost went into collisions and corrections
    e0, e1 = total_energy(s0), total_energy(s)
    resid = e0 - e1 - tot.collision_dissipated - tot.impulse_offset_work - tot.correction_work
    # up to the integrator's own O(dt) error, ~1e-3 m g w per body at dt = 0.01 (test_analytic)
    bound = 1e-3 * m.constants()["mass"].sum()
    assert abs(resid) < bound, f"energy budget residual {resid} (released {e0 - e1}) > {bound}"


# ---------------------------------------------------------------- collisions
def test_no_collisions_icebergs_pass_through_each_other():
    """Without collisions two icebergs on crossing paths pass through; only drag acts on vx."""
    dt, c = 0.01, 0.01
    h = 1.4
    bergs = [{"x": 5.0, "z": z_eq(h), "vx": 1.0}, {"x": 8.0, "z": z_eq(h), "vx": -1.0}]
    sc = make_scene(all_but("collisions"), bergs, {"density_ratio": R, "drag": c, "angular_drag": c}, dt=dt)
    m = Model(sc)
    s0 = initial(sc)
    q = 1.0 / (1.0 + c * dt)
    closest = np.inf
    n = 0
    for _ in range(40):
        m.advance(10)
        n += 10
        s = m.state()
        closest = min(closest, abs(s["x"][1] - s["x"][0]))
        np.testing.assert_allclose(s["vx"], s0["vx"] * q**n, rtol=1e-12)
        np.testing.assert_allclose(s["x"], s0["x"] + dt * s0["vx"] * q * (1 - q**n) / (1 - q), rtol=1e-12)
    assert closest < 0.1, f"the icebergs never overlapped (closest centre distance {closest})"
    assert s["x"][0] > s0["x"][1] and s["x"][1] < s0["x"][0], "they did not pass through each other"
    np.testing.assert_allclose(s["z"], s0["z"], atol=1e-12)
    assert m.totals().impulses == 0


# ---------------------------------------------------------------- wall
def test_no_wall_iceberg_crosses_wall_x():
    """Without the wall an iceberg moving left crosses x = wall_x unhindered."""
    dt, c = 0.01, 0.01
    h = 1.4
    bergs = [{"x": 1.0, "z": z_eq(h), "vx": -2.0}, {"x": 20.0, "z": z_eq(h)}]
    sc = make_scene(all_but("wall"), bergs, {"density_ratio": R, "drag": c, "angular_drag": c, "wall_x": 0.0}, dt=dt)
    m = Model(sc)
    s0 = initial(sc)
    n = 200
    m.advance(n)
    s = m.state()
    q = 1.0 / (1.0 + c * dt)
    np.testing.assert_allclose(s["vx"][0], -2.0 * q**n, rtol=1e-12)
    np.testing.assert_allclose(s["x"][0], 1.0 - 2.0 * dt * q * (1 - q**n) / (1 - q), rtol=1e-12)
    bound = 0.5 * math.hypot(1.0, h)
    assert s["x"][0] + bound < 0.0, f"x = {s['x'][0]}: not entirely beyond the wall line"
    assert m.totals().impulses == 0 and m.totals().wall_impulse == 0.0
    assert np.array_equal(s["x"][1], s0["x"][1])
