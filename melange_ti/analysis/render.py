"""``melange-ti render``: frames (PNG) and an MP4 movie of a run, headless (matplotlib Agg).

Each iceberg is drawn as its rectangle coloured by the capsize angle ``phi`` in
``[0, pi/2]`` (docs/model.md; capsized from ``pi/4``), optionally with the collision discs
(``--discs``), over the sea (the water line at ``physics.water_level``; with the ``waves``
effect, the moving surface ``water_level + eta`` over the wave grid) and the wall. With the
``bonds`` effect each bond intact at the frame's time is drawn as a cyan segment along the
face it glues (:class:`BondFaces`); a broken one is not drawn.
With ``--fragments`` each body is coloured by its piece of ice instead (``/snapshots/fragment``:
the bodies, cells or icebergs, held together by intact bonds): the bodies of one piece share a
colour, drawn from a qualitative palette by the piece's label (:func:`fragment_colors`: the
same piece keeps its colour from frame to frame), and the capsize angle's colour bar is left
out. A run without the bonds effect has no bonds, so each body is its own piece and gets its
own colour (as ``fragment_table`` and the ``fragments`` count have it), not a refusal.
The movie is encoded by the ``ffmpeg`` binary shipped in the ``imageio-ffmpeg`` wheel.
"""

from __future__ import annotations

import math
from itertools import takewhile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection, LineCollection, PolyCollection  # noqa: E402
from matplotlib.colors import Normalize  # noqa: E402
from matplotlib.patches import Polygon  # noqa: E402

from .. import diagnostics as diag  # noqa: E402
from ..errors import RunError  # noqa: E402
from ..geometry import body_outlines, disc_local, world_outlines  # noqa: E402
from ..io.hdf5 import OutputError, read_run  # noqa: E402
from ..scene import Scene, SceneError, stored_scene  # noqa: E402
from .fragments import check_labels  # noqa: E402
from .runs import DRAWN, check_finite  # noqa: E402

G_SI = 9.81  # m s^-2
CMAP = "plasma"
PHI_NORM = Normalize(0.0, 0.5 * math.pi)
WATER = "#cfe3f3"
WATER_LINE = "#1f5f99"
WALL = "0.35"
BOND = "#19d3f3"  # cyan: apart from the capsize angle's colours
# the pieces' colours (--fragments): tab20's, less its light blue (the sea's) and its cyans (the bonds')
PIECE_COLOURS = np.array([plt.get_cmap("tab20")(i) for i in range(20) if i not in (1, 18, 19)])
GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
ZOOM_SPAN = 60.0  # widths shown around the leading edge when the whole run is too wide
WIDE = 80.0  # widths beyond which a frame gets a leading-edge zoom panel


# ---------------------------------------------------------------------------------------
# Geometry (numpy; mirrors melange_ti.physics.shape.discs and melange_ti.scene)


def disc_centres(x, z, theta, width, thickness, discs: int) -> tuple[np.ndarray, np.ndarray]:
    """World disc centres (N, discs, 2) and radii (N,)."""
    local, r = disc_local(width, thickness, discs)
    theta = np.asarray(theta, dtype=float)[:, None]
    c, s = np.cos(theta), np.sin(theta)
    u, v = local[..., 0], local[..., 1]
    out = np.empty_like(local)
    out[..., 0] = np.asarray(x, dtype=float)[:, None] + u * c - v * s
    out[..., 1] = np.asarray(z, dtype=float)[:, None] + u * s + v * c
    return out, r


