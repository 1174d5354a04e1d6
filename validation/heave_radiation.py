"""A heaving iceberg in a moving sea (effect ``waves``) against linear water-wave theory:
the period and the decay of its free heave, with the theory's added mass and radiation
damping for a heaving rectangle (``melange_ti.analysis.radiation``: eigenfunction matching,
Porter 2008) and its free decay in the time domain (Cummins' equation).

    python validation/heave_radiation.py --out validation/results

The block: width 1, thickness 1 (draft 0.8946), water depth 6, released 0.05 w above its
equilibrium at rest (the runs of ``validation/capsize_waves.py``: wall at 0, block at x = 100,
wave_end 200 with a 40 w absorbing layer, wave_dx 0.125, dt 0.01), until t = 60. Model runs:
gravity + buoyancy + waves with the wave pressure taken at depths 0, 0.5, 1 (the default)
and 2; the same with ``added_mass`` (C_a = 0.5, its default) at depths 0.75, 1 and 1.25;
and ``added_mass`` without waves. Each run's period and amplitude ratio per period come from
its maxima after the first (``radiation.decay``), and its damping ratio from the ratio.
Writes ``heave_radiation.csv``, ``heave_radiation_coefficients.csv`` and
``heave_radiation.png``.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from melange_ti.analysis import radiation  # noqa: E402
from melange_ti.scene import DENSITY_RATIO  # noqa: E402

R = DENSITY_RATIO
LIFT = 0.05
DEPTH = 6.0
DURATION = 60.0


def damping_ratio(ratio: float) -> float:
    """zeta of a linear oscillator whose amplitude falls by ``ratio`` each period."""
    delta = -math.log(ratio)
    return delta / math.sqrt(4 * math.pi**2 + delta**2)


def model_heave(effects, depth: float, added_mass: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    from capsize_waves import model

    m = model(
        effects,
        {"x": 100.0, "z": -R + 0.5 + LIFT, "thickness": 1.0},
        {"wave_pressure_depth": depth, "added_mass": added_mass, "added_inertia": added_mass},
    )
    t, z = [], []
    # every wave step (0.1): between them the heave carries the ripple of the wave steps'
    # kicks, which would read as maxima
    for step in range(10, round(DURATION / 0.01) + 1, 10):
        m.advance(10)
        t.append(step * 0.01)
        z.append(float(m.state()["z"][0]) - (-R + 0.5))
    return np.array(t), np.array(z)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="validation/results")
    a = p.parse_args()
    from melange_ti import runtime

    runtime.init("cpu", threads=1, precision="f64")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)

    theory = radiation.free_decay(mass=R, stiffness=1.0, lift=LIFT, depth=DEPTH, draft=R, duration=DURATION)
    t_period, t_ratio = radiation.decay(theory["t"], theory["z"])
    omega_n = 2 * math.pi / t_period
    a_n, b_n, _ = radiation.heave_coefficients(omega_n, DEPTH, R)
    rows = [
        {
            "setup": "linear theory (Cummins)",
            "period": t_period,
            "ratio_per_period": t_ratio,
            "damping_ratio": damping_ratio(t_ratio),
        }
    ]
    curves = {"linear theory": (theory["t"], theory["z"])}
    runs = [(["gravity", "buoyancy", "waves"], d, f"waves, pressure depth {d:g}") for d in (0.0, 0.5, 1.0, 2.0)]
    with_am = ["gravity", "buoyancy", "added_mass", "waves"]
    runs += [(with_am, d, f"waves + added_mass 0.5, depth {d:g}") for d in (0.75, 1.0, 1.25)]
    runs += [(["gravity", "buoyancy", "added_mass"], 1.0, "added_mass 0.5, flat sea")]
    for effects, depth, label in runs:
        t, z = model_heave(effects, depth)
        period, ratio = radiation.decay(t, z)
        zeta = damping_ratio(min(ratio, 1.0))
        rows.append({"setup": label, "period": period, "ratio_per_period": ratio, "damping_ratio": zeta})
        curves[label] = (t, z)
        print(label, f"period {period:.3f} ratio {ratio:.3f}", flush=True)
    for r in rows:
        r["period_vs_theory"] = r["period"] / t_period
        r["damping_vs_theory"] = r["damping_ratio"] / rows[0]["damping_ratio"]
    with open(out / "heave_radiation.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()})
    with open(out / "heave_radiation_coefficients.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["omega", "added_mass", "added_mass_over_displaced", "damping", "damping_from_waves"])
        for omega in (0.25, 0.5, 0.75, omega_n, 1.0, 1.25, 1.5, 2.0):
            am, bp, bf = radiation.heave_coefficients(omega, DEPTH, R, modes=200)
            w.writerow([f"{omega:.4g}", f"{am:.5g}", f"{am / R:.4g}", f"{bp:.5g}", f"{bf:.5g}"])
    print(
        f"theory: period {t_period:.3f}, ratio {t_ratio:.3f}; at omega_n {omega_n:.3f}: a {a_n:.4f} "
        f"({a_n / R:.3f} of the displaced mass), b {b_n:.4f}, a_inf {theory['a_inf']:.4f} "
        f"(spread over four frequencies {theory['a_inf_spread']:.1e})"
    )

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(12, 4.2), gridspec_kw={"width_ratios": [1, 2]})
    ax[0].plot(theory["omega"], theory["added_mass"] / R, label="added mass / displaced mass")
    ax[0].plot(theory["omega"], theory["damping"], label="damping b (rho w^2 sqrt(g/w))")
    ax[0].axvline(omega_n, color="0.6", ls=":", label="heave frequency")
    ax[0].set_xlim(0, 3)
    ax[0].set_xlabel("omega (sqrt(g/w))")
    ax[0].set_title("linear theory, rectangle 1 x 0.8946 in depth 6")
    ax[0].legend(fontsize=8)
    for label, (t, z) in curves.items():
        if label == "linear theory":
            ax[1].plot(t, z / LIFT, color="k", lw=2, label=label)
        elif label in ("waves, pressure depth 1", "waves + added_mass 0.5, depth 1", "waves, pressure depth 0"):
            ax[1].plot(t, z / LIFT, lw=1, label=label)
    ax[1].set_xlabel("t (sqrt(w/g))")
    ax[1].set_ylabel("heave / initial lift")
    ax[1].set_title("free heave decay")
    ax[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "heave_radiation.png", dpi=120)


if __name__ == "__main__":
    main()
