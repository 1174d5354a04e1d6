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

from .diagnostics import HELD
from .physics.data.schema import STATE_NAMES

__all__ = ["HELD", "total_energy", "runaway"]


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
