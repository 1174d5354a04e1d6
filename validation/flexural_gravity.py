"""A bonded slab in the moving sea (effects ``bonds`` + ``waves``): its flexural-gravity waves
against the floating elastic plate with the water's inertia, and what today's coupling gives.

    python validation/flexural_gravity.py --out validation/results/flexural_gravity

The slab covers a closed basin of length L (the wave grid from the wall at x = 0 to L, no
absorbing layer, water depth H = 6): n blocks of width b, thickness t = 1, bonded face to
face (default modulus, unbreakable, no dashpot), effects gravity, buoyancy, bonds and waves
(``wave_pressure_depth`` 1, the default, and 0), and the same slab without waves. It starts
flat, each block moving as ``v_z = a omega_plate cos(k x)`` (and the matching rotation), k
one of the basin's cosine modes, ``k = m pi / L``, so the water's own modes are the plate's.
The mode's amplitude is the blocks' heave projected on ``cos(k x)``, its frequencies the peaks
of its spectrum over the run (interpolated). Three relations beside it, per unit length,
``rho_w = g = 1``, ``D = E' t^3 / 12`` (the bonds' beam in plane strain, ``E' = E / (1 - nu^2)``),
``m = rho_i t``, ``S = D k^4 + 1``, ``G = k tanh(k H)``:

- the plate with the water's inertia: ``omega^2 = S G / (1 + m G)``;
- the dry slab (no water inertia): ``omega^2 = S / m``;
- today's coupling, linearised: the surface under the slab keeps its own free-surface
  stepping (``eta' = G phi - f zeta'``, ``phi' = -eta``) and pushes the slab with ``f eta``
  (``f = cosh(k (H - d)) / cosh(k H)``, the pressure depth's filter): ``omega^2`` solves
  ``m omega^2 + f^2 omega^2 / (G - omega^2) = S``, two roots, one below the free waves'
  ``G`` and one above the dry slab's ``S / m``.

Writes ``flexural_gravity.csv`` and ``flexural_gravity.png``.
"""

from __future__ import annotations

import argparse
import csv
import math
import tempfile
from pathlib import Path

import numpy as np

R = 0.8946  # density ratio (the default)
E0 = 1420.7219  # the default bond_modulus (1 GPa at w = 70 m)
NU = 0.3  # the default poisson_ratio
DEPTH = 6.0
UNBREAKABLE = 1e9


def rigidity(E: float, t: float) -> float:
    """``D = E t^3 / (12 (1 - nu^2))``: the bonds' bending stiffness per unit width (plane strain)."""
    return E * t**3 / (12.0 * (1.0 - NU * NU))


def plate(k: float, t: float = 1.0, E: float = E0, H: float = DEPTH) -> float:
    """omega of the floating plate with the water's inertia."""
    s, g, m = rigidity(E, t) * k**4 + 1.0, k * math.tanh(k * H), R * t
    return math.sqrt(s * g / (1.0 + m * g))


def dry(k: float, t: float = 1.0, E: float = E0) -> float:
    """omega of the slab on a hydrostatic foundation without the water's inertia."""
    return math.sqrt((rigidity(E, t) * k**4 + 1.0) / (R * t))


def coupled_today(k: float, depth: float, t: float = 1.0, E: float = E0, H: float = DEPTH) -> tuple[float, float]:
    """The two omegas of today's coupling, linearised (module docstring): the roots of
    ``m x^2 - (S + m G + f^2) x + S G = 0`` in ``x = omega^2``."""
    s, g, m = rigidity(E, t) * k**4 + 1.0, k * math.tanh(k * H), R * t
    f = math.cosh(k * (H - depth)) / math.cosh(k * H)
    # m x + f^2 x / (G - x) = S  <=>  m x (G - x) + f^2 x = S (G - x)  <=>  m x^2 - (m G + f^2 + S) x + S G = 0
    b = m * g + f * f + s
    disc = math.sqrt(b * b - 4.0 * m * s * g)
    return math.sqrt((b - disc) / (2.0 * m)), math.sqrt((b + disc) / (2.0 * m))


