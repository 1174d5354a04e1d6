"""Which breaking criterion converges as the cells shrink (issue 50, item 4): a floating slab
loaded at its free edge, intact and with one crevasse, at five cell sizes (four halvings).

    python validation/fracture_convergence.py --out validation/results/fracture_convergence   # ~2 min on one core

The slab (thickness ``t = 1``, the default modulus and Poisson's ratio, density ratio 0.8946)
runs from its free face at x = 0 for ``7 / beta``; it is cut into square cells of side ``h``
(columns ``h`` wide, ``cells = [1, 1 / h]``; ``h = 1`` is one cell per column) bonded across
every face. A load at the free edge: blocks above the water on the columns from x = 0 to 0.5,
each 0.9 of its column's width and bonded to it (separate blocks, so they press the slab as a
pressure, not as a rigid punch whose edges would concentrate the stress at the finest cells),
weighing ``P = 0.05`` in all, centred at x = 0.25 at every ``h``. The slab settles under
unbreakable bonds, drag and the bonds' dashpots for 30
time units (the last snapshots differ by ~1e-7 w). The settled state is linear in ``P``, so the
load at which a criterion breaks the first bond follows from each bond's settled stress and
energy:

- **stress** (today's): a bond breaks when ``s = F_n / l + 6 |M| / l^2 >= s_t``, so
  ``P_c = P s_t / max s``;
- **energy**: a bond in tension (``s > 0``) breaks when the energy that opens it reaches the
  fracture energy of the crack it opens, ``U_I >= G_c l`` (``U_I = k_n max(d_n, 0)^2/2 +
  k_b dth^2/2``, its stretch and bending: mode I; its shear energy is mode II), so
  ``P_c = P sqrt(G_c) min sqrt(l / U_I)`` (quoted per ``sqrt(G_c)``).

Two slabs: **intact** (a smooth stress field: the moment peaks at ``pi / (4 beta)`` from the
load) and **crevassed** (one joint at x = 4, near that peak, open over the top half of the
thickness from t = 0: a notch, whose tip concentrates the stress). For the crevassed slab the
section's bending moment ``M`` at the crevasse is read from the model (the sum over the joint's
bonds of their forces' moment about the section's middle and their own moments), and linear
elastic fracture mechanics gives the crack's stress intensity ``K = (6 M / t^2) sqrt(pi a)
F(a / t)`` (Tada's single-edge-notched beam in bending) and energy release rate ``G = K^2 / E'``
(plane strain): the load at which ``G = G_c``, against the energy criterion's.

Expected (docs/bonds.md, "Strength and size"): in the smooth field a bond's stress converges
and its energy per crack length, ``s^2 h / (2 E')``, falls with ``h``; at the notch's tip the
bond's stress grows as ``K / sqrt(h)`` and its energy per length tends to a constant times
``K^2 / E'``. Writes ``fracture_convergence.csv``, ``fracture_convergence.png`` and the printed
lines in ``fracture_convergence.log``.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

_spec = importlib.util.spec_from_file_location("bonds_beam", Path(__file__).parent / "bonds_beam.py")
beam = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(beam)

R, E0, SIGMA_T = beam.R, beam.E0, beam.SIGMA_T
P = 0.05  # the load at the free edge
LOAD_WIDTH = 0.5  # the load's width: a pressure P / 0.45 on x = 0 to 0.5 at every cell size (its centre x = 0.25)
CREVASSE_X = 4.0  # the crevassed joint (a multiple of every cell size), near pi / (4 beta) from the load
CREVASSE_DEPTH = 0.5
SIZES = (1.0, 0.5, 0.25, 0.125, 0.0625)
G_C = 1e10 / (1420.7219 * 703868.0 / 0.91) / (703868.0 * 70.0)  # K_c^2 / E' of K_c = 0.1 MPa sqrt(m), in rho_w g w^2 at w = 70 m


def slab_text(h: float, t: float, crevassed: bool, *, dt: float, duration: float, E: float = E0, length: float = 7.0) -> str:
    """The scene: columns ``h`` wide from x = 0, each ``1 / h`` cells thick (square cells),
    the load block on the first, the crevassed joint at ``CREVASSE_X`` if ``crevassed``."""
    beta = beam.beta_of(E, t)
    n = int(math.ceil(length / beta / h))
    layers = int(round(t / h))
    delta = P / (R * 0.9 * LOAD_WIDTH)  # the load blocks' height: their weight is P in all
    out = [
        '[scene]\nname = "fracture_convergence"\neffects = ["gravity", "buoyancy", "bonds", "drag"]\n',
        f"[physics]\ndensity_ratio = {R}\ndrag = 1.0\nangular_drag = 1.0\nbond_modulus = {E!r}\n"
        f"bond_damping = 0.05\ntensile_strength = {beam.UNBREAKABLE!r}\nshear_strength = {beam.UNBREAKABLE!r}\n",
        f"[time]\ndt = {dt!r}\nduration = {duration!r}\n",
        f"[output]\nsnapshot_interval = {duration / 4!r}\ndiagnostic_interval = 1.0\ncheckpoint_interval = 1e6\n",
    ]
    cells = f"cells = [1, {layers}]\n" if layers > 1 else ""
    for i in range(n):
        out.append(f"[[iceberg]]\nx = {(i + 0.5) * h!r}\nz = {-R * t + t / 2!r}\nwidth = {h!r}\nthickness = {t!r}\n{cells}")
    for k in range(loads(h)):  # a block on each column under the load, 0.9 of its width: no rigid punch
        out.append(
            f"[[iceberg]]\nx = {(k + 0.5) * min(h, LOAD_WIDTH)!r}\nz = {(1 - R) * t + delta / 2!r}\n"
            f"width = {0.9 * min(h, LOAD_WIDTH)!r}\nthickness = {delta!r}\n"
        )
    joint = int(round(CREVASSE_X / h))  # the joint between columns joint - 1 and joint
    for i in range(n - 1):
        crevasse = f"crevasse_depth = {CREVASSE_DEPTH!r}\n" if crevassed and i + 1 == joint else ""
        out.append(f"[[bond]]\na = {i}\nb = {i + 1}\n{crevasse}")
    out += [f"[[bond]]\na = {n + k}\nb = {k}\n" for k in range(loads(h))]  # each load block on its column
    return "\n".join(out)


def loads(h: float) -> int:
    """The load blocks: one on each column under the load (one if a column is wider)."""
    return max(1, int(round(LOAD_WIDTH / h)))


def settled(path, load_body: int) -> dict:
    """Each slab bond's tensile stress, energy, crack length, x and height at t = 0, and its
    normal force and moment, in the last snapshot (as the break check reads them); whether it is
    a crack's tip from the start and its row. ``load_body``: the first load block's
    [[iceberg]] index (the slab's columns are the ones below it)."""
    from melange_ti.io.hdf5 import read_run
    from melange_ti.physics.effects.bonds import REST

    r = read_run(str(path))
    s, rest = r["snapshots"], np.asarray(r["bonds"]["rest"])
    col = {name: rest[:, k] for k, name in enumerate(REST)}
    body = np.asarray(r["icebergs"]["cell_iceberg"]) if "cell_iceberg" in r["icebergs"] else np.arange(s["x"].shape[1])
    a, b = col["A"].astype(np.int64), col["B"].astype(np.int64)
    x, z, th = s["x"][-1], s["z"][-1], s["theta"][-1]

    def at(frame, i, u, v):
        c, sn = np.cos(frame["theta"][i]), np.sin(frame["theta"][i])
        return np.stack([frame["x"][i] + c * u - sn * v, frame["z"][i] + sn * u + c * v], -1)

    now = {"x": x, "z": z, "theta": th}
    start = {k: s[k][0] for k in ("x", "z", "theta")}
    d = at(now, b, col["UB"], col["VB"]) - at(now, a, col["UA"], col["VA"])
    ca, sa = np.cos(th[a]), np.sin(th[a])
    n = np.stack([ca * col["NU"] - sa * col["NV"], sa * col["NU"] + ca * col["NV"]], -1)
    dn = np.sum(d * n, -1)
    dth = th[b] - th[a] - col["DTH"]
    fn, m = col["KN"] * dn, col["KB"] * dth
    length = col["LEN"]
    energy = 0.5 * (col["KN"] * np.maximum(dn, 0.0) ** 2 + col["KB"] * dth**2)  # what opens it (mode I), as the model reads
    p0 = at(start, a, col["UA"], col["VA"])
    slab = (body[a] < load_body) & (body[b] < load_body)
    return dict(
        stress=(fn / length + 6 * np.abs(m) / length**2)[slab],
        energy=energy[slab],
        length=length[slab],
        x=p0[slab, 0],
        z=p0[slab, 1],
        across=(np.abs(col["NU"]) > 0.5)[slab],
        fn=fn[slab],
        m=m[slab],
        tip=(col["TIP0"] > 0.5)[slab],
        row=np.flatnonzero(slab),
    )


def tada_f(alpha: float) -> float:
    """Tada's geometry factor of a single-edge-notched beam in pure bending (crack depth
    ``alpha`` of the thickness; Tada, Paris & Irwin 2000, within 0.5% for any ``alpha``)."""
    q = math.pi * alpha / 2.0
    return math.sqrt(math.tan(q) / q) * (0.923 + 0.199 * (1.0 - math.sin(q)) ** 4) / math.cos(q)


def beam_moment(E: float = E0, t: float = 1.0, length: float = 7.0, dx: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """The bending moment per unit load of an Euler-Bernoulli beam (``D = E' t^3 / 12``) on the
    water's foundation (``k = 1``), free at both ends, ``length / beta`` long, under a uniform
    load over x = 0 to ``LOAD_WIDTH``: finite differences (the beam's energy minimised over
    nodal deflections ``dx`` apart; hogging +)."""
    D = beam.plane_strain(E) * t**3 / 12.0
    x = np.arange(0.0, length / beam.beta_of(E, t) + dx / 2, dx)
    n = x.size
    c = np.zeros((n - 2, n))
    k = np.arange(n - 2)
    c[k, k], c[k, k + 1], c[k, k + 2] = 1.0, -2.0, 1.0
    c /= dx**2
    q = np.where(x <= LOAD_WIDTH + 1e-9, 1.0, 0.0)
    q /= q.sum() * dx
    w = np.linalg.solve(D * dx * (c.T @ c) + dx * np.eye(n), q * dx)
    return x[1:-1], D * (c @ w)


def run(
    h: float, crevassed: bool, t: float = 1.0, work=None, settle_time: float = 30.0, length: float = 7.0, dt_factor: float = 1.0
) -> dict:
    import melange_ti
    import melange_ti.scene

    work = Path(work or tempfile.mkdtemp())
    probe = slab_text(h, t, crevassed, dt=1.0, duration=1.0, length=length)
    dt = beam.stable_dt(probe) * dt_factor
    text = slab_text(h, t, crevassed, dt=dt, duration=settle_time, length=length)
    path = work / f"slab_{h:g}_{int(crevassed)}_{length:g}_{dt_factor:g}.h5"
    melange_ti.run(melange_ti.scene.loads(text), out=str(path), overwrite=True)
    n_cols = int(math.ceil(length / beam.beta_of(E0, t) / h))
    st = settled(path, load_body=n_cols)
    xm, mb = beam_moment(E0, t, length)
    Ep = beam.plane_strain(E0)
    i_s = int(np.argmax(st["stress"]))
    per_len = np.where(st["stress"] > 0.0, st["energy"] / st["length"], 0.0)  # a crack opens only where the bond is in tension
    i_e = int(np.argmax(per_len))
    row = dict(
        slab="crevassed" if crevassed else "intact",
        cell=h,
        length_per_beta=length,
        dt_factor=dt_factor,
        layers=int(round(t / h)),
        columns=n_cols,
        dt=dt,
        p_stress=P * SIGMA_T / float(st["stress"][i_s]),
        stress_bond_x=float(st["x"][i_s]),
        stress_bond_z=float(st["z"][i_s]),
        p_energy_per_sqrt_gc=P / math.sqrt(float(per_len[i_e])),
        energy_bond_x=float(st["x"][i_e]),
        energy_bond_z=float(st["z"][i_e]),
        peak_beam=float(xm[np.argmax(mb)]),
        p_stress_beam=SIGMA_T * t**2 / (6.0 * float(mb.max())),
    )
    # the section's moment at the joint x = CREVASSE_X: the joint's bonds' forces about its middle, and their moments
    # (hogging +: tension on top); the beam's there, (P / beta) e^(-beta x) sin(beta x) from the load, beside it
    joint = st["across"] & (np.abs(st["x"] - CREVASSE_X) < 1e-6)
    zmid = -R * t + t / 2
    moment = float(np.sum(st["fn"][joint] * (st["z"][joint] - zmid)) - np.sum(st["m"][joint]))
    row |= dict(joint_moment=moment, joint_moment_beam=P * float(np.interp(CREVASSE_X, xm, mb)), joint_bonds=int(joint.sum()))
    # the coupled criterion the model runs with physics.fracture_energy (docs/bonds.md): energy at a crack's tip
    # (TIP0: the crevasse's), stress elsewhere; with G_c of ice's K_c = 0.1 MPa sqrt(m) at w = 70 m
    tip_per_len = np.where(st["tip"], per_len, 0.0)
    by_stress = P * SIGMA_T / float(np.max(np.where(st["tip"], 0.0, st["stress"])))
    by_energy = P * math.sqrt(G_C / float(tip_per_len.max())) if st["tip"].any() else math.inf
    row |= dict(tips=int(st["tip"].sum()), p_coupled=min(by_stress, by_energy), coupled_at_tip=bool(by_energy < by_stress))
    if crevassed:
        k = 6.0 * abs(moment) / t**2 * math.sqrt(math.pi * CREVASSE_DEPTH * t) * tada_f(CREVASSE_DEPTH)
        # G = K^2 / E' = G_c at P_c: P_c / sqrt(G_c) = P sqrt(E') / K
        row |= dict(p_lefm_per_sqrt_gc=P * math.sqrt(Ep) / k)
        row |= model_check(path, text, st, float(tip_per_len.max()), work / f"check_{h:g}_{length:g}_{dt_factor:g}")
    else:
        row |= dict(p_lefm_per_sqrt_gc=float("nan"), model_breaks_tip_first=False, model_holds_above=False)
    return row


def model_check(path: Path, text: str, st: dict, per_tip: float, out: Path) -> dict:
    """The model's own break check with ``physics.fracture_energy``: the settled slab restarted
    with the tip's energy per length times 0.999 breaks the tip first, in the first step;
    times 1.001, nothing breaks in a time unit (its tensile strength stays unbreakable)."""
    import melange_ti
    import melange_ti.scene
    from melange_ti.io.hdf5 import read_run

    settle = float(text.split("duration = ")[1].split("\n")[0])
    got = {}
    for factor in (0.999, 1.001):
        head = text.split("[[iceberg]]")[0].replace(f"duration = {settle!r}", "duration = 1.0")
        head = head.replace("bond_damping = 0.05\n", f"bond_damping = 0.05\nfracture_energy = {factor * per_tip!r}\n")
        target = out.with_name(out.name + f"_{factor}.h5")
        melange_ti.run(
            melange_ti.scene.loads(head + f'\n[start]\nfile = "{path}"\ntime = {settle!r}\n'), out=str(target), overwrite=True
        )
        got[factor] = np.asarray(read_run(str(target))["bonds"]["break_time"])
    bt = got[0.999]
    tip_rows = st["row"][st["tip"]]
    first = np.flatnonzero(bt == np.nanmin(bt)) if np.isfinite(bt).any() else np.array([], dtype=np.int64)
    return dict(
        model_breaks_tip_first=bool(first.size == 1 and first[0] in tip_rows and bt[first[0]] == 0.0),
        model_holds_above=bool(np.all(np.isnan(got[1.001]))),
    )


CHECKS = ((0.125, 10.0, 1.0), (0.125, 7.0, 0.5))  # (cell, length * beta, step factor): a longer slab, half the step


def study(out_dir: Path, work=None) -> list[dict]:
    rows = []
    log = open(out_dir / "fracture_convergence.log", "w")
    for crevassed in (False, True):
        for h, length, factor in [(h, 7.0, 1.0) for h in SIZES] + list(CHECKS):
            row = run(h, crevassed, work=work, length=length, dt_factor=factor)
            rows.append(row)
            line = (
                f"{row['slab']:9s} h={h:<6g} layers={row['layers']} L={length:g}/beta dt={row['dt']:.3g}: stress P_c = "
                f"{row['p_stress']:.5f} at x = {row['stress_bond_x']:.4f}, z = {row['stress_bond_z']:+.4f} (beam "
                f"{row['p_stress_beam']:.5f} at x = {row['peak_beam']:.2f}); energy P_c / sqrt(G_c) = "
                f"{row['p_energy_per_sqrt_gc']:.4f} at x = {row['energy_bond_x']:.4f}, z = {row['energy_bond_z']:+.4f}; "
                f"moment at x = {CREVASSE_X:g}: {row['joint_moment']:.5f} (beam {row['joint_moment_beam']:.5f})"
            )
            line += f"; coupled (G_c {G_C:.3g}) P_c = {row['p_coupled']:.5f}{' at the tip' if row['coupled_at_tip'] else ''}"
            if crevassed:
                line += (
                    f"; LEFM P_c / sqrt(G_c) = {row['p_lefm_per_sqrt_gc']:.4f}; the model breaks the tip first at 0.999: "
                    f"{row['model_breaks_tip_first']}, holds at 1.001: {row['model_holds_above']}"
                )
            print(line, flush=True)
            log.write(line + "\n")
    log.close()
    beam.write_csv(out_dir / "fracture_convergence.csv", rows)
    plot([r for r in rows if r["length_per_beta"] == 7.0 and r["dt_factor"] == 1.0], out_dir / "fracture_convergence.png")
    return rows


def plot(rows: list[dict], path: Path) -> None:
    plt = beam.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), sharex=True)
    for ax, key, title in (
        (axes[0], "p_stress", "stress criterion: s >= s_t"),
        (axes[1], "p_energy_per_sqrt_gc", "energy criterion: U >= G_c l (per sqrt(G_c))"),
    ):
        for slab, mk in (("intact", "o-"), ("crevassed", "s-")):
            rs = [r for r in rows if r["slab"] == slab]
            ax.loglog([r["cell"] for r in rs], [r[key] for r in rs], mk, mfc="none", label=slab)
        if key == "p_stress":
            ax.axhline(rows[0]["p_stress_beam"], color="k", lw=0.8, ls=":", label="beam theory (intact)")
            tip = [r for r in rows if r["slab"] == "crevassed"][-1]
            hs = np.array([r["cell"] for r in rows if r["slab"] == "crevassed"])
            ax.loglog(hs, tip["p_stress"] * np.sqrt(hs / tip["cell"]), "k--", lw=0.8, label="~ sqrt(h): K / sqrt(h) at a tip")
        else:
            lefm = [r["p_lefm_per_sqrt_gc"] for r in rows if r["slab"] == "crevassed"]
            ax.loglog([r["cell"] for r in rows if r["slab"] == "crevassed"], lefm, "k:", label="LEFM at the crevasse (crevassed)")
        ax.set(xlabel="cell size h (w)", ylabel="load that breaks the first bond", title=title)
        ax.legend(fontsize=8)
    fig.suptitle("a floating slab loaded at its free edge: the first break's load against the cell size", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="validation/results/fracture_convergence")
    a = p.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as work:
        study(out, work=work)


if __name__ == "__main__":
    sys.exit(main())
