"""Impacts into elastic ice (issue 50, item 5): the peak stress a contact puts into a bonded
shelf, against the time step and the disc count, rigid (the paper's impulse) and crushing
(effect ``crushing``: a contact's force at most ``p_c h_c``).

    python validation/impact_stress.py --out validation/results/impact_stress   # ~10 min on one core

A contact is an impulse: it changes the two bodies' velocities within one step (docs/model.md,
Contacts). A bond answers a jump of velocity ``dv`` of one of its ends as a spring does, its
force growing over a quarter of its period to about ``dv sqrt(k m)``: the peak bond stress is
set by the impulse, not by the step, so it should converge as ``dt`` falls, to first order,
once ``dt`` resolves the bonds' period. Two cases, each with unbreakable bonds (so nothing
breaks and the peak is the stress field's), every snapshot a step, the stress of every bond
``F_n / t + 6 |M| / t^2`` (tension +) and ``|F_s| / t`` computed from the snapshot and the
bonds' rest table (as the break check does):

- ``head-on``: a block (1 x 1.4) at 0.05 w per time unit strikes the free end of a floating
  slab of 20 such blocks bonded face to face, no wall, to t = 3;
- ``leaning front``: the paper's shelf of 50 pieces cut at 20 degrees (``--cut-tilt 20`` of
  validation/shelf_breakup.py, seed 1), bonded to the wall, its free leaning front block
  tipping into it (the issue's "hammer blow": first contact near t = 2.4), to t = 6.

Each at ``dt`` = 0.01 (the paper's; where the bonds allow it), 0.005, 0.0025 and 0.00125, and
at ``contacts.discs`` = 28, 56 and 112 at the finest step; each with the rigid law and with
crushing at its defaults (``crushing_pressure`` 2.0, 1.4 MPa at w = 70 m, over
``crushing_height`` 0.1 w), and crushing at twice and half the pressure at dt = 0.0025 (what
the peak depends on). Writes ``impact_stress.csv`` and ``impact_stress.png``.
"""

from __future__ import annotations

import argparse
import csv
import math
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
R = 0.8946
H = 1.4
UNBREAKABLE = 1e9
PA = 1025 * 9.81 * 70.0 / 1000.0  # kPa per rho_w g w at w = 70 m
PRESSURE = 2.0  # physics.crushing_pressure's default (rho_w g w)


def crushing(pressure: float | None) -> tuple[str, str]:
    """The effect list's tail and the [physics] lines of the contact law: rigid (``None``), or
    crushing at ``pressure`` (rho_w g w)."""
    if pressure is None:
        return "", ""
    return ', "crushing"', f"crushing_pressure = {pressure!r}\n"


def head_on(dt: float, discs: int, pressure: float | None = None, duration: float = 3.0, n: int = 20, speed: float = 0.05) -> str:
    z = -R * H + H / 2
    bergs = "".join(f"[[iceberg]]\nx = {q + 0.5!r}\nz = {z!r}\n" for q in range(n))
    bergs += f"[[iceberg]]\nx = {n + 0.5 + 0.02!r}\nz = {z!r}\nvx = {-speed!r}\n"
    bonds = "".join(f"[[bond]]\na = {q}\nb = {q + 1}\n" for q in range(n - 1))
    effect, line = crushing(pressure)
    return (
        f'[scene]\nname = "head_on"\neffects = ["gravity", "buoyancy", "drag", "collisions", "bonds"{effect}]\n'
        f"[physics]\ntensile_strength = {UNBREAKABLE!r}\nshear_strength = {UNBREAKABLE!r}\n{line}"
        f"[contacts]\ndiscs = {discs}\n[time]\ndt = {dt!r}\nduration = {duration!r}\n"
        f"[output]\nsnapshot_interval = {dt!r}\ndiagnostic_interval = {duration / 10!r}\ncheckpoint_interval = 1e6\n"
        + bergs
        + bonds
    )


def leaning_front(dt: float, discs: int, pressure: float | None = None, duration: float = 6.0) -> str:
    import melange_ti as mt
    from melange_ti.scene import dumps_toml

    over = {
        "shelf.count": 50,
        "time.duration": duration,
        "time.dt": dt,
        "time.seed": 1,
        "contacts.discs": discs,
        "shelf.cut_tilt": math.radians(20.0),
        "shelf.cut_tilt_std": math.radians(2.5),
        "physics.tensile_strength": UNBREAKABLE,
        "physics.shear_strength": UNBREAKABLE,
        "output.snapshot_interval": dt,
        "output.diagnostic_interval": duration / 10,
        "output.checkpoint_interval": 1e6,
    }
    if pressure is not None:
        over["scene.effects+"] = "crushing"
        over["physics.crushing_pressure"] = pressure
    return dumps_toml(mt.load_scene(ROOT / "runs" / "shelf_breakup.toml", overrides=over).source)


