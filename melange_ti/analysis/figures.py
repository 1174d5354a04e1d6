"""``melange-ti plot``: the paper's figures and the energy budget from run files (PNG + PDF).

Runs are grouped by the scene keys whose values differ between them (``contacts.discs``,
``shelf.thickness_std``, ...; the seed, the duration and the output schedule never make a
group, see :data:`melange_ti.analysis.stats.NON_PARAMETER_KEYS`). Each group is one curve:
the ensemble mean with a band (or error bars) of one standard deviation over its runs, on
the time grid of the group's run that ends first. A curve's label names the group's value of
every key that differs between the runs (a key only some runs have, such as an effect's
``physics.form_drag``, included; :func:`melange_ti.analysis.runs.make_groups`); a single
run's label names its scene and every value it changed from the defaults (the bundled paper
scene): ``paper, shelf.count = 10``.

Axes are non-dimensional (widths ``w``, time ``sqrt(w/g)``, energy ``rho_w g w^3`` and force
``rho_w g w^2`` per unit length of ice front) with a second axis in physical units for an
iceberg ``--width-m`` metres wide (time unit ``sqrt(width_m / 9.81)`` s, ``rho_w = 1025``).

Files written to ``--out`` (each figure as PNG and PDF):

- ``fig2_snapshots``: icebergs with their discs near the leading edge at chosen times, one
  column per group (its first run; every group is drawn)
- ``fig3_capsized_fraction``: fraction capsized (``phi >= pi/4``) vs time: the bodies counted
  (``capsized_fraction``); with the ``bonds`` effect also, dashed and labelled "by area of the
  pieces of ice", the capsized pieces' share of the ice's area at the snapshots' times
  (:func:`melange_ti.analysis.fragments.capsized_area_fraction`), so a rolled piece of many
  cells counts by its area while the body count keeps its meaning
- ``fig4_leading_edge``: leading edge vs time
- ``fig5_capsized_by_position``: fraction capsized in bins of 10 widths, at several times
- ``energy_budget``: released, kinetic, dissipated (drag, collisions, corrections), residual
- ``impulse_rate_wall_force``: collision impulse rate (a seismic proxy) and force on the wall
- ``capsized_fraction_by_thickness_std``: Fig. 3 grouped by ``shelf.thickness_std`` (only when
  the runs have several spreads)
- ``fragments``: with the ``bonds`` effect, the sizes of the pieces of ice (bodies held
  together by intact bonds) at the end, as the complementary CDF on log-log axes with the
  exponent fitted per run and the 2-D fragmentation reference 3/2 (only when some run has
  bonds); ``fragments.csv``: per run, its pieces and exponent. A piece's size is its number
  of icebergs (a discrete law on 1..N, :func:`fit_power_law`) when every bonded run's bodies
  are whole icebergs; when some run's bodies are cells (``cells = [nx, nz]``), whose number
  says nothing of a piece's size across icebergs cut differently, every run's pieces are
  measured by their area in w^2 (the fragment table's ``area``; a continuous law from the
  run's smallest body to its whole ice, :func:`fit_power_law_area`), area and not width
  (``length``) because the 2-D fragmentation exponent is one of mass, and the icebergs
  counted of equal blocks are their area in block areas. ``fragments.csv`` then has the
  columns :data:`AREA_COLUMNS` (``bodies``, ``area``, ``largest_area`` in place of
  ``icebergs`` and ``largest``)
- ``summary.csv``: per group, runs, times of 50% / 90% capsized, final leading edge, energy
"""

from __future__ import annotations

import csv
import math
import textwrap
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from itertools import takewhile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402

from ..diagnostics import ENERGY_LEDGERS  # noqa: E402
from ..energy import budget_series, budget_verdict  # noqa: E402
from ..errors import RunError  # noqa: E402
from ..geometry import body_outlines, world_outlines  # noqa: E402
from ..io.hdf5 import OutputError, is_partial, read_diagnostics, read_run  # noqa: E402
from ..scene import SceneError, stored_scene  # noqa: E402
from . import stats  # noqa: E402
from .fragments import body_moments, capsized_area_fraction, celled, check_labels  # noqa: E402
from .render import BOND, BondFaces, IcebergArtist, draw_sea, phi_colorbar, wave_surface  # noqa: E402
from .runs import Group, Run, check_times, default_times, last_snapshot_time, load_run, make_groups, parse_times, snap_times

G_SI = 9.81  # m s^-2
RHO_WATER_SI = 1025.0  # kg m^-3, docs/model.md
BIN_WIDTH = 10.0  # widths, paper Fig. 5
SNAPSHOT_SPAN = 30.0  # widths behind the leading edge shown in Fig. 2
DPI = 150
LABEL_WIDTH = 70  # characters a line of a group's label in a legend or panel title


# ---------------------------------------------------------------------------------------
# Units


@dataclass(frozen=True)
class Units:
    """Physical scales for an iceberg ``width_m`` metres wide (docs/model.md)."""

    width_m: float = 70.0
    rho_water: float = RHO_WATER_SI

    @property
    def time_s(self) -> float:
        """One time unit ``sqrt(w/g)`` in seconds (2.67 s for 70 m)."""
        return math.sqrt(self.width_m / G_SI)

    @property
    def energy_j_per_m(self) -> float:
        """One energy unit ``rho_w g w^3`` in J per metre of ice front."""
        return self.rho_water * G_SI * self.width_m**3

    @property
    def force_n_per_m(self) -> float:
        """One force unit ``rho_w g w^2`` in N per metre of ice front."""
        return self.rho_water * G_SI * self.width_m**2


def _time_scale(units: Units, tmax: float) -> tuple[float, str]:
    seconds = tmax * units.time_s
    if seconds >= 2 * 3600:
        return units.time_s / 3600.0, "h"
    if seconds >= 120:
        return units.time_s / 60.0, "min"
    return units.time_s, "s"


def _length_scale(units: Units, lmax: float) -> tuple[float, str]:
    return (units.width_m / 1000.0, "km") if abs(lmax) * units.width_m >= 2000 else (units.width_m, "m")


def _si_scale(value: float, unit: str) -> tuple[float, str]:
    """A prefix for ``value`` in ``unit``: returns (factor to multiply by, prefixed unit)."""
    for factor, prefix in ((1e-12, "T"), (1e-9, "G"), (1e-6, "M"), (1e-3, "k")):
        if abs(value) * factor >= 1.0:
            return factor, prefix + unit
    return 1.0, unit


