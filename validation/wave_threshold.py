"""A conditionally stable iceberg capsized by an incoming wave (effect ``waves``): the wave
height above which it capsizes, and below which it rocks and recovers.

    python validation/wave_threshold.py --out validation/results

The block: width 1, thickness 1.30 (stable upright at density ratio 0.8946, whose critical
thickness is 1.330), upright and at rest at x = 100 in water of depth 6 (wave grid from the
wall at x = 0 to 200, a 40 w absorbing layer, wave_dx 0.125); gravity, buoyancy and waves,
with the water's form drag and added mass off or on (``--water``). A packet travelling
towards it, ``eta = a exp(-((x - 60) / 8)^2) cos(k (x - 60))`` with its potential for a
right-going wave, of carrier k (``--k``); run until t = 200. The threshold is bracketed by
bisection on the crest height ``a`` (capsized: |theta| > pi/4 at any time). Writes
``wave_threshold.csv`` (every run) and prints the bracket.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import numpy as np

from melange_ti.scene import DENSITY_RATIO

R = DENSITY_RATIO
H_BLOCK = 1.30


def run(a: float, k: float, water: bool, duration: float = 200.0) -> tuple[bool, float]:
    from melange_ti.model import Model
    from melange_ti.scene import dumps_toml, loads

    effects = ["gravity", "buoyancy", "waves"] + (["form_drag", "added_mass"] if water else [])
    doc = {
        "scene": {"name": "wave_threshold", "effects": effects},
        "physics": {"water_depth": 6.0, "wave_dx": 0.125, "wave_end": 200.0, "wave_sponge": 40.0},
        "time": {"dt": 0.01, "duration": duration},
        "iceberg": [{"x": 100.0, "z": -R * H_BLOCK + 0.5 * H_BLOCK, "thickness": H_BLOCK}],
    }
    m = Model(loads(dumps_toml(doc)), mode="serial")
    x = m.effect("waves").x()
    env = a * np.exp(-(((x - 60.0) / 8.0) ** 2))
    w = math.sqrt(k * math.tanh(k * 6.0))
    m.effect("waves").set_surface(env * np.cos(k * (x - 60.0)), env * (1.0 / w) * np.sin(k * (x - 60.0)))
    worst = 0.0
    for _ in range(round(duration)):
        m.advance(100)
        worst = max(worst, abs(float(m.state()["theta"][0])))
        if worst > math.pi / 4:
            return True, worst
    return False, worst


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="validation/results")
    p.add_argument("--k", type=float, nargs="+", default=[0.5, 1.0])
    p.add_argument("--water", choices=("off", "on", "both"), default="both")
    p.add_argument("--steps", type=int, default=7, help="bisection steps")
    a = p.parse_args()
    from melange_ti import runtime

    runtime.init("cpu", threads=1, precision="f64")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    waters = {"off": [False], "on": [True], "both": [False, True]}[a.water]
    for water in waters:
        for k in a.k:
            lo, hi = 0.0, 0.4
            capsized, worst = run(hi, k, water)
            rows.append((water, k, hi, capsized, worst))
            if not capsized:
                print(f"water={water} k={k}: no capsize up to a = {hi}")
                continue
            for _ in range(a.steps):
                mid = 0.5 * (lo + hi)
                capsized, worst = run(mid, k, water)
                rows.append((water, k, mid, capsized, worst))
                lo, hi = (lo, mid) if capsized else (mid, hi)
            print(f"water={water} k={k}: capsizes above a = {hi:.4f}, not below a = {lo:.4f} (crest height, widths)")
    with open(out / "wave_threshold.csv", "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(["water_loads", "k", "crest_height", "capsized", "max_abs_theta"])
        for water, k, amp, capsized, worst in rows:
            wr.writerow([int(water), k, f"{amp:.5f}", int(capsized), f"{worst:.4f}"])


if __name__ == "__main__":
    main()
