"""One iceberg capsizing in a moving sea (effect ``waves``): the share of the released energy
that the waves carry away, with the water's other loads (form drag, added mass) off and on,
against the laboratory's ~1% (Burton et al. 2012, JGR); and a stable block's heave decaying
as it radiates.

    python validation/capsize_waves.py --out validation/results

Capsize runs: an upright block (width 1, thickness 1.4) floating at equilibrium in the
middle of a wave grid (wall at x = 0, the block at x = 100, wave_end = 200 with a 40 w
absorbing layer, water_depth 6, wave_dx 0.125), tilted by 0.01 rad, gravity + buoyancy +
waves (+ form_drag, + added_mass), no linear drag, dt = 0.01 (the wave step the default
0.1), until t = 300. Reported:
the waves' share ``(E_w + absorbed) / released`` at the end, the iceberg's peak kinetic
energy over the capsize energy ``0.5 r (1 - r) w h (h - w)``, and the budget's residual:
at the end and the largest over the run, with the energy read from the state a step leaves
(``Model.sample()``, as run files before format 8 did: the velocities half a kick before the
positions), as run files read it from format 8 on (with the next step's ``half_kick``:
docs/model.md, "What the budget promises"), and, without the water's loads, as the mean of
two steps' velocities and ``phi``.
Heave runs: a block of thickness 1 (stable) lifted by 0.05 w, with and without waves: the
heave amplitude left after one and two periods. Each with the wave pressure taken at depth 1
(the default ``wave_pressure_depth``) and at the surface (0, the long-wave coupling).
Writes ``capsize_waves.csv`` and ``capsize_waves.png``.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import numpy as np

from melange_ti.scene import DENSITY_RATIO

R = DENSITY_RATIO
WAVES = {"water_depth": 6.0, "wave_dx": 0.125, "wave_end": 200.0, "wave_sponge": 40.0}


def model(effects, berg, physics, dt=0.01, duration=300.0):
    from melange_ti.model import Model
    from melange_ti.scene import dumps_toml, loads

    doc = {
        "scene": {"name": "capsize_waves", "effects": effects},
        "physics": {**WAVES, **physics},
        "time": {"dt": dt, "duration": duration},
        "iceberg": [berg],
    }
    return Model(loads(dumps_toml(doc)), mode="serial")


def capsize(cd: float, ca: float, waves: bool = True, depth: float = 1.0, duration: float = 300.0) -> dict:
    from melange_ti import diagnostics as dg

    h = 1.4
    effects = ["gravity", "buoyancy"] + (["form_drag"] if cd else []) + (["added_mass"] if ca else [])
    effects += ["waves"] if waves else []
    m = model(
        effects,
        {"x": 100.0, "z": -R * h + 0.5 * h, "theta": 0.01, "thickness": h},
        {"form_drag": cd, "added_mass": ca, "added_inertia": ca, "wave_pressure_depth": depth},
    )
    k = m.constants()
    mass, inertia = k["mass"][0], k["inertia"][0]
    released = dg.capsize_energy(R, 1.0, h)

    def energy():
        s, tot = m.sample_with_totals()
        v = np.array([s["vx"][0], s["vz"][0], s["omega"][0]])
        own_ke = 0.5 * mass * (v[0] ** 2 + v[1] ** 2) + 0.5 * inertia * v[2] ** 2
        w = m.effect("waves").surface() if waves else {"eta": np.zeros(1), "phi": np.zeros(1), "g_phi": np.zeros(1)}
        we = float(s["wave_energy"]) if waves else 0.0  # as the run reports it
        pot = float(np.sum(s["potential"]))
        e = float(np.sum(s["kinetic"])) + pot + we
        ledgers = float(np.sum(s["drag_dissipated"])) + float(np.sum(s.get("added_mass_work", 0.0))) + tot.wave_absorbed
        half = float(np.sum(s["half_kick"]))  # this sample's step's half kick: the run file's reading of the one before
        return e, own_ke, ledgers, we + tot.wave_absorbed, float(s["theta"][0]), (v, pot, w), half

    def step_time(before, after) -> float:
        """The energy at the step time of ``before``, the opening of a wave step (its positions
        and surface, the velocities and phi half a kick on: the mean of two steps', with
        ``G phi`` of that mean); exact without the water's loads."""
        (v0, pot, w0), (v1, _, w1) = before[5], after[5]
        v = 0.5 * (v0 + v1)
        phi = 0.5 * (w0["phi"] + w1["phi"])
        g_phi = m.effect("waves").apply_g(phi) if waves else phi
        ke = 0.5 * mass * (v[0] ** 2 + v[1] ** 2) + 0.5 * inertia * v[2] ** 2
        return ke + pot + (0.5 * m.effect("waves").dx * (w0["eta"] @ w0["eta"] + phi @ g_phi) if waves else 0.0)

    first = energy()
    e0 = first[0]
    m.advance(1)
    second = energy()
    e0_step = step_time(first, second)
    e0_file = e0 + second[6]  # as the run file reads it (format 8: the next step's half kick)
    at = 1
    times, waves_share, ke, res, res_step, res_file = [], [], [], [], [], []
    assert not waves or 10 % m.effect("waves").every == 0  # samples at openings of wave steps
    for step in range(10, round(duration / 0.01) + 1, 10):
        m.advance(step - at)
        before = energy()
        m.advance(1)
        after = energy()
        at = step + 1
        e, own, led, w, theta = before[:5]
        times.append(step * 0.01)
        waves_share.append(w / released)
        ke.append(own / released)
        res.append((e0 - e - led) / released)
        res_step.append((e0_step - step_time(before, after) - led) / released)
        res_file.append((e0_file - (e + after[6]) - led) / released)
    loads = bool(cd or ca)  # the mean of two steps' velocities is the step time's only without them
    return {
        "form_drag": cd,
        "added_mass": ca,
        "waves": int(waves),
        "pressure_depth": depth,
        "wave_share": waves_share[-1],
        "ke_peak_fraction": max(ke),
        "residual_fraction": res[-1],
        "largest_residual_fraction": float(np.max(np.abs(res))),
        "largest_file_residual_fraction": float(np.max(np.abs(res_file))),
        "largest_step_time_residual_fraction": float("nan") if loads else float(np.max(np.abs(res_step))),
        "capsized": int(abs(theta) > math.pi / 4),
        "_t": np.array(times),
        "_w": np.array(waves_share),
        "_ke": np.array(ke),
    }