def _secondary(ax, axis: str, factor: float, label: str):
    f = (lambda v, k=factor: v * k, lambda v, k=factor: v / k)
    sec = ax.secondary_xaxis("top", functions=f) if axis == "x" else ax.secondary_yaxis("right", functions=f)
    sec.set_xlabel(label) if axis == "x" else sec.set_ylabel(label)
    return sec


def time_axes(ax, units: Units, tmax: float, top: bool = True) -> None:
    ax.set_xlabel("time t (√(w/g))")
    if top:
        k, u = _time_scale(units, tmax)
        _secondary(ax, "x", k, f"time ({u}) for w = {units.width_m:g} m")


def length_axis(ax, axis: str, units: Units, lmax: float, what: str) -> None:
    k, u = _length_scale(units, lmax)
    _secondary(ax, axis, k, f"{what} ({u})")


# ---------------------------------------------------------------------------------------
# Figures


def _colors(n: int) -> list:
    cmap = plt.get_cmap("tab10")
    return [cmap(i % 10) for i in range(n)]


def _band(ax, ens: stats.Ensemble, color, label: str, **kw) -> None:
    ax.plot(ens.time, ens.mean, color=color, label=label, lw=1.4, **kw)
    if ens.runs > 1:
        ax.fill_between(ens.time, ens.mean - ens.std, ens.mean + ens.std, color=color, alpha=0.22, lw=0)


def _label(group: Group, what: str = "") -> str:
    """The group's label with its run count (and ``what``, the line's measure), wrapped: a run
    that changed many keys (a bonded shelf's) had a legend wider than the figure, which
    collapsed the axes."""
    n = len(group.runs)
    return textwrap.fill(f"{group.label} ({n} run{'s' if n != 1 else ''}){what}", LABEL_WIDTH)


def _tmax(groups: Sequence[Group]) -> float:
    return max(float(g.series("capsized_fraction").time[-1]) for g in groups)


BY_BODIES = ": bodies counted"  # the body count's line, where a group has the line by area too
BY_AREA = ": by area of the pieces of ice"  # the capsized pieces' share of the ice's area (dashed)


def capsized_area_series(run: Run) -> stats.Series:
    """``(t, fraction)`` at the run's snapshots: the capsized pieces' share of the ice's area
    (:func:`melange_ti.analysis.fragments.capsized_area_fraction` of its fragment table)."""
    frac = capsized_area_fraction(run.fragment_table())
    return frac.index.to_numpy(dtype=float), frac.to_numpy(dtype=float)


def capsized_area(group: Group) -> stats.Ensemble | None:
    """The group's capsized fraction by area (mean and s.d. over its runs, on the snapshots'
    times of the run that ends first); ``None`` unless every run has fragments (bonds)."""
    if not all(has_fragments(r) for r in group.runs):
        return None
    return stats.ensemble([capsized_area_series(r) for r in group.runs])


def fig_capsized_fraction(groups: Sequence[Group], units: Units, title: str | None = None):
    """Paper Fig. 3: the fraction capsized vs time, mean and one standard deviation. For a
    group with fragments (the bonds effect) a dashed line beside it: the capsized pieces'
    share of the ice's area, so a rolled piece of many cells counts by its area; the solid
    line stays the body count (``capsized_fraction``) and is labelled so."""
    fig, ax = plt.subplots(figsize=(7.0, 4.6), layout="constrained")
    areas = [capsized_area(g) for g in groups]
    for g, color, area in zip(groups, _colors(len(groups)), areas, strict=True):
        ens = g.series("capsized_fraction")
        _band(ax, ens, color, _label(g, BY_BODIES if area is not None else ""))
        for level, t in stats.capsize_times(ens.time, ens.mean).items():
            if math.isfinite(t):
                ax.plot([t], [level], marker="o", ms=4, color=color)
        if area is not None:
            _band(ax, area, color, _label(g, BY_AREA), ls="--")
    ax.set_ylabel("fraction capsized (φ ≥ 45°)")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    time_axes(ax, units, _tmax(groups))
    ax.legend(fontsize=8, loc="lower right")
    pieces = any(a is not None for a in areas)
    title = title or "Capsized fraction (mean ± 1 s.d.; dots: 50% and 90%)"
    if pieces:
        title += "\nsolid: the bodies counted; dashed: the capsized pieces of ice (bodies held by intact bonds) by area"
    ax.set_title(title, fontsize=9 if pieces else 10)
    return fig


def fig_leading_edge(groups: Sequence[Group], units: Units):
    """Paper Fig. 4: the leading edge ``max x(t) - max x(0)`` vs time."""
    fig, ax = plt.subplots(figsize=(7.0, 4.6), layout="constrained")
    lmax = 0.0
    for g, color in zip(groups, _colors(len(groups)), strict=True):
        ens = g.series("leading_edge")
        _band(ax, ens, color, _label(g))
        lmax = max(lmax, float(np.nanmax(np.abs(ens.mean))))
    ax.set_ylabel("leading edge (widths)")
    ax.grid(alpha=0.3)
    time_axes(ax, units, _tmax(groups))
    length_axis(ax, "y", units, lmax, f"leading edge for w = {units.width_m:g} m")
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title("Leading edge of the mélange (mean ± 1 s.d.)", fontsize=10)
    return fig


def position_edges(runs: Sequence[Run], times: Sequence[float], bin_width: float = BIN_WIDTH) -> np.ndarray:
    """Bins shared by all runs and times: from the wall (or the leftmost iceberg) on."""
    lo, hi = math.inf, -math.inf
    for r in runs:
        for t in times:
            x = r.snaps["x"][stats.nearest_index(r.snaps["time"], t)]
            lo, hi = min(lo, float(np.min(x))), max(hi, float(np.max(x)))
    start = runs[0].scene.physics.wall_x
    if lo < start:
        start -= bin_width * math.ceil((start - lo) / bin_width)
    return stats.position_edges(start, hi, bin_width)


