"""Floating stability against theory: the orientation and draft a lone block settles to (with
drag) against the global minimum of its potential energy, and its small roll period against
the metacentric height, for a square and the paper's 1 x 1.4 block at density ratios
0.1-0.9 (issue 33: the shapes beyond rectangles follow with the polygon icebergs).

    python validation/floating_stability.py --out validation/results

**Theory, computed independently in numpy.** At an angle ``theta`` the block floats at the
water line that leaves ``r A`` of it submerged (bisection of the clipped area); its potential
energy is then ``U(theta) = -rho g r A z_B`` with ``z_B`` the submerged part's centroid above
the block's centre of mass (``m g z_G - rho g int_sub z dA`` at that draft). The clipping is
Sutherland-Hodgman on the block's corners (:func:`melange_ti.geometry.below`, not the
model's edge-by-edge formula; :func:`melange_ti.testing.floating`, shared with the tests).
``U`` is swept over every orientation on a fine grid and its global minimum refined by
golden section. A square floats flat (a face up) only
for ``r < (3 - sqrt 3) / 6 = 0.2113`` or ``r > 0.7887``, where its metacentric height
``GM = 1 / (12 r) + r / 2 - 1/2`` is positive; in between it floats tilted, corner-up in the
middle. Flat and stable, a block of width ``w`` (the water line's length) and thickness ``h``
at draft ``r h`` rolls with ``I omega^2 = m g GM``, ``GM = w^2 / (12 r h) - h (1 - r) / 2``,
``I = m (w^2 + h^2) / 12``.

**The model.** One block per density ratio (``gravity``, ``buoyancy``, ``drag`` with
``drag = angular_drag = 0.5``, dt = 0.01), started upright-flat with a tilt of 0.05 rad, run
to t = 3000; its settled angle (folded by the block's symmetry) and centre height are compared
with the minimum: within 0.5 degrees and 1e-6 (issue 33's bounds). Its roll period, without
drag, from a tilt of 1e-3 rad off a stable flat position (upright, or else on its side),
against ``2 pi / omega`` within 1%.
Writes ``floating_stability.csv`` and ``floating_stability.png`` and prints the table.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import numpy as np

RATIOS = tuple(float(v) for v in np.round(np.arange(0.1, 0.91, 0.05), 2))
# the square's tilted equilibria lie between the flat and the corner-up ranges
SQUARE_EXTRA = (0.21, 0.22, 0.23, 0.24, 0.76, 0.77, 0.78, 0.79)
BLOCKS = {"square": (1.0, 1.0), "paper block": (1.0, 1.4)}
DRAG = 0.5
TILT0 = 0.05
SETTLE = 3000.0  # next to the square's bifurcations (r = 0.21, 0.79) the roll is slow and overdamped
DT = 0.01


# ---------------------------------------------------------------- theory (numpy)
def minimum(w: float, h: float, r: float) -> tuple[float, float]:
    """The global minimum of the floating potential over every orientation (numpy,
    :func:`melange_ti.testing.floating_minimum`): (folded angle, centre height)."""
    from melange_ti.testing import floating_minimum, rectangle

    square = w == h
    theta, z = floating_minimum(rectangle(w, h), r, math.pi / 2 if square else math.pi, 720)
    return fold(theta, square), z


def fold(theta: float, square: bool) -> float:
    """The angle from the nearest flat position (a face up), by the block's symmetry."""
    period = math.pi / 2 if square else math.pi
    return abs((theta + period / 2) % period - period / 2)


def roll_omega(w: float, h: float, r: float) -> float | None:
    """Small-roll angular frequency about the flat position with thickness h vertical, or
    None where that position is unstable (GM <= 0)."""
    gm = w**2 / (12 * r * h) - h * (1 - r) / 2
    return math.sqrt(12 * gm / (w**2 + h**2)) if gm > 0 else None