class BondFaces:
    """The bonds of a run (the ``bonds`` effect), each drawn as the face it glues: a segment
    of the face's length ``LEN`` through the bond's point, across its normal, both carried
    by iceberg A (``UA, VA, NU, NV`` of ``bonds/rest``), so it follows A's face as A moves;
    a bond to the wall lies on the wall. Intact at time ``t``: ``break_time`` NaN or > t."""

    def __init__(self, a, rest: dict[str, np.ndarray], break_time):
        self.a = np.asarray(a).astype(np.int64)
        self.u, self.v = rest["UA"], rest["VA"]
        self.nu, self.nv = rest["NU"], rest["NV"]
        self.half = 0.5 * rest["LEN"]
        self.break_time = np.asarray(break_time, dtype=float)

    def __len__(self) -> int:
        return len(self.a)

    @classmethod
    def read(cls, path, run: dict) -> BondFaces | None:
        """The bonds in ``run`` (:func:`read_run` data); None without the effect, or with no
        bonds. One-line :class:`OutputError` for a bond table that cannot be drawn."""
        from ..physics.effects.bonds import REST

        b = run.get("bonds")
        if not b or "rest" not in b or len(b["rest"]) == 0:
            return None
        rest = np.asarray(b["rest"], dtype=float)
        n = len(run["icebergs"]["width"])
        need = ("a", "break_time")
        # a file written before the last columns (TOUCHING, then TIP0 ... GCL) were kept has the ones before them
        widths = (REST.index("TOUCHING"), REST.index("TIP0"), len(REST))
        if any(k not in b for k in need) or rest.ndim != 2 or rest.shape[1] not in widths:
            raise OutputError(f"{path}: /bonds is not the bonds effect's table (columns {', '.join(REST)})")
        a = np.asarray(b["a"])
        if a.shape != (len(rest),) or np.any(~np.isfinite(a)) or np.any((a < 0) | (a >= n)):
            raise OutputError(f"{path}: /bonds/a holds values that are not iceberg indices 0..{n - 1}")
        if not np.all(np.isfinite(rest)):
            raise OutputError(f"{path}: /bonds/rest holds non-finite values (a corrupted file): nothing drawn")
        return cls(a, {name: rest[:, i] for i, name in enumerate(REST[: rest.shape[1]])}, b["break_time"])

    def intact(self, t: float) -> np.ndarray:
        return np.isnan(self.break_time) | (self.break_time > t)

    def segments(self, x, z, theta, t: float, keep: np.ndarray | None = None) -> np.ndarray:
        """World segments (n, 2, 2) of the bonds intact at ``t`` at the pose ``x, z, theta``
        (all icebergs); ``keep``: an optional mask of icebergs, a bond drawn if its A is kept."""
        on = self.intact(t)
        if keep is not None:
            on &= np.asarray(keep)[self.a]
        a = self.a[on]
        th = np.asarray(theta, dtype=float)[a]
        c, s = np.cos(th), np.sin(th)
        u, v, nu, nv, h = self.u[on], self.v[on], self.nu[on], self.nv[on], self.half[on]
        px = np.asarray(x, dtype=float)[a] + u * c - v * s
        pz = np.asarray(z, dtype=float)[a] + u * s + v * c
        tx, tz = -(nu * s + nv * c), nu * c - nv * s  # the normal turned by A's tilt, then a quarter turn
        out = np.empty((len(a), 2, 2))
        out[:, 0, 0], out[:, 0, 1] = px - h * tx, pz - h * tz
        out[:, 1, 0], out[:, 1, 1] = px + h * tx, pz + h * tz
        return out


def fragment_labels(run: dict, k: int) -> np.ndarray:
    """Snapshot ``k``'s piece of each body (``/snapshots/fragment``); without the bonds
    effect each body is its own piece (its index)."""
    labels = run["snapshots"].get("fragment")
    return np.arange(len(run["icebergs"]["width"])) if labels is None else np.asarray(labels[k])


def fragment_colors(labels) -> np.ndarray:
    """Each body's face colour (N, 4 RGBA) by its piece's ``labels``: the palette
    :data:`PIECE_COLOURS` cycled by label, colour ``floor(n frac(label g))`` of its ``n``
    (``g`` the golden ratio's fractional part: pieces whose labels differ by a few bodies,
    neighbours on a shelf, get distinct colours, and a piece's colour depends on its label
    alone, so it holds from frame to frame). Bodies of one piece share its colour; two pieces
    share one only by chance (about one in ``n`` for labels far apart)."""
    labels = np.asarray(labels, dtype=np.int64)
    index = np.floor(np.mod(labels * GOLDEN, 1.0) * len(PIECE_COLOURS)).astype(np.int64)
    return PIECE_COLOURS[np.minimum(index, len(PIECE_COLOURS) - 1)]


