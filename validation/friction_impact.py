"""Coulomb friction (effect ``friction``): oblique impacts swept through the stick and the slip
regimes against the analytic impulses, with the energy the friction removes booked.

    python validation/friction_impact.py --out validation/results

The set-up of ``tests/physics/test_friction.py`` (its helpers copied here: validation does not
import from tests/). Restitution e = 0.5, friction mu = 0.3, 16 discs per block, dt = 0.01,
no gravity. For one contact with tangent ``t`` and arms ``r``, after the normal impulse
``J_n`` the tangential relative velocity ``v_t`` meets
``K_t = 1/m_i + 1/m_j + (r_i x t)^2/I_i + (r_j x t)^2/I_j``; the friction impulse is
``J_t = clamp(-v_t / K_t, -mu J_n, mu J_n)`` (stick while ``|v_t| <= mu J_n K_t``, the
threshold) and removes ``-J_t (v_t + J_t K_t / 2)`` of kinetic energy; the normal impulse
removes ``(1 - e^2) v_n^2 / (2 K_n)``.

Wall sweep: one upright block (width 1, thickness 1.4) half a step from the wall, moving into
it at v_x = -1 with v_z from 0 to 3 thresholds (26 values). Pair sweep: two blocks side by
side (the test's ``pair_model``: mass ratio 1, the same block twice, and mass ratio 10, a
0.2 x 0.7 block beside it) closing at relative speed 2 while sliding past each other at
0 to 2.5 (26 values), one pair moving at a time. One Model per sweep, reset with
``set_state`` for each point. The model's impulses are read off the velocity change of the
first step with an impulse, the pair's arms off the spins (as the test does; where J_t is
~0, at v_t = 0, from the case's other points). The friction energy booked is the step's change of
``Totals.friction_dissipated``; the kinetic energy lost is compared with the change of
``collision_dissipated + friction_dissipated``. Relative errors are against the analytic
value, or against mu J_n (impulse) and the kinetic energy lost (energy) where that is zero.
Writes ``friction_impact.csv`` and ``friction_impact.png`` and prints the largest errors.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import numpy as np

from melange_ti.bench.common import pyplot
from melange_ti.physics.schema import STATE_NAMES
from melange_ti.scene import DENSITY_RATIO, dumps_toml, loads

R = DENSITY_RATIO
E = 0.5
MU = 0.3
WALL_X = -50.0
DISCS = 16  # k = 4 per face: a disc at each face centre, so an upright block meets the wall centrally
W, H = 1.0, 1.4
MASS = R * W * H
INERTIA = MASS * (W * W + H * H) / 12.0
DT = 0.01


# ---------------------------------------------------------------- the test's set-up (tests/physics)
def make_scene(effects, bergs, physics, contacts):
    doc = {
        "scene": {"name": "friction_impact", "effects": list(effects)},
        "physics": dict(physics),
        "contacts": dict(contacts),
        "time": {"dt": DT, "duration": DT},
        "output": {"snapshot_interval": DT, "diagnostic_interval": DT, "checkpoint_interval": DT},
        "iceberg": [{k: float(v) for k, v in b.items()} for b in bergs],
    }
    return loads(dumps_toml(doc))


def initial(sc) -> dict[str, np.ndarray]:
    b = sc.icebergs()
    return {k: np.array(getattr(b, k), dtype=float) for k in STATE_NAMES}


def kinetic(s, idx, mass, inertia) -> float:
    return sum(0.5 * mass[q] * (s["vx"][q] ** 2 + s["vz"][q] ** 2) + 0.5 * inertia[q] * s["omega"][q] ** 2 for q in idx)


def first_impulse(m, steps=40):
    """Step one at a time until some velocity changes: (state before, after, totals before, after)."""
    for _ in range(steps):
        b, tb = m.state(), m.totals()
        m.advance(1)
        a, ta = m.state(), m.totals()
        if ta.impulses > tb.impulses:
            return b, a, tb, ta
    raise RuntimeError(f"no impulse within {steps} steps")


def wall_model():
    from melange_ti.model import Model

    physics = {"restitution": E, "density_ratio": R, "wall_x": WALL_X, "friction": MU}
    bergs = [{"x": WALL_X + 2.0, "z": 3.0, "width": W, "thickness": H}]
    sc = make_scene(["collisions", "wall", "friction"], bergs, physics, {"discs": DISCS})
    return Model(sc), sc


def approach_wall(sc, vz):
    """The block moving into the wall at v_x = -1 with v_z, half a step's approach away."""
    s = initial(sc)
    s["vx"][0], s["vz"][0] = -1.0, vz
    s["x"][0] = WALL_X + sc.icebergs().width[0] / 2 + 0.5 * sc.time.dt  # the discs' union is tangent to the face
    return s


