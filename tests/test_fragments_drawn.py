"""``plot`` and ``render`` draw fragments (issue 50, item 3): Fig. 3's capsized fraction by
the pieces' area beside the body count, the fragment-size figure by area when bodies are
cells, and ``render --fragments`` colouring each body by its piece.

References derived, not measured: a block of 4 x 2 cells that capsizes whole beside a wide
flat iceberg that does not is, at the end, 8 of 9 bodies capsized but only the block's share
of the ice's area (its ``w h`` over the sum of both); pieces partition the ice, so their
areas are the sums of their bodies' ``w h`` by label; a continuous power law's exponent is
recovered from samples drawn from it, within its Fisher standard error.
"""

from __future__ import annotations

import csv
import math
import shutil

import h5py
import numpy as np
import pytest
from matplotlib.image import imread

import melange_ti as mt
from melange_ti import diagnostics
from melange_ti.analysis import figures, render
from melange_ti.analysis.fragments import celled
from melange_ti.analysis.runs import load_run
from melange_ti.cli import main as cli
from melange_ti.io.hdf5 import read_run
from melange_ti.scene import dumps_toml, loads

from .physics.test_cells import FULL, scene_text
from .test_fragments_table import BREAKING_PAIR

FLAT = "[[iceberg]]\nx = 8.0\nwidth = 2.0\nthickness = 0.5\n"  # wide and thin: it floats flat


@pytest.fixture(scope="module")
def block_and_flat(tmp_path_factory):
    """A 1 x 1.4 block of 4 x 2 cells (unbreakable bonds) capsizing from a tilt of 0.01, and
    a whole 2 x 0.5 iceberg far off that stays upright: 9 bodies, 2 pieces."""
    path = tmp_path_factory.mktemp("drawn") / "block.h5"
    text = scene_text("x = 3.0\ntheta = 0.01\ncells = [4, 2]\n", dt=0.002, duration=40.0, snapshot=2.0, more=FLAT)
    mt.run(loads(text), path)
    return path


@pytest.fixture(scope="module")
def breaking_pair(tmp_path_factory):
    """Two blocks of 3 x 2 cells thrown at each other with weak bonds: they break into pieces."""
    path = tmp_path_factory.mktemp("drawn") / "pair.h5"
    mt.run(loads(BREAKING_PAIR), path)
    return path


@pytest.fixture(scope="module")
def whole_shelf(tmp_path_factory):
    """A bonded shelf of 6 whole icebergs (no cells), the wall end bonded, weak bonds."""
    d = tmp_path_factory.mktemp("drawn")
    scene = d / "shelf.toml"
    scene.write_text(
        dumps_toml(
            {
                "scene": {"name": "shelf", "effects": ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]},
                "physics": {"tensile_strength": 0.05},
                "time": {"duration": 20.0, "seed": 1},
                "output": {"snapshot_interval": 5.0},
                "shelf": {"count": 6, "bonded": True, "bonded_wall": True, "front": 2},
            }
        )
    )
    assert cli(["run", str(scene), "--out", str(d / "shelf.h5")]) == 0
    return d / "shelf.h5"


@pytest.fixture(scope="module")
def unbonded(tmp_path_factory):
    out = tmp_path_factory.mktemp("drawn") / "paper.h5"
    argv = ["run", "--out", str(out), "--set", "shelf.count=6", "--set", "time.duration=10"]
    assert cli([*argv, "--set", "output.snapshot_interval=5"]) == 0
    return out


def body_areas(path) -> np.ndarray:
    """Each body's area from the file's widths and thicknesses (the scenes here: rectangles)."""
    bergs = read_run(path)["icebergs"]
    assert "corner_u" not in bergs
    return bergs["width"] * bergs["thickness"]


def lines_by_label(fig) -> dict[str, object]:
    """Fig. 3's lines by their legend label, unwrapped (labels are wrapped to the legend's width)."""
    ax = fig.axes[0]
    return {line.get_label().replace("\n", " "): line for line in ax.get_lines() if not line.get_label().startswith("_")}


# ---------------------------------------------------------------------------------------
# plot: Fig. 3


