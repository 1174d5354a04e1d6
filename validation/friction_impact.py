"""Coulomb friction (effect ``friction``): oblique impacts at central and off-centre contacts,
swept through the stick and the slide regimes, against the analytic impulses of the coupled
law, with the energy booked.

    python validation/friction_impact.py --out validation/results

The law (docs/model.md, "Contacts"): the contact point's relative velocity ``u = (v_n, v_t)``
changes by ``K J``, ``K`` its 2x2 effective-mass matrix; ``v_n' = -e v_n``; the contact sticks
(``v_t' = 0``) when that impulse lies in the cone ``|J_t| <= mu J_n``, else it slides on the
cone's edge. It is written again in numpy (:func:`melange_ti.testing.coulomb_impulse`) and the
model's impulses are compared with it at the contact point and normal the model's impulse pass
met (read from its contact columns after the step).

Cases (restitution 0.5, mu = 0.3, 16 discs, dt = 0.01, no gravity): a block (1 x 1.4) tilted
by 0, 0.2, 0.4 and 0.6 rad driven into the wall at v_x = -1, its corner first; a tilted
block's corner into an upright block's face, mass ratios 1 and 10 (the 1 x 1.4 block against a
1 x 1.4 or a 0.2 x 0.7 one), closing at 2 in the centre-of-mass frame; and two polygons
(case ``polygons``, issue 33, 32 discs): a triangle tilted 0.5 rad (the ``tilt`` column) strikes
a trapezoid's slanted face (its normal 20.6 degrees from horizontal) with a corner, closing at
2 in the centre-of-mass frame from 0.02 apart (the discs' gap, by bisection). Each at 25
sliding speeds from -3 to 3. Reported per case: the regimes, the largest error of the impulse
(against |J|), of v_n' against -e v_n, of each ledger against its impulse's work and of the
kinetic energy lost against the ledgers; how often the friction's ledger is negative (the coupling
passes energy from the normal direction) and whether any impact gains energy. For comparison,
the effective restitution ``-v_n' / v_n`` the law of version 0.2 gave at the same contacts (a
normal impulse, then a clamped tangential one, each with its own K).
Writes ``friction_impact.csv`` and ``friction_impact.png`` and prints the table.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from melange_ti.geometry import polygon_disc_local
from melange_ti.scene import DENSITY_RATIO
from melange_ti.testing import (
    contact_matrix,
    contacts_seen,
    corner_x,
    coulomb_impulse,
    first_impulse,
    initial,
    kinetic,
    make_scene,
    point_velocity,
)

R = DENSITY_RATIO
E = 0.5
MU = 0.3
WALL_X = -50.0
DISCS = 16
W, H = 1.0, 1.4
TILTS = (0.0, 0.2, 0.4, 0.6)
SLIDES = np.linspace(-3.0, 3.0, 25)
TRIANGLE = [[0.0, 0.0], [1.0, 0.0], [0.5, 0.8]]
TRAPEZOID = [[-0.6, -0.4], [0.6, -0.4], [0.3, 0.4], [-0.3, 0.4]]
POLY_TILT, POLY_DISCS = 0.5, 32


def models():
    from melange_ti.model import Model

    wall = make_scene(
        ["collisions", "wall", "friction"],
        [{"x": WALL_X + 2.0, "z": 3.0, "width": W, "thickness": H}],
        {"restitution": E, "density_ratio": R, "wall_x": WALL_X, "friction": MU},
        contacts={"discs": DISCS},
    )
    bergs = []
    for k, (wl, hl) in enumerate(((1.0, 1.4), (0.2, 0.7))):
        x, z = 137.0 + 100.0 * k, -40.0 + 25.0 * k
        bergs += [{"x": x, "z": z, "width": W, "thickness": H}, {"x": x + 3.0, "z": z, "width": wl, "thickness": hl}]
    pair = make_scene(
        ["collisions", "friction"], bergs, {"restitution": E, "density_ratio": R, "friction": MU}, contacts={"discs": DISCS}
    )
    polys = make_scene(
        ["collisions", "friction"],
        [
            {"x": 40.0, "z": 10.25, "theta": POLY_TILT, "vertices": TRIANGLE},
            {"x": 41.4, "z": 10.0, "theta": 0.0, "vertices": TRAPEZOID},
        ],
        {"restitution": E, "density_ratio": R, "friction": MU},
        contacts={"discs": POLY_DISCS},
    )
    return (Model(wall), wall), (Model(pair), pair), (Model(polys), polys)


def discs_world(m, s, q, x):
    """World disc centres and radius of polygon ``q`` of state ``s`` with its centre at ``x``."""
    k = m.constants()
    corners = np.stack([k["corner_u"][q], k["corner_v"][q]], -1)[: k["corners"][q]]
    local, r = polygon_disc_local(corners, POLY_DISCS)
    c, sn = np.cos(s["theta"][q]), np.sin(s["theta"][q])
    return np.stack([x + local[:, 0] * c - local[:, 1] * sn, s["z"][q] + local[:, 0] * sn + local[:, 1] * c], -1), r


def touching(m, s, gap=0.02):
    """Body 0 moved in x until its discs are ``gap`` from body 1's (bisection)."""
    other, rj = discs_world(m, s, 1, s["x"][1])
    lo, hi = s["x"][0] - 3.0, s["x"][1]  # far apart, and overlapping
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        mine, ri = discs_world(m, s, 0, mid)
        d = np.linalg.norm(mine[:, None, :] - other[None, :, :], axis=-1).min() - ri - rj
        lo, hi = (mid, hi) if d > gap else (lo, mid)
    s["x"][0] = lo