def pair_model():
    """Two blocks side by side (mass ratios 1 and 10), far apart from each other and from the wall."""
    from melange_ti.model import Model

    light = {1: (1.0, 1.4), 10: (0.2, 0.7)}
    bergs = []
    for k, ratio in enumerate((1, 10)):
        wl, hl = light[ratio]
        x, z = 137.0 + 100.0 * k, -40.0 + 25.0 * k
        bergs.append({"x": x, "z": z, "width": W, "thickness": H})
        bergs.append({"x": x + 0.5 + wl / 2 + 0.01, "z": z, "width": wl, "thickness": hl})
    physics = {"restitution": E, "density_ratio": R, "friction": MU}
    sc = make_scene(["collisions", "friction"], bergs, physics, {"discs": DISCS})
    return Model(sc), sc


# ---------------------------------------------------------------- the sweeps
def clamp_jt(vt, kt, jn):
    return min(max(-vt / kt, -MU * jn), MU * jn) + 0.0  # + 0.0: no -0


def rubbed(vt, jt, kt):
    return -jt * (vt + 0.5 * jt * kt)


def wall_sweep(count: int) -> list[dict]:
    m, sc = wall_model()
    rx_guess = -(W / 2 + 0.5 * DT)
    threshold = MU * (1 + E) * MASS * (1 / MASS + rx_guess**2 / INERTIA)
    rows = []
    for vz in np.linspace(0.0, 3.0 * threshold, count):
        m.set_state(approach_wall(sc, float(vz)))
        b, a, tb, ta = first_impulse(m)
        rx = WALL_X - b["x"][0]  # the impulse acts at the start-of-step position; the wall's point is at x = WALL_X
        jn_seen = MASS * (a["vx"][0] - b["vx"][0])
        jt_seen = MASS * (a["vz"][0] - b["vz"][0])
        rz = (rx * jt_seen - INERTIA * (a["omega"][0] - b["omega"][0])) / jn_seen
        kt = 1 / MASS + rx * rx / INERTIA
        vt = b["vz"][0] + b["omega"][0] * rx
        jn = (1 + E) * MASS * 1.0
        rows.append(
            point(
                "wall",
                vt,
                jn_seen,
                jn,
                jt_seen,
                kt,
                a["vz"][0] + a["omega"][0] * rx,
                0.5 * (1 - E * E) * MASS * 1.0,
                kinetic(b, (0,), [MASS], [INERTIA]) - kinetic(a, (0,), [MASS], [INERTIA]),
                tb,
                ta,
                abs(rz),
            )
        )
    return rows


def readable(b, a, i, mass) -> bool:
    """A friction impulse on body i large enough to read the arms off the spins."""
    jn, jt = -mass * (a["vx"][i] - b["vx"][i]), -mass * (a["vz"][i] - b["vz"][i])
    return abs(jt) > 1e-6 * MU * jn


