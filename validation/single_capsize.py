"""One iceberg capsizing in open water: how much of the released energy reaches its motion,
and how long the capsize takes, against the water's coefficients (form drag C_d, added
mass C_a = C_i). Compared with the laboratory (Burton et al. 2012, JGR): the iceberg's peak
kinetic energy is ~15% of the potential energy released, ~1% goes to surface waves.

    python validation/single_capsize.py --out validation/results --aspects 1.4,2.0 --drag 0,1,2,4,8 --added 0,0.5,1,2

Each run: an upright block (width 1, thickness = aspect) floating at equilibrium, tilted by
0.01 rad, gravity + buoyancy (+ form_drag, + added_mass), no linear drag, dt = 0.01, until
t = 300. Reported per run: ``ke_peak_fraction`` = the iceberg's own peak kinetic energy
(0.5 m |v|^2 + 0.5 I omega^2, not the water's) over the capsize energy
``0.5 r (1 - r) w h (h - w)``; ``capsize_time`` = time for the capsize angle to go from
pi/8 to 3 pi/8 (22.5 to 67.5 degrees), in sqrt(w/g) and in seconds for a 70 m wide
iceberg. Writes ``single_capsize.csv`` and ``single_capsize.png``.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import numpy as np

from melange_ti.scene import DENSITY_RATIO

R = DENSITY_RATIO


def run_one(aspect: float, cd: float, ca: float, dt: float = 0.01, duration: float = 300.0) -> dict:
    from melange_ti import diagnostics as dg
    from melange_ti.model import Model
    from melange_ti.scene import dumps_toml, loads

    h = aspect
    effects = ["gravity", "buoyancy"] + (["form_drag"] if cd > 0 else []) + (["added_mass"] if ca > 0 else [])
    doc = {
        "scene": {"name": "single_capsize", "effects": effects},
        "physics": {"density_ratio": R, "form_drag": cd, "added_mass": ca, "added_inertia": ca},
        "time": {"dt": dt, "duration": duration},
        "iceberg": [{"x": 0.0, "z": -R * h + 0.5 * h, "theta": 0.01, "width": 1.0, "thickness": h}],
    }
    m = Model(loads(dumps_toml(doc)))
    k = m.constants()
    mass, inertia = k["mass"][0], k["inertia"][0]
    every = max(1, round(0.1 / dt))
    t, ke, phi = [], [], []
    for step in range(every, round(duration / dt) + 1, every):
        m.advance(every)
        s = m.state()
        t.append(step * dt)
        ke.append(0.5 * mass * (s["vx"][0] ** 2 + s["vz"][0] ** 2) + 0.5 * inertia * s["omega"][0] ** 2)
        phi.append(dg.capsize_angle(s["theta"])[0])
    t, ke, phi = map(np.asarray, (t, ke, phi))
    released = dg.capsize_energy(R, 1.0, h)

    def first(level):
        idx = np.flatnonzero(phi >= level)
        return float(t[idx[0]]) if idx.size else float("nan")

    duration_capsize = first(3 * math.pi / 8) - first(math.pi / 8)
    return {
        "aspect": aspect,
        "form_drag": cd,
        "added_mass": ca,
        "ke_peak_fraction": float(ke.max() / released),
        "capsize_time": duration_capsize,
        "capsize_time_s_70m": duration_capsize * math.sqrt(70.0 / 9.81),
        "capsized": bool(phi[-1] >= math.pi / 4),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("validation/results"))
    p.add_argument("--aspects", default="1.4,2.0")
    p.add_argument("--drag", default="0,0.5,1,2")
    p.add_argument("--added", default="0,0.5,1")
    a = p.parse_args()
    from melange_ti import runtime

    runtime.init("cpu", precision="f64")
    a.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for aspect in (float(v) for v in a.aspects.split(",")):
        for ca in (float(v) for v in a.added.split(",")):
            for cd in (float(v) for v in a.drag.split(",")):
                row = run_one(aspect, cd, ca)
                rows.append(row)
                print(
                    f"aspect {aspect}: C_d {cd:g}, C_a = C_i {ca:g}: peak KE {row['ke_peak_fraction']:.1%} of released, "
                    f"capsize {row['capsize_time']:.1f} ({row['capsize_time_s_70m']:.0f} s at 70 m)",
                    flush=True,
                )
    with open(a.out / "single_capsize.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    aspects = sorted({r["aspect"] for r in rows})
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    for aspect, ls in zip(aspects, ("-", "--", ":"), strict=False):
        for ca, color in zip(
            sorted({r["added_mass"] for r in rows}),
            ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple"),
            strict=False,
        ):
            sel = [r for r in rows if r["aspect"] == aspect and r["added_mass"] == ca]
            x = [r["form_drag"] for r in sel]
            axes[0].plot(
                x,
                [100 * r["ke_peak_fraction"] for r in sel],
                ls=ls,
                color=color,
                marker="o",
                label=f"h/w {aspect:g}, C_a = C_i = {ca:g}",
            )
            axes[1].plot(x, [r["capsize_time"] for r in sel], ls=ls, color=color, marker="o")
    axes[0].axhspan(10, 20, color="0.85", zorder=0, label="laboratory ~15% (Burton et al. 2012)")
    axes[0].set_xlabel("form drag C_d")
    axes[0].set_ylabel("peak kinetic energy / released (%)")
    axes[0].legend(fontsize=7)
    axes[1].set_xlabel("form drag C_d")
    axes[1].set_ylabel("capsize time, 22.5° to 67.5° (sqrt(w/g))")
    fig.suptitle("One capsize in open water: the water's coefficients")
    fig.savefig(a.out / "single_capsize.png", dpi=120)


if __name__ == "__main__":
    main()
