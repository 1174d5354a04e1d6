"""The scene a run file was made with, as a :class:`~.core.Scene` (the file's own text from
:mod:`melange_ti.io.hdf5`). Its keys are validated; its geometry is not: the scene ran
already, and a ``[start]`` file it began from need not exist any more (plotting and resuming
read the run file alone)."""

from __future__ import annotations

from pathlib import Path

from ..io.hdf5 import read_run, scene_text
from .core import Scene, loads
from .errors import SceneError


def stored_scene(path: str | Path, data: dict | None = None) -> Scene:
    """The scene stored in the run file ``path`` (``data``: its :func:`read_run` contents, if
    read already); one-line :class:`~melange_ti.io.hdf5.OutputError` or :class:`SceneError`."""
    text = scene_text(path, read_run(path) if data is None else data)
    try:
        return loads(text, geometry=False)
    except SceneError as exc:
        raise SceneError(f"{path}: stored scene: {exc}") from None
