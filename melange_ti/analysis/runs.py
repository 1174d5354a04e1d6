"""Run files loaded for plotting, grouped into ensembles, and the times figures show."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import diagnostics
from ..io.hdf5 import OutputError, read_run
from ..scene import Scene, SceneError, stored_scene
from . import fragments, stats

PAPER_FIG2_TIMES = (100.0, 200.0, 300.0, 400.0)

# What the figures and the movie read: a NaN or inf in any of these stops them in one line
# (check_finite) instead of deep in matplotlib. Every diagnostic feeds a curve or the budget.
DRAWN = (
    "snapshots/time",
    "snapshots/x",
    "snapshots/z",
    "snapshots/theta",
    "snapshots/eta",
    "icebergs/width",
    "icebergs/thickness",
    "waves/x",
)


@dataclass
class Run:
    path: Path
    data: dict
    scene: Scene
    flat: dict
    pieces: object = field(default=None, init=False, repr=False, compare=False)  # fragment_table, once read

    def fragment_table(self):
        """:func:`melange_ti.analysis.fragments.fragment_table` of this run: one row per piece
        of ice per snapshot (computed once, from the data already read)."""
        if self.pieces is None:
            self.pieces = fragments.table_of(self.data)
        return self.pieces

    @property
    def diag(self) -> dict:
        return self.data["diagnostics"]

    @property
    def snaps(self) -> dict:
        return self.data["snapshots"]

    @property
    def seed(self) -> int:
        return self.scene.time.seed


@dataclass
class Group:
    key: tuple
    label: str
    runs: list[Run]

    def series(self, name: str) -> stats.Ensemble:
        return stats.ensemble([(r.diag["time"], r.diag[name]) for r in self.runs])


def load_run(path: str | Path) -> Run:
    """One run file with its scene; a one-line :class:`OutputError` if it cannot be plotted."""
    path = Path(path)
    data = read_run(path)
    scene = stored_scene(path, data)
    # a diagnostic newer than the file's format is absent from it (the budget counts it 0)
    version = int(data["attrs"].get("format_version", 1))
    missing = [k for k in diagnostics.required(version, scene.effects) if k not in data["diagnostics"]]
    missing += [f"snapshots/{k}" for k in ("time", "x", "z", "theta") if k not in data["snapshots"]]
    missing += [f"icebergs/{k}" for k in ("width", "thickness") if k not in data["icebergs"]]
    if missing:
        raise OutputError(f"{path}: not a melange_ti run file (missing {', '.join(missing)})")
    if len(data["snapshots"]["time"]) == 0:
        raise OutputError(f"{path}: no snapshots yet (nothing to plot)")
    if len(data["diagnostics"]["time"]) == 0:
        raise OutputError(f"{path}: no diagnostics yet (nothing to plot)")
    check_finite(path, data, (*DRAWN, *(f"diagnostics/{k}" for k in data["diagnostics"])))
    return Run(path=path, data=data, scene=scene, flat=stats.parameters(scene))


def check_finite(path: str | Path, data: dict, names: Sequence[str]) -> None:
    """One-line :class:`OutputError` naming the first of the datasets ``names`` ("group/name",
    absent ones skipped) that holds a NaN or an infinity, and where: a corrupted file, or a
    run the numerical guard stopped (its last snapshot holds the state that blew up)."""
    for name in names:
        group, key = name.split("/")
        values = data.get(group, {}).get(key)
        if values is None or values.dtype.kind not in "fc":
            continue
        bad = ~np.isfinite(values)
        count = int(bad.sum())
        if not count:
            continue
        first = np.unravel_index(int(np.argmax(bad)), values.shape)
        at = f"{'NaN' if np.isnan(values[first]) else 'inf'} at "
        if group in ("snapshots", "diagnostics"):
            t = data[group].get("time")
            at += f"{'snapshot' if group == 'snapshots' else 'row'} {first[0]}"
            at += f" (t = {float(t[first[0]]):g})" if t is not None and np.isfinite(t[first[0]]) else ""
            at += f", {'cell' if key == 'eta' else 'iceberg'} {first[1]}" if values.ndim == 2 else ""
        else:
            at += f"{'iceberg' if group == 'icebergs' else 'cell'} {first[0]}"
        raise OutputError(
            f"{path}: /{name} holds {count} non-finite value{'s' if count > 1 else ''} (first: {at}); "
            "a corrupted file, or a run stopped by its numerical guard: nothing drawn"
        )


def make_groups(runs: Sequence[Run], keys: Sequence[str] | None = None) -> list[Group]:
    """Group runs by ``keys`` (default: every parameter key whose value differs between them).

    A group's label names its value of each of those keys (:func:`stats.shown_values`); a
    single run is labelled by its scene's name and the values it changed from the defaults
    (:func:`stats.run_label`), several runs with nothing between them ``all runs``."""
    flats = [r.flat for r in runs]
    if keys is None:
        keys = stats.differing_keys(flats)
    # keys only some runs have, with one value among them (an effect's keys where one group has it)
    partial = {k for k in keys if any(k not in f for f in flats) and len({repr(f[k]) for f in flats if k in f}) == 1}
    groups = stats.group_by_keys(flats, keys)

    def label(key: tuple) -> str:
        if len(runs) == 1:
            return stats.run_label(flats[0])
        shown = stats.shown_values(key, partial)
        return stats.group_label(shown if shown or not key else key)

    return [Group(key=k, label=label(k), runs=[runs[i] for i in idx]) for k, idx in groups.items()]


def parse_times(text: str | None) -> list[float] | None:
    """``"100,200,300"`` -> ``[100.0, 200.0, 300.0]``; one-line :class:`SceneError` if malformed."""
    if text is None:
        return None
    out = []
    for item in text.split(","):
        item = item.strip()
        try:
            t = float(item)
        except ValueError:
            raise SceneError(f"--times {text!r}: {item!r} is not a number") from None
        if not math.isfinite(t) or t < 0:
            raise SceneError(f"--times {text!r}: {item!r} must be a finite time >= 0")
        out.append(t)
    if not out:
        raise SceneError(f"--times {text!r}: give comma-separated times")
    return sorted(set(out))


def last_snapshot_time(runs: Sequence[Run]) -> float:
    return min(float(r.snaps["time"][-1]) for r in runs)


def default_times(t_end: float) -> tuple[list[float], list[float]]:
    """Default times for Fig. 2 (the start, then the paper's 100..400 when the runs reach
    them) and Fig. 5."""
    fig2 = [0.0, *(PAPER_FIG2_TIMES if t_end >= PAPER_FIG2_TIMES[-1] else [t_end * f for f in (0.25, 0.5, 0.75, 1.0)])]
    fig5 = [t_end * f for f in (0.125, 0.25, 0.5, 1.0)]
    return fig2, fig5


def snap_times(times: Sequence[float], runs: Sequence[Run]) -> list[float]:
    """Each time moved to the nearest snapshot of the run that ends first; duplicates dropped."""
    shortest = min(runs, key=lambda r: float(r.snaps["time"][-1]))
    t = shortest.snaps["time"]
    return sorted({float(t[stats.nearest_index(t, x)]) for x in times})


def check_times(times: Sequence[float], runs: Sequence[Run]) -> None:
    t_end = last_snapshot_time(runs)
    late = [t for t in times if t > t_end * (1 + 1e-9) + 1e-9]
    if late:
        shortest = min(runs, key=lambda r: float(r.snaps["time"][-1]))
        raise SceneError(f"--times {late[0]:g}: after the last snapshot (t = {t_end:g}) of {shortest.path}")
