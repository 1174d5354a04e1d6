"""Benchmarks: ``melange-ti bench scaling|accuracy|effects|peers [--out DIR] [--quick]``.

A leaf beside the model: it uses only the public ``Model`` API and the physics studies
(:mod:`melange_ti.studies`, which it times or puts costs next to), and nothing in melange_ti
imports it except the command line. Each subcommand writes ``{out}/{which}.csv`` and
``{out}/{which}.png`` (plus a few side files ``{which}_*.csv``) and prints a short table.
Benchmarks measure; they never assert a speed. Wall-clock figures vary 2-3x from run to run
on a shared machine: compare ratios taken in one run (see ``benchmarks/README.md``).

``scaling``   time per step against N, by stage (``Model.profile``) (:mod:`.scaling`).
``accuracy``  cost against error for dt, discs, precision and contact passes, in worker
              processes (:mod:`.accuracy`, :mod:`.worker`); the single-iceberg errors and
              the largest stable dt are the physics studies' (:mod:`melange_ti.studies`).
``effects``   cost per step of each effect (:mod:`.effects`).
``peers``     the paper scene in pymunk (Chipmunk2D) with numpy buoyancy and drag
              (:mod:`melange_ti.studies.peer`), timed beside melange_ti (:mod:`.peers`).

Shared helpers are in :mod:`.common`. ``python -m melange_ti.bench WHICH --help`` lists
finer options (sizes, steps, seeds, ...).
"""

from .cli import build_parser, main

__all__ = ["build_parser", "main"]