def stress_history(path) -> dict:
    """The largest tensile and shear stress over every bond and snapshot of a run, where and
    when: from each snapshot and the bonds' rest table (docs/bonds.md, Breaking)."""
    import h5py

    from melange_ti.physics.effects.bonds import REST

    with h5py.File(path, "r") as f:
        rest = f["bonds/rest"][()]
        x, z, th, t = (f[f"snapshots/{k}"][()] for k in ("x", "z", "theta", "time"))
    col = {name: rest[:, k] for k, name in enumerate(REST)}
    a, b = col["A"].astype(np.int64), col["B"].astype(np.int64)
    wall = b < 0
    bb = np.where(wall, 0, b)
    ca, sa = np.cos(th[:, a]), np.sin(th[:, a])
    pa = np.stack([x[:, a] + ca * col["UA"] - sa * col["VA"], z[:, a] + sa * col["UA"] + ca * col["VA"]], -1)
    cb, sb = np.cos(th[:, bb]), np.sin(th[:, bb])
    pb = np.stack([x[:, bb] + cb * col["UB"] - sb * col["VB"], z[:, bb] + sb * col["UB"] + cb * col["VB"]], -1)
    pb = np.where(wall[None, :, None], np.stack([col["UB"], col["VB"]], -1)[None], pb)
    d = pb - pa
    n = np.stack([ca * col["NU"] - sa * col["NV"], sa * col["NU"] + ca * col["NV"]], -1)
    s = np.stack([-n[..., 1], n[..., 0]], -1)
    dth = np.where(wall[None], 0.0, th[:, bb]) - th[:, a] - col["DTH"]
    fn, fs = col["KN"] * np.sum(d * n, -1), col["KS"] * np.sum(d * s, -1)
    sig = fn / col["LEN"] + 6 * np.abs(col["KB"] * dth) / col["LEN"] ** 2
    tau = np.abs(fs) / col["LEN"]
    k, q = np.unravel_index(np.argmax(sig), sig.shape)
    return dict(
        peak_tension=float(sig[k, q]),
        peak_time=float(t[k]),
        peak_bond=int(q),
        peak_bond_a=int(a[q]),
        peak_shear=float(tau.max()),
        first_half_peak=float(sig[: len(t) // 2].max()),
    )


def one(case: str, dt: float, discs: int, work: Path, pressure: float | None = None) -> dict:
    import melange_ti as mt
    from melange_ti.scene import loads

    text = head_on(dt, discs, pressure) if case == "head-on" else leaning_front(dt, discs, pressure)
    law = "rigid" if pressure is None else "crushing"
    out = work / f"{case}_{law}_{pressure}_{dt:g}_{discs}.h5"
    t0 = time.time()
    mt.run(loads(text), out, overwrite=True, threads=1)
    row = dict(case=case, law=law, pressure=pressure or 0.0, dt=dt, discs=discs, **stress_history(out))
    row["wall_s"] = round(time.time() - t0, 1)
    row["peak_tension_kPa"] = row["peak_tension"] * PA
    print(
        f"{case} {law} p={pressure} dt={dt:g} discs={discs}: "
        f"peak tension {row['peak_tension']:.5f} ({row['peak_tension_kPa']:.1f} kPa) "
        f"at t = {row['peak_time']:.4f}, bond {row['peak_bond']} (iceberg {row['peak_bond_a']}); "
        f"shear {row['peak_shear']:.5f}",
        flush=True,
    )
    return row


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=ROOT / "validation" / "results" / "impact_stress")
    p.add_argument("--no-run", action="store_true", help="redraw the figure from the CSV in --out")
    a = p.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    if a.no_run:
        with open(a.out / "impact_stress.csv", newline="") as fh:
            rows = [{k: v if k in ("case", "law") else float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
        draw(rows, a.out)
        return
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for pressure in (None, PRESSURE):
            for case in ("head-on", "leaning front"):
                for dt in (0.01, 0.005, 0.0025, 0.00125):
                    try:
                        rows.append(one(case, dt, 28, Path(work), pressure))
                    except Exception as exc:  # a step above the bonds' limit is refused: said, not run
                        print(f"{case} dt={dt:g}: {exc}", flush=True)
                for discs in (56, 112):
                    rows.append(one(case, 0.00125, discs, Path(work), pressure))
        for case in ("head-on", "leaning front"):
            for pressure in (PRESSURE / 2, PRESSURE * 2):
                rows.append(one(case, 0.0025, 28, Path(work), pressure))
    with open(a.out / "impact_stress.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    draw(rows, a.out)


def draw(rows: list[dict], out: Path) -> None:
    """The blow (the largest tension over each run's first half, kPa at w = 70 m) against the
    step, per law, with the other disc counts and pressures as points."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, case in zip(axes, ("head-on", "leaning front"), strict=True):
        for law, colour in (("rigid", "tab:red"), ("crushing", "tab:blue")):
            mine = [r for r in rows if r["case"] == case and r["law"] == law and r["pressure"] in (0.0, PRESSURE)]
            rs = [r for r in mine if r["discs"] == 28]
            ax.plot([r["dt"] for r in rs], [blow(r) for r in rs], "o-", color=colour, label=f"{law}: discs = 28")
            for r, mk in zip([r for r in mine if r["discs"] != 28], "s^", strict=False):
                ax.plot(r["dt"], blow(r), mk, color=colour, mfc="none", label=f"{law}: discs = {r['discs']:g}")
        for r in rows:
            if r["case"] == case and r["law"] == "crushing" and r["pressure"] != PRESSURE:
                ax.plot(r["dt"], blow(r), "x", color="tab:blue", label=f"crushing, p_c x {r['pressure'] / PRESSURE:g}")
        ax.set_xscale("log")
        ax.set_ylim(bottom=0)
        ax.set(xlabel="dt (sqrt(w/g))", ylabel="the blow: peak bond tension (kPa at w = 70 m)", title=case)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3, which="both")
    fig.suptitle("the peak stress an impact puts into elastic bonds, rigid and crushing, against step and discs", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "impact_stress.png", dpi=120)


def blow(row: dict) -> float:
    """The largest tension over the run's first half, kPa at w = 70 m (the leaning front's
    first contact and what follows it; later, the slab's own motion loads the wall's bond)."""
    return row["first_half_peak"] * PA


if __name__ == "__main__":
    main()