def fig_capsized_by_position(groups: Sequence[Group], units: Units, times: Sequence[float], bin_width: float = BIN_WIDTH):
    """Paper Fig. 5: fraction capsized in bins of ``bin_width`` widths, one curve per time."""
    all_runs = [r for g in groups for r in g.runs]
    edges = position_edges(all_runs, times, bin_width)
    centres = 0.5 * (edges[1:] + edges[:-1])
    n = len(groups)
    fig, axes = plt.subplots(n, 1, figsize=(7.5, 2.2 + 2.4 * n), layout="constrained", squeeze=False, sharex=True)
    cmap = plt.get_cmap("viridis")
    for row, g in enumerate(groups):
        ax = axes[row, 0]
        snaps = [r.snaps for r in g.runs]
        for j, t in enumerate(times):
            axes_ = [r.data["icebergs"].get("axis") for r in g.runs]  # polygons: their principal axes
            mean, std, count = stats.capsized_by_position_ensemble(snaps, t, edges, axes=axes_)
            ok = count > 0
            color = cmap(j / max(len(times) - 1, 1))
            t_snap = float(g.runs[0].snaps["time"][stats.nearest_index(g.runs[0].snaps["time"], t)])
            ax.errorbar(
                centres[ok],
                mean[ok],
                yerr=std[ok] if len(g.runs) > 1 else None,
                color=color,
                marker="o",
                ms=3,
                lw=1.2,
                capsize=2,
                label=f"t = {t_snap:g}",
            )
        ax.set_ylim(-0.03, 1.03)
        ax.set_ylabel("fraction capsized")
        ax.grid(alpha=0.3)
        ax.set_title(f"{_label(g)}; bins of {bin_width:g} widths", fontsize=9, loc="left")
        ax.legend(fontsize=7, loc="best", ncol=2)
        if row == 0:
            length_axis(ax, "x", units, float(edges[-1]), f"position for w = {units.width_m:g} m")
    axes[-1, 0].set_xlabel("position x (widths)")
    axes[-1, 0].set_xlim(edges[0], edges[-1])
    fig.suptitle("Capsized fraction by position (mean ± 1 s.d. over runs)", fontsize=10)
    return fig


def fig_snapshots(groups: Sequence[Group], units: Units, times: Sequence[float], span: float = SNAPSHOT_SPAN):
    """Paper Fig. 2: icebergs and their discs near the leading edge at ``times``, one column
    per group (its first run): every group, the columns narrower from the fourth on."""
    shown = list(groups)
    windows = []
    zlo, zhi = math.inf, -math.inf
    for g in shown:
        r = g.runs[0]
        body = body_outlines(r.data["icebergs"])
        col = []
        for t in times:
            k = stats.nearest_index(r.snaps["time"], t)
            x, z, th = r.snaps["x"][k], r.snaps["z"][k], r.snaps["theta"][k]
            corners = world_outlines(x, z, th, body)
            front = float(corners[:, :, 0].max())
            left = max(front - span, float(corners[:, :, 0].min()))
            sel = corners[:, :, 0].max(axis=1) >= left - 1.0
            zlo, zhi = min(zlo, float(corners[sel, :, 1].min())), max(zhi, float(corners[sel, :, 1].max()))
            col.append((k, sel, left - 0.5, front + 1.0))
        windows.append(col)
    nrow, ncol = len(times), len(shown)
    width_w = max(c[3] - c[2] for col in windows for c in col)
    zlo, zhi = min(zlo, 0.0) - 0.4, max(zhi, 0.0) + 0.4
    panel_w = 10.0 if ncol == 1 else min(6.0, max(18.0 / ncol, 3.5))  # 6 in up to three groups
    panel_h = max(1.3, panel_w * (zhi - zlo) / width_w)  # room for the y label "z (widths)"
    fig, axes = plt.subplots(
        nrow, ncol, figsize=(panel_w * ncol + 1.0, panel_h * nrow + 1.4), squeeze=False, layout="constrained"
    )
    mappable = None
    bonded = discs_drawn = False
    for c, (g, col) in enumerate(zip(shown, windows, strict=True)):
        r = g.runs[0]
        w, h = r.data["icebergs"]["width"], r.data["icebergs"]["thickness"]
        polygons = "corner_u" in r.data["icebergs"]
        body, axis = body_outlines(r.data["icebergs"]), r.data["icebergs"].get("axis")
        faces = BondFaces.read(r.path, r.data)
        for row, (k, sel, _, x1) in enumerate(col):
            ax = axes[row, c]
            draw_sea(ax, r.scene, (zlo, zhi), wave_surface(r.data, k))
            art = IcebergArtist(
                ax,
                w[sel],
                h[sel],
                discs=r.scene.contacts.discs,
                outline=body[sel] if polygons else None,
                axis=np.asarray(axis)[sel] if polygons else None,
            )
            art.update(r.snaps["x"][k][sel], r.snaps["z"][k][sel], r.snaps["theta"][k][sel])
            mappable = art.rects
            discs_drawn |= art.circles is not None  # a polygon's are not drawn
            if faces is not None:  # the bonds effect: the bonds intact then, on the faces they glue
                x, z, th = r.snaps["x"][k], r.snaps["z"][k], r.snaps["theta"][k]
                segments = faces.segments(x, z, th, float(r.snaps["time"][k]), keep=sel)
                ax.add_collection(LineCollection(segments, colors=BOND, linewidths=1.2, zorder=5.5))
                bonded = True
            ax.set_xlim(x1 - width_w, x1)
            ax.set_ylim(zlo, zhi)
            ax.set_aspect("equal")
            ax.text(0.01, 0.95, f"t = {float(r.snaps['time'][k]):g}", transform=ax.transAxes, va="top", fontsize=8)
            ax.set_ylabel("z (widths)", fontsize=8)
            ax.tick_params(labelsize=7)
            if row == 0:
                title = f"{g.label}, seed {r.seed}" + ("" if polygons else f" ({r.scene.contacts.discs} discs)")
                ax.set_title(textwrap.fill(title, int(13 * panel_w)), fontsize=9)  # ~13 characters an inch
                length_axis(ax, "x", units, x1, f"x for w = {units.width_m:g} m")
            if row == nrow - 1:
                ax.set_xlabel("x (widths)")
    phi_colorbar(fig, mappable, axes.ravel().tolist(), shrink=0.8, fraction=0.04)
    bonds = "; cyan: the bonds intact at that time" if bonded else ""
    discs = ", with their collision discs" if discs_drawn else ""
    fig.suptitle(f"The leading edge of the mélange (icebergs coloured by capsize angle{discs}{bonds})", fontsize=10)
    return fig


