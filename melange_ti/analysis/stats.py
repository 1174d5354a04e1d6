"""Ensemble statistics as pure numpy functions (no matplotlib, no files).

Conventions (docs/model.md, docs/output.md): times in ``sqrt(w/g)``, lengths in widths ``w``,
energies in ``rho_water g w^3`` per unit length into the page. A *series* is a pair of 1-D
arrays ``(t, y)`` with ``t`` increasing; an ensemble is a list of series, one per run.
Runs of different duration or output interval are put on the time grid of the run that
ends first (the common grid), by linear interpolation.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .. import diagnostics as diag
from ..diagnostics import ENERGY_LEDGERS, HELD
from ..energy import budget_series

Series = tuple[np.ndarray, np.ndarray]

# Scene keys that never define a parameter value: the seed makes an ensemble member; the
# duration and output schedule only change how much of the same run is recorded.
NON_PARAMETER_KEYS = (
    "time.seed",
    "time.duration",
    "output.snapshot_interval",
    "output.diagnostic_interval",
    "output.checkpoint_interval",
    "contacts.max_partners",
    "scene.name",
)


@dataclass(frozen=True)
class Ensemble:
    """Runs on one time grid: ``values`` has shape (runs, len(time))."""

    time: np.ndarray
    values: np.ndarray
    mean: np.ndarray
    std: np.ndarray

    @property
    def runs(self) -> int:
        return int(self.values.shape[0])


def common_grid(times: Sequence[np.ndarray]) -> np.ndarray:
    """The time grid of the run that ends first (ties: the first such run given)."""
    if not times:
        raise ValueError("no runs")
    ends = [float(t[-1]) if len(t) else -math.inf for t in times]
    return np.asarray(times[int(np.argmin(ends))], dtype=float)


def on_grid(t: np.ndarray, y: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """``y(t)`` linearly interpolated at ``grid``; NaN outside ``[t[0], t[-1]]``."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.size == 0:
        return np.full(len(grid), np.nan)
    return np.interp(grid, t, y, left=np.nan, right=np.nan)


def ensemble(series: Sequence[Series], grid: np.ndarray | None = None, ddof: int = 0) -> Ensemble:
    """Mean and standard deviation over runs at each time of ``grid`` (default: common grid).

    ``ddof = 0`` (the default) is the spread of the given runs, defined for a single run
    (zero); pass ``ddof = 1`` for the unbiased sample estimate.
    """
    if not series:
        raise ValueError("no runs")
    if grid is None:
        grid = common_grid([t for t, _ in series])
    grid = np.asarray(grid, dtype=float)
    values = np.vstack([on_grid(t, y, grid) for t, y in series])
    mean, std = mean_std(values, ddof=ddof)
    return Ensemble(time=grid, values=values, mean=mean, std=std)