def test_fig3_draws_the_capsized_fraction_by_area_beside_the_body_count(block_and_flat):
    fig = figures.fig_capsized_fraction(figures.make_groups([load_run(block_and_flat)]), figures.Units())
    lines = lines_by_label(fig)
    [bodies] = [v for k, v in lines.items() if k.endswith(figures.BY_BODIES)]
    [area] = [v for k, v in lines.items() if k.endswith(figures.BY_AREA)]
    assert area.get_linestyle() == "--" and bodies.get_linestyle() == "-"
    figures.plt.close(fig)
    # the dashed line is capsized_area_fraction of the run's fragment table, at its snapshots
    want = mt.capsized_area_fraction(mt.fragment_table(block_and_flat))
    np.testing.assert_allclose(area.get_xdata(), want.index.to_numpy(), rtol=0, atol=0)
    np.testing.assert_allclose(area.get_ydata(), want.to_numpy(), rtol=0, atol=1e-15)
    # the solid line keeps its meaning: the bodies counted, the diagnostic capsized_fraction
    diag = read_run(block_and_flat)["diagnostics"]
    np.testing.assert_array_equal(bodies.get_xdata(), diag["time"])
    np.testing.assert_array_equal(bodies.get_ydata(), diag["capsized_fraction"])
    # derived: the block (8 cells) capsized whole, the flat iceberg not: 8 of 9 bodies, but
    # by area the block's share of the ice
    a = body_areas(block_and_flat)
    labels = read_run(block_and_flat)["snapshots"]["fragment"][-1]
    np.testing.assert_array_equal(labels, [0] * 8 + [8])
    assert bodies.get_ydata()[-1] == pytest.approx(8 / 9, abs=1e-15)
    assert area.get_ydata()[-1] == pytest.approx(a[:8].sum() / a.sum(), rel=1e-12)
    assert a[:8].sum() == pytest.approx(1.4, rel=1e-12) and a.sum() == pytest.approx(2.4, rel=1e-12)
    assert area.get_ydata()[0] == 0.0


def test_a_celled_block_that_capsizes_whole_is_capsized_by_area_and_by_count_alike(block_and_flat):
    """Without the flat iceberg (the same run's first 8 bodies): one piece, every cell of it
    capsized, so the area fraction reaches 1 when the count does, at every snapshot equal."""
    table = mt.fragment_table(block_and_flat)
    block = table[table["fragment"] == 0]
    assert (block["bodies"] == 8).all()
    snaps = read_run(block_and_flat)["snapshots"]
    cells = np.array([diagnostics.capsized_fraction(th[:8]) for th in snaps["theta"]])
    np.testing.assert_array_equal(mt.capsized_area_fraction(block).to_numpy(), cells)
    assert cells[-1] == 1.0 and cells[0] == 0.0


def test_fig3_without_bonds_has_no_line_by_area(unbonded):
    fig = figures.fig_capsized_fraction(figures.make_groups([load_run(unbonded)]), figures.Units())
    labels = list(lines_by_label(fig))
    figures.plt.close(fig)
    assert len(labels) == 1 and not labels[0].endswith((figures.BY_AREA, figures.BY_BODIES)), labels


# ---------------------------------------------------------------------------------------
# plot: the fragment-size figure by area when bodies are cells


def truncated_continuous(rng, tau: float, lo: float, hi: float, n: int) -> np.ndarray:
    """Samples of p(s) ~ s^-tau on [lo, hi] by inverting its CDF."""
    q = rng.random(n)
    a, b = lo ** (1 - tau), hi ** (1 - tau)
    return (a + q * (b - a)) ** (1 / (1 - tau))


@pytest.mark.parametrize("tau", [0.6, 1.5, 2.3])
def test_the_continuous_exponent_is_recovered(tau):
    rng = np.random.default_rng(50)
    lo, hi, n = 0.175, 400.0, 3000
    sizes = truncated_continuous(rng, tau, lo, hi, n)
    fit = figures.fit_power_law_area(sizes, s_min=lo, s_max=hi)
    # Fisher's error from the law's own variance of ln s, by quadrature on a fine log grid
    x = np.linspace(math.log(lo), math.log(hi), 200001)

    def integral(f):  # the trapezoid rule
        return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x)))

    def sigma(t):  # 1 / sqrt(n Var(ln s)) under the law of exponent t
        w = np.exp((1 - t) * x)
        w /= integral(w)
        return 1 / math.sqrt(n * (integral(w * x**2) - integral(w * x) ** 2))

    assert fit.continuous and fit.error == pytest.approx(sigma(fit.tau), rel=1e-6)  # the fit's own, at its tau
    assert abs(fit.tau - tau) < 4 * sigma(tau), (fit.tau, tau, sigma(tau))
    # the model's CCDF: 1 at s_min, 0 at s_max, and between them the closed form
    mid = math.sqrt(lo * hi)
    a, b = lo ** (1 - fit.tau), hi ** (1 - fit.tau)
    closed = (mid ** (1 - fit.tau) - b) / (a - b)
    np.testing.assert_allclose(fit.ccdf(np.array([lo, hi, mid])), [1.0, 0.0, closed], atol=1e-12)
    assert math.isnan(figures.fit_power_law_area([lo, lo, lo], s_min=lo, s_max=hi).tau)  # shattered
    assert math.isnan(figures.fit_power_law_area([1.0], s_min=lo, s_max=hi).tau)  # one piece


