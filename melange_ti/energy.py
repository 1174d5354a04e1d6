"""The energy of a run, and when it ran away: one definition of each (no Taichi).

``E`` is the icebergs' kinetic and potential energy plus every energy an effect holds (the
waves' ``wave_energy``: :data:`HELD`, from the effects' declarations). The energy budget
closes ``E(0) - E(t)`` against the ledgers (:data:`melange_ti.physics.data.schema.ENERGY_LEDGERS`).

A run **ran away** when its state is no longer finite or ``E`` rose above its start by more
than the icebergs' total mass times ``g w`` (every iceberg lifted by one width: far beyond
any energy the model can release or round off): :func:`runaway`. The run's guard, the
stability study (``validation/stability.py``) and the benchmarks' largest stable step use it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .diagnostics import ENERGY_LEDGERS, HELD
from .physics.data.schema import STATE_NAMES

__all__ = ["HELD", "RESIDUAL_PROMISED", "RESIDUAL_TRUSTED", "budget_promise", "budget_verdict", "total_energy", "runaway"]


def total_energy(data: Mapping[str, Any]) -> Any:
    """``E``: the sum of every energy part of the budget's ``E``.

    ``data`` is a diagnostics row or table (``kinetic_energy``, ``potential_energy``, ...:
    a ``read_run(...)["diagnostics"]`` dict, ``open_run(...)["diagnostics"]`` or one row;
    a time series gives a time series) or a :meth:`Model.sample` (per-iceberg ``kinetic``
    and ``potential``, summed, plus the held energies). An energy an effect holds that is
    missing (a scene without the effect, or a file older than it) counts as 0."""
    if "kinetic_energy" in data:
        total = data["kinetic_energy"] + data["potential_energy"]
        for name in HELD:
            if name in data:
                total = total + data[name]
        return total
    if "kinetic" in data:
        total = float(np.sum(data["kinetic"])) + float(np.sum(data["potential"]))
        return total + sum(float(data[name]) for name in HELD if name in data)
    raise KeyError("total_energy: need a diagnostics row or table (kinetic_energy, ...) or a Model.sample() (kinetic, ...)")


def runaway(sample: Mapping[str, np.ndarray], energy: float | None, e0: float, total_mass: float) -> str | None:
    """Why the run ran away, in words, or ``None``: a non-finite state column of ``sample``
    (a :meth:`Model.sample`), or ``energy`` (:func:`total_energy`; ``None``: not checked)
    non-finite or above ``e0`` by more than ``total_mass`` (``g = w = 1``)."""
    for name in STATE_NAMES:
        if name in sample:
            bad = np.flatnonzero(~np.isfinite(sample[name]))
            if bad.size:
                return f"iceberg {int(bad[0])} has non-finite {name}"
    if energy is None:
        return None
    rise = energy - e0
    if not math.isfinite(energy) or rise > total_mass:
        worst = f"; fastest iceberg {int(np.argmax(sample['kinetic']))}" if "kinetic" in sample else ""
        return f"energy ran away (rose by {rise:.3g} > total mass {total_mass:.3g}{worst})"
    return None


def budget_series(diagnostics: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """The budget over a run from its diagnostics table (``read_run(...)["diagnostics"]``):
    ``released`` (``E_p(0) - E_p(t)``), ``dissipated`` (the sum of the ledgers it holds) and
    ``residual`` (``E(0) - E(t) - dissipated``), with ``time`` and ``energy`` (``E``)."""
    energy = np.asarray(total_energy(diagnostics), dtype=float)
    pe = np.asarray(diagnostics["potential_energy"], dtype=float)
    dissipated = sum((np.asarray(diagnostics[n], dtype=float) for n in ENERGY_LEDGERS if n in diagnostics), np.zeros_like(pe))
    if pe.size == 0:
        return {"time": pe, "released": pe, "dissipated": pe, "residual": pe, "energy": pe}
    return {
        "time": np.asarray(diagnostics["time"], dtype=float) if "time" in diagnostics else np.full(pe.shape, np.nan),
        "released": pe[0] - pe,
        "dissipated": dissipated,
        "residual": energy[0] - energy - dissipated,
        "energy": energy,
    }


# What the budget promises (docs/model.md, "What the budget promises"): with the energy read at
# the step time, the residual of largest magnitude over a run at the default time step stays
# within this share of the largest energy released over it, with every effect (measured:
# validation/budget_over_run.py, docs/validation.md, "The budget at every instant").
RESIDUAL_PROMISED = 1e-3
# The largest budget residual over a run, as a fraction of the largest energy it released (or
# dissipated, where that is larger), that a run reports without a warning: ten times the
# promise. Past it the usual cause is a time step near the stability limit (the paper scene:
# -3.9% at dt = 0.1, -590% at 0.5, read from the state a step leaves; a lone capsize at dt = 0.5,
# accepted, 3.4% at t = 56).
RESIDUAL_TRUSTED = 10 * RESIDUAL_PROMISED
# Below this share of the run's largest |E| an energy is rounding: a budget whose releases and
# ledgers are all that small (icebergs floated at rest) is judged against it, not against them;
# in a precision whose rounding is larger, ROUNDING_ULPS of its epsilon instead (f32: 1.2e-3, so
# 1% of it is 100 ulps of |E|; a quiet f32 scene's residual reached 4.5e-7 of |E|, 3.8 ulps, over
# 1000 steps, which the f64 share had flagged as 4.8% of the little energy released; the 25x
# margin is for longer runs, whose rounding grows with the steps)
ROUNDING_SHARE = 1e-8
ROUNDING_ULPS = 1e4
EPSILON = {"f64": 2.0**-52, "f32": 2.0**-23}


def worst(residual: Any) -> int:
    """Index of the residual the budget is judged by: the first non-finite one, else the one
    of largest magnitude (0 for an empty series)."""
    res = np.atleast_1d(np.asarray(residual, dtype=float))
    if res.size == 0:
        return 0
    bad = ~np.isfinite(res)
    return int(np.argmax(bad)) if bad.any() else int(np.argmax(np.abs(res)))


def budget_promise(
    residual: float, released: float, dissipated: float, time: float, energy: float = 0.0, precision: str = "f64"
) -> str:
    """One line comparing a run's largest residual over the run (``residual``, at ``time``)
    with :data:`RESIDUAL_PROMISED` of the scale :func:`budget_verdict` judges it by: the
    largest energy released (``released``), or dissipated where that is larger, and no less
    than the rounding of the run's largest ``|E|`` (``energy``) in its ``precision``."""
    scale = _scale(released, dissipated, energy, precision)
    if scale == 0.0:
        return f"budget: largest residual over the run {residual:.3g} (nothing released or dissipated)"
    share = abs(residual) / scale
    if abs(released) >= scale:
        what = "of the largest energy released"
    elif abs(dissipated) >= scale:
        what = "of the largest energy dissipated"
    else:
        what = "of the rounding of the run's energy"
    where = "within" if share <= RESIDUAL_PROMISED else "past"
    return (
        f"budget: largest residual over the run {100 * share:.3g}% {what} (t = {time:g}), "
        f"{where} the {RESIDUAL_PROMISED:.1%} the budget promises at the default time step"
    )


