"""Restart checkpoints: everything the next step depends on, written atomically.

A checkpoint is an ``.npz`` file beside the run file (``RUN.h5.ckpt``), written to a
temporary name, fsynced, then renamed over the previous one, so a kill at any moment leaves
either the old or the new checkpoint, never a torn one.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np


def checkpoint_path(run_path: str | Path) -> Path:
    run_path = Path(run_path)
    return run_path.with_name(run_path.name + ".ckpt")


def save(path: str | Path, data: dict[str, np.ndarray | str | int | float]) -> None:
    """Write ``data`` atomically (tmp + fsync + rename + directory fsync)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as fh:
        np.savez(fh, **{k: np.asarray(v) for k, v in data.items()})
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


def load(path: str | Path) -> dict[str, np.ndarray]:
    with np.load(Path(path), allow_pickle=False) as z:
        return {k: z[k] for k in z.files}
