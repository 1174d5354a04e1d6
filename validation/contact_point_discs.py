"""Where a corner's contact acts: the discs' merge against the outlines (issue 50, item 5).

    python validation/contact_point_discs.py --out validation/results/contact_point_discs   # ~2 min on one core

The leaning front of validation/impact_stress.py (the N = 50 shelf cut at 20 degrees, seed 1,
bonded to the wall, unbreakable bonds, crushing at its defaults, ``dt`` = 0.00125) is run at
28, 56 and 112 discs, one step at a time, and after each step every contact between the
free front block and the shelf is read from the model's contact table: its point and
normal, which the narrow phase merges from the closing disc pairs (docs/model.md,
Contacts). Beside it, the same contact as the two outlines give it: the corner of one body
deepest past the other's nearest face (the point a corner-on-face contact has, whatever the
discs). For each, the lever arm of a unit force along the normal about the struck block's
centre, ``h = (p - c) x n``: the moment the contact puts into the shelf's bonds is the
contact force times ``h``.

Writes ``contact_point_discs.csv.gz`` (one row per step and contact) and
``contact_point_discs.png`` (the lever arm against time, merge and outline, per disc count),
and prints per disc count the first contact's time, the lever arm's mean and range over the
contact's life, and the merge point's mean distance from the outline's corner.
"""

from __future__ import annotations

import argparse
import csv
import gzip
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "validation"))

from impact_stress import PRESSURE, leaning_front  # noqa: E402

DT = 0.00125
DURATION = 6.0
DISCS = (28, 56, 112)


def world_corners(b: np.ndarray, i: int, body) -> np.ndarray:
    """Body i's outline corners in the world frame, counter-clockwise."""
    n = int(round(b[i, body.CORNERS]))
    c, s = math.cos(b[i, body.TH]), math.sin(b[i, body.TH])
    uv = np.array([[b[i, body.U0 + 2 * k], b[i, body.U0 + 2 * k + 1]] for k in range(n)])
    return np.stack([b[i, body.X] + c * uv[:, 0] - s * uv[:, 1], b[i, body.Z] + s * uv[:, 0] + c * uv[:, 1]], -1)


