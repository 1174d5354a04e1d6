"""One floating iceberg against closed forms: the errors ``melange-ti bench accuracy`` puts
next to the cost of each ``dt`` and precision (no contacts, so they depend on nothing else).

- roll period: the 1.4 x 1 block lying flat, released at ``roll_amplitude`` rad, drag off,
  ``roll_periods`` periods; period from zero crossings against
  ``2 pi / sqrt(12 g GM / (w^2 + h^2))`` (:func:`melange_ti.diagnostics.roll_period`);
- capsize energy: the 1 x 1.4 iceberg released upright at 0.01 rad with drag, until it lies
  still (``capsize_duration``): the energy released against the exact one (numpy
  hydrostatics, :mod:`melange_ti.geometry`; ``0.5 r (1-r) w h (h-w)`` from exactly upright);
- energy drift: the same capsize with drag off over ``drift_duration``:
  ``max |E(t) - E(0)|`` over the capsize energy.
"""

from __future__ import annotations

import math

import numpy as np

from ..scene.keys import DENSITY_RATIO
from ..testing import zero_crossing_period
from .scenes import single_scene


def single_iceberg_errors(
    dt: float,
    precision: str = "f64",
    *,
    roll_periods: float = 10.5,
    drift_duration: float = 300.0,
    capsize_duration: float = 1500.0,
    sample_every: float = 0.05,
    roll_amplitude: float = 0.002,
) -> dict:
    """Roll period (stable block), capsize energy (drag on), energy drift (drag off) at ``dt``:
    each measured value, its reference and its relative error (``roll_period_error``,
    ``capsize_energy_error``, ``energy_drift``; ``inf`` when the state stops being finite)."""
    from .. import diagnostics as dg
    from ..energy import total_energy
    from ..geometry import potential_energy
    from ..model import Model
    from ..physics.data.schema import STATE_NAMES
    from ..scene import equilibrium_z

    r = DENSITY_RATIO
    dt = float(dt)
    # Stable block: the paper iceberg lying flat (width 1.4, thickness 1), small roll.
    bw, bh, amp = 1.4, 1.0, float(roll_amplitude)
    t_roll = float(dg.roll_period(r, bw, bh))
    # Capsizing iceberg: the paper's 1 x 1.4, upright with a small tilt (single_capsize scene).
    cw, ch, tilt = 1.0, 1.4, 0.01
    e_caps = float(dg.capsize_energy(r, cw, ch))
    roll_duration = float(roll_periods) * t_roll
    drift_duration = float(drift_duration)
    span = max(roll_duration, drift_duration)
    bergs = [
        {"x": 0.0, "z": float(equilibrium_z(bh, r, 0.0)), "theta": amp, "width": bw, "thickness": bh},
        {"x": 10.0, "z": float(equilibrium_z(ch, r, 0.0)), "theta": tilt, "width": cw, "thickness": ch},
    ]

    def energy_of_1(s) -> float:  # the capsizing iceberg's own energy (the block beside it is apart)
        return float(np.float64(s["kinetic"][1]) + np.float64(s["potential"][1]))

    m = Model(single_scene(precision, dt, span, bergs, ["gravity", "buoyancy"]))
    every = max(1, int(round(float(sample_every) / dt)))
    total = int(round(span / dt))
    s = m.sample()
    ts, th, e1 = [0.0], [float(s["theta"][0])], [energy_of_1(s)]
    finite = True
    step = 0
    while step < total:
        k = min(every, total - step)
        m.advance(k)
        step += k
        s = m.sample()
        if not all(np.all(np.isfinite(s[name])) for name in STATE_NAMES):
            finite = False
            break
        ts.append(step * dt)
        th.append(float(s["theta"][0]))
        e1.append(energy_of_1(s))
    ts, th, e1 = np.array(ts), np.array(th), np.array(e1)
    in_roll = ts <= roll_duration
    period = zero_crossing_period(ts[in_roll], th[in_roll]) if finite else float("nan")
    in_drift = ts <= drift_duration
    drift = float(np.max(np.abs(e1[in_drift] - e1[0])) / e_caps) if finite else float("inf")

    # Capsize with drag: energy released once the iceberg has settled flat.
    caps_duration = float(capsize_duration)
    m2 = Model(single_scene(precision, dt, caps_duration, [bergs[1]], ["gravity", "buoyancy", "drag"]))
    e_start = total_energy(m2.sample())
    m2.advance(int(round(caps_duration / dt)))
    s1 = m2.sample()
    released = e_start - total_energy(s1)
    # Exact reference: the initial state's energy (f64, numpy) minus the flat rest state's;
    # upright-to-flat that is 0.5 r (1-r) w h (h-w); the 0.01 tilt changes it by ~2e-5.
    u0 = float(potential_energy(np.array([bergs[1]["z"]]), np.array([tilt]), cw, ch, r)[0])
    u_flat = float(potential_energy(np.array([equilibrium_z(cw, r, 0.0)]), np.array([math.pi / 2]), cw, ch, r)[0])
    exact = u0 - u_flat
    return {
        "roll_period": period,
        "roll_period_analytic": t_roll,
        "roll_period_error": abs(period - t_roll) / t_roll if math.isfinite(period) else float("inf"),
        "capsize_released": released,
        "capsize_energy_analytic": e_caps,
        "capsize_energy_exact_start": exact,
        "capsize_energy_error": abs(released - exact) / exact if math.isfinite(released) else float("inf"),
        "capsize_final_phi": float(dg.capsize_angle(s1["theta"])[0]),
        "energy_drift": drift,
        "ok": bool(finite and math.isfinite(released)),
        "error": "" if finite else "non-finite single-iceberg state",
    }
