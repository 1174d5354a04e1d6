"""Ice crushing at contacts (effect ``crushing``): a contact passes at most ``F_c dt`` of normal
impulse a step, ``F_c = crushing_pressure * crushing_height``.

Derived (docs/model.md, "Crushing"): a block of mass ``m`` driven at ``v_0`` into the wall (no
other force) feels the constant force ``F_c`` while it crushes, so its velocity falls by
``F_c dt / m`` every step, it stops at ``t = m v_0 / F_c`` after the first contact, and the
wall takes the momentum ``m v_0`` (the last step's impulse, below the cap, rebounds at ``e``
what little is left); the work of every impulse, ``-J (v_n + J K / 2)``, is the kinetic
energy lost. Two blocks meeting head-on close at ``F_c dt (1/m_1 + 1/m_2)`` a step, with their
momentum kept. An impact stopped within one step by ``F_c`` is the rigid law's, to the bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from melange_ti import scene as scene_mod
from melange_ti.model import Model
from melange_ti.physics.data.schema import ENERGY_LEDGERS
from melange_ti.scene import DENSITY_RATIO

from .scenes import KERNEL_FORMS, initial, make_scene

R = DENSITY_RATIO
WALL_X = -50.0
W, H = 1.0, 1.4
MASS = R * W * H
INERTIA = MASS * (W * W + H * H) / 12.0
P_C, H_C = 2.0, 0.1  # the keys' defaults: F_c = 0.2
F_C = P_C * H_C


def block_into_wall(dt=0.01, restitution=0.5, friction=False, tilt=0.0, vz=0.0, pressure=P_C):
    """One block (no gravity, no water) at v_x = -1 half a step from the wall."""
    effects = ["collisions", "wall", "crushing"] + (["friction"] if friction else [])
    physics = {"restitution": restitution, "density_ratio": R, "wall_x": WALL_X, "crushing_pressure": pressure}
    sc = make_scene(
        effects,
        [{"x": WALL_X + 2.0, "z": 3.0, "width": W, "thickness": H, "theta": tilt}],
        physics,
        contacts={"discs": 16},
        dt=dt,
    )
    m = Model(sc)
    s = initial(sc)
    reach = 0.5 * W * abs(np.cos(tilt)) + 0.5 * H * abs(np.sin(tilt))
    s["x"][0] = WALL_X + reach + 0.5 * dt
    s["vx"][0], s["vz"][0] = -1.0, vz
    m.set_state(s)
    return m, sc


def history(m, steps):
    """Velocities and run-wide totals after each of ``steps`` steps."""
    out = []
    for _ in range(steps):
        m.advance(1)
        out.append((m.state(), m.totals()))
    return out


@pytest.mark.parametrize("friction", [False, True])
def test_a_block_crushing_into_the_wall_slows_at_the_crushing_force(friction):
    dt = 0.01
    m, _ = block_into_wall(dt, friction=friction)
    stop = MASS * 1.0 / F_C  # 6.3: the block stops this long after its first contact
    hist = history(m, round(1.2 * stop / dt))
    vx = np.array([s["vx"][0] for s, _ in hist])
    impulses = np.array([t.impulses for _, t in hist])
    first = int(np.argmax(impulses > 0))
    assert first <= 1, "the block meets the wall within its first steps"
    crushing = np.arange(first, first + int(stop / dt) - 2)
    # every step of the crush (mid-run as at its start) takes exactly F_c dt of momentum
    dv = np.diff(np.concatenate([[-1.0], vx]))[crushing]
    np.testing.assert_allclose(dv * MASS, F_C * dt, rtol=1e-9)
    np.testing.assert_allclose(vx[first + 300], -1.0 + 301 * F_C * dt / MASS, rtol=1e-9)
    # it stops within a step of m v_0 / F_c, and stays (the last impulse rebounds at e what was left)
    stopped = int(np.argmax(vx > -1e-12))
    assert abs((stopped - first + 1) * dt - stop) <= dt
    assert 0 <= vx[-1] <= 0.5 * F_C * dt / MASS
    tot = hist[-1][1]
    np.testing.assert_allclose(tot.wall_impulse, MASS * (1.0 + vx[-1]), rtol=1e-12)
    lost = 0.5 * MASS * (1.0 - vx[-1] ** 2)
    booked = tot.collision_dissipated + (tot.friction_dissipated if friction else 0.0)
    np.testing.assert_allclose(booked, lost, rtol=1e-10)


def test_the_crush_converges_in_the_step():
    """The velocity at fixed times is the same at dt and dt / 4 (the force, not the step, sets it)."""
    seen = []
    for dt in (0.01, 0.0025):
        m, _ = block_into_wall(dt)
        hist = history(m, round(3.0 / dt))
        seen.append(np.array([s["vx"][0] for s, _ in hist])[round(1.0 / dt) - 1 :: round(1.0 / dt)])
    exact = -1.0 + F_C * np.array([1.0, 2.0, 3.0]) / MASS
    for v in seen:
        np.testing.assert_allclose(v, exact, atol=2 * F_C * 0.01 / MASS)


def test_an_off_centre_crush_with_friction_takes_the_cap_and_gains_nothing():
    """A tilted block's corner into the wall, sliding down it, restitution 1 (where Newton's law
    with Coulomb's cone could gain): each crushing step the wall takes exactly F_c dt normal
    impulse, the block's kinetic energy never grows, and its loss is the two ledgers."""
    m, _ = block_into_wall(restitution=1.0, friction=True, tilt=0.4, vz=-0.6)
    kin0 = 0.5 * MASS * (1.0 + 0.36)
    hist = history(m, 200)
    walls = np.diff([0.0] + [t.wall_impulse for _, t in hist])
    capped = walls[walls > 0]
    assert capped.size > 100
    np.testing.assert_allclose(capped[:-1], F_C * 0.01, rtol=1e-9)  # every step but the last
    kin = np.array([0.5 * MASS * (s["vx"][0] ** 2 + s["vz"][0] ** 2) + 0.5 * INERTIA * s["omega"][0] ** 2 for s, _ in hist])
    assert np.all(np.diff(np.concatenate([[kin0], kin])) <= 1e-14 * kin0)
    assert abs(hist[-1][0]["omega"][0]) > 1e-3, "an off-centre contact: the block spins"
    tot = hist[-1][1]
    assert abs(tot.friction_dissipated) > 1e-3, "friction acts (its ledger may be negative off centre: docs/model.md)"
    np.testing.assert_allclose(kin0 - kin[-1], tot.collision_dissipated + tot.friction_dissipated, rtol=1e-10)