def old_restitution(kk, vn, vt):
    """``-v_n' / v_n`` under version 0.2's law: J_n = -(1 + e) v_n / K_nn, then J_t clamped
    with K_tt alone, each applied in turn."""
    jn = -(1 + E) * vn / kk[0, 0]
    vt1 = vt + kk[0, 1] * jn
    jt = min(max(-vt1 / kk[1, 1], -MU * jn), MU * jn)
    return -(vn + kk[0, 0] * jn + kk[0, 1] * jt) / vn


def measure(m, case, tilt, slide, s, moving):
    k = m.constants()
    mass, inertia = k["mass"], k["inertia"]
    m.set_state(s)
    b, a, tb, ta = first_impulse(m)
    (c,) = [c for c in contacts_seen(m) if c.i in moving or c.j in moving]
    i, j, n = c.i, c.j, c.n
    t = np.array([-n[1], n[0]])
    bodies = [(i, 1.0, c.p - np.array([b["x"][i], b["z"][i]]))]
    if j >= 0:
        bodies.append((j, -1.0, c.p - np.array([b["x"][j], b["z"][j]])))
    u = sum(sign * point_velocity(b, q, r) for q, sign, r in bodies)
    u_after = sum(sign * point_velocity(a, q, r) for q, sign, r in bodies)
    kk = contact_matrix(n, [(r, mass[q], inertia[q]) for q, _, r in bodies])
    vn, vt = u @ n, u @ t
    jn, jt, regime = coulomb_impulse(kk, vn, vt, E, MU)
    p = jn * n + jt * t
    err = 0.0
    for q, sign, r in bodies:
        seen = np.array([mass[q] * (a["vx"][q] - b["vx"][q]), mass[q] * (a["vz"][q] - b["vz"][q])])
        spin = inertia[q] * (a["omega"][q] - b["omega"][q])
        err = max(err, np.abs(seen - sign * p).max(), abs(spin - sign * (r[0] * p[1] - r[1] * p[0])))
    vn_after, vt_after = u_after @ n, u_after @ t
    seen_regime = "stick" if abs(vt_after) <= 1e-9 * max(abs(vn), abs(vt)) else "slide"
    idx = [q for q, _, _ in bodies]
    lost = kinetic(b, idx, mass, inertia) - kinetic(a, idx, mass, inertia)
    coll = ta.collision_dissipated - tb.collision_dissipated
    fric = ta.friction_dissipated - tb.friction_dissipated
    scale = jn * max(abs(vn), abs(vt))
    return {
        "case": case,
        "tilt": tilt,
        "slide": slide,
        "K_nt_over_K_nn": kk[0, 1] / kk[0, 0],
        "v_n": vn,
        "v_t": vt,
        "regime": regime,
        "regime_model": seen_regime,
        "J_n": jn,
        "J_t": jt,
        "J_rel_error": err / np.hypot(jn, jt),
        "restitution_model": -vn_after / vn,
        "restitution_error": abs(vn_after + E * vn) / abs(vn),
        "restitution_v02": old_restitution(kk, vn, vt),
        "collision_booked": coll,
        "friction_booked": fric,
        "ledger_error": max(abs(coll + 0.5 * jn * (vn + vn_after)), abs(fric + 0.5 * jt * (vt + vt_after))) / scale,
        "ke_lost": lost,
        "budget_error": abs(lost - coll - fric) / scale,
    }


