"""Physics studies: what the model computes, checked against theory, an independent engine and
itself as dt grows. No timing here (that is :mod:`melange_ti.bench`) and no Taichi at import.

Callers: the validation scripts (``validation/stability.py``, ``validation/capsize_peer.py``),
``melange-ti bench accuracy`` (which puts these errors next to its costs) and the tests. The
layers point one way: ``validation/`` and ``bench/`` import this package; it imports neither.
A caller initialises Taichi (:func:`melange_ti.runtime.init`) at the precision it asks for.

- :mod:`.scenes`: the scenes the studies run (the paper scene at any ``dt``, one iceberg).
- :mod:`.analytic`: one floating iceberg against closed forms (roll period, the energy one
  capsize releases, energy drift without drag): :func:`single_iceberg_errors`.
- :mod:`.stability`: the largest stable ``dt`` (a ladder, then bisection): of the paper scene,
  where unstable means the run would stop (:func:`melange_ti.energy.runaway`, the run's own
  rule, or its contact slots overflow), and the linear limit of one floating block.
- :mod:`.peer`: the paper scene in pymunk (Chipmunk2D), an engine that shares none of the
  model's contact code (optional dependency).
"""

from .analytic import single_iceberg_errors
from .peer import PymunkMelange, have_pymunk
from .scenes import dt_overrides, paper_scene, single_scene
from .stability import largest_stable_dt_paper, largest_stable_dt_single, scan_dt, watch

__all__ = [
    "PymunkMelange",
    "dt_overrides",
    "have_pymunk",
    "largest_stable_dt_paper",
    "largest_stable_dt_single",
    "paper_scene",
    "scan_dt",
    "single_iceberg_errors",
    "single_scene",
    "watch",
]