def test_two_blocks_crushing_head_on_keep_their_momentum():
    dt = 0.01
    sc = make_scene(
        ["collisions", "crushing"],
        [{"x": 0.0, "z": 3.0, "width": W, "thickness": H}, {"x": 1.5 + 0.5 * dt, "z": 3.0, "width": 2 * W, "thickness": H}],
        {"restitution": 0.5, "density_ratio": R},
        contacts={"discs": 16},
        dt=dt,
    )
    m = Model(sc)
    s = initial(sc)
    s["vx"][0], s["vx"][1] = 0.5, -0.5
    m.set_state(s)
    m1, m2 = MASS, 2 * MASS
    hist = history(m, 300)
    vrel = np.array([st["vx"][1] - st["vx"][0] for st, _ in hist])
    step = F_C * dt * (1 / m1 + 1 / m2)
    np.testing.assert_allclose(np.diff(vrel[:250]), step, rtol=1e-9)
    for st, _ in hist:
        assert st["vx"][0] * m1 + st["vx"][1] * m2 == pytest.approx(0.5 * m1 - 0.5 * m2, abs=1e-13)


def row_scene(pressure: float | None, count: int = 12, friction: bool = True, duration: float = 60.0) -> scene_mod.Scene:
    effects = ["gravity", "buoyancy", "drag", "collisions", "wall"] + (["friction"] if friction else [])
    overrides = {
        "shelf.count": count,
        "shelf.tilt": 0.3,
        "shelf.gap": 0.35,
        "time.duration": duration,
        "scene.effects": effects + (["crushing"] if pressure is not None else []),
    }
    if pressure is not None:
        overrides["physics.crushing_pressure"] = pressure
    return scene_mod.load(None, overrides=list(overrides.items()))


def test_impacts_the_cap_never_reaches_are_the_rigid_laws_to_the_bit():
    steps = 3000
    rigid, high = Model(row_scene(None)), Model(row_scene(1e6))
    rigid.advance(steps)
    high.advance(steps)
    assert rigid.totals().impulses > 30
    # the premise: the rigid run's correction pushes nothing (crushing keeps overlaps it would push)
    assert rigid.totals().correction_work == 0.0
    for k, v in rigid.state().items():
        assert v.tobytes() == high.state()[k].tobytes(), k
    # and at a pressure the capsizes' impacts reach, the run differs
    low = Model(row_scene(0.5))
    low.advance(steps)
    assert low.state()["x"].tobytes() != rigid.state()["x"].tobytes()


def test_crushing_is_bit_identical_across_kernel_forms_and_closes_the_budget():
    sc = row_scene(0.5, count=12)
    results = []
    for mode, islands, groups in KERNEL_FORMS:
        kw = {} if mode == "serial" else {"islands": islands, **({"groups": groups} if groups else {})}
        m = Model(sc, mode=mode, **kw)
        s0 = m.sample()
        m.advance(round(sc.time.duration / sc.time.dt))
        results.append((m.state(), m.totals(), s0, m.sample()))
    state0, tot0, s0, s = results[0]
    for state, tot, _, _ in results[1:]:
        for k in state0:
            assert state0[k].tobytes() == state[k].tobytes(), k
        assert tot == tot0
    ledgers = {name: float(s[name].sum()) if name in s else float(getattr(tot0, name)) for name in ENERGY_LEDGERS}
    lost = (s0["kinetic"].sum() + s0["potential"].sum()) - (s["kinetic"].sum() + s["potential"].sum())
    released = s0["potential"].sum() - s["potential"].sum()
    assert tot0.impulses > 1000 and released > 0.1
    residual = lost - sum(ledgers.values())
    assert abs(residual) < 5e-4 * released, f"residual {residual / released:.4%} of released"