ENERGY_STYLE = {
    "released": ("potential energy released", "k", "-", 2.0),
    "kinetic": ("kinetic energy gained", "tab:orange", "-", 1.2),
    "drag": ("drag dissipated", "tab:blue", "-", 1.2),
    "collision": ("collision dissipated", "tab:red", "-", 1.2),
    "correction": ("overlap-correction work", "tab:purple", "-", 1.2),
    "impulse_offset": ("impulses' half-kick offset", "tab:green", ":", 1.2),
    "added_mass": ("added-mass exchange", "tab:brown", "-", 1.2),
    "friction": ("friction dissipated", "tab:cyan", "-", 1.2),
    "waves": ("wave energy gained", "tab:olive", "-", 1.2),
    "wave_absorbed": ("wave energy absorbed at the open end", "tab:gray", "-", 1.2),
    "bonds": ("bonds' elastic energy gained", "gold", "-", 1.2),
    "bond_damping": ("bond dashpots dissipated", "tab:pink", "-", 1.2),
    "fracture_released": ("elastic energy of broken bonds", "darkgoldenrod", "--", 1.2),
    "bond_offset": ("bonds' half-step offset", "khaki", ":", 1.2),
    "bond_correction": ("overlap-correction work on bonds", "tab:brown", ":", 1.2),
    "residual": ("residual: energy lost but not booked (the time integrator's error)", "0.4", "--", 1.2),
}


def energy_terms(group: Group) -> tuple[np.ndarray, dict[str, stats.Ensemble]]:
    """Ensemble (mean, std) of each term of :func:`stats.energy_budget` for one group."""
    budgets = [(r.diag["time"], stats.energy_budget(r.diag)) for r in group.runs]
    grid = stats.common_grid([t for t, _ in budgets])
    out = {name: stats.ensemble([(t, b[name]) for t, b in budgets], grid=grid) for name in (*stats.ENERGY_TERMS, "total_loss")}
    return grid, out


def run_verdict(diagnostics, dt: float | None = None, precision: str = "f64") -> str | None:
    """:func:`melange_ti.energy.budget_verdict` of one run's diagnostics table."""
    b = budget_series(diagnostics)
    energy = float(np.nanmax(np.abs(b["energy"]), initial=0.0))
    return budget_verdict(b["residual"], b["released"], b["dissipated"], b["time"], dt=dt, energy=energy, precision=precision)


def fig_energy_budget(groups: Sequence[Group], units: Units):
    """Energy budget over time: potential released = kinetic + dissipated + residual."""
    n = len(groups)
    ncol = min(n, 2)
    nrow = math.ceil(n / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(7.0 * ncol, 4.4 * nrow), squeeze=False, layout="constrained")
    for i, g in enumerate(groups):
        ax = axes[i // ncol, i % ncol]
        grid, terms = energy_terms(g)
        for name in stats.ENERGY_TERMS:
            if (name in stats.LEDGER_TERMS or name in stats.HELD_TERMS) and not np.any(terms[name].mean):
                continue  # a ledger that booked nothing (an effect the runs do not name)
            # a ledger added later (an effect's) is drawn with a default style
            label, color, ls, lw = ENERGY_STYLE.get(name, (f"{name} dissipated", None, "-", 1.2))
            if name == "released":
                _band(ax, terms[name], color, label, ls=ls)
            else:
                ax.plot(grid, terms[name].mean, color=color, ls=ls, lw=lw, label=label)
        rel = terms["released"].mean[-1]
        res = terms["residual"].mean[-1]
        ratio = f" ({res / rel:.2%} of released)" if rel else ""
        title = f"{_label(g)}\nresidual at t = {grid[-1]:g}: {res:.3g}{ratio}"
        failing = [r for r in g.runs if run_verdict(r.diag, precision=r.scene.precision)]  # each run, not the mean
        if failing:  # plainly, on the figure
            title += f"\nTHE BUDGET DOES NOT CLOSE in {len(failing)} of {len(g.runs)} run(s) (time step too long?)"
        ax.set_title(title, fontsize=9, color="tab:red" if failing else "black")
        ax.set_ylabel("energy (ρ_w g w³ per unit length)")
        ax.grid(alpha=0.3)
        time_axes(ax, units, float(grid[-1]))
        emax = float(np.nanmax(np.abs(terms["released"].mean))) * units.energy_j_per_m
        k, u = _si_scale(emax, "J/m")
        _secondary(ax, "y", units.energy_j_per_m * k, f"energy ({u}) for w = {units.width_m:g} m")
        ax.legend(fontsize=7, loc="upper left")
    for j in range(n, nrow * ncol):
        axes[j // ncol, j % ncol].set_visible(False)
    fig.suptitle("Energy budget (mean over runs; band: ±1 s.d. of the released energy)", fontsize=10)
    return fig


def fig_impulse_wall(groups: Sequence[Group], units: Units):
    """Collision impulse rate (a seismic proxy) and the force on the wall vs time."""
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 7.0), layout="constrained", sharex=True)
    panels = (
        ("impulse_rate", "collision impulse rate (ρ_w g w²)", "impulse rate"),
        ("wall_force", "force on the wall (ρ_w g w²)", "wall force"),
    )
    for ax, (name, ylabel, short) in zip(axes, panels, strict=True):
        fmax = 0.0
        for g, color in zip(groups, _colors(len(groups)), strict=True):
            ens = g.series(name)
            _band(ax, ens, color, _label(g))
            fmax = max(fmax, float(np.nanmax(np.abs(ens.mean))) if ens.mean.size else 0.0)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        k, u = _si_scale(max(fmax, 1e-300) * units.force_n_per_m, "N/m")
        _secondary(ax, "y", units.force_n_per_m * k, f"{short} ({u})")
        ax.legend(fontsize=7, loc="upper right")
    time_axes(axes[0], units, _tmax(groups), top=True)
    axes[0].set_xlabel("")
    time_axes(axes[1], units, _tmax(groups), top=False)
    fig.suptitle("Collision impulse rate and force on the wall (per unit length of ice front; mean ± 1 s.d.)", fontsize=10)
    return fig


# ---------------------------------------------------------------------------------------
# Fragments (the bonds effect)

# 2-D fragmentation: the number of pieces of size s falls as s^-3/2 (Astrom et al. 2004,
# Phys. Rev. E 70, 026606); a reference drawn and reported, never fitted to
FRAGMENTATION_TAU = 1.5


