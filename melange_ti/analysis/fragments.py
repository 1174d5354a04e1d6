"""Fragments as bodies: the pieces of ice of a run's snapshots, each a union of bodies (cells
or whole icebergs) held together by intact bonds, described as one body of ice.

For every snapshot and every fragment (``/snapshots/fragment``'s labels; without the bonds
effect each body is its own fragment): the bodies it holds, its area, its centroid, its width
and thickness along the principal axes of its area (the rectangle of the same area and second
moments: ``L = sqrt(12 lambda_1 / A)``, ``H = sqrt(12 lambda_2 / A)``, ``lambda_1 >= lambda_2``
the eigenvalues of ``int r r^T dA`` about the centroid), the long axis' angle from the
horizontal, its aspect ``H / L`` against the capsize threshold of an upright rectangle (an
upright fragment thinner than ``sqrt(6 r (1 - r))`` in ``width / thickness`` rolls; SPEC
section 2), and whether it has **capsized**: its rotation, the area-weighted mean of its
bodies' tilts, has taken the axis the bodies' capsize is measured by 45 degrees or more from
vertical (a single body: :func:`melange_ti.diagnostics.capsized`, the rule of
``capsized_fraction``), so a rolled fragment of many cells counts as capsized.
:func:`capsized_area_fraction` sums the capsized fragments' areas over the ice's.

Read from the run file alone (numpy and pandas; xarray's dependency): ``table`` holds one
row per fragment per snapshot. :func:`celled` says whether a run's bodies are cells (then
``melange-ti plot`` measures a piece by its area, not by its bodies), :func:`check_labels`
refuses labels that are not body indices in one line (``plot`` and ``render --fragments``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import diagnostics
from ..geometry import body_outlines, polygon_moments
from ..io.hdf5 import OutputError, read_run

COLUMNS = (
    "time",
    "fragment",
    "bodies",
    "area",
    "x",
    "z",
    "length",
    "height",
    "axis_angle",
    "aspect",
    "rolls_on_end",
    "tilt",
    "capsized",
)


def body_moments(icebergs: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each body's area (N,), centroid offset in its body frame (N, 2; 0 but for rounding)
    and second moments ``(int u^2, int v^2, int u v) dA`` about its centroid in its body frame
    (N, 3), from a run's ``/icebergs``."""
    outlines = body_outlines(icebergs)
    out = [polygon_moments(_unpadded(o)) for o in outlines]
    return np.array([a for a, _, _ in out]), np.array([c for _, c, _ in out]), np.array([s for _, _, s in out])


def _unpadded(corners: np.ndarray) -> np.ndarray:
    """An outline without the repeated last corners :func:`body_outlines` pads with."""
    keep = np.ones(len(corners), dtype=bool)
    keep[1:] = np.any(np.diff(corners, axis=0) != 0, axis=1)
    return corners[keep]


def snapshot_fragments(x, z, theta, labels, area, offset, second, density_ratio: float, axis=None) -> list[dict]:
    """The fragments of one snapshot (bodies' poses ``x, z, theta``, fragment ``labels``), from
    the bodies' areas, centroid offsets and body-frame second moments; ``axis``: the bodies'
    capsize axes (``/icebergs/axis``, polygons) or ``None``. ``rolls_on_end``: stood on its
    short side, the fragment would roll (its aspect below ``sqrt(6 r (1 - r))``)."""
    c, s = np.cos(theta), np.sin(theta)
    cx = x + c * offset[:, 0] - s * offset[:, 1]
    cz = z + s * offset[:, 0] + c * offset[:, 1]
    uu, vv, uv = second[:, 0], second[:, 1], second[:, 2]
    # the body-frame tensor turned into the world: J = R J_b R^T
    jxx = c * c * uu - 2 * c * s * uv + s * s * vv
    jzz = s * s * uu + 2 * c * s * uv + c * c * vv
    jxz = c * s * (uu - vv) + (c * c - s * s) * uv
    threshold = 1.0 / diagnostics.critical_aspect(density_ratio)  # width / thickness below which upright rolls
    out = []
    for label in np.unique(labels):
        k = np.flatnonzero(labels == label)
        a = area[k]
        total = float(a.sum())
        mx, mz = float(a @ cx[k]) / total, float(a @ cz[k]) / total
        dx, dz = cx[k] - mx, cz[k] - mz
        j = np.array(
            [
                [float(jxx[k].sum() + a @ (dx * dx)), float(jxz[k].sum() + a @ (dx * dz))],
                [float(jxz[k].sum() + a @ (dx * dz)), float(jzz[k].sum() + a @ (dz * dz))],
            ]
        )
        lam, vec = np.linalg.eigh(j)  # ascending
        length, height = np.sqrt(12.0 * np.maximum(lam[::-1], 0.0) / total)
        long_axis = vec[:, 1]
        angle = float(np.arctan2(long_axis[1], long_axis[0]))
        angle = (angle + np.pi / 2) % np.pi - np.pi / 2  # an axis: in [-pi/2, pi/2)
        tilt = float(a @ theta[k]) / total
        spin = None if axis is None else np.array([float(a @ axis[k]) / total])
        out.append(
            dict(
                fragment=int(label),
                bodies=int(k.size),
                area=total,
                x=mx,
                z=mz,
                length=float(length),
                height=float(height),
                axis_angle=angle,
                aspect=float(height / length) if length > 0 else 1.0,
                rolls_on_end=bool(height / length < threshold) if length > 0 else False,
                tilt=tilt,
                capsized=bool(diagnostics.capsized(np.array([tilt]), spin)[0]),
            )
        )
    return out


