"""The run file (docs/output.md): streamed, chunked, flushed after every write.

Rows are appended with the ``time`` dataset of each group grown last, in a flush of its own
(:meth:`RunWriter._write`), so a reader (or a file cut short by ``kill -9``) can trust the
shortest consistent length:
:func:`consistent_length`. The file uses HDF5's default (oldest compatible) format and no
SWMR: with the HDF5 2.x library a file opened with ``libver="latest"`` for writing keeps a
status flag in its superblock after a kill, and plain ``h5py.File(path)`` then refuses it.
The writer opens the file without HDF5's file lock, so a reader can open the running file
at any time with plain ``h5py.File(path, "r")`` and sees every row up to the writer's last
flush (an open or a read that meets one of the writer's flushes can fail, HDF5's "addr
overflow", as the file's superblock and the metadata it points to are written at different
moments without SWMR: open it again). Every reader here opens with h5py's default locking (no ``locking`` argument): HDF5
refuses a second open of a file that this process holds with other locking flags ("file
locking flag values don't match"), so a user's own ``h5py.File(path)`` must be able to sit
next to ours.

This module alone knows the file's layout and attributes; it hands out plain values (the
stored scene as TOML text, a snapshot as numpy arrays). Turning those into a ``Scene`` is
the scene package's work (:func:`melange_ti.scene.stored_scene`, ``[start]``), above this one.
"""

from __future__ import annotations

import contextlib
import math
import os
import shutil
from pathlib import Path

import h5py
import numpy as np

from ..diagnostics import FIELDS
from ..physics.data.schema import BODIES
from ..physics.data.schema import STATE_NAMES as STATE
from ..physics.effects import REGISTRY

# 8: the energy of the diagnostics read at the step time: kinetic_energy 0.5 m v0 . v1 of the
# velocities half a kick before and after it, an effect's held energy at the positions
# (Quantity.at_step; docs/model.md, "What the budget promises"); older files hold the kinetic
# energy of the velocities the step left;
# 7: a run holds only the diagnostics of the effects its scene names (diagnostics.fields: an effect's
# energies, ledgers and reports absent without it; older files hold them all, 0);
# 6: an effect's reports (diagnostics beyond energies), datasets over the icebergs, datasets
# rewritten with every snapshot, and each effect's own dtype (docs/output.md);
# 5: the energy an effect holds and its run-wide ledger (0 without it); the datasets and
# dimensions an effect declares (docs/output.md);
# 4: friction_dissipated (the friction effect's ledger, 0 without it), the taichi_arch attribute;
# 3: every diagnostic of diagnostics.FIELDS with since <= 3 (contacts, wall_force,
# impulse_rate, impulse_offset_work, added_mass_work were added during version 2);
# 2: self-describing as netCDF-4 (dimension scales, units and long_name on every variable,
# global attributes); 1: plain HDF5 (still read). A diagnostic added later carries the next
# version as its ``since``, and the figures read the older files without it.
FORMAT_VERSION = 8
SCENE_ATTR = "scene_toml"  # root attribute: the resolved scene, as run (TOML text)
# root attribute of a file with outlines (polygons): their collision discs' rule, ``discs // K``
# on each of an outline's K edges (geometry.polygon_discs); a file without it was made with the
# earlier rule (the fewest discs by bisection), and a resume of it is refused
OUTLINE_DISCS_ATTR = "outline_discs"
OUTLINE_DISCS = "discs // corners per edge"
COMPLETE_ATTR = "complete"  # root attribute: True once the run reached its end
DIAGNOSTICS = tuple(f.name for f in FIELDS)
DIAG_INT = tuple(f.name for f in FIELDS if f.dtype.startswith("i"))
GROUPS = ("icebergs", "snapshots", "diagnostics")  # the model's own; an effect may add more
# every variable and dimension an effect declares (Effect.datasets, Effect.dims): written in the
# file of a run whose scene names the effect
DATASETS = tuple(d for e in REGISTRY for d in e.datasets)
DIMS = {name: doc for e in REGISTRY for name, doc in e.dims}
# each dataset's effect's own dimensions: the effect is named when its State gives them all
OWN_DIMS = {d.path: {name for name, _ in e.dims} for e in REGISTRY for d in e.datasets}
TIME_UNITS = "sqrt(w/g)"
REFERENCE = (
    "Guttenberg, N., Abbot, D. S., Amundson, J. M., Burton, J. C., Cathles, L. M., MacAyeal, D. R. and Zhang, W. W. "
    "(2011): Numerical model of ice melange expansion during abrupt ice-shelf collapse. Annals of Glaciology 52(59)."
)
UNITS_COMMENT = (
    "Non-dimensional units: lengths in iceberg widths w, time in sqrt(w/g), densities in rho_water; quantities are per "
    "unit length into the page (2-D). width_m gives w in metres."
)