def fragment_sizes(labels) -> np.ndarray:
    """The size of each piece of ice (number of icebergs) in one snapshot's fragment labels
    (``snapshots/fragment``: any label shared by the icebergs of a piece), ascending."""
    _, counts = np.unique(np.asarray(labels), return_counts=True)
    return np.sort(counts)


def ccdf(sizes) -> tuple[np.ndarray, np.ndarray]:
    """``(s, P)``: each distinct size ``s`` (ascending) and the fraction of pieces at least
    that large, ``P(S >= s)`` (1 at the smallest)."""
    sizes = np.sort(np.asarray(sizes))
    s, first = np.unique(sizes, return_index=True)
    return s, 1.0 - first / len(sizes)


@dataclass(frozen=True)
class PowerLaw:
    """A power law ``n(s) ~ s^-tau`` for ``s_min <= s <= s_max`` fitted to ``n`` sizes:
    discrete (on the integers; icebergs counted) or ``continuous`` (areas); ``error``: the
    fit's standard error ``1 / sqrt(n Var(ln s))`` (Fisher)."""

    tau: float
    error: float
    n: int
    s_min: float
    s_max: float
    continuous: bool = False

    def ccdf(self, s) -> np.ndarray:
        """The model's ``P(S >= s)`` at sizes ``s``."""
        if self.continuous:
            span = math.log(self.s_max / self.s_min)
            y = np.clip(np.log(np.asarray(s, dtype=float) / self.s_min), 0.0, span)
            return _log_tail(self.tau - 1.0, y, span)
        support = np.arange(self.s_min, self.s_max + 1)
        p = _weights(self.tau, np.log(support))
        tail = np.cumsum(p[::-1])[::-1]
        return tail[np.clip(np.asarray(s, dtype=int) - self.s_min, 0, len(support) - 1)]


def _weights(tau: float, log_s: np.ndarray) -> np.ndarray:
    """``s^-tau`` normalised over the support ``exp(log_s)`` (in logs: no overflow)."""
    x = -tau * log_s
    w = np.exp(x - x.max())
    return w / w.sum()


def _log_tail(lam: float, y: np.ndarray, span: float) -> np.ndarray:
    """``P(Y >= y)`` for ``Y = ln(s / s_min)`` of the continuous law (density ``~ exp(-lam y)``
    on ``[0, span]``, ``lam = tau - 1``), without overflow at either sign of ``lam``."""
    if abs(lam * span) < 1e-9:
        return (span - y) / span
    if lam > 0:
        return np.exp(-lam * y) * -np.expm1(-lam * (span - y)) / -np.expm1(-lam * span)
    return np.expm1(lam * (span - y)) / np.expm1(lam * span)


def _log_moments(u: float) -> tuple[float, float]:
    """Mean and variance of ``Y / span`` for the law of :func:`_log_tail` with ``u = lam span``:
    a truncated exponential on [0, 1] (series near ``u = 0``, where the closed forms cancel)."""
    if abs(u) < 1e-3:
        return 0.5 - u / 12.0, 1.0 / 12.0 - u * u / 720.0
    if u > 0:
        e = math.exp(-u)
        return 1.0 / u - e / -math.expm1(-u), 1.0 / u**2 - e / math.expm1(-u) ** 2
    e = math.exp(u)
    return 1.0 / u - 1.0 / math.expm1(u), 1.0 / u**2 - e / math.expm1(u) ** 2


def fit_power_law(sizes, s_max: int, s_min: int = 1) -> PowerLaw:
    """Maximum likelihood exponent ``tau`` of a discrete power law ``p(s) ~ s^-tau`` on the
    integers ``s_min .. s_max`` (truncated: a run of N icebergs has no piece larger than N)
    from the sizes at least ``s_min``. The likelihood is concave in ``tau``; its maximum is
    where the model's mean of ``ln s`` equals the sample's, found by bisection. ``tau`` is
    NaN where no power law is defined: fewer than two pieces, or all of one size at an end
    of the range (every piece one iceberg: tau -> infinity)."""
    sizes = np.asarray(sizes)
    s_max = int(s_max)
    sizes = sizes[sizes >= s_min]
    if np.any(sizes > s_max):
        raise ValueError(f"a piece of {int(sizes.max())} icebergs is larger than s_max = {s_max}")
    n = len(sizes)
    nan = PowerLaw(math.nan, math.nan, n, s_min, s_max)
    log_s = np.log(np.arange(s_min, s_max + 1, dtype=float))
    target = float(np.mean(np.log(sizes))) if n else math.nan
    lo, hi = -30.0, 60.0  # the model's mean of ln s falls with tau from ~ln s_max to ~ln s_min

    def mean_log(tau: float) -> float:
        return float(_weights(tau, log_s) @ log_s)

    if n < 2 or s_max <= s_min or not mean_log(hi) < target < mean_log(lo):
        return nan
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mean_log(mid) > target else (lo, mid)
        if hi - lo < 1e-12:
            break
    tau = 0.5 * (lo + hi)
    p = _weights(tau, log_s)
    var = float(p @ log_s**2 - (p @ log_s) ** 2)
    return PowerLaw(tau, 1.0 / math.sqrt(n * var) if var > 0 else math.nan, n, s_min, s_max)


def fit_power_law_area(sizes, s_min: float, s_max: float) -> PowerLaw:
    """Maximum likelihood exponent ``tau`` of a continuous power law ``p(s) ~ s^-tau`` on
    ``[s_min, s_max]`` (areas: ``s_min`` the run's smallest body, ``s_max`` its ice) from the
    sizes in that range. As for :func:`fit_power_law` the maximum is where the model's mean
    of ``ln s`` equals the sample's (``ln s`` is then a truncated exponential: its mean falls
    with ``tau``), found by bisection; NaN where no power law is defined: fewer than two
    pieces, or all at an end of the range (every piece a smallest body: tau -> infinity)."""
    sizes = np.asarray(sizes, dtype=float)
    sizes = sizes[(sizes >= s_min * (1 - 1e-9)) & (sizes <= s_max * (1 + 1e-9))]
    n = len(sizes)
    nan = PowerLaw(math.nan, math.nan, n, s_min, s_max, continuous=True)
    span = math.log(s_max / s_min) if s_min > 0 and s_max > s_min else 0.0
    if n < 2 or span <= 0:
        return nan
    target = float(np.mean(np.clip(np.log(sizes / s_min), 0.0, span))) / span
    lo, hi = -1e6, 1e6  # u = (tau - 1) ln(s_max / s_min): the mean of ln(s / s_min) / span falls from 1 to 0
    if not _log_moments(hi)[0] < target < _log_moments(lo)[0]:
        return nan
    for _ in range(400):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _log_moments(mid)[0] > target else (lo, mid)
        if hi - lo < 1e-12 * max(1.0, abs(mid)):
            break
    u = 0.5 * (lo + hi)
    var = _log_moments(u)[1] * span**2  # Var(ln s), the Fisher information per piece
    return PowerLaw(1.0 + u / span, 1.0 / math.sqrt(n * var) if var > 0 else math.nan, n, s_min, s_max, continuous=True)