def test_pieces_of_cells_are_measured_by_area(block_and_flat, tmp_path):
    out = tmp_path / "figs"
    written = {p.name for p in figures.plot([block_and_flat], out, names={"fragments"})}
    assert {"fragments.png", "fragments.csv"} <= written
    with open(out / "fragments.csv") as fh:
        reader = csv.DictReader(fh)
        [row] = list(reader)
    assert tuple(reader.fieldnames) == figures.AREA_COLUMNS
    a = body_areas(block_and_flat)
    t = float(read_run(block_and_flat)["snapshots"]["time"][-1])
    assert float(row["t"]) == t and int(row["bodies"]) == 9 and int(row["pieces"]) == 2
    assert float(row["area"]) == pytest.approx(a.sum(), rel=1e-5)
    assert float(row["largest_area"]) == pytest.approx(a[:8].sum(), rel=1e-5)  # the block, not its 8 cells
    fit = figures.fit_power_law_area(np.sort([a[:8].sum(), a[8]]), s_min=a.min(), s_max=a.sum())
    assert float(row["tau"]) == pytest.approx(fit.tau, rel=1e-5)


def test_a_piece_of_cells_and_one_of_whole_icebergs_are_sized_alike(breaking_pair, whole_shelf):
    """Plotted together, both runs' pieces are measured by area: each piece's area is the sum
    of its bodies' w h over its label, whether the bodies are cells or whole icebergs; the
    figure's curve of each run is the CCDF of those areas."""
    runs = [load_run(breaking_pair), load_run(whole_shelf)]
    assert figures.by_area(runs) and not figures.by_area(runs[1:])
    t = figures.fragments_time(runs)
    for r in runs:
        p = figures.run_fragments(r, t, area=True)
        k = int(np.argmin(np.abs(r.snaps["time"] - t)))
        labels = r.snaps["fragment"][k]
        by_hand = np.bincount(labels, weights=body_areas(r.path))[np.unique(labels)]
        np.testing.assert_allclose(p.sizes, np.sort(by_hand), rtol=1e-12)
        assert p.fit.continuous and p.fit.s_min == pytest.approx(body_areas(r.path).min(), rel=1e-12)
    pair = figures.run_fragments(runs[0], t, area=True)
    assert len(pair.sizes) > 2  # it broke
    fig = figures.fig_fragments(figures.make_groups(runs), t)
    steps = [ln for ln in fig.axes[0].get_lines() if ln.get_drawstyle() == "steps-pre"]
    figures.plt.close(fig)
    drawn = sorted(tuple(np.round(ln.get_xdata(), 12)) for ln in steps)
    want = sorted(tuple(np.round(figures.ccdf(figures.run_fragments(r, t, area=True).sizes)[0], 12)) for r in runs)
    assert drawn == want
    # alone, the whole icebergs' run is counted in icebergs, as before cells
    alone = figures.fragment_rows(figures.make_groups(runs[1:]), t)
    assert set(alone[0]) == set(figures.FRAGMENT_COLUMNS)


def test_a_run_begun_from_a_run_of_cells_is_of_cells(block_and_flat, whole_shelf, tmp_path):
    """A run of cells writes each body's iceberg and place in its grid (``/icebergs/cell_iceberg``,
    ``cell_ix``, ``cell_iz``); a ``[start]`` scene says nothing of cells, and the run it begins
    keeps them from the file it starts from, so its pieces are told apart the same way."""
    src = read_run(block_and_flat)
    assert celled(src["icebergs"])
    g = src["icebergs"]
    places = {(int(p), int(ix), int(iz)) for p, ix, iz in zip(g["cell_iceberg"], g["cell_ix"], g["cell_iz"], strict=True)}
    assert len(g["cell_iceberg"]) == 9 and places == {(0, ix, iz) for ix in range(4) for iz in range(2)} | {(1, 0, 0)}
    t = float(src["snapshots"]["time"][-1])
    out = tmp_path / "begun.h5"
    begun = f'[scene]\neffects = {FULL}\n[time]\ndt = 0.002\nduration = 1.0\n[start]\nfile = "{block_and_flat}"\ntime = {t}\n'
    mt.run(loads(begun), out)
    got = read_run(out)["icebergs"]
    assert celled(got)
    for k in ("cell_iceberg", "cell_ix", "cell_iz"):
        np.testing.assert_array_equal(got[k], src["icebergs"][k])
    assert not celled(read_run(whole_shelf)["icebergs"])  # whole icebergs write none


# ---------------------------------------------------------------------------------------
# render --fragments