# ---------------------------------------------------------------------------------------
# Drawing


class IcebergArtist:
    """Rectangles (coloured by capsize angle, or with ``pieces`` by their piece of ice:
    :func:`fragment_colors`) and optional disc outlines on one axes.

    Created once and updated per frame with :meth:`update`, so a movie does not rebuild its
    artists. With ``bonds`` (:class:`BondFaces`), the bonds intact at the time given to
    :meth:`update` are drawn too.
    """

    def __init__(
        self,
        ax,
        width,
        thickness,
        discs: int | None = None,
        cmap: str = CMAP,
        edge_width: float = 0.6,
        bonds: BondFaces | None = None,
        bond_width: float = 1.8,
        outline: np.ndarray | None = None,
        axis: np.ndarray | None = None,
        pieces: bool = False,
    ):
        self.ax = ax
        self.pieces = pieces
        self.width = np.asarray(width, dtype=float)
        self.thickness = np.asarray(thickness, dtype=float)
        # every outline's body-frame corners (geometry.body_outlines: a run's /icebergs/corner_u,
        # ... for polygons, rectangles' from their width and thickness), and the principal axes
        # a polygon's capsize angle is measured by (None: rectangles)
        self.outline = outline
        self.body = outline if outline is not None else body_outlines({"width": self.width, "thickness": self.thickness})
        self.axis = axis
        self.discs = discs if outline is None else None  # the rectangles' discs only (a polygon's are not drawn)
        n = self.width.shape[0]
        self.rects = PolyCollection(
            np.zeros((n, self.body.shape[1], 2)),
            cmap=None if pieces else cmap,
            norm=None if pieces else PHI_NORM,
            edgecolors="k",
            linewidths=edge_width,
            zorder=3,
        )
        if not pieces:
            self.rects.set_array(np.zeros(n))
        ax.add_collection(self.rects)
        self.circles = None
        if self.discs:
            _, r = disc_local(self.width, self.thickness, discs)
            d = np.repeat(2.0 * r, discs)
            self.circles = EllipseCollection(
                d,
                d,
                np.zeros_like(d),
                units="xy",
                offsets=np.zeros((d.size, 2)),
                offset_transform=ax.transData,
                facecolors="none",
                edgecolors="w",
                linewidths=0.5,
                alpha=0.9,
                zorder=4,
            )
            ax.add_collection(self.circles)
        self.bonds = bonds
        self.bond_lines = None
        if bonds is not None:
            self.bond_lines = LineCollection([], colors=BOND, linewidths=bond_width, capstyle="butt", zorder=5.5)
            ax.add_collection(self.bond_lines)

    def update(self, x, z, theta, t: float | None = None, labels=None) -> None:
        """Draw the icebergs at ``x, z, theta``, and (with bonds) the bonds intact at ``t``;
        with ``pieces``, coloured by their pieces' ``labels`` (:func:`fragment_labels`)."""
        self.rects.set_verts(world_outlines(x, z, theta, self.body))
        if self.bond_lines is not None:
            self.bond_lines.set_segments(self.bonds.segments(x, z, theta, t))
        if self.pieces:
            self.rects.set_facecolor(fragment_colors(labels))
        else:
            self.rects.set_array(diag.capsize_angle(np.asarray(theta, dtype=float), self.axis))
        if self.circles is not None:
            centres, _ = disc_centres(x, z, theta, self.width, self.thickness, self.discs)
            self.circles.set_offsets(centres.reshape(-1, 2))


def wave_surface(run: dict, k: int) -> tuple[np.ndarray, np.ndarray] | None:
    """``(x, eta)``: the wave grid's cell centres and snapshot ``k``'s surface elevation, for a
    run with the ``waves`` effect; ``None`` otherwise."""
    x = run.get("waves", {}).get("x")
    eta = run["snapshots"].get("eta")
    if x is None or eta is None or k >= len(eta):
        return None
    return np.asarray(x, dtype=np.float64), np.asarray(eta[k], dtype=np.float64)


