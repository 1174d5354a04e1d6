"""The Python API: load a scene, run it, open the result (also at the package's top level)::

    import melange_ti as mt

    scene = mt.load_scene("runs/paper.toml", overrides={"shelf.count": 50})
    summary = mt.run(scene, "out.h5")          # initialises Taichi itself
    tree = mt.open_run("out.h5")               # xarray.DataTree of the file

Errors are the command line's, as exceptions with the same one-line messages:
:class:`SceneError` (a scene or value that cannot be run), :class:`RunError` (an output that
exists, a resume that cannot continue), :class:`ArchError` (no usable backend),
:class:`OutputError` (a file that cannot be written or read), :class:`NumericalError` and
:class:`ContactOverflow` (a run stopped by a guard; its output up to there is kept),
:class:`Interrupted` (Ctrl-C, a ``KeyboardInterrupt``: a checkpoint is written where the run
stopped; ``resume=True`` continues it). :func:`extend` continues a run to a later time.
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .analysis.fragments import capsized_area_fraction, fragment_table  # noqa: F401  (the package's API)
from .energy import runaway, total_energy
from .errors import ArchError, ContactOverflow, Interrupted, NumericalError, RunError
from .io.hdf5 import OutputError
from .scene import Scene, SceneError


def load_scene(path: str | Path | None = None, overrides: Mapping[str, Any] | None = None) -> Scene:
    """The scene in the TOML file ``path`` (``None``: the bundled paper scene), with
    ``overrides`` such as ``{"time.dt": 0.005, "shelf.count": 50}`` applied and everything
    validated. Raises :class:`SceneError` with a one-line message."""
    from . import scene

    return scene.load(path, list((overrides or {}).items()))


def validated(scene: Scene, geometry: bool = True) -> Scene:
    """``scene`` checked again as if read from a file (e.g. after :func:`dataclasses.replace`),
    so what runs and what the output stores are the same text; ``geometry=False`` skips the
    initial state's checks (for a resumed run, whose ``[start]`` file may have moved)."""
    from . import scene as scn

    if not isinstance(scene, Scene):
        raise SceneError(f"scene = {type(scene).__name__}: must be a melange_ti Scene (see load_scene)")
    return scn.loads(scene.to_toml(), geometry=geometry)


def run(
    scene: Scene,
    out: str | Path,
    *,
    overwrite: bool = False,
    resume: bool = False,
    arch: str = "cpu",
    threads: int | None = None,
    progress: bool | None = False,
):
    """Run ``scene`` into the run file ``out`` and return its :class:`RunSummary`.

    The scene is validated again (a scene changed with :func:`dataclasses.replace` is checked
    like a file) and stored in the output exactly as run. Taichi is initialised on demand
    for ``arch``, ``threads`` and the scene's precision. An existing ``out`` is refused
    unless ``overwrite``; ``resume`` continues an interrupted run from its checkpoint, with
    ``scene`` equal to the stored one but for ``time.duration``: a later one extends the run,
    finished or not (as :func:`extend`)."""
    from . import runtime
    from .simulation import Simulation

    scene = validated(scene, geometry=not resume)
    sim = Simulation(
        scene, out, overwrite=overwrite, resume=resume, arch=arch, progress=progress, history="melange_ti.run()", interface="api"
    )
    runtime.init(arch, threads, scene.precision)
    return sim.run()


def extend(path: str | Path, duration: float, *, arch: str = "cpu", threads: int | None = None, progress: bool | None = False):
    """Continue the run in ``path``, finished or stopped on the way, to the later time
    ``duration`` with the scene stored in it, and return its :class:`RunSummary`. The file
    grows bit for bit as if the run had gone to ``duration`` at once (from the checkpoint
    ``path.ckpt`` that a finished run keeps for this); its ``scene_toml`` then holds the new
    ``time.duration`` and its ``history`` says when it changed. Stopped on the way, the file
    keeps what it held and ``run(..., resume=True)`` or ``extend`` again goes on."""
    from . import scene as scn

    stored = scn.stored_scene(path)
    scene = scn.loads(stored.to_toml(), [("time.duration", duration)], geometry=False)
    return run(scene, path, resume=True, arch=arch, threads=threads, progress=progress)


_OPEN_ATTEMPTS = 20


