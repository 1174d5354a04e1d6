"""Restart checkpoints: everything the next step depends on, written atomically.

A checkpoint is an ``.npz`` file beside the run file (``RUN.h5.ckpt``), written to a
temporary name, fsynced, then renamed over the previous one, so a kill at any moment leaves
either the old or the new checkpoint, never a torn one. A finished run keeps the one at its
end: from it the run can be extended to a later time (docs/reliability.md).
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np


def checkpoint_path(run_path: str | Path) -> Path:
    run_path = Path(run_path)
    return run_path.with_name(run_path.name + ".ckpt")


FORMAT_VERSION = 11  # 11: an owning effect's table gained columns (the largest stresses its rows' check saw);
# 10: an owning effect's table gained columns (its neighbours along a line, a crack's tip);
# 9: an owning effect's table gained a column (TOUCHING: a joint's walls touch);
# 8: the icebergs' outlines (a polygon's corners), besides width and thickness;
# 7: an owning effect's table gained a column; an effect's per-body state carried (BODY_CARRIED);
# 6: the coloured passes' counters; an owning effect's table may have changed its rows;
# 5: an effect's run-wide ledger in acc (and an owning effect's table, under its name);
# 4: the friction ledger in acc;
# 3: ledgers and counters named by the schema
# Versions a resume still reads: a version-7 checkpoint lacks only the outlines, which a run of
# rectangles does not need (Simulation._check_resume refuses one of a run with polygons); a
# version-8 to -10 one differs only in an owning effect's table, refused there when it is narrower
READABLE = (7, 8, 9, 10, FORMAT_VERSION)


def save(path: str | Path, data: dict[str, np.ndarray | str | int | float]) -> None:
    """Write ``data`` atomically (tmp + fsync + rename + directory fsync).

    Raises ``OSError`` (e.g. a full disk) with the previous checkpoint left intact and no
    temporary file behind."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        with open(tmp, "wb") as fh:
            np.savez(fh, format_version=FORMAT_VERSION, **{k: np.asarray(v) for k, v in data.items()})
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError:
        tmp.unlink(missing_ok=True)
        raise
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


def load(path: str | Path) -> dict[str, np.ndarray]:
    """Read a checkpoint; ``ValueError`` if it is damaged or from another format version."""
    try:
        with np.load(Path(path), allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, EOFError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        raise ValueError(f"damaged ({exc.__class__.__name__})") from None
    if int(data.get("format_version", -1)) not in READABLE:
        raise ValueError(
            f"format version {int(data.get('format_version', -1))}, expected {FORMAT_VERSION} (written by another "
            "melange_ti version: continue the run with that version, or start it again)"
        )
    return data