# ---------------------------------------------------------------- the model
def settle(w: float, h: float, r: float, drag: float, theta0: float, duration: float, every: int = 0):
    """A lone block from the flat position tilted by theta0: its final (theta, z), and with
    ``every`` its tilt every so many steps."""
    from melange_ti.model import Model
    from melange_ti.scene.initial import equilibrium_z
    from melange_ti.testing import make_scene

    bergs = [{"x": 0.0, "z": equilibrium_z(h, r, 0.0), "theta": theta0, "width": w, "thickness": h}]
    physics = {"density_ratio": r, "drag": drag, "angular_drag": drag, "wall_x": -50.0}
    m = Model(make_scene(["gravity", "buoyancy", "drag"], bergs, physics, dt=DT))
    steps = int(round(duration / DT))
    if not every:
        m.advance(steps)
        s = m.state()
        return float(s["theta"][0]), float(s["z"][0]), None
    tilts = []
    for _ in range(steps // every):
        m.advance(every)
        tilts.append(float(m.state()["theta"][0]))
    s = m.state()
    return float(s["theta"][0]), float(s["z"][0]), np.array(tilts)


def roll_period(w: float, h: float, r: float) -> float:
    """The roll's period from zero crossings over about eight periods of the theory's."""
    from melange_ti.testing import zero_crossing_period

    every = 5
    _, _, tilts = settle(w, h, r, 0.0, 1e-3, 8 * 2 * math.pi / roll_omega(w, h, r) + 10.0, every)
    t = every * DT * np.arange(1, len(tilts) + 1)
    return zero_crossing_period(t, tilts, least=5)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="validation/results")
    p.add_argument("--plot-only", action="store_true", help="redraw the figure from the CSV in --out")
    a = p.parse_args()
    if a.plot_only:
        with open(Path(a.out) / "floating_stability.csv") as f:
            rows = [{k: (v if k == "block" else float(v)) for k, v in row.items()} for row in csv.DictReader(f)]
        plot(rows, Path(a.out) / "floating_stability.png")
        return
    from melange_ti import runtime

    runtime.init("cpu", precision="f64")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name, (w, h) in BLOCKS.items():
        for r in sorted(RATIOS + (SQUARE_EXTRA if w == h else ())):
            angle, z = minimum(w, h, r)
            theta, zm, _ = settle(w, h, r, DRAG, TILT0, SETTLE)
            # the roll about a stable flat position: thickness h vertical, or else on its side
            # (the same block as a rectangle h wide and w thick)
            rw, rh = (w, h) if roll_omega(w, h, r) is not None else (h, w)
            om = roll_omega(rw, rh, r)
            period = roll_period(rw, rh, r) if om is not None else float("nan")
            rows.append(
                {
                    "block": name,
                    "density_ratio": r,
                    "theory_deg": math.degrees(angle),
                    "model_deg": math.degrees(fold(theta, w == h)),
                    "theory_z": z,
                    "model_z": zm,
                    "roll_period_theory": 2 * math.pi / om if om else float("nan"),
                    "roll_period_model": period,
                }
            )
            q = rows[-1]
            print(
                f"{name:12s} r = {r:.2f}: settled {q['model_deg']:8.4f} deg (theory {q['theory_deg']:8.4f}), "
                f"z {zm:+.8f} ({z:+.8f}), roll period {period:.4f} ({q['roll_period_theory']:.4f})",
                flush=True,
            )
    with open(out / "floating_stability.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    plot(rows, out / "floating_stability.png")
    worst_deg = max(abs(q["model_deg"] - q["theory_deg"]) for q in rows)
    worst_z = max(abs(q["model_z"] - q["theory_z"]) for q in rows)
    stable = [q for q in rows if math.isfinite(q["roll_period_theory"])]
    rel = [abs(q["roll_period_model"] / q["roll_period_theory"] - 1) for q in stable]
    print(f"largest angle error {worst_deg:.2e} deg, centre height {worst_z:.2e}, roll period {max(rel):.2e} relative")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from melange_ti.testing import floating_minimum, rectangle

    fig, ax = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for k, name in enumerate(BLOCKS):
        q = [row for row in rows if row["block"] == name]
        r = [row["density_ratio"] for row in q]
        w, h = BLOCKS[name]
        # the theory at the cases' ratios, and for the square finely across its bifurcations
        curve = {row["density_ratio"]: row["theory_deg"] for row in q}
        if w == h:
            for v in np.concatenate([np.linspace(0.205, 0.3, 20), np.linspace(0.7, 0.795, 20)]):
                curve[float(v)] = math.degrees(fold(floating_minimum(rectangle(w, h), float(v), math.pi / 2, 90)[0], True))
        fine = sorted(curve)
        ax[k].plot(fine, [curve[v] for v in fine], "-", color="0.5", label="minimum of U (numpy)")
        ax[k].plot(r, [row["model_deg"] for row in q], "o", mfc="none", color="C0", label="model, settled with drag")
        ax[k].set_ylim(-3, 93 if w != h else 48)
        ax[k].ticklabel_format(useOffset=False)
        ax[k].set_title(f"{name} ({w:g} x {h:g})")
        ax[k].set_xlabel("density ratio r")
        ax[k].set_ylabel("angle from theta = 0, folded (degrees)")
        ax[k].legend(loc="upper left" if w == h else "center right", fontsize=8)
    if BLOCKS["square"][0] == BLOCKS["square"][1]:
        for x in ((3 - math.sqrt(3)) / 6, (3 + math.sqrt(3)) / 6):
            ax[0].axvline(x, color="0.8", lw=0.8, ls="--")
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