def _close_handles(path: Path) -> None:
    """Close every HDF5 handle this process holds on ``path``."""
    import h5py

    target = os.path.realpath(path)
    for fid in h5py.h5f.get_obj_ids(types=h5py.h5f.OBJ_FILE):
        try:
            name = fid.name.decode() if isinstance(fid.name, bytes) else str(fid.name)
            if os.path.realpath(name) == target:
                while fid.valid:
                    fid.close()
        except (OSError, ValueError, RuntimeError):
            pass


def _open_tree(xr, path: Path, complete: bool):
    """The file as a DataTree. A file still being written (or cut short) is read through
    a Python file object of its own: HDF5 then shares nothing with any earlier open of the
    file in this process (with a path, it serves a new open from a still-open view of the
    same file, which a failed open can leave behind: stale, it never shows a later row).
    Closing the tree closes that file object too. h5py's default locking, as a user's own
    ``h5py.File(path)`` or ``xr.open_datatree(path, engine="h5netcdf")`` takes it: HDF5
    refuses two opens of one file in a process with different locking flags."""
    kw = dict(engine="h5netcdf", phony_dims="access")
    if complete:
        return xr.open_datatree(path, **kw)
    fh = open(path, "rb")  # noqa: SIM115 (closed with the tree)
    try:
        tree = xr.open_datatree(fh, **kw)
    except BaseException:
        fh.close()
        raise
    close_root = tree._close

    def close() -> None:
        try:
            if close_root is not None:
                close_root()
        finally:
            fh.close()

    tree.set_close(close)
    return tree


# Variables of the run file whose name an attribute of xarray's DataTree or Dataset takes
# first, so ``tree["icebergs"].width`` is DataTree's own ``width`` (an integer) and not the
# variable: read these as ``tree["icebergs"]["width"]`` (docs/output.md, README). The file's
# names are the contract and stay; tests/test_analysis.py finds every such name anew.
XARRAY_SHADOWED = ("icebergs/width",)


def open_run(path: str | Path):
    """The run file ``path`` as an :class:`xarray.DataTree`: groups ``icebergs``,
    ``snapshots`` and ``diagnostics`` with named dimensions ``time`` and ``iceberg``, ``time``
    as a coordinate, ``units`` and ``long_name`` on every variable. What an effect declares
    is there too (docs/output.md): its groups, and its snapshot variables over its own
    dimensions, each dimension's declared coordinate attached to every group that has the
    dimension (docs/output.md shows one plotted against it). A file still being
    written (or cut short by a kill) is read up to its last consistent row. The tree reads
    lazily and keeps the file open: close it (``tree.close()``, or ``with mt.open_run(p) as
    tree:``) before opening the file again to see rows written since. Read a variable by
    item, ``tree["icebergs"]["width"]``, where an xarray attribute shadows its name
    (:data:`XARRAY_SHADOWED`); attribute access works for the others."""
    import xarray as xr

    from .io.hdf5 import DATASETS, consistent_lengths

    path = Path(path)
    for attempt in range(_OPEN_ATTEMPTS):
        lengths, complete = consistent_lengths(path, complete=True)  # also: one-line OutputError for a missing or foreign file
        try:
            tree = _open_tree(xr, path, complete)
            break
        except (OSError, KeyError, ValueError) as exc:
            # a file being written (HDF5 without SWMR) can be caught mid-write; the failed
            # open leaves its handle open, and HDF5 would serve every later open of the file
            # from that stale view: close it, wait a moment, try again
            _close_handles(path)
            if attempt == _OPEN_ATTEMPTS - 1:
                raise OutputError(f"{path}: cannot be read now ({str(exc).splitlines()[0]}); try again") from None
            time.sleep(0.05 * (attempt + 1))
    try:
        for group, n in lengths.items():
            node = tree[group]
            if "time" in node.dims and node.sizes["time"] != n:
                tree[group] = node.to_dataset().isel(time=slice(0, n))
        for d in DATASETS:
            # a declared coordinate (a dimension's positions) on every group with its dimension
            if d.coordinate and d.group in tree.children:
                for group in tree.children:
                    if d.dims[0] in tree[group].dims and group != d.group:
                        tree[group] = tree[group].to_dataset().assign_coords({d.coordinate: tree[d.group][d.name].variable})
    except Exception:
        tree.close()  # an open handle would pin HDF5's view of a growing file
        raise
    return tree


__all__ = [
    "ArchError",
    "ContactOverflow",
    "Interrupted",
    "NumericalError",
    "OutputError",
    "RunError",
    "Scene",
    "SceneError",
    "extend",
    "load_scene",
    "open_run",
    "run",
    "runaway",
    "total_energy",
    "validated",
]