def has_fragments(run: Run) -> bool:
    """A run with the bonds effect: its file holds each snapshot's fragment labels."""
    return "fragment" in run.snaps


def check_fragments(run: Run) -> None:
    """Every snapshot's fragment labels are iceberg indices (a corrupted file is one line,
    not a wrong figure); nothing to check without the bonds effect."""
    if has_fragments(run):
        check_labels(run.path, run.snaps["fragment"], len(run.data["icebergs"]["width"]))


def by_area(runs: Sequence[Run]) -> bool:
    """Whether the fragments figure measures a piece by its area: when some bonded run's
    bodies are cells (:func:`melange_ti.analysis.fragments.celled`), whose number says
    nothing of a piece's size; otherwise, as before cells, by its icebergs."""
    return any(has_fragments(r) and celled(r.data["icebergs"]) for r in runs)


@dataclass
class RunFragments:
    run: Run
    time: float
    sizes: np.ndarray  # each piece's icebergs, or its area in w^2 (fit.continuous)
    fit: PowerLaw


def run_fragments(run: Run, t: float, area: bool = False) -> RunFragments:
    """The pieces of ``run`` at its snapshot nearest to ``t`` and their fitted exponent:
    sized by their icebergs, or with ``area`` by their area in w^2 (the fragment table's, a
    continuous law from the run's smallest body to its whole ice)."""
    k = stats.nearest_index(run.snaps["time"], t)
    time = float(run.snaps["time"][k])
    if not area:
        sizes = fragment_sizes(run.snaps["fragment"][k])
        return RunFragments(run, time, sizes, fit_power_law(sizes, s_max=int(sizes.sum())))
    table = run.fragment_table()
    sizes = np.sort(table.loc[table["time"] == time, "area"].to_numpy(dtype=float))
    smallest = float(body_moments(run.data["icebergs"])[0].min())
    return RunFragments(run, time, sizes, fit_power_law_area(sizes, s_min=smallest, s_max=float(sizes.sum())))


def fragments_time(runs: Sequence[Run]) -> float:
    """The time the figure shows: the last snapshot of the bonded run that ends first."""
    return last_snapshot_time([r for r in runs if has_fragments(r)])


def exponent_text(fits: Sequence[PowerLaw]) -> str:
    """``tau = mean ± s.d. over seeds`` (one run: ± its fit's standard error), in words."""
    taus = np.array([f.tau for f in fits])
    ok = np.isfinite(taus)
    if not ok.any():
        smallest = "one body" if fits and fits[0].continuous else "one iceberg"
        return f"no exponent (every piece {smallest}, or one piece)"
    if len(fits) == 1:
        return f"τ = {taus[0]:.2f} ± {fits[0].error:.2f} (standard error of the fit)"
    part = "" if ok.all() else f" of {ok.sum()} runs fitted"
    return f"τ = {taus[ok].mean():.2f} ± {taus[ok].std():.2f} (s.d. over {ok.sum()} seeds{part})"


def fig_fragments(groups: Sequence[Group], t: float, area: bool | None = None):
    """The sizes of the pieces of ice at time ``t`` (each run's nearest snapshot): the
    complementary CDF per run on log-log axes, the power law fitted per run (dashed: at the
    group's mean exponent) and the 2-D fragmentation reference ``tau = 3/2`` (slope -1/2).
    A piece's size: its icebergs, or with ``area`` (default: :func:`by_area` of the runs,
    some of them cells) its area in w^2."""
    if area is None:
        area = by_area([r for g in groups for r in g.runs])
    fig, ax = plt.subplots(figsize=(7.5, 5.6), layout="constrained")
    shown = [g for g in groups if any(has_fragments(r) for r in g.runs)]
    s_top, p_low, s_low = 1.0, 1.0, math.inf
    for g, color in zip(shown, _colors(len(shown)), strict=True):
        pieces = [run_fragments(r, t, area) for r in g.runs if has_fragments(r)]
        for j, p in enumerate(pieces):
            s, prob = ccdf(p.sizes)
            label = textwrap.fill(f"{_label(g)}: {exponent_text([q.fit for q in pieces])}", 110) if j == 0 else None
            # P(S >= s) holds its value at s_k on (s_(k-1), s_k]: steps drawn before each point
            ax.plot(s, prob, color=color, marker="o", ms=3, lw=0.9, alpha=0.7, drawstyle="steps-pre", label=label)
            s_top, p_low = max(s_top, p.fit.s_max), min(p_low, float(prob[-1]))
            s_low = min(s_low, p.fit.s_min)
        taus = [p.fit.tau for p in pieces if math.isfinite(p.fit.tau)]
        if taus:
            s_min, s_max = min(p.fit.s_min for p in pieces), max(p.fit.s_max for p in pieces)
            model = PowerLaw(float(np.mean(taus)), math.nan, 0, s_min, s_max, continuous=area)
            grid = np.geomspace(s_min, s_max, 200) if area else np.unique(np.round(np.geomspace(1, s_max, 200)).astype(int))
            ax.plot(grid, model.ccdf(grid), color=color, ls="--", lw=1.0)
    s_low = s_low if area and math.isfinite(s_low) else 1.0  # counted: from one iceberg
    grid = np.geomspace(s_low, max(s_top, 2 * s_low), 50)
    ax.plot(
        grid,
        (grid / s_low) ** (1.0 - FRAGMENTATION_TAU),
        color="k",
        ls=":",
        lw=1.2,
        label="2-D fragmentation reference, τ = 3/2 (Åström et al. 2004): slope −1/2, not fitted",
    )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(0.8 * s_low, 1.25 * max(s_top, 2 * s_low))
    ax.set_ylim(0.4 * p_low, 1.4)  # the data's range (the fitted law falls to 0 at the run's size)
    ax.grid(alpha=0.3, which="both")
    fig.legend(fontsize=7, loc="outside lower center")
    if area:
        ax.set_xlabel("piece size s: its area (w²; the bodies, cells or icebergs, held together by intact bonds)")
        ax.set_ylabel("fraction of pieces at least s in area")
        title = (
            f"Pieces of ice at t = {t:g}: the fraction at least s in area, one curve per run\n"
            "τ: the number of pieces of area s falls as s^−τ (s_min ≤ s ≤ the run's ice, s_min its smallest body),\n"
            "fitted to each run by maximum likelihood; dashed: that law at the group's mean τ"
        )
    else:
        ax.set_xlabel("piece size s (icebergs held together by intact bonds)")
        ax.set_ylabel("fraction of pieces at least s icebergs in size")
        title = (
            f"Pieces of ice at t = {t:g}: the fraction at least s icebergs in size, one curve per run\n"
            "τ: the number of pieces of size s falls as s^−τ (1 ≤ s ≤ the run's icebergs), fitted to each run by "
            "maximum likelihood;\ndashed: that law at the group's mean τ"
        )
    ax.set_title(title, fontsize=8)
    return fig