class SeaSurface:
    """The water below a moving surface ``water_level + eta(x)`` (flat beyond the wave grid)
    and the surface line; :meth:`update` moves them to another snapshot's ``eta``."""

    FAR = 1e6

    def __init__(self, ax, water_level: float, x: np.ndarray, bottom: float):
        self.wl = water_level
        self.x = np.concatenate(([x[0] - self.FAR], x, [x[-1] + self.FAR]))
        self.bottom = bottom
        self.water = Polygon(np.zeros((2 * len(self.x), 2)), closed=True, color=WATER, lw=0, zorder=0)
        ax.add_patch(self.water)
        (self.line,) = ax.plot(self.x, np.full(len(self.x), water_level), color=WATER_LINE, lw=1.0, zorder=2)

    def update(self, eta: np.ndarray) -> None:
        z = self.wl + np.concatenate(([0.0], eta, [0.0]))
        self.line.set_ydata(z)
        self.water.set_xy(np.vstack([np.column_stack([self.x, z]), [[self.x[-1], self.bottom], [self.x[0], self.bottom]]]))


def draw_sea(ax, scene: Scene, zlim: tuple[float, float], surface: tuple[np.ndarray, np.ndarray] | None = None):
    """Water below the water line, the line itself and (with the ``wall`` effect) the wall.
    With ``surface`` (:func:`wave_surface`) the water line is the waves' moving surface;
    returns its :class:`SeaSurface` (None for a flat sea)."""
    wl = scene.physics.water_level
    sea = None
    if surface is None:
        ax.axhspan(zlim[0] - 1e3, wl, color=WATER, zorder=0, lw=0)
        ax.axhline(wl, color=WATER_LINE, lw=1.0, zorder=2)
    else:
        sea = SeaSurface(ax, wl, surface[0], zlim[0] - 1e3)
        sea.update(surface[1])
    if scene.effects.wall:
        ax.axvline(scene.physics.wall_x, color=WALL, lw=3.0, zorder=5)
    return sea


def phi_colorbar(fig, mappable, ax, **kw):
    """Colorbar of the capsize angle with ticks at multiples of pi/8 and the pi/4 threshold."""
    cb = fig.colorbar(mappable, ax=ax, **kw)
    ticks = np.arange(5) * math.pi / 8
    cb.set_ticks(ticks)
    cb.set_ticklabels(["0", "π/8", "π/4", "3π/8", "π/2"])
    cb.set_label("capsize angle φ")
    cb.ax.axhline(math.pi / 4, color="w", lw=1.0) if cb.orientation == "vertical" else cb.ax.axvline(math.pi / 4, color="w")
    return cb


def extent(corners: np.ndarray) -> tuple[float, float, float, float]:
    """``(xmin, xmax, zmin, zmax)`` of corner arrays of any leading shape (..., 2)."""
    c = corners.reshape(-1, 2)
    return float(c[:, 0].min()), float(c[:, 0].max()), float(c[:, 1].min()), float(c[:, 1].max())


# ---------------------------------------------------------------------------------------
# Loading


def load_run(path: str | Path) -> tuple[dict, Scene]:
    """A run file and its scene; one-line errors for anything that cannot be rendered."""
    run = read_run(path)
    scene = stored_scene(path, run)
    snaps = run["snapshots"]
    if "time" not in snaps or len(snaps["time"]) == 0:
        raise OutputError(f"{path}: no snapshots yet (nothing to draw)")
    for key in ("x", "z", "theta"):
        if key not in snaps:
            raise OutputError(f"{path}: not a melange_ti run file (no /snapshots/{key})")
    for key in ("width", "thickness"):
        if key not in run["icebergs"]:
            raise OutputError(f"{path}: not a melange_ti run file (no /icebergs/{key})")
    check_finite(path, run, DRAWN)
    BondFaces.read(path, run)  # a bond table that cannot be drawn is refused before anything is written
    return run, scene


# ---------------------------------------------------------------------------------------
# Frames and movie


def _time_text(t: float, width_m: float) -> str:
    seconds = t * math.sqrt(width_m / G_SI)
    if seconds >= 7200:
        phys = f"{seconds / 3600:.2f} h"
    elif seconds >= 120:
        phys = f"{seconds / 60:.1f} min"
    else:
        phys = f"{seconds:.0f} s"
    return f"t = {t:g} √(w/g)  ({phys} for w = {width_m:g} m)"