# A run with polygon icebergs (``[[iceberg]] vertices``) also holds each outline: its corners
# about the centroid in the body frame over the dimension ``corner`` (zero past the iceberg's
# count), and the principal axis its capsize angle is measured by. A run of rectangles has none
# of them: its outlines are its widths and thicknesses.
OUTLINE_ATTRS = {
    "corners": {"units": "1", "long_name": "polygons: the number of corners of the iceberg's outline"},
    "corner_u": {"units": "w", "long_name": "polygons: each corner's body-frame u about the centroid (0 past corners)"},
    "corner_v": {"units": "w", "long_name": "polygons: each corner's body-frame v about the centroid (0 past corners)"},
    "axis": {"units": "rad", "long_name": "polygons: the angle from the body's v axis to its principal axis nearest it"},
}
# A run whose icebergs are partitioned into cells (``cells = [nx, nz]``) also holds each body's
# iceberg and its place in that iceberg's grid, so that the pieces can be told from the file
# (and a ``[start]`` from it keeps them); a run without cells has none of them.
CELL_ATTRS = {
    "cell_iceberg": {"units": "1", "long_name": "cells: the iceberg (0-based, in the scene's order) this body is a cell of"},
    "cell_ix": {"units": "1", "long_name": "cells: the cell's column in its iceberg's grid, across the width"},
    "cell_iz": {"units": "1", "long_name": "cells: the cell's layer in its iceberg's grid, through the thickness from the base"},
}
INTEGER_CONSTANTS = ("corners", *CELL_ATTRS)


def variable_attrs() -> dict[str, dict[str, dict[str, str]]]:
    """``{group: {variable: {"units": ..., "long_name": ...}}}`` for every variable of a run
    file, from the schema and the diagnostics table (so the file cannot drift from them)."""
    cols = {c.output: c for c in BODIES.columns if c.output}
    bergs = {k: {"units": cols[k].units, "long_name": cols[k].doc} for k in ("width", "thickness", "mass", "inertia")}
    bergs.update(OUTLINE_ATTRS)
    bergs.update(CELL_ATTRS)
    snaps = {k: {"units": cols[k].units, "long_name": cols[k].doc} for k in STATE}
    diags = {f.name: {"units": f.units, "long_name": f.long_name} for f in FIELDS}
    out = {"icebergs": bergs, "snapshots": snaps, "diagnostics": diags}
    for d in DATASETS:
        out.setdefault(d.group, {})[d.name] = {"units": d.units, "long_name": d.doc}
    for g in (snaps, diags):
        g["time"] = {"units": TIME_UNITS, "long_name": "time", "axis": "T"}
    return out


class OutputError(RuntimeError):
    """The output file cannot be written (one-line message)."""


class SnapshotTimeError(OutputError):
    """No snapshot of a run file is as early as the time asked for (one-line message)."""