def facecolors(path, k: int, fragments: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The bodies' face colours drawn in frame ``k`` and the labels of their pieces."""
    run, scene = render.load_run(path)
    maker = render.FrameMaker(run, scene, False, np.array([k]), fragments=fragments)
    maker.draw(k)
    colours = [a.rects.get_facecolor().copy() for a in maker.artists]
    maker.close()
    assert all(np.array_equal(c, colours[0]) for c in colours)
    return colours[0], render.fragment_labels(run, k)


def assert_one_colour_a_piece(colours: np.ndarray, labels: np.ndarray) -> None:
    """Bodies of one piece share a colour; bodies of two pieces differ (labels here < 12)."""
    same_label = labels[:, None] == labels[None, :]
    same_colour = np.all(colours[:, None, :] == colours[None, :, :], axis=-1)
    np.testing.assert_array_equal(same_colour, same_label)


def test_render_colours_each_body_by_its_piece(block_and_flat, breaking_pair):
    colours, labels = facecolors(block_and_flat, -1)
    assert len(colours) == 9 and len(np.unique(labels)) == 2
    assert_one_colour_a_piece(colours, labels)
    snaps = read_run(breaking_pair)["snapshots"]
    assert len(np.unique(snaps["fragment"][-1])) > 2
    for k in (0, len(snaps["time"]) - 1):
        colours, labels = facecolors(breaking_pair, k)
        np.testing.assert_array_equal(labels, snaps["fragment"][k])
        assert_one_colour_a_piece(colours, labels)
    # a piece keeps its colour while its label holds: label 0 at the start and at the end
    first, _ = facecolors(breaking_pair, 0)
    last, labels = facecolors(breaking_pair, -1)
    np.testing.assert_array_equal(first[0], last[labels == 0][0])
    # the default is the capsize angle's colours (one per tilt, not per piece)
    angle, _ = facecolors(block_and_flat, 0, fragments=False)
    theta = read_run(block_and_flat)["snapshots"]["theta"][0]
    cmap = figures.plt.get_cmap(render.CMAP)
    np.testing.assert_allclose(angle, cmap(render.PHI_NORM(np.abs(theta))), atol=1e-12)


def test_the_palette_keeps_neighbouring_labels_apart():
    """Labels 0..11 (a shelf's neighbours, the runs here) all get distinct colours, none the
    bonds' cyan; a label's colour is its own in any snapshot."""
    colours = render.fragment_colors(np.arange(12))
    assert len({tuple(c) for c in colours}) == 12
    from matplotlib.colors import to_rgba

    assert not any(np.allclose(c, to_rgba(render.BOND), atol=0.1) for c in colours)
    np.testing.assert_array_equal(render.fragment_colors([7, 3, 7]), colours[[7, 3, 7]])


def test_render_fragments_writes_frames_in_the_pieces_colours(block_and_flat, tmp_path, capsys):
    out = tmp_path / "frames"
    assert cli(["render", str(block_and_flat), "--out", str(out), "--fragments", "--every", "10"]) == 0
    n = len(render.frame_indices(len(read_run(block_and_flat)["snapshots"]["time"]), 10))
    frames = sorted(out.glob("frame_*.png"))
    assert len(frames) == n == 3
    image = imread(frames[-1])[..., :3]
    colours, labels = facecolors(block_and_flat, -1)
    for label in np.unique(labels):
        rgb = colours[labels == label][0][:3]
        assert np.sum(np.all(np.abs(image - rgb) < 2 / 255, axis=-1)) > 200, label  # each piece's colour is drawn


def test_render_fragments_of_a_run_without_bonds_gives_each_body_its_own_colour(unbonded, tmp_path):
    assert "fragment" not in read_run(unbonded)["snapshots"]
    colours, labels = facecolors(unbonded, -1)
    np.testing.assert_array_equal(labels, np.arange(6))
    assert_one_colour_a_piece(colours, labels)
    assert cli(["render", str(unbonded), "--out", str(tmp_path / "f"), "--fragments", "--every", "4"]) == 0


def test_render_fragments_refuses_bad_labels_in_one_line(block_and_flat, tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    shutil.copy(block_and_flat, bad)
    with h5py.File(bad, "r+") as f:
        f["snapshots/fragment"][3, 2] = 40
    assert cli(["render", str(bad), "--out", str(tmp_path / "frames"), "--fragments"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("melange-ti: error: --fragments:") and "/snapshots/fragment (snapshot 3)" in err, err
    assert "\n" not in err and not (tmp_path / "frames").exists()
    with pytest.raises(SystemExit) as exc:
        cli(["render", str(block_and_flat), "--out", str(tmp_path / "frames"), "--fragments=yes"])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and "--fragments" in err and "\n" not in err and "Traceback" not in err, err