def scene_text(
    n: int, b: float, k: float, waves: bool, depth: float, dt: float, duration: float, a: float = 0.01, t: float = 1.0
) -> str:
    x = (np.arange(n) + 0.5) * b
    om = plate(k, t)
    vz = a * om * np.cos(k * x)
    omega = -a * om * k * np.sin(k * x)  # the slope's rate: d/dt of dz/dx
    effects = '"gravity", "buoyancy", "bonds"' + (', "waves"' if waves else "")
    out = [
        f'[scene]\nname = "flexural_gravity"\neffects = [{effects}]\n',
        f"[physics]\ndensity_ratio = {R}\nbond_modulus = {E0!r}\nbond_damping = 0.0\n"
        f"tensile_strength = {UNBREAKABLE!r}\nshear_strength = {UNBREAKABLE!r}\nwall_x = 0.0\n"
        f"water_depth = {DEPTH}\nwave_end = {n * b!r}\nwave_sponge = 0.0\nwave_dx = 0.25\nwave_pressure_depth = {depth!r}\n",
        f"[time]\ndt = {dt!r}\nduration = {duration!r}\n",
        "[output]\nsnapshot_interval = 0.1\ndiagnostic_interval = 1.0\ncheckpoint_interval = 1e6\n",
    ]
    for i in range(n):
        out.append(
            f"[[iceberg]]\nx = {float(x[i])!r}\nz = {-R * t + t / 2!r}\nwidth = {b!r}\nthickness = {t!r}\n"
            f"vz = {float(vz[i])!r}\nomega = {float(omega[i])!r}\n"
        )
    out += [f"[[bond]]\na = {i}\nb = {i + 1}\n" for i in range(n - 1)]
    return "\n".join(out)


def peaks(tt: np.ndarray, a: np.ndarray, count: int = 2) -> list[tuple[float, float]]:
    """The ``count`` largest peaks of ``a``'s spectrum (Hann window, zero-padded 16x), each
    ``(omega, relative height)``, the omega interpolated through the parabola of the log
    spectrum at the peak."""
    h = tt[1] - tt[0]
    y = (a - a.mean()) * np.hanning(a.size)
    nfft = 16 * a.size
    spec = np.abs(np.fft.rfft(y, nfft))
    om = 2 * math.pi * np.fft.rfftfreq(nfft, h)
    i = np.flatnonzero((spec[1:-1] > spec[:-2]) & (spec[1:-1] >= spec[2:])) + 1
    i = i[np.argsort(spec[i])[::-1][:count]]
    out = []
    for j in sorted(i):
        la, lb, lc = np.log(spec[j - 1 : j + 2])
        shift = 0.5 * (la - lc) / (la - 2 * lb + lc)
        out.append((float(om[j] + shift * (om[1] - om[0])), float(spec[j] / spec[i].max())))
    return out


