"""The largest stable ``dt``: raised along a ladder, then bisected (geometrically) between the
last stable and the first unstable rung (:func:`scan_dt`).

- The paper scene (:func:`largest_stable_dt_paper`): unstable when the run would stop, by the
  run's own rules: it ran away (:func:`melange_ti.energy.runaway`: a non-finite state, or
  ``E`` above its start by more than the icebergs' total mass) or its contact slots
  overflowed (:class:`melange_ti.errors.ContactOverflow`). :func:`watch` applies them.
- One floating block (:func:`largest_stable_dt_single`): the linear limit ``omega dt = 2`` of
  the semi-implicit Euler step, measured. A run that runs away is unstable here too, but the
  limit is found earlier and sharper: a small oscillation whose excitation energy grows
  ``growth`` (100) times. A stable orbit exceeds its initial excitation by at most
  ``(1 + omega dt/2) / (1 - omega dt/2)``, which is 100 only 1% below ``omega dt = 2``; a
  runaway (the whole mass lifted one width) would need a growth of ~10^8.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..scene.keys import DENSITY_RATIO
from .scenes import paper_scene, single_scene

PAPER_LADDER = (0.01, 0.02, 0.04, 0.08, 0.16, 0.32, 0.64, 1.28, 2.56)
SINGLE_LADDER = (0.25, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0)


def scan_dt(test: Callable[[float], tuple[bool, str]], ladder, refine: int) -> dict:
    """Largest stable dt: ``test(dt) -> (stable, why)`` up ``ladder`` to its first unstable
    rung, then ``refine`` bisections (geometric). Returns ``largest_stable`` and
    ``first_unstable`` (NaN when not found) and every ``tried`` dt with its verdict."""
    tried = []
    lo = hi = None
    for dt in ladder:
        stable, why = test(dt)
        tried.append({"dt": dt, "stable": stable, "reason": why})
        if stable:
            lo = dt
        else:
            hi = dt
            break
    if lo is not None and hi is not None:
        for _ in range(refine):
            mid = math.sqrt(lo * hi)
            stable, why = test(mid)
            tried.append({"dt": mid, "stable": stable, "reason": why})
            if stable:
                lo = mid
            else:
                hi = mid
    return {
        "largest_stable": lo if lo is not None else float("nan"),
        "first_unstable": hi if hi is not None else float("nan"),
        "tried": tried,
    }


def watch(model, dt: float, steps: int, every: int, check=None) -> tuple[str | None, float]:
    """Advance ``model`` ``steps`` steps, sampling every ``every``: ``(why, rise)``, ``why``
    the reason the run would stop (:func:`melange_ti.energy.runaway`, a contact overflow, or
    ``check(sample, energy)`` returning a reason), else ``None``; ``rise`` the largest rise of
    ``E`` (:func:`melange_ti.energy.total_energy`) above its start seen."""
    from ..energy import runaway, total_energy
    from ..errors import ContactOverflow

    total_mass = float(model.constants()["mass"].sum())
    e0 = total_energy(model.sample())
    worst, done = 0.0, 0
    while done < steps:
        k = min(every, steps - done)
        try:
            model.advance(k)
        except ContactOverflow:
            return f"contact overflow by t = {(done + k) * dt:g}", worst
        done += k
        s = model.sample()
        e = total_energy(s)
        why = runaway(s, e, e0, total_mass) or (check(s, e) if check else None)
        if why:
            return f"{why} at t = {done * dt:g}", worst
        worst = max(worst, e - e0)
    return None, worst


def largest_stable_dt_paper(
    n: int = 400,
    duration: float = 200.0,
    *,
    precision: str = "f64",
    discs: int = 28,
    passes: int = 1,
    seed: int = 1,
    ladder=PAPER_LADDER,
    refine: int = 3,
    log: Callable[[dict], None] | None = None,
) -> dict:
    """The paper scene (``n`` icebergs, ``duration`` time units; :func:`scan_dt`): stable
    while the run would not stop (:func:`watch`, checked every time unit). ``log`` is
    called with each tried rung as it finishes."""
    from ..model import Model

    def test(dt: float) -> tuple[bool, str]:
        sc = paper_scene(n, precision=precision, dt=dt, duration=duration, discs=discs, passes=passes, seed=seed)
        m = Model(sc)
        why, rise = watch(m, dt, sc.time.steps, max(1, int(round(1.0 / dt))))
        total_mass = float(m.constants()["mass"].sum())
        verdict = (why is None, why or f"energy rose at most {rise:.3g} (a runaway: above the total mass, {total_mass:.4g})")
        if log:
            log({"dt": dt, "stable": verdict[0], "reason": verdict[1]})
        return verdict

    out = scan_dt(test, [float(v) for v in ladder], int(refine))
    out.update(ok=True, error="")
    return out


def largest_stable_dt_single(
    precision: str = "f64",
    *,
    heave: float = 1e-4,
    roll: float = 1e-4,
    periods: float = 60,
    growth: float = 100.0,
    ladder=SINGLE_LADDER,
    refine: int = 6,
) -> dict:
    """A stable floating block (1.4 x 1) released with ``heave`` and ``roll`` offsets, drag
    off, for ``periods`` heave periods: unstable when it runs away (:func:`watch`) or its
    excitation energy above the rest state grows past ``growth`` times its initial value.
    ``predicted`` is the linear limit ``2 / omega`` of the stiffer of heave and roll."""
    from .. import diagnostics as dg
    from ..energy import total_energy
    from ..geometry import potential_energy
    from ..model import Model
    from ..scene import equilibrium_z

    r = DENSITY_RATIO
    bw, bh = 1.4, 1.0
    z_eq = float(equilibrium_z(bh, r, 0.0))
    u_eq = float(potential_energy(np.array([z_eq]), np.array([0.0]), bw, bh, r)[0])
    t_heave = float(dg.heave_period(r, bh))
    duration = float(periods) * t_heave
    berg = {"x": 0.0, "z": z_eq + float(heave), "theta": float(roll), "width": bw, "thickness": bh}

    def test(dt: float) -> tuple[bool, str]:
        m = Model(single_scene(precision, dt, duration, [berg], ["gravity", "buoyancy"]))
        e0 = total_energy(m.sample()) - u_eq
        seen = [0.0]

        def grown(s, e):
            seen[0] = max(seen[0], abs(e - u_eq) / e0)
            return f"excitation energy grew x{seen[0]:.3g}" if seen[0] > growth else None

        why, _ = watch(m, dt, int(round(duration / dt)), max(1, int(round(0.05 / dt))), grown)
        return why is None, why or f"excitation energy at most x{seen[0]:.3g} its initial value"

    out = scan_dt(test, [float(v) for v in ladder], int(refine))
    omega_heave = 2 * math.pi / t_heave
    omega_roll = 2 * math.pi / float(dg.roll_period(r, bw, bh))
    out.update(predicted=2.0 / max(omega_heave, omega_roll), ok=True, error="")
    return out