def _scale(released: Any, dissipated: Any, energy: float, precision: str) -> float:
    """What a budget's residual is judged against: the largest energy released or dissipated
    over the run, and no less than the rounding of its largest ``|E|`` (:data:`ROUNDING_SHARE`,
    or :data:`ROUNDING_ULPS` of the precision's epsilon where that is larger)."""
    rel, dis = (np.atleast_1d(np.asarray(a, dtype=float)) for a in (released, dissipated))
    scale = max(float(np.nanmax(np.abs(rel), initial=0.0)), float(np.nanmax(np.abs(dis), initial=0.0)))
    return max(scale, max(ROUNDING_SHARE, ROUNDING_ULPS * EPSILON[precision]) * abs(float(energy)))


def budget_verdict(
    residual: Any,
    released: Any,
    dissipated: Any,
    time: Any,
    dt: float | None = None,
    accepted: float | None = None,
    energy: float = 0.0,
    precision: str = "f64",
) -> str | None:
    """A warning, in one sentence, when an energy budget does not close, else ``None``.

    ``residual``, ``released`` (``E_p(0) - E_p(t)``) and ``dissipated`` (the ledgers' sum) are
    time series over the run (or single values, the end's), ``time`` their times. The verdict
    takes the residual of largest magnitude over the run against :data:`RESIDUAL_TRUSTED` of
    the largest energy released, or dissipated where that is larger (a run that released
    little while its ledgers booked much, e.g. a struck iceberg, is not judged by the little);
    ``energy``, the run's largest ``|E|``, sets a floor: :data:`ROUNDING_SHARE` of it, or
    :data:`ROUNDING_ULPS` of the ``precision``'s epsilon where that is larger (a still scene's
    residual at rounding is no warning; a residual far past it with nothing released or
    dissipated is one). A NaN residual is always told. ``dt`` and ``accepted`` (the scene's time
    step and the largest its hydrostatics accept: docs/model.md, "The largest time step"; when
    known) make the advice concrete."""
    res, rel, t = (np.atleast_1d(np.asarray(a, dtype=float)) for a in (residual, released, time))
    if res.size == 0:
        return None
    scale = _scale(released, dissipated, energy, precision)
    bad = ~np.isfinite(res)
    k = worst(res)
    if not bad.any() and (scale == 0.0 or abs(res[k]) <= RESIDUAL_TRUSTED * scale):
        return None
    top = float(np.nanmax(np.abs(rel), initial=0.0))
    if bad.any():
        size = "is not finite"
    elif top > 0:
        pct = 100.0 * res[k] / top
        size = f"reached {pct:.2g}%" if abs(pct) < 10 else f"reached {pct:.0f}%"
        size += " of the largest energy released"
    else:
        size = f"reached {res[k]:.3g} (nothing was released)"
    when = f" at t = {t[k]:g}" if t.size == res.size else ""
    step = ""
    if dt is not None and accepted is not None and math.isfinite(accepted):
        step = f" (time.dt = {dt:g}; the icebergs' hydrostatics accept up to {accepted:.3g}, other effects may ask less)"
    elif dt is not None:
        step = f" (time.dt = {dt:g})"
    return (
        f"warning: the energy budget does not close: its residual {size}{when}, past the {RESIDUAL_TRUSTED:.0%} a sound "
        f"time step keeps; do not trust these results. The usual cause is a time step near a stability limit{step}: "
        "a smaller time.dt shrinks it (docs/model.md, 'What the budget promises')"
    )
