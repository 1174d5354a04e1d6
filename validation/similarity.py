"""The drag similarity law and the paper scene's end state, from ensembles at several linear
drags (``physics.drag = physics.angular_drag = c``) and the long paper ensemble.

    melange-ti ensemble runs/paper_long.toml --seeds 8 --out long --workers 2
    for c in 0.04 0.005; do melange-ti ensemble --seeds 4 --out sim_c$c --workers 2 \\
        --set physics.drag=$c --set physics.angular_drag=$c --set time.duration=8000 \\
        --set output.snapshot_interval=100 --set output.diagnostic_interval=5; done
    melange-ti ensemble --seeds 4 --out sim_c0.0025 --workers 2 --set physics.drag=0.0025 \\
        --set physics.angular_drag=0.0025 --set time.duration=14000 \\
        --set output.snapshot_interval=100 --set output.diagnostic_interval=5
    python validation/similarity.py long/*.h5 sim_c*/*.h5 --out validation/results

Writes ``similarity.png`` (the curves against t and against the scaled times),
``end_state.png`` (the long ensemble: capsize, front and kinetic energy to the end) and
``similarity.txt`` (misfits, fitted laws with bootstrap uncertainties, end-state numbers,
the energy budget's residual over the long runs).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from melange_ti.analysis import similarity as sim  # noqa: E402
from melange_ti.analysis import stats  # noqa: E402
from melange_ti.io.hdf5 import read_run  # noqa: E402

LATE = 20.0  # fits from t c >= 20 (t >= 2000 at the paper's drag): past the thrown leader's return


def load(paths):
    """drag -> list of diagnostics dicts (each run's own scene gives its drag)."""
    from melange_ti.scene import stored_scene

    runs: dict[float, list[dict]] = {}
    for p in paths:
        data = read_run(p)
        scene = stored_scene(p, data)
        if scene.physics.drag != scene.physics.angular_drag:
            sys.exit(f"{p}: drag {scene.physics.drag} != angular_drag {scene.physics.angular_drag}")
        runs.setdefault(float(scene.physics.drag), []).append(data["diagnostics"])
    return dict(sorted(runs.items()))


def curves(runs, name):
    out = []
    for c, group in runs.items():
        ens = stats.ensemble([(d["time"], d[name]) for d in group])
        out.append((c, ens))
    return out


def leading_edge_law(runs):
    """L = A (t / c)^beta, pooled over drags, t c >= LATE."""
    return sim.fit_power_law(*sim.pooled(runs, "leading_edge", "t / c", late=LATE))


def capsize_law(runs):
    """capsized fraction = a + b L over the late phase, before everything has capsized."""
    xs, ys = [], []
    for c, g in runs.items():
        for d in g:
            keep = (d["time"] * c >= LATE) & (d["capsized_fraction"] < 0.98)
            xs.append(d["leading_edge"][keep])
            ys.append(d["capsized_fraction"][keep])
    return sim.fit_line(np.concatenate(xs), np.concatenate(ys))


def end_state(group):
    """Per run: first time all have capsized, leading edge then and at the end, kinetic
    energy's decay rate after it (against 2 c for linear drag alone)."""
    rows = []
    for d in group:
        t, f = d["time"], d["capsized_fraction"]
        full = np.flatnonzero(f >= 1.0)
        t_all = float(t[full[0]]) if full.size else float("nan")
        row = {"t_end": float(t[-1]), "f_end": float(f[-1]), "t_all": t_all, "L_end": float(d["leading_edge"][-1])}
        if full.size:
            row["L_all"] = float(d["leading_edge"][full[0]])
            after = (t >= t_all + 200.0) & (t <= t_all + 2000.0) & (d["kinetic_energy"] > 0)
            if after.sum() > 10:
                slope = np.polyfit(t[after], np.log(d["kinetic_energy"][after]), 1)[0]
                row["ke_rate"] = float(-slope)
            late = t >= t_all + 1000.0
            if late.sum() > 2:
                row["front_speed_after"] = float(np.polyfit(t[late], d["leading_edge"][late], 1)[0])
        before = (t >= 0.5 * t[-1]) & (f < 1.0)
        if before.sum() > 2:
            row["front_speed_before"] = float(np.polyfit(t[before], d["leading_edge"][before], 1)[0])
        rows.append(row)
    return rows


def fig_similarity(runs, misfits, law_l, out):
    fig, axes = plt.subplots(2, 3, figsize=(15, 8.5), layout="constrained")
    colors = plt.cm.viridis(np.linspace(0, 0.85, len(runs)))
    for row, (name, ylabel) in enumerate((("capsized_fraction", "capsized fraction"), ("leading_edge", "leading edge (widths)"))):
        for (c, ens), col in zip(curves(runs, name), colors, strict=True):
            n = ens.runs
            for k, x in enumerate((ens.time, ens.time * c, ens.time / c)):
                ax = axes[row, k]
                ok = x > 0
                ax.plot(x[ok], ens.mean[ok], color=col, lw=1.3, label=f"c = {c:g} ({n} seeds)")
                ax.fill_between(x[ok], (ens.mean - ens.std)[ok], (ens.mean + ens.std)[ok], color=col, alpha=0.2, lw=0)
        for k, scaling in enumerate(("t", "t c", "t / c")):
            ax = axes[row, k]
            ax.set_xscale("log")
            if row == 1:
                ax.set_yscale("log")
            ax.set_xlabel(scaling)
            ax.set_ylabel(ylabel)
            ax.grid(alpha=0.3, which="both")
            if scaling != "t":
                ax.set_title(
                    f"against {scaling}: largest RMS difference from the longest run, t c >= {LATE:g}: "
                    f"{misfits[name][scaling]:.3g}",
                    fontsize=8,
                )
    a, beta = law_l
    x = np.geomspace(LATE / max(runs) ** 2, max(float(d["time"][-1]) / c for c, g in runs.items() for d in g), 50)
    axes[1, 2].plot(x, a * x**beta, "k--", lw=1, label=f"L = {a:.3f} (t/c)^{beta:.3f}")
    axes[0, 0].legend(fontsize=8)
    axes[1, 2].legend(fontsize=8)
    fig.suptitle("Paper scene at several linear drags c (drag = angular_drag = c): mean ± 1 SD over seeds", fontsize=10)
    fig.savefig(out / "similarity.png", dpi=110)
    plt.close(fig)


def residual_lines(group, drag, times=(300.0, 1000.0, 8000.0, 60000.0)):
    """The energy budget's residual (and what it was without the impulses' offset term, and
    the correction work) as shares of the released energy, mean ± SD over the runs."""
    lines = []
    for t_at in times:
        vals = []
        for d in group:
            t = d["time"]
            if t[-1] < t_at:
                continue
            b = stats.energy_budget(d)
            i = int(np.searchsorted(t, t_at))
            rel = b["released"][i]
            res = b["residual"][: i + 1]
            vals.append(
                (res[-1] / rel, np.abs(res).max() / rel, (res[-1] + b["impulse_offset"][i]) / rel, b["correction"][i] / rel)
            )
        if not vals:
            continue
        v = np.array(vals)
        m, sd = v.mean(axis=0), v.std(axis=0, ddof=1) if len(v) > 1 else np.zeros(4)
        lines.append(
            f"drag {drag:g}, t = {t_at:g} ({len(v)} runs): residual {m[0]:+.4%} ± {sd[0]:.4%}, largest |residual| up to t "
            f"{v[:, 1].max():.4%}, without the offset term {m[2]:+.3%} ± {sd[2]:.3%}, correction work {m[3]:+.2%} ± {sd[3]:.2%}"
        )
    return lines


def smooth(t, y, window):
    """Moving average of ``y`` over ``window`` time units (uniform sampling assumed)."""
    k = max(1, int(round(window / (t[1] - t[0])))) if len(t) > 1 else 1
    return np.convolve(y, np.ones(k) / k, mode="same")


def fig_end_state(groups, out):
    """Capsized fraction, leading edge and kinetic energy (moving average over 500 time
    units) of each run, one column per drag."""
    fig, axes = plt.subplots(3, len(groups), figsize=(7 * len(groups), 9), squeeze=False, layout="constrained")
    for col, (drag, group) in enumerate(groups.items()):
        for d in group:
            t = d["time"]
            axes[0, col].plot(t, d["capsized_fraction"], lw=0.8)
            axes[1, col].plot(t, d["leading_edge"], lw=0.8)
            ke = smooth(t, d["kinetic_energy"], 500.0)
            axes[2, col].semilogy(t, np.where(ke > 0, ke, np.nan), lw=0.8)
        axes[0, col].set_title(f"drag = angular_drag = {drag:g}: {len(group)} seeds", fontsize=10)
        axes[0, col].set_ylabel("capsized fraction")
        axes[1, col].set_ylabel("leading edge (widths)")
        axes[2, col].set_ylabel("kinetic energy, 500-unit mean (ρ_w g w³)")
        axes[2, col].set_xlabel("t (sqrt(w/g); 1 = 2.67 s at w = 70 m)")
        for ax in axes[:, col]:
            ax.grid(alpha=0.3)
    fig.suptitle("The paper scene run on towards its end state", fontsize=10)
    fig.savefig(out / "end_state.png", dpi=110)
    plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--end-drags", default="0.01,0.001", help="drags whose runs show the end state")
    a = p.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    runs = load(a.runs)
    described = [f"{c:g} ({len(g)} runs, t <= {min(d['time'][-1] for d in g):g})" for c, g in runs.items()]
    lines = ["drags: " + ", ".join(described)]
    misfits = {}
    reference = max(runs, key=lambda c: max(d["time"][-1] for d in runs[c]))  # the longest: the reference
    for name in ("capsized_fraction", "leading_edge"):
        cs = [sim.Curve(c, ens.time, ens.mean) for c, ens in curves(runs, name)]
        ref = next(c for c in cs if c.drag == reference)
        misfits[name] = {}
        for scaling in sim.SCALINGS:
            m, (lo, hi) = sim.collapse_misfit(cs, scaling)
            late = sim.misfit_to_reference(cs, ref, scaling, late=LATE)
            worst = max((v for v in late.values() if np.isfinite(v)), default=float("nan"))
            misfits[name][scaling] = worst
            lines.append(
                f"{name} against {scaling}: spread over all times {m:.4g} ({lo:.4g} .. {hi:.4g}); from t c >= {LATE:g}, "
                f"RMS difference from c = {reference:g}: " + ", ".join(f"c = {c:g}: {v:.4g}" for c, v in late.items())
            )
    law_l, sd_l = sim.bootstrap(runs, leading_edge_law)
    law_f, sd_f = sim.bootstrap(runs, capsize_law)
    lines.append(
        f"leading edge L = A (t/c)^beta, t c >= {LATE:g}: "
        f"A = {law_l[0]:.4f} ± {sd_l[0]:.4f}, beta = {law_l[1]:.4f} ± {sd_l[1]:.4f}"
    )
    lines.append(
        f"capsized fraction = a + b L (late, < 0.98): a = {law_f[0]:.4f} ± {sd_f[0]:.4f}, b = {law_f[1]:.5f} ± {sd_f[1]:.5f}"
    )
    l_full = (1.0 - law_f[0]) / law_f[1]
    lines.append(f"all capsized at L = {l_full:.1f}, t / c = {(l_full / law_l[0]) ** (1 / law_l[1]):.4g} (from the fits)")
    fig_similarity(runs, misfits, law_l, a.out)
    ends = {c: runs[c] for c in (float(v) for v in a.end_drags.split(",")) if c in runs}
    for c, group in ends.items():
        rows = end_state(group)
        for k, r in enumerate(rows):
            lines.append(f"drag {c:g} run {k + 1}: " + ", ".join(f"{key} {v:.4g}" for key, v in r.items()))
        for key in ("t_all", "L_all", "L_end", "f_end", "ke_rate", "front_speed_before", "front_speed_after"):
            v = np.array([r.get(key, np.nan) for r in rows])
            ok = np.isfinite(v)
            if ok.any():
                sd = v[ok].std(ddof=1) if ok.sum() > 1 else 0.0
                lines.append(f"drag {c:g} ensemble {key}: mean {v[ok].mean():.4g} ± {sd:.3g} ({ok.sum()} runs)")
        lines.append(f"drag {c:g}: kinetic energy decay rate of linear drag alone, 2 c = {2 * c:g}")
        lines += residual_lines(group, c)
    if ends:
        fig_end_state(ends, a.out)
    text = "\n".join(lines)
    (a.out / "similarity.txt").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