def fragment_table(path: str | Path, times=None):
    """One row per fragment per snapshot of the run file ``path`` (``times``: only the
    snapshots nearest these), as a :class:`pandas.DataFrame` of :data:`COLUMNS` (lengths in w,
    areas in w^2, angles in rad)."""
    return table_of(read_run(str(path)), times)


def table_of(data: dict, times=None):
    """:func:`fragment_table` of a run file already read (:func:`melange_ti.io.hdf5.read_run`)."""
    import pandas as pd
    import tomllib

    from ..io.hdf5 import SCENE_ATTR

    snaps, bergs = data["snapshots"], data["icebergs"]
    scene = tomllib.loads(str(data["attrs"][SCENE_ATTR]))
    r = float(scene.get("physics", {}).get("density_ratio", 0.8946))
    area, offset, second = body_moments(bergs)
    axis = np.asarray(bergs["axis"]) if "axis" in bergs else None
    t = np.asarray(snaps["time"])
    which = range(len(t)) if times is None else sorted({int(np.argmin(np.abs(t - q))) for q in np.atleast_1d(times)})
    n = area.size
    rows = []
    for k in which:
        labels = np.asarray(snaps["fragment"][k]) if "fragment" in snaps else np.arange(n)
        for row in snapshot_fragments(snaps["x"][k], snaps["z"][k], snaps["theta"][k], labels, area, offset, second, r, axis):
            rows.append({"time": float(t[k]), **row})
    return pd.DataFrame(rows, columns=list(COLUMNS))


def capsized_area_fraction(table):
    """The capsized fragments' share of the ice's area at each snapshot of ``table``
    (:func:`fragment_table`), a :class:`pandas.Series` indexed by time: a rolled fragment of
    many cells counts by its area, beside the body count ``capsized_fraction``."""
    capsized = table["area"].where(table["capsized"], 0.0)
    return capsized.groupby(table["time"]).sum() / table["area"].groupby(table["time"]).sum()


def check_labels(path, labels, n: int, flag: str = "") -> None:
    """One-line :class:`OutputError` (after ``flag``, the option that reads them) if the
    fragment labels ``labels`` (snapshots, bodies) are not indices of the run's ``n`` bodies:
    a corrupted file is refused, not drawn wrong."""
    labels = np.asarray(labels)
    bad = (labels < 0) | (labels >= n) if labels.dtype.kind in "iu" else np.ones(labels.shape, bool)
    if labels.ndim != 2 or labels.shape[1] != n or bad.any():
        k = int(np.argmax(bad.any(axis=-1))) if labels.ndim == 2 and bad.any() else 0
        raise OutputError(
            f"{flag}{path}: /snapshots/fragment (snapshot {k}) holds labels that are not iceberg indices 0..{n - 1}"
        )


def celled(icebergs) -> bool:
    """Whether a run's bodies are cells of icebergs: its ``/icebergs`` (a mapping, from
    :func:`melange_ti.io.hdf5.read_run`) holds each body's iceberg (``cell_iceberg``), as a run with
    ``cells`` on its ``[shelf]`` or an ``[[iceberg]]`` writes it, and a ``[start]`` from one
    keeps it."""
    return "cell_iceberg" in icebergs