def mean_std(values: np.ndarray, ddof: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation over axis 0, ignoring NaN (NaN where a column has none)."""
    values = np.asarray(values, dtype=float)
    ok = np.isfinite(values)
    n = ok.sum(axis=0)
    filled = np.where(ok, values, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n > 0, filled.sum(axis=0) / np.maximum(n, 1), np.nan)
        dev = np.where(ok, values - mean, 0.0)
        var = np.where(n - ddof > 0, (dev**2).sum(axis=0) / np.maximum(n - ddof, 1), np.nan)
    return mean, np.sqrt(var)


def crossing_time(t: np.ndarray, y: np.ndarray, level: float) -> float:
    """First time ``y`` reaches ``level`` (linear between samples); NaN if it never does."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    hit = np.flatnonzero(y >= level)
    if hit.size == 0:
        return math.nan
    k = int(hit[0])
    if k == 0:
        return float(t[0])
    t0, t1, y0, y1 = t[k - 1], t[k], y[k - 1], y[k]
    if not np.isfinite(y0) or y1 == y0:
        return float(t1)
    return float(t0 + (level - y0) * (t1 - t0) / (y1 - y0))


def capsize_times(t: np.ndarray, fraction: np.ndarray, levels: Iterable[float] = (0.5, 0.9)) -> dict[float, float]:
    """Times at which a (mean) capsized fraction first reaches each level: ``{level: t}``."""
    return {float(level): crossing_time(t, fraction, level) for level in levels}


def values_at(t: np.ndarray, y: np.ndarray, times: Iterable[float]) -> np.ndarray:
    """``y`` linearly interpolated at ``times`` (e.g. the leading edge); NaN outside the run."""
    return on_grid(t, y, np.asarray(list(times), dtype=float))


def leading_edge_at(t: np.ndarray, leading_edge: np.ndarray, times: Iterable[float]) -> np.ndarray:
    """Leading edge (widths) at the given times: :func:`values_at` by name."""
    return values_at(t, leading_edge, times)


def nearest_index(times: np.ndarray, t: float) -> int:
    """Index of the sample of ``times`` nearest to ``t`` (earlier one on a tie)."""
    times = np.asarray(times, dtype=float)
    return int(np.argmin(np.abs(times - t)))


def position_edges(x_min: float, x_max: float, bin_width: float = 10.0) -> np.ndarray:
    """Bin edges ``x_min, x_min + bin_width, ...`` covering ``x_max`` (at least one bin)."""
    nbins = max(1, int(math.floor((x_max - x_min) / bin_width)) + 1)
    return x_min + bin_width * np.arange(nbins + 1)


def capsized_by_position(
    x: np.ndarray, theta: np.ndarray, edges: np.ndarray, axis: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Fraction capsized and count of icebergs (centres) in each bin of ``edges``.

    Empty bins have fraction NaN. Fixed edges, so that several runs share their bins.
    ``axis``: a polygon run's principal axes (``/icebergs/axis``, :func:`..diagnostics.capsize_angle`).
    """
    x = np.asarray(x, dtype=float)
    count, _ = np.histogram(x, edges)
    caps, _ = np.histogram(x[diag.capsized(np.asarray(theta, dtype=float), axis)], edges)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(count > 0, caps / np.maximum(count, 1), np.nan)
    return frac, count


def capsized_by_position_ensemble(
    snapshots: Sequence[Mapping[str, np.ndarray]],
    t: float,
    edges: np.ndarray,
    ddof: int = 0,
    axes: Sequence[np.ndarray | None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-bin mean and std over runs of the capsized fraction at the snapshot nearest ``t``.

    ``snapshots`` are the runs' ``/snapshots`` groups (``time``, ``x``, ``theta``). Bins that
    are empty in a run do not count for that run. Returns ``(mean, std, runs_with_icebergs)``.
    ``axes``: per run, a polygon run's principal axes (``/icebergs/axis``) or ``None``.
    """
    fracs = []
    for n, snap in enumerate(snapshots):
        k = nearest_index(snap["time"], t)
        frac, _ = capsized_by_position(snap["x"][k], snap["theta"][k], edges, axes[n] if axes is not None else None)
        fracs.append(frac)
    values = np.vstack(fracs)
    mean, std = mean_std(values, ddof=ddof)
    return mean, std, np.isfinite(values).sum(axis=0)


def capsized_by_position_history(
    snapshots: Mapping[str, np.ndarray], edges: np.ndarray, axis: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Fraction capsized in each bin at every snapshot of one run: shapes (S, bins) each.

    Returns ``(fraction, count)``; a space-time view of paper Fig. 5.
    """
    x, theta = np.asarray(snapshots["x"]), np.asarray(snapshots["theta"])
    rows = [capsized_by_position(x[k], theta[k], edges, axis) for k in range(x.shape[0])]
    nb = len(edges) - 1
    frac = np.array([r[0] for r in rows]).reshape(-1, nb)
    count = np.array([r[1] for r in rows]).reshape(-1, nb)
    return frac, count


def ledger_term(name: str) -> str:
    """A ledger's term in the energy budget: ``drag_dissipated`` -> ``drag``,
    ``correction_work`` -> ``correction``."""
    return name.removesuffix("_dissipated").removesuffix("_work")


# every energy ledger of the schema (diagnostics.ENERGY_LEDGERS) is a term of the budget
LEDGER_TERMS = {ledger_term(name): name for name in ENERGY_LEDGERS}
# every energy an effect holds (diagnostics.HELD: wave_energy, bond_energy) is a term, its gain
HELD_TERMS = {name.removesuffix("_energy") + "s": name for name in HELD}
ENERGY_TERMS = ("released", "kinetic", *HELD_TERMS, *LEDGER_TERMS, "residual")


def energy_budget(diagnostics: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The energy budget over time from a run's ``/diagnostics`` (docs/output.md).

    Returns arrays over the diagnostic times:

    - ``released``: potential energy released, ``E_p(0) - E_p(t)``;
    - ``kinetic``: kinetic energy gained, ``E_k(t) - E_k(0)``;
    - one term per energy ledger (:data:`LEDGER_TERMS`: ``drag``, ``collision``,
      ``correction``, ...): cumulative energy removed by it (0 where an older file lacks it);
    - one term per energy an effect holds (:data:`HELD_TERMS`): ``waves``, wave energy gained,
      ``E_w(t) - E_w(0)``; ``bonds``, the bonds' elastic energy gained (0 without the effect);
    - ``residual``: ``E(0) - E(t) - sum(ledgers)``, the integrator's error;
    - ``total_loss``: ``E(0) - E(t)`` with ``E = E_k + E_p + E_w + E_b``.

    By construction ``sum(ledgers) + residual == total_loss`` and
    ``released == kinetic + waves + bonds + sum(ledgers) + residual`` (up to rounding).
    """
    pe = np.asarray(diagnostics["potential_energy"], dtype=float)
    ke = np.asarray(diagnostics["kinetic_energy"], dtype=float)
    if pe.size == 0:
        empty = np.zeros(0)
        return {k: empty for k in (*ENERGY_TERMS, "total_loss")}
    ledgers = {
        term: np.asarray(diagnostics[name], dtype=float) if name in diagnostics else np.zeros_like(pe)
        for term, name in LEDGER_TERMS.items()
    }
    held = {
        term: np.asarray(diagnostics[name], dtype=float) if name in diagnostics else np.zeros_like(pe)
        for term, name in HELD_TERMS.items()
    }
    # E, released and the residual: the budget's one reading (melange_ti.energy.budget_series,
    # which the run's verdict and summary take too)
    b = budget_series(diagnostics)
    return {
        "released": b["released"],
        "kinetic": ke - ke[0],
        **{term: e - e[0] for term, e in held.items()},
        **ledgers,
        "residual": b["residual"],
        "total_loss": b["energy"][0] - b["energy"],
    }


def flatten_scene(source: Mapping) -> dict[str, object]:
    """A resolved scene dict -> ``{"section.key": value}`` (lists and tables made hashable)."""
    out: dict[str, object] = {}
    for section, body in source.items():
        if isinstance(body, Mapping):
            for key, value in body.items():
                out[f"{section}.{key}"] = _hashable(value)
        else:
            out[section] = _hashable(body)
    return out


def _hashable(v):
    if isinstance(v, Mapping):
        return tuple(sorted((k, _hashable(x)) for k, x in v.items()))
    if isinstance(v, (list, tuple)):
        return tuple(_hashable(x) for x in v)
    return v


def parameters(scene) -> dict[str, object]:
    """A scene's keys as ``{"section.key": value}`` (:func:`flatten_scene`), without the
    ``[physics]`` keys of effects it does not name: they change nothing in its run (a run
    without waves has a ``physics.wave_dx`` too, which must not tell it from one with)."""
    from ..physics.effects import REGISTRY

    flat = flatten_scene(scene.source)
    used = {c.source for e in REGISTRY if getattr(scene.effects, e.name) for c in e.params if c.source}
    for e in REGISTRY:
        if not getattr(scene.effects, e.name):
            for k in e.keys:
                if f"physics.{k.name}" not in used:  # e.g. wall_x: the wave grid starts there
                    flat.pop(f"physics.{k.name}", None)
    return flat


def differing_keys(scenes: Sequence[Mapping[str, object]], ignore: Iterable[str] = NON_PARAMETER_KEYS) -> list[str]:
    """Keys of flattened scenes whose values are not the same in all of them (sorted). A key
    only some of them have (an effect's, ``physics.form_drag``) differs too: absent is a
    value of its own, so that ``form_drag = 8`` next to runs without form drag is named."""
    ignore = set(ignore)
    keys = sorted({k for s in scenes for k in s} - ignore)
    return [k for k in keys if len({repr(s[k]) if k in s else None for s in scenes}) > 1]


@functools.cache
def default_parameters() -> dict[str, object]:
    """Every key's default (the bundled paper scene's values) as ``{"section.key": value}``,
    with the keys of every effect; ``scene.effects`` is the paper's effects."""
    from ..physics.effects import PAPER_EFFECTS
    from ..scene import loads

    every = loads("", geometry=False)  # [physics] holds every effect's keys, named or not
    return {**flatten_scene(every.source), "scene.effects": PAPER_EFFECTS}


def changed_parameters(flat: Mapping[str, object], ignore: Iterable[str] = NON_PARAMETER_KEYS) -> tuple:
    """``((key, value), ...)``: the keys of a flattened scene (:func:`parameters`) whose values
    are not their defaults (:func:`default_parameters`), ``scene.effects`` first; keys without
    a default (``[[iceberg]]``, ``[start]``) and ``ignore`` left out."""
    defaults = default_parameters()
    ignore = set(ignore)
    out = [(k, v) for k, v in flat.items() if k in defaults and k not in ignore and repr(v) != repr(defaults[k])]
    return tuple(sorted(out, key=lambda kv: kv[0] != "scene.effects"))


def run_label(flat: Mapping[str, object]) -> str:
    """A single run's label: its scene's name and every value changed from the defaults,
    ``"paper, physics.form_drag = 8, shelf.count = 10"``; ``"paper, defaults"`` if none."""
    changed = changed_parameters(flat)
    return f"{flat.get('scene.name', 'scene')}, {group_label(changed) if changed else 'defaults'}"


def shown_values(group: tuple, partial: Collection[str]) -> tuple:
    """The pairs of a group key a label names: not a key the group's runs lack (value None:
    an effect they do not name), nor one of the ``partial`` keys (which only some runs have,
    all with one value) at its default (``physics.wave_dx`` of the runs with waves, whose
    effect the ``scene.effects`` value names already); ``scene.effects`` first."""
    defaults = default_parameters()
    shown = [(k, v) for k, v in group if v is not None and not (k in partial and repr(v) == repr(defaults.get(k)))]
    return tuple(sorted(shown, key=lambda kv: kv[0] != "scene.effects"))


def group_by_keys(scenes: Sequence[Mapping[str, object]], keys: Sequence[str]) -> dict[tuple, list[int]]:
    """Indices of runs grouped by their values of ``keys``, in order of first appearance.

    The group key is ``((key, value), ...)``; an empty ``keys`` gives one group ``()``.
    """
    groups: dict[tuple, list[int]] = {}
    for i, s in enumerate(scenes):
        groups.setdefault(tuple((k, s.get(k)) for k in keys), []).append(i)
    return dict(sorted(groups.items(), key=lambda kv: _sort_key(kv[0])))


def _sort_key(group: tuple) -> tuple:
    out = []
    for _, v in group:
        out.append((0, v, "") if isinstance(v, (int, float)) and not isinstance(v, bool) else (1, 0, repr(v)))
    return tuple(out)


def _effects_label(effects: tuple) -> str:
    """``("gravity", ..., "waves")`` -> ``"the paper's effects + waves"``."""
    from ..physics.effects import PAPER_EFFECTS

    added = [e for e in effects if e not in PAPER_EFFECTS]
    removed = [e for e in PAPER_EFFECTS if e not in effects]
    return "the paper's effects" + "".join(f" + {e}" for e in added) + "".join(f" - {e}" for e in removed)


def group_label(group: tuple) -> str:
    """``(("contacts.discs", 12),)`` -> ``"contacts.discs = 12"``; ``()`` -> ``"all runs"`` (the
    runs of one scene: :func:`melange_ti.analysis.runs.make_groups` labels a single run with
    :func:`run_label`)."""
    if not group:
        return "all runs"
    parts = []
    for k, v in group:
        if k == "scene.effects" and isinstance(v, tuple):
            parts.append(_effects_label(v))
            continue
        text = repr(v) if isinstance(v, tuple) else f"{v:g}" if isinstance(v, float) else str(v)
        if len(text) > 30:
            text = text[:27] + "..."
        parts.append(f"{k} = {text}")
    return ", ".join(parts)