FRAGMENT_COLUMNS = ("group", "seed", "path", "t", "icebergs", "pieces", "largest", "tau", "tau_error")
# pieces measured by area (runs of cells): the bodies (cells, or icebergs) and areas in w^2
AREA_COLUMNS = ("group", "seed", "path", "t", "bodies", "area", "pieces", "largest_area", "tau", "tau_error")


def fragment_rows(groups: Sequence[Group], t: float, area: bool | None = None) -> list[dict]:
    """``fragments.csv``: per bonded run, its pieces at ``t`` and the fitted exponent; with
    ``area`` (default: :func:`by_area`) the columns :data:`AREA_COLUMNS`."""
    if area is None:
        area = by_area([r for g in groups for r in g.runs])
    rows = []
    for g in groups:
        for r in g.runs:
            if has_fragments(r):
                p = run_fragments(r, t, area)
                if area:
                    size = {"bodies": len(r.data["icebergs"]["width"]), "area": float(p.sizes.sum())}
                    size |= {"pieces": len(p.sizes), "largest_area": float(p.sizes.max())}
                else:
                    size = {"icebergs": int(p.sizes.sum()), "pieces": len(p.sizes), "largest": int(p.sizes.max())}
                rows.append(
                    {
                        "group": g.label,
                        "seed": r.seed,
                        "path": str(r.path),
                        "t": p.time,
                        **size,
                        "tau": p.fit.tau,
                        "tau_error": p.fit.error,
                    }
                )
    return rows


# ---------------------------------------------------------------------------------------
# Driver


def save(fig, out: Path, name: str, written: list[Path] | None = None) -> list[Path]:
    """Write ``name.png`` and ``name.pdf`` in ``out`` and close the figure; each file is added
    to ``written`` before it is written (so that a failed plot can remove it)."""
    paths = [out / f"{name}.png", out / f"{name}.pdf"]
    try:
        for p in paths:
            if written is not None:
                written.append(p)
            fig.savefig(p, dpi=DPI)
    except OSError as exc:
        raise OutputError(f"{p}: cannot write ({exc.strerror or exc})") from None
    finally:
        plt.close(fig)
    return paths


def summary_rows(groups: Sequence[Group]) -> list[dict]:
    """Per group: runs, times of 50% / 90% mean capsized fraction, final leading edge and the
    energy residual, with the ledgers the runs' files hold (``budget``: a file written before
    a ledger existed lacks it, and its residual then leaves that term in)."""
    rows = []
    for g in groups:
        frac = g.series("capsized_fraction")
        edge = g.series("leading_edge")
        cross = stats.capsize_times(frac.time, frac.mean)
        grid, terms = energy_terms(g)
        rows.append(
            {
                "group": g.label,
                "runs": len(g.runs),
                "seeds": " ".join(str(r.seed) for r in g.runs),
                "t_end": float(frac.time[-1]),
                "capsized_fraction_end": float(frac.mean[-1]),
                "capsized_fraction_end_std": float(frac.std[-1]),
                "t_50": cross[0.5],
                "t_90": cross[0.9],
                "leading_edge_end": float(edge.mean[-1]),
                "leading_edge_end_std": float(edge.std[-1]),
                "energy_released_end": float(terms["released"].mean[-1]),
                "energy_residual_end": float(terms["residual"].mean[-1]),
                "budget": " + ".join(n for n in ENERGY_LEDGERS if all(n in r.diag for r in g.runs)),
            }
        )
    return rows


# the columns of summary.csv (the bundled runs/*/summary.csv are checked against them)
SUMMARY_COLUMNS = (
    "group",
    "runs",
    "seeds",
    "t_end",
    "capsized_fraction_end",
    "capsized_fraction_end_std",
    "t_50",
    "t_90",
    "leading_edge_end",
    "leading_edge_end_std",
    "energy_released_end",
    "energy_residual_end",
    "budget",
)


def write_summary(rows: list[dict], path: Path, columns: Sequence[str] = SUMMARY_COLUMNS) -> Path:
    try:
        with open(path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=columns)
            w.writeheader()
            for row in rows:
                w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
    except OSError as exc:
        raise OutputError(f"{path}: cannot write ({exc.strerror or exc})") from None
    return path


FIGURES = (
    "fig2_snapshots",
    "fig3_capsized_fraction",
    "fig4_leading_edge",
    "fig5_capsized_by_position",
    "energy_budget",
    "impulse_rate_wall_force",
    "capsized_fraction_by_thickness_std",
    "fragments",
)