def deepest_corner(corners: np.ndarray, other: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The corner of ``corners`` deepest past ``other``'s outline (convex, counter-clockwise):
    for each corner its largest signed distance to ``other``'s edge lines (negative inside);
    the corner whose largest is smallest, with the outward normal of ``other``'s face it is
    nearest and that distance."""
    best = (None, None, math.inf)
    m = len(other)
    for p in corners:
        dists = []
        for k in range(m):
            a, b = other[k], other[(k + 1) % m]
            e = b - a
            n = np.array([e[1], -e[0]]) / math.hypot(*e)  # outward for counter-clockwise
            dists.append(float(np.dot(p - a, n)))
        k = int(np.argmax(dists))
        if dists[k] < best[2]:
            e = other[(k + 1) % m] - other[k]
            best = (p, np.array([e[1], -e[0]]) / math.hypot(*e), dists[k])
    return best


def outline_contact(b, i, j, body) -> tuple[np.ndarray, np.ndarray]:
    """The pair's contact from the outlines: the deeper of i's corner into j and j's into i;
    the normal pointing from j to i, as the contact table's does."""
    ci, cj = world_corners(b, i, body), world_corners(b, j, body)
    pi, nj, di = deepest_corner(ci, cj)  # i's corner near j's face: j's outward normal, j -> i
    pj, ni, dj = deepest_corner(cj, ci)  # j's corner near i's face: i's outward normal, i -> j
    return (pi, nj) if di <= dj else (pj, -ni)


def lever(p, n, c) -> float:
    """``(p - c) x n``: the moment about ``c`` of a unit force along ``n`` at ``p``."""
    return float((p[0] - c[0]) * n[1] - (p[1] - c[1]) * n[0])


def track(discs: int, spacing: float) -> list[dict]:
    from melange_ti import runtime, scene
    from melange_ti.model import Model
    from melange_ti.physics.data.schema import Body, BodyInt, Contact

    runtime.init("cpu", threads=1)
    m = Model(scene.loads(leaning_front(DT, discs, PRESSURE, DURATION), [("contacts.disc_spacing", spacing)]))
    front = int(np.argmax(m.state()["x"]))
    rows = []
    for step in range(1, round(DURATION / DT) + 1):
        m.advance(1)
        bi = m.arrays.bi.to_numpy()
        cp = m.arrays.cp.to_numpy()
        cd = m.arrays.cd.to_numpy()
        b = None
        for i in range(bi.shape[0]):
            for q in range(int(bi[i, BodyInt.NCONTACT])):
                j = int(cp[q, i])
                if front not in (i, j) or j < 0:
                    continue
                if b is None:
                    b = m.arrays.b.to_numpy()
                struck = j if i == front else i
                p = cd[q, i, [Contact.PX, Contact.PZ]]
                n = cd[q, i, [Contact.NX, Contact.NZ]]  # from j to i
                po, no = outline_contact(b, i, j, Body)
                c = b[struck, [Body.X, Body.Z]]
                rows.append(
                    dict(
                        discs=discs,
                        spacing=spacing,
                        t=round(step * DT, 6),
                        i=i,
                        j=j,
                        gap=float(cd[q, i, Contact.GAP]),
                        px=float(p[0]),
                        pz=float(p[1]),
                        nx=float(n[0]),
                        nz=float(n[1]),
                        outline_px=float(po[0]),
                        outline_pz=float(po[1]),
                        outline_nx=float(no[0]),
                        outline_nz=float(no[1]),
                        lever=lever(p, n, c),
                        outline_lever=lever(po, no, c),
                        point_offset=float(np.hypot(*(p - po))),
                        normal_angle=float(math.degrees(math.atan2(n[0] * no[1] - n[1] * no[0], float(np.dot(n, no))))),
                    )
                )
    return rows


def summary(rows: list[dict]) -> None:
    spacing = rows[0]["spacing"]
    print(f"disc spacing {spacing:g} radii: a disc rolling over a face's discs tilts the normal by up to "
          f"asin(spacing / 4) = {math.degrees(math.asin(spacing / 4)):.1f} deg at every disc count")  # fmt: skip
    for discs in DISCS:
        mine = [r for r in rows if r["discs"] == discs and r["gap"] <= 0.0]
        if not mine:
            print(f"discs = {discs}: no touching contact")
            continue
        lev = np.array([r["lever"] for r in mine])
        olev = np.array([r["outline_lever"] for r in mine])
        off = np.array([r["point_offset"] for r in mine])
        ang = np.array([abs(r["normal_angle"]) for r in mine])
        print(
            f"discs = {discs}: touching from t = {mine[0]['t']:.4f} for {len(mine)} contact-steps; "
            f"lever arm (merge) mean {lev.mean():.4f} range {lev.min():.4f}..{lev.max():.4f}; "
            f"(outline) mean {olev.mean():.4f} range {olev.min():.4f}..{olev.max():.4f}; "
            f"merge point {off.mean():.4f} from the outline's (max {off.max():.4f}); "
            f"normals {ang.mean():.2f} deg apart (max {ang.max():.2f})",
            flush=True,
        )


def draw(rows: list[dict], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4), layout="constrained")
    for discs, colour in zip(DISCS, ("tab:blue", "tab:orange", "tab:green"), strict=True):
        mine = [r for r in rows if r["discs"] == discs and r["gap"] <= 0.0]
        t = [r["t"] for r in mine]
        axes[0].plot(t, [r["lever"] for r in mine], ".", ms=2, color=colour, label=f"merge, {discs} discs")
        axes[0].plot(t, [r["outline_lever"] for r in mine], "-", lw=0.8, color=colour, label=f"outline, {discs} discs")
        axes[1].plot(t, [r["point_offset"] for r in mine], ".", ms=2, color=colour, label=f"{discs} discs")
    axes[0].set(xlabel="t (sqrt(w/g))", ylabel="lever arm about the struck block's centre (w)")
    axes[1].set(xlabel="t (sqrt(w/g))", ylabel="merge point's distance from the outline's (w)")
    for ax in axes:
        ax.legend(fontsize=7)
    spacing = rows[0]["spacing"]
    fig.suptitle(f"The leaning front's touching contact: the discs' merge against the outlines (disc spacing {spacing:g} radii)")
    fig.savefig(out / "contact_point_discs.png", dpi=120)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=ROOT / "validation" / "results" / "contact_point_discs")
    p.add_argument("--no-run", action="store_true", help="summarise and redraw from the CSV in --out")
    p.add_argument("--spacing", type=float, default=2.0, help="contacts.disc_spacing (disc radii; 2: the paper's)")
    a = p.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "contact_point_discs.csv.gz"
    if a.no_run:
        with gzip.open(path, "rt", newline="") as fh:
            rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    else:
        rows = [r for discs in DISCS for r in track(discs, a.spacing)]
        with gzip.open(path, "wt", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    summary(rows)
    draw(rows, a.out)


if __name__ == "__main__":
    main()