class FrameMaker:
    """One figure, reused for every frame of a run; :meth:`draw` returns an RGB array."""

    def __init__(
        self,
        run: dict,
        scene: Scene,
        discs: bool,
        frames: np.ndarray,
        width_m: float = 70.0,
        px_width: int = 1280,
        fragments: bool = False,
    ):
        self.run = run
        self.scene = scene
        self.fragments = fragments
        self.width_m = width_m
        self.bonds = BondFaces.read("run", run)
        snaps = run["snapshots"]
        width = run["icebergs"]["width"]
        thickness = run["icebergs"]["thickness"]
        body = body_outlines(run["icebergs"])
        self.outline, self.axis = (body, run["icebergs"].get("axis")) if "corner_u" in run["icebergs"] else (None, None)
        corners = world_outlines(
            snaps["x"][frames].ravel(),
            snaps["z"][frames].ravel(),
            snaps["theta"][frames].ravel(),
            np.tile(body, (len(frames), 1, 1)),
        )
        xmin, xmax, zmin, zmax = extent(corners)
        if scene.effects.wall:
            xmin = min(xmin, scene.physics.wall_x)
        pad = 0.5
        self.xlim = (xmin - pad, xmax + pad)
        self.zlim = (min(zmin, scene.physics.water_level) - pad, max(zmax, scene.physics.water_level) + pad)
        span = self.xlim[1] - self.xlim[0]
        height = self.zlim[1] - self.zlim[0]
        self.zoom = span > WIDE
        dpi = 100
        w_in = px_width / dpi
        if self.zoom:
            zoom_h = w_in * 0.8 * height / ZOOM_SPAN
            h_in = 1.2 + 1.6 + zoom_h
        else:
            h_in = 1.2 + w_in * 0.8 * height / span
        h_in = min(max(h_in, 2.4), 9.0)
        h_px = int(math.ceil(h_in * dpi / 16.0) * 16)  # even sizes for yuv420p / macro blocks
        self.fig = plt.figure(figsize=(w_in, h_px / dpi), dpi=dpi, layout="constrained")
        self._laid_out = False
        ndisc = scene.contacts.discs if discs else None
        if self.zoom:
            gs = self.fig.add_gridspec(2, 1, height_ratios=[1.0, max(zoom_h / 1.6, 0.6)], hspace=0.45)
            self.ax = self.fig.add_subplot(gs[0])
            self.axz = self.fig.add_subplot(gs[1])
            axes = (self.ax, self.axz)
        else:
            self.ax = self.fig.add_subplot(1, 1, 1)
            self.axz = None
            axes = (self.ax,)
        self.artists = []
        self.seas = []
        first = wave_surface(run, int(frames[0]))
        for k, ax in enumerate(axes):
            sea = draw_sea(ax, scene, self.zlim, first)
            if sea is not None:
                self.seas.append(sea)
            ax.set_ylim(*self.zlim)
            ax.set_ylabel("z (widths)")
            overview = self.zoom and k == 0  # edges would hide the icebergs at that scale
            art = IcebergArtist(
                ax,
                width,
                thickness,
                None if overview else ndisc,
                edge_width=0.0 if overview else 0.6,
                bonds=self.bonds,
                bond_width=1.0 if overview else 1.8,
                outline=self.outline,
                axis=self.axis,
                pieces=fragments,
            )
            self.artists.append(art)
        self.ax.set_xlim(*self.xlim)
        if self.zoom:
            self.ax.set_aspect("auto")
            self.axz.set_aspect("equal", adjustable="box")
            self.axz.set_xlabel("x (widths)")
            self.ax.set_title("whole run (stretched)", fontsize=9, loc="left")
        else:
            self.ax.set_aspect("equal", adjustable="box")
            self.ax.set_xlabel("x (widths)")
        if not fragments:  # the pieces' colours are no scale
            phi_colorbar(self.fig, self.artists[0].rects, list(axes), fraction=0.03, pad=0.02)
        self.title = self.fig.suptitle("", fontsize=10)

    def draw(self, k: int) -> np.ndarray:
        snaps = self.run["snapshots"]
        x, z, theta = snaps["x"][k], snaps["z"][k], snaps["theta"][k]
        t = float(snaps["time"][k])
        labels = fragment_labels(self.run, k) if self.fragments else None
        for art in self.artists:
            art.update(x, z, theta, t, labels)
        if self.seas:  # the run has waves: read_run cut eta to the snapshots' length
            _, eta = wave_surface(self.run, k)
            for sea in self.seas:
                sea.update(eta)
        if self.axz is not None:
            front = float(np.max(x)) + 2.0
            self.axz.set_xlim(front - ZOOM_SPAN, front)
            self.axz.set_ylim(*self.zlim)
            self.axz.set_title("leading edge", fontsize=9, loc="left")
        frac = diag.capsized_fraction(theta)
        text = f"{_time_text(t, self.width_m)}    capsized {100 * frac:.0f}%"
        if self.bonds is not None:
            text += f"    bonds intact (cyan) {int(self.bonds.intact(t).sum())} of {len(self.bonds)}"
        if labels is not None:
            text += f"    pieces {len(np.unique(labels))} (one colour each)"
        self.title.set_text(text)
        self.fig.canvas.draw()
        if not self._laid_out:  # lay out once (first frame), then keep the axes still
            self.fig.set_layout_engine("none")
            self._laid_out = True
        return np.asarray(self.fig.canvas.buffer_rgba())[..., :3].copy()

    def close(self) -> None:
        plt.close(self.fig)