def plot(
    paths: Sequence[str | Path],
    out: str | Path,
    times: Sequence[float] | None = None,
    width_m: float | None = None,
    names: Collection[str] | None = None,
) -> list[Path]:
    """Every figure (or only those in ``names``, see :data:`FIGURES`) for the given run files
    into directory ``out``, plus ``summary.csv``; returns the files written. ``width_m``:
    the iceberg width in metres for the physical axes (default: the first run's
    ``scene.width_m``). Every file is read and checked (:func:`load_run`: a NaN is one line)
    before ``out`` is made; a plot that fails later removes the files it wrote and the
    folders it made."""
    if width_m is not None and not (math.isfinite(width_m) and width_m > 0):
        raise SceneError(f"--width-m = {width_m:g}: must be a positive number of metres")
    wanted = set(FIGURES if names is None else names)
    unknown = wanted - set(FIGURES)
    if unknown:
        raise ValueError(f"unknown figures {sorted(unknown)}; known: {', '.join(FIGURES)}")
    runs = [load_run(p) for p in paths]
    for r in runs:  # the bonds effect's data, checked before anything is drawn
        check_fragments(r)
        BondFaces.read(r.path, r.data)
    units = Units(width_m=width_m if width_m is not None else runs[0].scene.width_m)
    out = Path(out)
    made = list(takewhile(lambda d: not d.exists(), (out, *out.parents)))  # innermost first
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"--out {str(out)!r}: cannot create directory ({exc.strerror or exc})") from None
    written: list[Path] = []
    try:
        _plot(runs, out, units, times, wanted, written)
    except BaseException:  # half a plot is no plot: leave --out as it was (bar what --overwrite replaced)
        for p in written:
            p.unlink(missing_ok=True)
        for d in made:
            if d.is_dir() and not any(d.iterdir()):
                d.rmdir()
        raise
    return written


def _plot(runs: list[Run], out: Path, units: Units, times, wanted: set[str], written: list[Path]) -> None:
    """:func:`plot`'s figures, each file added to ``written`` before it is written."""
    fig2_times, fig5_times = default_times(last_snapshot_time(runs))
    if times is not None:
        check_times(times, runs)
        fig2_times = fig5_times = list(times)
    fig2_times, fig5_times = snap_times(fig2_times, runs), snap_times(fig5_times, runs)
    groups = make_groups(runs)
    makers = {
        "fig2_snapshots": lambda: fig_snapshots(groups, units, fig2_times),
        "fig3_capsized_fraction": lambda: fig_capsized_fraction(groups, units),
        "fig4_leading_edge": lambda: fig_leading_edge(groups, units),
        "fig5_capsized_by_position": lambda: fig_capsized_by_position(groups, units, fig5_times),
        "energy_budget": lambda: fig_energy_budget(groups, units),
    }
    if all("impulse_rate" in r.diag and "wall_force" in r.diag for r in runs):
        makers["impulse_rate_wall_force"] = lambda: fig_impulse_wall(groups, units)
    if len({r.flat.get("shelf.thickness_std") for r in runs}) > 1:
        title = "Capsized fraction by thickness spread (shelf.thickness_std; mean ± 1 s.d.)"
        makers["capsized_fraction_by_thickness_std"] = lambda: fig_capsized_fraction(
            make_groups(runs, keys=["shelf.thickness_std"]), units, title=title
        )
    if any(has_fragments(r) for r in runs):  # the bonds effect
        t_frag, area = fragments_time(runs), by_area(runs)
        makers["fragments"] = lambda: fig_fragments(groups, t_frag, area)
    for name, make in makers.items():
        if name in wanted:
            save(make(), out, name, written)
    written.append(out / "summary.csv")
    write_summary(summary_rows(groups), out / "summary.csv")
    if "fragments" in makers and "fragments" in wanted:
        written.append(out / "fragments.csv")
        columns = AREA_COLUMNS if area else FRAGMENT_COLUMNS
        write_summary(fragment_rows(groups, t_frag, area), out / "fragments.csv", columns)


def run_files(args: Sequence[str | Path]) -> list[Path]:
    """The run files named: each folder stands for the ``*.h5`` files in it (sorted)."""
    paths: list[Path] = []
    for arg in map(Path, args):
        if arg.is_dir():
            found = sorted(p for p in arg.glob("*.h5") if p.is_file())
            if not found:
                raise OutputError(f"{arg}: a folder with no run files (*.h5) in it")
            paths += found
        else:
            paths.append(arg)
    return paths


def refuse_overwrite(out: Path) -> None:
    """``melange-ti plot`` never replaces figures already in ``out`` unless ``--overwrite``."""
    ours = {f"{n}.{ext}" for n in FIGURES for ext in ("png", "pdf")} | {"summary.csv", "fragments.csv"}
    there = sorted(p.name for p in out.iterdir() if p.name in ours) if out.is_dir() else []
    if there:
        raise RunError(
            f"--out {str(out)!r}: holds {len(there)} files of an earlier plot, e.g. {there[0]} "
            "(use --overwrite to replace them, or another --out)"
        )


def main(args) -> int:
    """Entry point of ``melange-ti plot``."""
    paths = run_files(args.runs)
    out = Path(args.out)
    if not args.overwrite:
        refuse_overwrite(out)
    for path in paths:
        if is_partial(path):
            data = read_run(path)
            end = stored_scene(path, data).time.duration
            t = data["diagnostics"]["time"]
            upto = f"t = {t[-1]:g}" if len(t) else "no diagnostics"
            print(f"note: {path} is a partial run (stopped, or still running): up to {upto} of {end:g}")
    written = plot(paths, args.out, times=parse_times(args.times), width_m=args.width_m)
    for path in paths:  # a budget that does not close, said per run (the figure's title says it too)
        stored = stored_scene(path)
        verdict = run_verdict(read_diagnostics(path), dt=stored.time.dt, precision=stored.precision)
        if verdict:
            print(f"{path}: {verdict}")
    with open(out / "summary.csv") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        when = {k: (f"t = {row[k]}" if row[k] != "nan" else "not reached") for k in ("t_50", "t_90")}
        print(
            f"{row['group']}: {row['runs']} run(s); at t = {row['t_end']} capsized {float(row['capsized_fraction_end']):.3f}, "
            f"leading edge {float(row['leading_edge_end']):.3g} widths; 50% capsized {when['t_50']}, 90% {when['t_90']}"
        )
    if (out / "fragments.csv") in written:
        with open(out / "fragments.csv") as fh:
            frags = list(csv.DictReader(fh))
        for group in dict.fromkeys(row["group"] for row in frags):
            mine = [row for row in frags if row["group"] == group]
            area = "largest_area" in mine[0]  # pieces measured by area (runs of cells)
            fits = [  # what exponent_text says: tau and its error
                PowerLaw(float(row["tau"]), float(row["tau_error"]), int(row["pieces"]), 1, 1, continuous=area) for row in mine
            ]
            pieces = ", ".join(row["pieces"] for row in mine)
            print(f"{group}: pieces of ice at t = {mine[0]['t']}: {pieces}; {exponent_text(fits)}, 2-D fragmentation 3/2")
    print(f"wrote {len(written)} files to {out}")
    return 0