def run(n: int, b: float, k: float, waves: bool, depth: float, duration: float, dt: float, work: Path) -> dict:
    import melange_ti
    import melange_ti.scene
    from melange_ti.errors import NumericalError
    from melange_ti.io.hdf5 import read_run

    text = scene_text(n, b, k, waves, depth, dt, duration)
    path = work / f"slab_{k:.4f}_{'waves' if waves else 'dry'}_{depth:g}.h5"
    ran_away = ""
    try:
        melange_ti.run(melange_ti.scene.loads(text), out=str(path), overwrite=True)
    except NumericalError as exc:  # the output up to there is kept: its spectrum still tells
        ran_away = str(exc).split(";")[0]
        print(f"k = {k:.4f}, waves {waves}, d = {depth:g}: {ran_away}", flush=True)
    r = read_run(str(path))
    tt = r["snapshots"]["time"]
    x = r["snapshots"]["x"][0]
    w = r["snapshots"]["z"] - (-R + 0.5)
    shape = np.cos(k * x)
    amp = w @ shape / (shape @ shape)
    return {"t": tt, "a": amp, "peaks": peaks(tt, amp), "ran_away": ran_away}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("validation/results/flexural_gravity"))
    p.add_argument("--width", type=float, default=0.5, help="block width b")
    p.add_argument("--half-waves", type=int, default=8, help="half wavelengths over the basin, m")
    p.add_argument("--duration", type=float, default=300.0)
    p.add_argument("--dt", type=float, default=0.005)
    a = p.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp())
    rows, traces = [], []
    for kt in (0.1, 0.27):
        k = kt  # t = 1
        length = a.half_waves * math.pi / k
        n = int(round(length / a.width))
        k = a.half_waves * math.pi / (n * a.width)  # the basin's cosine mode exactly
        low, high = coupled_today(k, 1.0)
        low0, high0 = coupled_today(k, 0.0)
        share = (rigidity(E0, 1.0) * k**4) / (rigidity(E0, 1.0) * k**4 + 1.0)
        for waves, depth in ((False, 1.0), (True, 1.0), (True, 0.0)):
            got = run(n, a.width, k, waves, depth, a.duration, a.dt, work)
            traces.append((k, waves, depth, got))
            theory = plate(k)
            for om, height in got["peaks"]:
                rows.append(
                    dict(
                        k_t=k,
                        length=n * a.width,
                        blocks=n,
                        waves=waves,
                        wave_pressure_depth=depth if waves else "",
                        omega_model=om,
                        peak_height=height,
                        omega_plate=theory,
                        error_vs_plate=om / theory - 1,
                        omega_dry=dry(k),
                        omega_today_low=low if depth == 1.0 else low0,
                        omega_today_high=high if depth == 1.0 else high0,
                        omega_free_waves=math.sqrt(k * math.tanh(k * DEPTH)),
                        bending_share=share,
                        ran_away=got["ran_away"],
                    )
                )
                print({k_: (round(v, 5) if isinstance(v, float) else v) for k_, v in rows[-1].items()}, flush=True)
    with open(a.out / "flexural_gravity.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.5))
    for k, waves, depth, got in traces:
        label = f"k t = {k:.3f}, " + (f"waves, d = {depth:g}" if waves else "no waves")
        a1.plot(got["t"], got["a"], lw=0.7, label=label)
    a1.set(xlabel="t (sqrt(w/g))", ylabel="cos(k x) amplitude (w)", title="a bonded slab covering a closed basin (H = 6)")
    a1.legend(fontsize=7)
    ks = np.linspace(0.02, 0.35, 200)
    a2.plot(ks, [plate(k) for k in ks], "k-", label="plate with the water's inertia")
    a2.plot(ks, [dry(k) for k in ks], "k--", label="dry slab")
    a2.plot(ks, [math.sqrt(k * math.tanh(k * DEPTH)) for k in ks], "k:", label="free waves")
    a2.plot(ks, [coupled_today(k, 1.0)[0] for k in ks], "C1-", lw=0.8, label="today's coupling, d = 1 (two roots)")
    a2.plot(ks, [coupled_today(k, 1.0)[1] for k in ks], "C1-", lw=0.8)
    for r in rows:
        marker = "s" if not r["waves"] else ("o" if r["wave_pressure_depth"] == 1.0 else "^")
        a2.plot(r["k_t"], r["omega_model"], marker, mfc="none", color="C0" if r["peak_height"] > 0.5 else "C7")
    a2.set(
        xlabel="k (1/w), t = 1",
        ylabel="omega (1/sqrt(w/g))",
        title="model (s: no waves, o: d = 1, ^: d = 0) and theory",
        ylim=(0, 2.2),
    )
    a2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(a.out / "flexural_gravity.png", dpi=120)


if __name__ == "__main__":
    main()