def frame_indices(n: int, every: int) -> np.ndarray:
    """Every ``every``-th snapshot, always including the last one."""
    idx = list(range(0, n, every))
    if idx[-1] != n - 1:
        idx.append(n - 1)
    return np.asarray(idx)


def render(
    path: str | Path,
    out: str | Path,
    discs: bool = False,
    every: int = 1,
    fps: int = 20,
    width_m: float | None = None,
    overwrite: bool = False,
    fragments: bool = False,
) -> list[Path]:
    """Render a run to ``out``: an ``.mp4`` file, or a directory of ``frame_00000.png`` ...

    ``fragments``: each body coloured by its piece of ice, not by its capsize angle (without
    the bonds effect each body is its own piece); labels in the file that are not body
    indices are refused in one line naming ``--fragments`` before anything is written.

    An existing movie, or a directory holding frames, is refused unless ``overwrite`` (then
    the old frames are removed first, so none of an earlier render is left). ``width_m``:
    the iceberg width in metres for the time label (default: the run's ``scene.width_m``).
    Returns the files written. A render that fails (a NaN in the run is refused before
    anything is written) leaves no movie, no frames and no directory of its own behind.
    """
    if every < 1:
        raise SceneError(f"--every = {every}: must be >= 1")
    if fps < 1:
        raise SceneError(f"--fps = {fps}: must be >= 1")
    out = Path(out)
    movie = out.suffix.lower() == ".mp4" and not out.is_dir()
    if not movie and out.suffix and not out.is_dir():
        raise SceneError(f"--out {str(out)!r}: give FILE.mp4 or a directory for PNG frames")
    if width_m is not None and not (math.isfinite(width_m) and width_m > 0):
        raise SceneError(f"--width-m = {width_m:g}: must be a positive number of metres")
    stale = sorted(out.glob("frame_*.png")) if not movie and out.is_dir() else []
    # an empty file is no movie (one left by a render that failed before its first frame)
    if not overwrite and (movie and out.exists() and out.stat().st_size > 0 or stale):
        what = "file exists" if movie else f"holds {len(stale)} frames of an earlier render"
        raise RunError(f"--out {str(out)!r}: {what} (use --overwrite to replace, or another --out)")
    run, scene = load_run(path)
    if fragments and "fragment" in run["snapshots"]:
        check_labels(path, run["snapshots"]["fragment"], len(run["icebergs"]["width"]), flag="--fragments: ")
    width_m = width_m if width_m is not None else scene.width_m
    frames = frame_indices(len(run["snapshots"]["time"]), every)
    for old in stale:
        old.unlink()
    writer = None
    made = []  # the directories this render creates, innermost first
    if movie:
        writer = _movie_writer(out, fps)
    else:
        made = list(takewhile(lambda d: not d.exists(), (out, *out.parents)))
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"--out {str(out)!r}: cannot create directory ({exc.strerror or exc})") from None
    maker = None
    written: list[Path] = []
    done = False
    try:
        maker = FrameMaker(run, scene, discs, frames, width_m=width_m, fragments=fragments)
        for n, k in enumerate(frames):
            rgb = maker.draw(int(k))
            if writer is not None:
                writer.write(rgb)
            else:
                target = out / f"frame_{n:05d}.png"
                written.append(target)
                try:
                    plt.imsave(target, rgb)
                except OSError as exc:
                    raise OutputError(f"{target}: cannot write ({exc.strerror or exc})") from None
        if writer is not None:
            writer.close()
            written.append(out)
        done = True
    finally:
        if maker is not None:
            maker.close()
        if writer is not None:
            writer.abort()  # a half-written movie is no movie
        if not done:  # nor are half the frames: leave --out as it was
            for target in written:
                target.unlink(missing_ok=True)
            for d in made:
                if d.is_dir() and not any(d.iterdir()):
                    d.rmdir()
    return written