def heave(waves: bool, depth: float = 1.0, duration: float = 60.0) -> dict:
    h = 1.0
    effects = ["gravity", "buoyancy"] + (["waves"] if waves else [])
    m = model(effects, {"x": 100.0, "z": -R * h + 0.5 * h + 0.05, "thickness": h}, {"wave_pressure_depth": depth})
    z_eq = -R * h + 0.5 * h
    t, z = [], []
    for step in range(10, round(duration / 0.01) + 1, 10):  # every wave step (0.1)
        m.advance(10)
        t.append(step * 0.01)
        z.append(float(m.state()["z"][0]) - z_eq)
    t, z = np.array(t), np.array(z)
    # the heave amplitude left after one and two natural periods (2 pi sqrt(d / g), d the
    # draft), as a fraction of the initial lift
    period = 2 * math.pi * math.sqrt(R * h)
    left = [float(np.max(np.abs(z[(t > q * period) & (t <= (q + 1) * period)])) / 0.05) for q in (1, 2)]
    return {
        "waves": int(waves),
        "pressure_depth": depth,
        "period": period,
        "left_after_1": left[0],
        "left_after_2": left[1],
        "_t": t,
        "_z": z,
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="validation/results")
    a = p.parse_args()
    from melange_ti import runtime

    runtime.init("cpu", threads=1, precision="f64")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    runs = [
        capsize(0, 0),
        capsize(1, 0.5),
        capsize(8, 1),
        capsize(0, 0, depth=0.0),
        capsize(1, 0.5, depth=0.0),
        capsize(0, 0, waves=False),
    ]
    heaves = [heave(False), heave(True), heave(True, depth=0.0)]
    with open(out / "capsize_waves.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(
            [
                "case",
                "form_drag",
                "added_mass",
                "waves",
                "pressure_depth",
                "wave_share",
                "ke_peak_fraction",
                "residual_fraction",
                "largest_residual_fraction",
                "largest_step_time_residual_fraction",
                "largest_file_residual_fraction",
                "capsized",
            ]
        )
        for r in runs:
            w.writerow(
                [
                    "capsize",
                    r["form_drag"],
                    r["added_mass"],
                    r["waves"],
                    r["pressure_depth"],
                    f"{r['wave_share']:.4f}",
                    f"{r['ke_peak_fraction']:.4f}",
                    f"{r['residual_fraction']:.2e}",
                    f"{r['largest_residual_fraction']:.2e}",
                    ""
                    if math.isnan(r["largest_step_time_residual_fraction"])
                    else f"{r['largest_step_time_residual_fraction']:.2e}",
                    f"{r['largest_file_residual_fraction']:.2e}",
                    r["capsized"],
                ]
            )
        w.writerow(["case", "waves", "pressure_depth", "period", "amplitude_left_after_1_period", "after_2_periods"])
        for r in heaves:
            w.writerow(
                [
                    "heave",
                    r["waves"],
                    r["pressure_depth"],
                    f"{r['period']:.3f}",
                    f"{r['left_after_1']:.4f}",
                    f"{r['left_after_2']:.4f}",
                ]
            )
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(11, 4), layout="constrained")
    for r in runs[:5]:
        lab = f"C_d = {r['form_drag']:g}, C_a = C_i = {r['added_mass']:g}, pressure depth {r['pressure_depth']:g}"
        (line,) = ax[0].plot(r["_t"], r["_w"], label=f"waves' share: {lab}")
        ax[0].plot(r["_t"], r["_ke"], ls=":", color=line.get_color())
    ax[0].axhline(0.01, color="k", lw=0.8, ls="--", label="laboratory: ~1% to waves (Burton et al. 2012)")
    ax[0].set_xlabel("time (sqrt(w/g))")
    ax[0].set_ylabel("fraction of the capsize energy")
    ax[0].set_title("one capsize, aspect 1.4: waves' energy (solid), iceberg's KE (dotted)", fontsize=9)
    ax[0].legend(fontsize=7)
    for r in heaves:
        lab = (f"waves, pressure depth {r['pressure_depth']:g}" if r["waves"] else "flat sea") + (
            f": {r['left_after_2']:.0%} of the lift left after 2 periods"
        )
        ax[1].plot(r["_t"], r["_z"], label=lab)
    ax[1].set_xlabel("time (sqrt(w/g))")
    ax[1].set_ylabel("heave z - z_eq (w)")
    ax[1].set_title("a stable block (thickness 1) released 0.05 w above equilibrium", fontsize=9)
    ax[1].legend(fontsize=7)
    fig.savefig(out / "capsize_waves.png", dpi=120)
    for r in runs:
        print({k: v for k, v in r.items() if not k.startswith("_")})
    for r in heaves:
        print({k: v for k, v in r.items() if not k.startswith("_")})


if __name__ == "__main__":
    main()