class RunWriter:
    """Appends snapshots and diagnostics to one HDF5 run file.

    ``mode="w"`` creates the file (refusing an existing one unless ``overwrite``);
    ``mode="r+"`` reopens a file to resume it, truncated to ``resume_time`` (a time, or one
    per group: ``{"snapshots": t_s, "diagnostics": t_d}``), after setting
    ``attrs`` (an extended run's scene and history). ``own``: what the effects that own
    state write, ``{"dims": {dimension: length}, "constants": {path: values}}`` (their
    ``State.dims()``, ``State.constants()``): each declared dataset whose dimensions are
    there is made, the snapshot ones (``snapshots/...``) appended with every snapshot.
    """

    def __init__(
        self,
        path: str | Path,
        attrs: dict | None = None,
        constants: dict[str, np.ndarray] | None = None,
        dtype: type = np.float64,
        mode: str = "w",
        resume_time: float | dict[str, float] | None = None,
        own: dict | None = None,
        diagnostics: tuple[str, ...] | None = None,
    ):
        self.path = Path(path)
        # the diagnostics a new file holds (diagnostics.fields of its scene; default: every one);
        # a file reopened holds what it was made with
        self._diag_names = DIAGNOSTICS if diagnostics is None else tuple(diagnostics)
        self.dtype = np.dtype(dtype)
        try:
            if mode == "w":
                self.f = h5py.File(self.path, "w", locking=False)
                self._create(attrs or {}, constants or {}, own or {})
            else:
                self.f = h5py.File(self.path, "r+", locking=False)
                if attrs:  # first, with complete false: cut short, the file still says what it is
                    self.f.attrs.update({**attrs, COMPLETE_ATTR: False})
                    self.f.flush()
                self._truncate(resume_time)
            self.f.flush()
        except (OSError, RuntimeError) as exc:
            raise OutputError(f"--out {str(self.path)!r}: cannot write ({_reason(exc)})") from None
        self._pending: list[dict] = []
        # Dataset handles looked up once: h5py's group lookup costs more than a small write.
        self._state = (*STATE, *(d.name for d in DATASETS if d.group == "snapshots" and d.name in self.f["snapshots"]))
        self._updated = {d.name: self.f[d.path] for d in DATASETS if d.updated and d.path in self.f}
        self._snap = {k: self.f["snapshots"][k] for k in ("time", *self._state)}
        if mode != "w":
            self._diag_names = tuple(k for k in DIAGNOSTICS if k in self.f["diagnostics"])
        self._diag = {k: self.f["diagnostics"][k] for k in ("time", *self._diag_names)}
        self._nsnap = self._snap["time"].shape[0]
        self._ndiag = self._diag["time"].shape[0]
        # The most one write can allocate (a new chunk of every dataset, plus metadata):
        # refuse to start a write without twice that free, so a filling disk stops the run
        # between writes and the file stays whole.
        snap_chunks = sum(
            int(np.prod(ds.chunks)) * ds.dtype.itemsize for k, ds in self._snap.items() if k != "time" and ds.chunks
        )
        self._room = 2 * (snap_chunks + (len(self._diag_names) + 2) * 8192) + (64 << 10)

    @property
    def diagnostic_names(self) -> tuple[str, ...]:
        """The diagnostics this file holds (besides ``time``)."""
        return self._diag_names

    def _create(self, attrs: dict, constants: dict[str, np.ndarray], own: dict) -> None:
        f = self.f
        attrs = dict(attrs)  # history is taken out below; the caller's dict stays as it was
        version = attrs.get("melange_ti_version", "")
        f.attrs["title"] = f"melange_ti run: {attrs.get('scene_name', 'scene')}"
        f.attrs["source"] = f"melange_ti {version} (Taichi {attrs.get('taichi_version', '')})".strip()
        f.attrs["history"] = attrs.pop("history", "")
        f.attrs["references"] = REFERENCE
        f.attrs["Conventions"] = "CF-1.8"
        f.attrs["comment"] = UNITS_COMMENT
        for k, v in attrs.items():
            f.attrs[k] = v
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs[COMPLETE_ATTR] = False
        meta = variable_attrs()
        n = len(next(iter(constants.values()))) if constants else 0
        # dimension scales (netCDF-4 dimensions): iceberg at the root, time in each group
        iceberg = f.create_dataset("iceberg", data=np.arange(n, dtype=np.int64))
        iceberg.attrs.update({"units": "1", "long_name": "iceberg index (order of the initial state)"})
        iceberg.make_scale("iceberg")
        g = f.create_group("icebergs")
        corner = None
        if "corner_u" in constants:  # polygons: the outlines' dimension
            f.attrs[OUTLINE_DISCS_ATTR] = OUTLINE_DISCS
            corner = f.create_dataset("corner", data=np.arange(np.shape(constants["corner_u"])[1], dtype=np.int64))
            corner.attrs.update({"units": "1", "long_name": "corner of an iceberg's outline, counter-clockwise"})
            corner.make_scale("corner")
        for k, v in constants.items():
            ds = g.create_dataset(k, data=np.asarray(v, dtype=np.int64 if k in INTEGER_CONSTANTS else self.dtype))
            ds.dims[0].attach_scale(iceberg)
            if ds.ndim == 2:
                ds.dims[1].attach_scale(corner)
            ds.attrs.update(meta["icebergs"].get(k, {}))
        rows = max(1, min(64, 65536 // max(n, 1)))
        s = f.create_group("snapshots")
        st = s.create_dataset("time", shape=(0,), maxshape=(None,), dtype=np.float64, chunks=(256,))
        st.make_scale("time")
        st.attrs.update(meta["snapshots"]["time"])
        for k in STATE:
            ds = s.create_dataset(k, shape=(0, n), maxshape=(None, n), dtype=self.dtype, chunks=(rows, max(n, 1)))
            ds.dims[0].attach_scale(st)
            ds.dims[1].attach_scale(iceberg)
            ds.attrs.update(meta["snapshots"][k])
        # the effects' dimensions (at the root like iceberg, so netCDF readers see them from
        # every group) and the datasets they declare over them
        sizes = dict(own.get("dims", {}))
        scales = {"iceberg": iceberg}
        effect_dims = set(sizes)
        sizes["iceberg"] = n
        for name, size in sizes.items():
            if size <= 0 or name == "iceberg":
                continue
            scales[name] = f.create_dataset(name, data=np.arange(size, dtype=np.int64))
            scales[name].attrs.update({"units": "1", "long_name": DIMS[name]})
            scales[name].make_scale(name)
        for d in DATASETS:
            if not OWN_DIMS[d.path] <= effect_dims or not all(sizes.get(dim, 0) > 0 for dim in d.dims):
                continue  # an effect the scene does not name (its State gave no dims), or a dimension of no length
            shape = tuple(sizes[dim] for dim in d.dims)
            dtype = np.dtype(d.dtype) if d.dtype else self.dtype
            if d.group == "snapshots":
                rows_d = max(1, min(64, 65536 // max(1, int(np.prod(shape)))))
                ds = s.create_dataset(d.name, shape=(0, *shape), maxshape=(None, *shape), dtype=dtype, chunks=(rows_d, *shape))
                ds.dims[0].attach_scale(st)
                first = 1
            elif d.updated:
                group = f[d.group] if d.group in f else f.create_group(d.group)
                ds = group.create_dataset(d.name, data=np.full(shape, np.nan, dtype=dtype))
                first = 0
            else:
                group = f[d.group] if d.group in f else f.create_group(d.group)
                ds = group.create_dataset(
                    d.name, data=np.asarray(own["constants"][d.path], dtype=dtype if d.dtype else np.float64)
                )
                first = 0
            for k, dim in enumerate(d.dims):
                ds.dims[first + k].attach_scale(scales[dim])
            ds.attrs.update(meta[d.group][d.name])
        d = f.create_group("diagnostics")
        dt_ = d.create_dataset("time", shape=(0,), maxshape=(None,), dtype=np.float64, chunks=(1024,))
        dt_.make_scale("time")
        dt_.attrs.update(meta["diagnostics"]["time"])
        for k in self._diag_names:
            ds = d.create_dataset(
                k, shape=(0,), maxshape=(None,), dtype=np.int64 if k in DIAG_INT else np.float64, chunks=(1024,)
            )
            ds.dims[0].attach_scale(dt_)
            ds.attrs.update(meta["diagnostics"][k])

    def _truncate(self, cut: float | dict[str, float] | None) -> None:
        """Drop rows after time ``cut`` (a time per group if a dict), and any rows past the
        consistent length."""
        for group in ("snapshots", "diagnostics"):
            t = cut.get(group) if isinstance(cut, dict) else cut
            g = self.f[group]
            n = consistent_length(g)
            times = g["time"][:n]
            keep = int(np.searchsorted(times, t + 1e-9 * max(1.0, abs(t)), side="right")) if t is not None else n
            for ds in g.values():
                ds.resize(keep, axis=0)
        self.f.attrs[COMPLETE_ATTR] = False

    @property
    def snapshots_written(self) -> int:
        return self._nsnap

    def _check_room(self) -> None:
        try:
            free = shutil.disk_usage(self.path.parent).free
        except OSError:
            return
        if free < self._room:
            # a new file without a snapshot holds nothing: Simulation.run removes it
            kept = "the file holds everything up to the last write" if self._nsnap else "nothing was recorded: no file is left"
            raise OutputError(
                f"{self.path}: no space left on device ({free >> 10} kB free, a write may need {self._room >> 10} kB); {kept}"
            )

    def snapshot(self, t: float, state: dict[str, np.ndarray]) -> None:
        """Append one snapshot of every iceberg; written and flushed at once."""
        self._write((t, state))

    def diagnostic(self, row: dict[str, float]) -> None:
        """Queue one diagnostic row; rows are written at the next :meth:`flush`."""
        self._pending.append(row)

    def flush(self) -> None:
        """Write queued diagnostics (time last) and flush the file to disk."""
        self._write(None)

    def _write(self, snap: tuple[float, dict[str, np.ndarray]] | None) -> None:
        """Append a snapshot (if any) and the queued diagnostics in two flushes: every other
        dataset first, then the two ``time`` datasets. HDF5 writes its dirty metadata in
        address order at a flush, and ``time`` is each group's first dataset, so within one
        flush a reader opening the file meanwhile could see a ``time`` longer than the data
        it stands for; after the first flush the data are on disk before ``time`` grows."""
        m = len(self._pending)
        if snap is not None or m:
            self._check_room()
        try:
            if snap is not None:
                for name in self._state:
                    ds = self._snap[name]
                    ds.resize(self._nsnap + 1, axis=0)
                    ds[self._nsnap] = snap[1][name]
                for name, ds in self._updated.items():
                    ds[...] = snap[1][name]
            k = self._ndiag
            if m:
                for name in self._diag_names:
                    ds = self._diag[name]
                    ds.resize(k + m, axis=0)
                    ds[k:] = np.array([r[name] for r in self._pending], dtype=ds.dtype)
            if snap is not None or m:
                self.f.flush()  # the rows on disk before any time grows
            if m:
                ds = self._diag["time"]
                ds.resize(k + m, axis=0)
                ds[k:] = np.array([r["time"] for r in self._pending], dtype=ds.dtype)
                self._ndiag = k + m
                self._pending.clear()
            if snap is not None:
                ds = self._snap["time"]
                ds.resize(self._nsnap + 1, axis=0)
                ds[self._nsnap] = snap[0]
                self._nsnap += 1
            self.f.flush()
        except (OSError, RuntimeError) as exc:
            raise OutputError(f"{self.path}: write failed ({self._reason(exc)})") from None

    def _reason(self, exc: Exception) -> str:
        """errno text if there is one; HDF5's own errors carry none, so check the disk."""
        if getattr(exc, "errno", None):
            return os.strerror(exc.errno)
        try:
            if shutil.disk_usage(self.path.parent).free < 1 << 20:
                return "no space left on device"
        except OSError:
            pass
        return _reason(exc)

    def close(self, complete: bool = False) -> None:
        """Flush and close; after a failed write, close without raising again."""
        if not self.f.id.valid:
            return
        try:
            self.flush()
            if complete:
                self.f.attrs[COMPLETE_ATTR] = True
                self.f.flush()
        except (OSError, RuntimeError, OutputError):
            if complete:
                raise
        finally:
            try:
                self.f.close()
            except (OSError, RuntimeError):
                pass


def _reason(exc: Exception) -> str:
    text = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
    if getattr(exc, "errno", None):
        return os.strerror(exc.errno)
    return text


def consistent_length(group: h5py.Group) -> int:
    """Rows of a group that every dataset holds (the time dataset is written last)."""
    return min(ds.shape[0] for ds in group.values())


def consistent_lengths(path: str | Path, complete: bool = False):
    """``{"snapshots": S, "diagnostics": D}``: the rows every dataset of each group holds;
    with ``complete``, also whether the run finished (its ``complete`` attribute)."""
    with _reading(path) as f:
        lengths = {group: consistent_length(f[group]) for group in ("snapshots", "diagnostics")}
        return (lengths, bool(f.attrs.get(COMPLETE_ATTR, False))) if complete else lengths


@contextlib.contextmanager
def _reading(path: str | Path):
    """The run file open for reading (h5py's default locking, see the module's docstring);
    a missing or unreadable file is a one-line :class:`OutputError`."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            yield f
    except FileNotFoundError:
        raise OutputError(f"{path}: not found") from None
    except (OSError, KeyError, ValueError, RuntimeError) as exc:
        raise OutputError(f"{path}: not a readable melange_ti run file ({str(exc).splitlines()[0]})") from None


def is_partial(path: str | Path) -> bool:
    """Whether the run file says its run has not finished (stopped, or still running); a
    file without the ``complete`` attribute (hand-made) counts as finished."""
    with _reading(path) as f:
        return COMPLETE_ATTR in f.attrs and not bool(f.attrs[COMPLETE_ATTR])


def read_run(path: str | Path) -> dict:
    """Load a run file into plain numpy arrays, cut to consistent lengths.

    Returns ``{"attrs": {...}, "icebergs": {...}, "snapshots": {...}, "diagnostics": {...}}``,
    and each group an effect declares that the file holds (``{group: {name: values}}``:
    its datasets written once, :data:`DATASETS`). Raises :class:`OutputError` with one line for a file that is not a readable run.
    """
    with _reading(path) as f:
        out = {"attrs": {k: _plain(v) for k, v in f.attrs.items()}}
        for group in GROUPS:
            g = f[group]
            n = consistent_length(g) if group != "icebergs" else None
            out[group] = {k: (ds[:n] if n is not None else ds[:]) for k, ds in g.items()}
        for group in sorted({d.group for d in DATASETS} - set(GROUPS)):
            if group in f:
                out[group] = {k: ds[:] for k, ds in f[group].items()}
    return out


def read_diagnostics(path: str | Path) -> dict[str, np.ndarray]:
    """The ``/diagnostics`` group alone as ``{name: values}``, cut to its consistent length
    (the run's energy budget at its end, without reading the snapshots)."""
    with _reading(path) as f:
        g = f["diagnostics"]
        n = consistent_length(g)
        return {k: ds[:n] for k, ds in g.items()}


def read_group(path: str | Path, group: str) -> tuple[dict, np.ndarray] | None:
    """One group an effect declares (:data:`DATASETS`, written once) as ``{name: values}``,
    with the snapshots' times (to their consistent length); ``None`` if the file has no
    such group. One-line :class:`OutputError` for a file that is not a readable run."""
    with _reading(path) as f:
        if group not in f:
            return None
        snaps = f["snapshots"]
        return {k: ds[:] for k, ds in f[group].items()}, snaps["time"][: consistent_length(snaps)]


def _plain(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.generic):
        return v.item()
    return v


def scene_text(path: str | Path, data: dict) -> str:
    """The resolved scene a run file was made with, as TOML text (from :func:`read_run` data)."""
    text = data["attrs"].get(SCENE_ATTR)
    if not isinstance(text, str):
        raise OutputError(f"{path}: not a melange_ti run file (no {SCENE_ATTR} attribute)")
    return text


def run_status(path: str | Path) -> tuple[str | None, bool] | None:
    """``(stored scene text or None, complete)`` of a run file; ``None`` if it cannot be read."""
    try:
        with h5py.File(path, "r") as f:  # default locking (the module docstring)
            text = _plain(f.attrs.get(SCENE_ATTR))
            return (None if text is None else str(text)), bool(f.attrs.get(COMPLETE_ATTR, False))
    except (OSError, ValueError, KeyError):
        return None


def last_row(path: str | Path, names: tuple[str, ...]) -> dict[str, float]:
    """The last consistent diagnostic row's ``names`` (with ``time``); empty if there is none
    or the file cannot be read."""
    try:
        with h5py.File(path, "r") as f:
            g = f["diagnostics"]
            n = consistent_length(g)
            return {k: float(g[k][n - 1]) for k in ("time", *names)} if n else {}
    except (OSError, KeyError, ValueError):
        return {}


def last_snapshot(path: str | Path, time: float = math.inf) -> dict[str, np.ndarray | float]:
    """The last snapshot at or before ``time`` (within 1e-9 relative): ``{"time": t, "x": ...,
    ..., "omega": ..., "width": ..., "thickness": ...}``, float64 arrays of shape (N,); a run
    of polygons adds ``outline`` (N, corners, 2) and ``corners`` (N,) (:data:`OUTLINE_ATTRS`),
    one of cells ``parent`` (N,) and ``cell`` (N, 2) (:data:`CELL_ATTRS`).
    One-line :class:`OutputError` for an unreadable file or one without snapshots,
    :class:`SnapshotTimeError` if the first snapshot is later than ``time``."""
    data = read_run(path)
    times = data["snapshots"]["time"]
    if times.size == 0:
        raise OutputError(f"{path}: the run has no snapshot")
    k = int(np.searchsorted(times, time + 1e-9 * max(1.0, abs(time)), side="right")) - 1 if time < math.inf else -1
    if k < 0 and time < math.inf:
        raise SnapshotTimeError(f"before the run's first snapshot (t = {times[0]:g})")
    out: dict = {"time": float(times[k])}
    out.update({name: np.asarray(data["snapshots"][name][k], dtype=np.float64) for name in STATE})
    out.update({name: np.asarray(data["icebergs"][name], dtype=np.float64) for name in ("width", "thickness")})
    if "corner_u" in data["icebergs"]:  # polygons: the outlines, (N, corners, 2) and their counts
        g = data["icebergs"]
        out["outline"] = np.stack([np.asarray(g["corner_u"], dtype=np.float64), np.asarray(g["corner_v"], dtype=np.float64)], -1)
        out["corners"] = np.asarray(g["corners"], dtype=np.int64)
    if "cell_iceberg" in data["icebergs"]:  # cells: each body's iceberg and place in its grid
        g = data["icebergs"]
        out["parent"] = np.asarray(g["cell_iceberg"], dtype=np.int64)
        out["cell"] = np.stack([np.asarray(g["cell_ix"], dtype=np.int64), np.asarray(g["cell_iz"], dtype=np.int64)], -1)
    return out