class _Movie:
    """Feeds RGB frames to the ffmpeg binary of ``imageio-ffmpeg`` (H.264, yuv420p)."""

    def __init__(self, path: Path, fps: int, exe: str):
        self.path = path
        self.fps = fps
        self.exe = exe
        self.gen = None
        self.done = False

    def write(self, rgb: np.ndarray) -> None:
        import imageio_ffmpeg

        if self.gen is None:
            h, w = rgb.shape[:2]
            self.gen = imageio_ffmpeg.write_frames(
                str(self.path),
                (w, h),
                fps=self.fps,
                codec="libx264",
                pix_fmt_in="rgb24",
                pix_fmt_out="yuv420p",
                quality=7,
                macro_block_size=16,
                ffmpeg_log_level="error",
            )
            self.gen.send(None)
        try:
            self.gen.send(np.ascontiguousarray(rgb))
        except (OSError, RuntimeError) as exc:
            raise OutputError(f"{self.path}: ffmpeg failed ({str(exc).splitlines()[0] if str(exc) else exc})") from None

    def close(self) -> None:
        if self.gen is not None:
            try:
                self.gen.close()
            except (OSError, RuntimeError) as exc:
                raise OutputError(f"{self.path}: ffmpeg failed ({str(exc).splitlines()[0] if str(exc) else exc})") from None
        self.done = True

    def abort(self) -> None:
        if self.done:
            return
        if self.gen is not None:
            try:
                self.gen.close()
            except Exception:  # already failing: the first error is the one reported
                pass
        self.path.unlink(missing_ok=True)  # a half-written movie is no movie


def _movie_writer(out: Path, fps: int) -> _Movie:
    try:
        import imageio_ffmpeg
    except ImportError:
        raise OutputError(
            "MP4 output needs the imageio-ffmpeg package (pip install imageio-ffmpeg); or give a directory for PNG frames"
        ) from None
    try:
        exe = imageio_ffmpeg.get_ffmpeg_exe()
    except RuntimeError as exc:
        raise OutputError(f"no ffmpeg binary for MP4 output ({str(exc).splitlines()[0]})") from None
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"--out {str(out)!r}: directory {str(parent)!r} does not exist")
    try:
        with open(out, "wb"):
            pass
    except OSError as exc:
        raise OutputError(f"--out {str(out)!r}: cannot write ({exc.strerror or exc})") from None
    return _Movie(out, fps, exe)


def main(args) -> int:
    """Entry point of ``melange-ti render``."""
    written = render(
        args.run,
        args.out,
        discs=args.discs,
        every=args.every,
        fps=args.fps,
        width_m=args.width_m,
        overwrite=args.overwrite,
        fragments=args.fragments,
    )
    if len(written) == 1:
        print(f"wrote {written[0]}")
    else:
        print(f"wrote {len(written)} frames to {Path(args.out)}")
    return 0