def test_crushing_keys_are_checked():
    with pytest.raises(scene_mod.SceneError, match="physics.crushing_pressure"):
        row_scene(0.0)
    with pytest.raises(scene_mod.SceneError, match="physics.crushing_height"):
        scene_mod.load(None, overrides=[("scene.effects+", "crushing"), ("physics.crushing_height", -1.0)])
    with pytest.raises(scene_mod.SceneError, match="crushing_pressure"):
        scene_mod.load(None, overrides=[("physics.crushing_pressure", 2.0), ("physics.crushing_pressure_pa", 1.4e6)])
    with pytest.raises(scene_mod.SceneError, match="crushing acts at contacts"):
        scene_mod.load(None, overrides=[("scene.effects", ["gravity", "buoyancy", "crushing"])])
    sc = scene_mod.load(None, overrides=[("scene.effects+", "crushing"), ("physics.crushing_pressure_pa", 1.4e6)])
    assert sc.physics.crushing_pressure == pytest.approx(1.4e6 / (1025 * 9.81 * sc.width_m))


# ------------------------------------------------------------ an impact into elastic ice
def _impact_stress_module():
    import importlib.util

    from ..conftest import ROOT

    spec = importlib.util.spec_from_file_location("impact_stress", ROOT / "validation" / "impact_stress.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_a_crushing_impact_loads_a_bonded_slab_with_its_crushing_force_not_its_speed(tmp_path):
    """The validation's head-on case (docs/validation.md, "Impacts into elastic ice"): a block
    strikes the end of a free floating slab of 20 bonded blocks. Derived: a force ``F_c`` held
    at one end of a free elastic bar sends a compression ``F_c / t`` along it, which the far,
    free end reflects as a tension of the same size; the crushing contact holds ``F_c`` as long
    as the block crushes, so the peak tension is ``F_c / t`` (the lattice's dispersion and the
    bonds' bending add a little: allowed 25%), whatever the speed. The rigid impulse's peak
    grows with the speed instead (linear: a velocity jump into springs), and at 0.05 w per
    time unit is already above twice ``F_c / t``."""
    mod = _impact_stress_module()
    import melange_ti as mt
    from melange_ti.scene import loads

    peak = {}
    for law, pressure in (("rigid", None), ("crushing", P_C)):
        for speed in (0.05, 0.1):
            out = tmp_path / f"{law}_{speed}.h5"
            mt.run(loads(mod.head_on(0.0025, 28, pressure, duration=2.0, speed=speed)), out, threads=1)
            peak[(law, speed)] = mod.stress_history(out)["peak_tension"]
    bound = F_C / H
    for speed in (0.05, 0.1):
        assert bound <= peak[("crushing", speed)] <= 1.25 * bound, peak
    assert peak[("crushing", 0.1)] == pytest.approx(peak[("crushing", 0.05)], rel=0.05)
    assert peak[("rigid", 0.1)] == pytest.approx(2 * peak[("rigid", 0.05)], rel=0.05)
    assert peak[("rigid", 0.05)] > 2 * bound


@pytest.mark.parametrize("form", ["serial", "device parts"])
def test_coloured_passes_with_crushing_give_the_parallel_forms_bits(form):
    """The coloured order (a device's default) with crushing: two layers of blocks driven
    into the wall and each other (tests/physics/test_colours.py), friction on, a pressure at
    which their impacts crush; the serial form and the device's parts on the CPU give the
    parallel form's bits (the device parts' energy sums within rounding)."""
    from .test_colours import jammed

    effects = ("gravity", "buoyancy", "drag", "collisions", "wall", "friction", "crushing")

    def run(**kw):
        sc = jammed("coloured", n=40, effects=effects)
        m = Model(sc, **kw)
        m.advance(100)
        return m.state(), m.totals()

    state, tot = run(mode="parallel")
    other, tot_o = run(mode="serial") if form == "serial" else run(mode="parallel", device_parts=True)
    for k in state:
        assert np.array_equal(other[k], state[k]), k
    assert tot_o.impulses == tot.impulses > 300, "many impulses: crushing contacts act step after step"
    if form == "serial":
        assert tot_o == tot
    else:
        for name in ("collision_dissipated", "friction_dissipated", "impulse_sum", "correction_work"):
            assert getattr(tot_o, name) == pytest.approx(getattr(tot, name), rel=1e-12, abs=1e-15)