def pair_sweep(count: int, slide_max: float) -> list[dict]:
    m, sc = pair_model()
    k = m.constants()
    mass, inertia = k["mass"], k["inertia"]
    rows = []
    for p, case in enumerate(("pair_1", "pair_10")):
        i, j = 2 * p, 2 * p + 1
        raw = []
        for slide in np.linspace(0.0, slide_max, count):
            s = initial(sc)  # the other pair stays at rest, apart by 0.01
            s["vx"][i], s["vx"][j] = 1.0, -1.0
            s["vz"][i], s["vz"][j] = slide / 2, -slide / 2
            m.set_state(s)
            raw.append(first_impulse(m))
        arms = []
        for b, a, _, _ in raw:
            jt = -mass[i] * (a["vz"][i] - b["vz"][i])
            if readable(b, a, i, mass[i]):
                r1x = -inertia[i] * (a["omega"][i] - b["omega"][i]) / jt
                arms.append((r1x, inertia[j] * (a["omega"][j] - b["omega"][j]) / jt))
        arms_ref = arms[len(arms) // 2]
        kn = 1 / mass[i] + 1 / mass[j]
        for b, a, tb, ta in raw:
            # side by side at one height: n = (-1, 0), t = (0, -1); J on i is (-J_n, -J_t)
            jn_seen = -mass[i] * (a["vx"][i] - b["vx"][i])
            jt_seen = -mass[i] * (a["vz"][i] - b["vz"][i])
            if readable(b, a, i, mass[i]):
                r1x = -inertia[i] * (a["omega"][i] - b["omega"][i]) / jt_seen
                r2x = inertia[j] * (a["omega"][j] - b["omega"][j]) / jt_seen
            else:
                r1x, r2x = arms_ref
            gap = abs((r1x - r2x) - (b["x"][j] - b["x"][i]))  # one contact point: r_i - r_j = x_j - x_i
            vt = 0.0 - (b["vz"][i] + b["omega"][i] * r1x - b["vz"][j] - b["omega"][j] * r2x)  # 0.0 -: no -0
            vt_after = -(a["vz"][i] + a["omega"][i] * r1x - a["vz"][j] - a["omega"][j] * r2x)
            kt = 1 / mass[i] + 1 / mass[j] + r1x**2 / inertia[i] + r2x**2 / inertia[j]
            vn = 2.0
            rows.append(
                point(
                    case,
                    vt,
                    jn_seen,
                    (1 + E) * vn / kn,
                    jt_seen,
                    kt,
                    vt_after,
                    0.5 * (1 - E * E) * vn * vn / kn,
                    kinetic(b, (i, j), mass, inertia) - kinetic(a, (i, j), mass, inertia),
                    tb,
                    ta,
                    gap,
                )
            )
    return rows


def point(case, vt, jn_seen, jn, jt_seen, kt, vt_after, collision_a, lost, tb, ta, geometry) -> dict:
    """One row: the model's impulses and ledgers against the analytic law (J_n from the model)."""
    jt = clamp_jt(vt, kt, jn_seen)
    fr_a = rubbed(vt, jt, kt)
    fr_m = ta.friction_dissipated - tb.friction_dissipated
    booked = ta.collision_dissipated - tb.collision_dissipated + fr_m
    regime = "stick" if abs(jt) < MU * jn_seen else "slip"
    if regime == "stick":
        seen = "stick" if abs(vt_after) <= 1e-9 * max(abs(vt), 1e-300) or vt == 0.0 else "slip"
    else:
        seen = "slip" if np.sign(vt_after) == np.sign(vt) and abs(vt_after) < abs(vt) else "stick"
    return {
        "case": case,
        "v_t": vt,
        "v_t_over_threshold": abs(vt) / (MU * jn_seen * kt),
        "regime": regime,
        "regime_model": seen,
        "J_n": jn_seen,
        "J_n_analytic": jn,
        "J_n_rel_error": abs(jn_seen - jn) / jn,
        "J_t_model": jt_seen,
        "J_t_analytic": jt,
        "J_t_rel_error": abs(jt_seen - jt) / (abs(jt) if jt != 0.0 else MU * jn_seen),
        "friction_booked": fr_m,
        "friction_analytic": fr_a,
        "friction_rel_error": abs(fr_m - fr_a) / (abs(fr_a) if fr_a != 0.0 else lost),
        "ke_lost": lost,
        "ke_lost_analytic": collision_a + fr_a,
        "booked_total": booked,
        "budget_rel_error": abs(lost - booked) / lost,
        "geometry_error": geometry,  # wall: |r_z|; pair: |(r_i - r_j) - (x_j - x_i)|
        "_kt": kt,
        "_collision_a": collision_a,
    }


# ---------------------------------------------------------------- output
def plot(rows: list[dict], path: Path) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.4), layout="constrained")
    xmax = max(r["v_t_over_threshold"] for r in rows) * 1.03
    xs = np.linspace(0.0, xmax, 400)
    ax[0].plot(xs, np.minimum(xs, 1.0), color="k", lw=1.2, label="analytic: min(|v_t| / (mu J_n K_t), 1)")
    styles = {
        "wall": ("o", "C0", "wall (e = 0.5)"),
        "pair_1": ("s", "C1", "pair, mass ratio 1"),
        "pair_10": ("^", "C2", "pair, mass ratio 10"),
    }
    for case, (marker, color, label) in styles.items():
        rs = [r for r in rows if r["case"] == case]
        x = np.array([r["v_t_over_threshold"] for r in rs])
        against = np.array([-math.copysign(1.0, r["v_t"]) * r["J_t_model"] / (MU * r["J_n"]) if r["v_t"] else 0.0 for r in rs])
        ax[0].plot(x, against, marker, color=color, mfc="none", label=f"model: {label}")
        share = np.array([r["friction_booked"] / r["ke_lost"] for r in rs])
        ax[1].plot(x, share, marker, color=color, mfc="none", label=f"model: {label}")
        # analytic share for this case's J_n, K_t and collision loss, along the sweep
        jn, kt, coll = rs[-1]["J_n"], rs[-1]["_kt"], rs[-1]["_collision_a"]
        vt = xs * MU * jn * kt
        jt = np.minimum(vt / kt, MU * jn)
        fr = jt * (vt - 0.5 * jt * kt)
        ax[1].plot(xs, fr / (coll + fr), color=color, lw=1)
    ax[0].axvline(1.0, color="0.6", ls=":")
    ax[0].set_xlabel("|v_t| / threshold  (threshold = mu J_n K_t)")
    ax[0].set_ylabel("friction impulse against the sliding / (mu J_n)")
    ax[0].set_title("oblique impact: stick (J_t = -v_t / K_t), then slip (|J_t| = mu J_n); mu = 0.3", fontsize=9)
    ax[0].legend(fontsize=8)
    ax[1].axvline(1.0, color="0.6", ls=":")
    ax[1].set_xlabel("|v_t| / threshold")
    ax[1].set_ylabel("friction_dissipated / kinetic energy lost")
    ax[1].set_title("friction's share of the energy lost: booked (markers), analytic (lines; wall = equal pair)", fontsize=9)
    ax[1].legend(fontsize=8)
    fig.savefig(path, dpi=120)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="validation/results")
    p.add_argument("--points", type=int, default=26, help="points per sweep")
    p.add_argument("--slide", type=float, default=2.5, help="the pair sweep's largest sliding speed")
    a = p.parse_args()
    from melange_ti import runtime

    runtime.init("cpu", threads=1, precision="f64")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = wall_sweep(a.points) + pair_sweep(a.points, a.slide)
    cols = [k for k in rows[0] if not k.startswith("_")]
    with open(out / "friction_impact.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.15g}" if isinstance(v, float) else v) for k, v in r.items() if k in cols})
    plot(rows, out / "friction_impact.png")
    print(
        f"{'case':8} {'points':>6} {'stick':>5} {'slip':>4} {'mismatch':>8} {'max err J_n':>11} {'max err J_t':>11} "
        f"{'max err E_fric':>14} {'max err budget':>14} {'geometry':>9}"
    )
    for case in ("wall", "pair_1", "pair_10"):
        rs = [r for r in rows if r["case"] == case]
        stick = sum(r["regime"] == "stick" for r in rs)
        mismatch = sum(r["regime"] != r["regime_model"] for r in rs)
        print(
            f"{case:8} {len(rs):6d} {stick:5d} {len(rs) - stick:4d} {mismatch:8d} "
            f"{max(r['J_n_rel_error'] for r in rs):11.2e} {max(r['J_t_rel_error'] for r in rs):11.2e} "
            f"{max(r['friction_rel_error'] for r in rs):14.2e} {max(r['budget_rel_error'] for r in rs):14.2e} "
            f"{max(r['geometry_error'] for r in rs):9.1e}"
        )


if __name__ == "__main__":
    main()
