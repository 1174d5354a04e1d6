"""The drag similarity law: ensembles at several linear drags ``c`` collapsed onto one curve
against a scaled time, and the fitted laws for the leading edge and the capsized fraction
(docs/validation.md, "The similarity law").

Two scalings are tried, because two mechanisms compete: a body coasting against linear drag
covers its distance on the time ``1/c`` (``t c``), while a front spreading diffusively
against drag advances as ``sqrt(t / c)`` (``t / c``). :func:`collapse_misfit` measures how
far apart the ensembles' mean curves stay under each; the fits use the scaling given.

Uncertainties are bootstrap standard deviations over runs, resampled within each drag
(:func:`bootstrap`, a fixed seed: the numbers are reproducible).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

Series = tuple[np.ndarray, np.ndarray]

SCALINGS: dict[str, Callable[[np.ndarray, float], np.ndarray]] = {
    "t c": lambda t, c: np.asarray(t, dtype=float) * c,
    "t / c": lambda t, c: np.asarray(t, dtype=float) / c,
}


@dataclass(frozen=True)
class Curve:
    """One drag's ensemble mean of a diagnostic on its time grid."""

    drag: float
    time: np.ndarray
    mean: np.ndarray


def collapse_misfit(curves: Sequence[Curve], scaling: str, points: int = 200) -> tuple[float, tuple[float, float]]:
    """RMS over a log-spaced grid of the scaled time of the spread (standard deviation across
    drags) of the mean curves, where all of them are defined; and that grid's range. NaN if
    the curves do not overlap under ``scaling``."""
    to_x = SCALINGS[scaling]
    xs = [to_x(c.time, c.drag) for c in curves]
    lo = max(float(np.min(x[x > 0])) for x in xs)
    hi = min(float(np.max(x)) for x in xs)
    if not hi > lo:
        return float("nan"), (lo, hi)
    grid = np.geomspace(lo, hi, points)
    ys = np.vstack([np.interp(np.log(grid), np.log(x[x > 0]), c.mean[x > 0]) for x, c in zip(xs, curves, strict=True)])
    return float(np.sqrt(np.mean(np.var(ys, axis=0)))), (lo, hi)


def misfit_to_reference(
    curves: Sequence[Curve], reference: Curve, scaling: str, late: float = 0.0, points: int = 200
) -> dict[float, float]:
    """Per drag, the RMS difference of its mean curve from ``reference``'s under
    ``scaling``, over a log-spaced grid of the scaled time where both are defined and the
    drag's own ``t c >= late`` (past the drag-independent start); NaN where they do not
    overlap."""
    to_x = SCALINGS[scaling]
    xr = to_x(reference.time, reference.drag)
    okr = xr > 0
    out = {}
    for c in curves:
        if c.drag == reference.drag:
            continue
        x = to_x(c.time, c.drag)
        ok = (x > 0) & (c.time * c.drag >= late)
        if ok.sum() < 2:
            out[c.drag] = float("nan")
            continue
        lo = max(float(x[ok].min()), float(xr[okr].min()))
        hi = min(float(x[ok].max()), float(xr[okr].max()))
        if not hi > lo:
            out[c.drag] = float("nan")
            continue
        grid = np.geomspace(lo, hi, points)
        y = np.interp(np.log(grid), np.log(x[ok]), c.mean[ok])
        yr = np.interp(np.log(grid), np.log(xr[okr]), reference.mean[okr])
        out[c.drag] = float(np.sqrt(np.mean((y - yr) ** 2)))
    return out


def fit_power_law(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """``y = A x^beta`` by least squares in log-log; returns ``(A, beta)``."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 2:
        raise ValueError("a power law needs at least two positive points")
    beta, log_a = np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)
    return float(np.exp(log_a)), float(beta)


def fit_line(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """``y = a + b x`` by least squares; returns ``(a, b)``."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 2:
        raise ValueError("a line needs at least two points")
    b, a = np.polyfit(x[ok], y[ok], 1)
    return float(a), float(b)


def pooled(runs: Mapping[float, Sequence[Mapping[str, np.ndarray]]], name: str, scaling: str, late: float = 0.0) -> Series:
    """Every run's ``(scaled time, diagnostic)`` points with ``t c >= late``, all drags
    pooled (``runs``: drag -> run diagnostics with ``time``)."""
    xs, ys = [], []
    for drag, group in runs.items():
        for d in group:
            t = np.asarray(d["time"], dtype=float)
            keep = t * drag >= late
            xs.append(SCALINGS[scaling](t[keep], drag))
            ys.append(np.asarray(d[name], dtype=float)[keep])
    return np.concatenate(xs), np.concatenate(ys)


def bootstrap(
    runs: Mapping[float, Sequence[object]],
    statistic: Callable[[dict[float, list[object]]], Sequence[float]],
    samples: int = 200,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """``statistic`` of the runs as given, and its bootstrap standard deviation: runs are
    resampled with replacement within each drag, ``samples`` times."""
    rng = np.random.default_rng(seed)
    value = np.asarray(statistic({c: list(g) for c, g in runs.items()}), dtype=float)
    draws = []
    for _ in range(samples):
        resampled = {c: [g[k] for k in rng.integers(0, len(g), len(g))] for c, g in runs.items()}
        draws.append(statistic(resampled))
    return value, np.std(np.asarray(draws, dtype=float), axis=0, ddof=1)