def sweep() -> list[dict]:
    (mw, sw), (mp, sp), (mg, sg) = models()
    rows = []
    for tilt in TILTS:
        for slide in SLIDES:
            s = initial(sw)
            s["theta"][0], s["vx"][0], s["vz"][0] = tilt, -1.0, slide
            s["x"][0] = WALL_X + corner_x(W, H, tilt) + 0.02
            rows.append(measure(mw, "wall", tilt, slide, s, {0}))
    k = mp.constants()
    for case, (i, j) in (("pair_1", (0, 1)), ("pair_10", (2, 3))):
        share = k["mass"][j] / (k["mass"][i] + k["mass"][j])
        for tilt in TILTS:
            for slide in SLIDES:
                s = initial(sp)
                s["theta"][j] = tilt
                s["x"][j] = s["x"][i] + 0.5 * W + corner_x(k["width"][j], k["thickness"][j], tilt) + 0.02
                # the centre-of-mass frame: neither body leaves faster than it came, so the step
                # detects once and its contact columns hold the contact the impulse met
                s["vx"][i], s["vx"][j] = 2.0 * share, -2.0 * (1.0 - share)
                s["vz"][i], s["vz"][j] = slide * share, -slide * (1.0 - share)
                rows.append(measure(mp, case, tilt, slide, s, {i, j}))
    k = mg.constants()
    share = k["mass"][1] / (k["mass"][0] + k["mass"][1])
    for slide in SLIDES:
        s = initial(sg)
        touching(mg, s)
        s["vx"][0], s["vx"][1] = 2.0 * share, -2.0 * (1.0 - share)
        s["vz"][0], s["vz"][1] = slide * share, -slide * (1.0 - share)
        rows.append(measure(mg, "polygons", POLY_TILT, slide, s, {0, 1}))
    return rows


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(16, 4.6), layout="constrained")
    colors = {t: f"C{q}" for q, t in enumerate(TILTS)}
    markers = {"wall": "o", "pair_1": "s", "pair_10": "^"}
    for case, marker in markers.items():
        for tilt in TILTS:
            rs = [r for r in rows if r["case"] == case and r["tilt"] == tilt]
            x = np.array([r["slide"] for r in rs])
            label = f"{case}, tilt {tilt}" if case == "wall" else None
            ax[0].plot(x, [r["J_t"] / (MU * r["J_n"]) for r in rs], marker, color=colors[tilt], mfc="none", ms=4, label=label)
            ax[1].plot(x, [r["restitution_model"] for r in rs], marker, color=colors[tilt], mfc="none", ms=4)
            ax[1].plot(x, [r["restitution_v02"] for r in rs], "-", color=colors[tilt], lw=0.8)
            ax[2].plot(x, [r["friction_booked"] / r["ke_lost"] for r in rs], marker, color=colors[tilt], mfc="none", ms=4)
    rs = [r for r in rows if r["case"] == "polygons"]
    x = np.array([r["slide"] for r in rs])
    style = dict(color="k", ms=5, ls="none")
    ax[0].plot(x, [r["J_t"] / (MU * r["J_n"]) for r in rs], "D", label="polygons (triangle into trapezoid)", **style)
    ax[1].plot(x, [r["restitution_model"] for r in rs], "D", **style)
    ax[1].plot(x, [r["restitution_v02"] for r in rs], "-", color="k", lw=0.8)
    ax[2].plot(x, [r["friction_booked"] / r["ke_lost"] for r in rs], "D", **style)
    ax[0].set_xlabel("sliding speed (case's set-up)")
    ax[0].set_ylabel("J_t / (mu J_n)  (|.| = 1: sliding on the cone)")
    ax[0].set_title("model impulses (markers: o wall, s pair 1:1, ^ pair 1:10, D polygons)", fontsize=9)
    ax[0].legend(fontsize=7)
    ax[1].axhline(E, color="k", lw=1)
    ax[1].set_xlabel("sliding speed")
    ax[1].set_ylabel("effective restitution -v_n' / v_n")
    ax[1].set_title(f"the coupled law keeps e = {E} (markers); version 0.2's law (lines) did not", fontsize=9)
    ax[2].axhline(0, color="0.6", lw=0.8)
    ax[2].set_xlabel("sliding speed")
    ax[2].set_ylabel("friction_dissipated / kinetic energy lost")
    ax[2].set_title("friction's share of the loss (negative: the coupling moves energy)", fontsize=9)
    fig.savefig(path, dpi=120)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="validation/results")
    a = p.parse_args()
    from melange_ti import runtime

    runtime.init("cpu", threads=1, precision="f64")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = sweep()
    with open(out / "friction_impact.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.15g}" if isinstance(v, float) else v) for k, v in r.items()})
    plot(rows, out / "friction_impact.png")
    print(
        f"{'case':8} {'points':>6} {'stick':>5} {'slide':>5} {'wrong':>5} {'max |K_nt/K_nn|':>15} {'err J':>8} {'err e':>8} "
        f"{'err ledgers':>11} {'err budget':>10} {'fric<0':>6} {'gains':>5} {'e (v0.2)':>12}"
    )
    for case in ("wall", "pair_1", "pair_10", "polygons"):
        rs = [r for r in rows if r["case"] == case]
        stick = sum(r["regime"] == "stick" for r in rs)
        old = [r["restitution_v02"] for r in rs]
        print(
            f"{case:8} {len(rs):6d} {stick:5d} {len(rs) - stick:5d} {sum(r['regime'] != r['regime_model'] for r in rs):5d} "
            f"{max(abs(r['K_nt_over_K_nn']) for r in rs):15.3f} {max(r['J_rel_error'] for r in rs):8.1e} "
            f"{max(r['restitution_error'] for r in rs):8.1e} {max(r['ledger_error'] for r in rs):11.1e} "
            f"{max(r['budget_error'] for r in rs):10.1e} {sum(r['friction_booked'] < 0 for r in rs):6d} "
            f"{sum(r['ke_lost'] < 0 for r in rs):5d} {min(old):5.3f}-{max(old):5.3f}"
        )


if __name__ == "__main__":
    main()
