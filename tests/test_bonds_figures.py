"""The bonds effect in ``plot`` and ``render`` (issue 31, point 5): the fragment-size figure
and its fitted exponent, the intact bonds drawn in each frame.

One small bonded run (10 icebergs, the wall end bonded, 2 free at the front, weak bonds that
break) and one unbonded run of the paper's effects are made once with the real command line.
"""

import csv
import math
import shutil

import h5py
import numpy as np
import pytest

from melange_ti.analysis import figures, render
from melange_ti.analysis.runs import load_run
from melange_ti.cli import main as cli
from melange_ti.io.hdf5 import OutputError, read_run
from melange_ti.physics.effects.bonds import REST
from melange_ti.scene import dumps_toml

PAPER = ["gravity", "buoyancy", "drag", "collisions", "wall"]


@pytest.fixture(scope="module")
def bonded(tmp_path_factory):
    d = tmp_path_factory.mktemp("bonded")
    scene = d / "bonded.toml"
    scene.write_text(
        dumps_toml(
            {
                "scene": {"name": "bonded", "effects": [*PAPER, "bonds"]},
                "physics": {"tensile_strength": 0.05},
                "time": {"duration": 40.0, "seed": 1},
                "output": {"snapshot_interval": 5.0},
                "shelf": {"count": 10, "bonded": True, "bonded_wall": True, "front": 2},
            }
        )
    )
    out = d / "bonded.h5"
    assert cli(["run", str(scene), "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def unbonded(tmp_path_factory):
    out = tmp_path_factory.mktemp("unbonded") / "paper.h5"
    argv = ["run", "--out", str(out), "--set", "shelf.count=6", "--set", "time.duration=20"]
    assert cli([*argv, "--set", "output.snapshot_interval=5"]) == 0
    return out


def components(n: int, a, b, intact) -> np.ndarray:
    """Each iceberg's piece, by hand: the lowest index of its component over intact bonds."""
    label = list(range(n))

    def root(i):
        while label[i] != i:
            i = label[i]
        return i

    for i, j, on in zip(a, b, intact, strict=True):
        if on and j >= 0:
            ri, rj = root(int(i)), root(int(j))
            label[max(ri, rj)] = min(ri, rj)
    return np.array([root(i) for i in range(n)])


# ---------------------------------------------------------------------------------------
# The exponent (functions, no figure)


def truncated_power_law(rng, tau: float, s_max: int, pieces: int) -> np.ndarray:
    s = np.arange(1, s_max + 1)
    p = s ** -float(tau)
    return rng.choice(s, size=pieces, p=p / p.sum())


@pytest.mark.parametrize("tau", [0.8, 1.5, 2.2])
def test_the_exponent_of_synthetic_labels_is_recovered(tau):
    """Labels of pieces whose sizes follow n(s) ~ s^-tau on 1..s_max: the maximum-likelihood
    exponent is tau within four of its own standard errors (Fisher's, from the model, not
    from the sample's scatter), and that error is what the law's variance of ln s gives."""
    rng = np.random.default_rng(31)
    s_max, pieces = 500, 3000
    sizes = truncated_power_law(rng, tau, s_max, pieces)
    labels = rng.permutation(np.repeat(np.arange(pieces) * 7, sizes))  # any label per piece, any order
    found = figures.fragment_sizes(labels)
    np.testing.assert_array_equal(found, np.sort(sizes))
    fit = figures.fit_power_law(found, s_max=s_max)
    s = np.arange(1, s_max + 1)
    p = s**-tau / np.sum(s**-tau)
    sigma = 1.0 / math.sqrt(pieces * (p @ np.log(s) ** 2 - (p @ np.log(s)) ** 2))
    assert fit.error == pytest.approx(sigma, rel=0.1)
    assert abs(fit.tau - tau) < 4 * sigma, (fit.tau, tau, sigma)
    # the model's own CCDF is 1 at s = 1 and falls to P(s_max) at s_max
    assert fit.ccdf([1])[0] == pytest.approx(1.0) and fit.ccdf([s_max])[0] < fit.ccdf([2])[0]


def test_ccdf_and_undefined_fits_by_hand():
    s, prob = figures.ccdf(figures.fragment_sizes([4, 4, 4, 0, 9, 9]))  # pieces of 3, 1 and 2
    np.testing.assert_array_equal(s, [1, 2, 3])
    np.testing.assert_allclose(prob, [1.0, 2 / 3, 1 / 3])
    assert math.isnan(figures.fit_power_law([1, 1, 1], s_max=3).tau)  # shattered: tau -> infinity
    assert math.isnan(figures.fit_power_law([5], s_max=5).tau)  # one piece
    assert figures.fit_power_law([1, 1, 2], s_max=3).tau > figures.fit_power_law([1, 2, 2], s_max=3).tau


# ---------------------------------------------------------------------------------------
# plot


def test_plot_draws_fragments_for_a_bonded_run_only(bonded, unbonded, tmp_path):
    out = tmp_path / "bonded"
    written = {p.name for p in figures.plot([bonded], out, names={"fragments"})}
    assert {"fragments.png", "fragments.pdf", "fragments.csv"} <= written
    from matplotlib.image import imread

    assert imread(out / "fragments.png").shape[1] >= 600
    # the pieces in fragments.csv: the components of the bonds intact at the last snapshot
    data = read_run(bonded)
    t = float(data["snapshots"]["time"][-1])
    bonds = data["bonds"]
    intact = np.isnan(bonds["break_time"]) | (bonds["break_time"] > t)
    labels = components(10, bonds["a"], bonds["b"], intact)
    np.testing.assert_array_equal(labels, data["snapshots"]["fragment"][-1])
    with open(out / "fragments.csv") as fh:
        [row] = list(csv.DictReader(fh))
    sizes = np.bincount(labels)[np.bincount(labels) > 0]
    assert float(row["t"]) == t and int(row["icebergs"]) == 10
    assert int(row["pieces"]) == len(sizes) == data["diagnostics"]["fragments"][np.searchsorted(data["diagnostics"]["time"], t)]
    assert int(row["largest"]) == sizes.max()
    tau = figures.fit_power_law(sizes, s_max=10).tau
    if math.isnan(tau):
        assert row["tau"] == "nan"
    else:
        assert float(row["tau"]) == pytest.approx(tau, rel=1e-5)

    # without bonds: the figures as before, no fragments figure and no error
    plain = [p.name for p in figures.plot([unbonded], tmp_path / "plain", names={"fragments", "fig3_capsized_fraction"})]
    assert plain == ["fig3_capsized_fraction.png", "fig3_capsized_fraction.pdf", "summary.csv"]
    # both: one curve, the bonded run's group
    fig = figures.fig_fragments(figures.make_groups([load_run(bonded), load_run(unbonded)]), 20.0)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert len(labels) == 2 and "bonds" in labels[0] and "τ = 3/2" in labels[1], labels


def test_a_run_without_bonds_holds_no_bond_diagnostics(unbonded):
    """A run without the bonds effect holds none of its diagnostics (issue 47: they were all
    zeros); what the budget and readers take in their place is the effect's declared value
    without it (``Quantity.without``): every iceberg its own piece, no bond, no bond energy."""
    from melange_ti.energy import total_energy
    from melange_ti.physics.effects import REGISTRY

    data = read_run(unbonded)
    d = data["diagnostics"]
    assert d["time"].size > 2
    assert not {"fragments", "bonds_intact", "bond_energy", "fracture_released"} & set(d)
    bonds = next(e for e in REGISTRY if e.name == "bonds")
    snap = {k: v[-1] for k, v in data["snapshots"].items() if k != "time"}
    without = {q.name: q.without(snap) for q in (*bonds.reports, *bonds.held)}
    assert without == {"bonds_intact": 0, "fragments": 6, "bond_energy": 0}
    assert np.array_equal(total_energy(d), d["kinetic_energy"] + d["potential_energy"])


def test_fig2_draws_the_bonds_of_a_bonded_run_only(bonded, unbonded):
    from matplotlib.collections import LineCollection
    from matplotlib.colors import to_rgba

    def drawn(path, t):
        """Segments in each collection of lines of the bonds' colour (the colour bar's own lines aside)."""
        fig = figures.fig_snapshots(figures.make_groups([load_run(path)]), figures.Units(), [t])
        lines = [c for ax in fig.axes for c in ax.collections if isinstance(c, LineCollection)]
        segments = [len(c.get_segments()) for c in lines if np.allclose(c.get_color(), to_rgba(render.BOND))]
        figures.plt.close(fig)
        return segments

    data = read_run(bonded)
    t = float(data["snapshots"]["time"][-1])
    intact = np.isnan(data["bonds"]["break_time"]) | (data["bonds"]["break_time"] > t)
    assert drawn(bonded, 0.0) == [len(intact)]  # every bond holds at t = 0; the shelf is in the window
    assert drawn(bonded, t) == [int(intact.sum())]
    assert drawn(unbonded, 0.0) == []


def test_a_failed_fragments_figure_leaves_nothing(bonded, tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise OutputError("broken rows")

    monkeypatch.setattr(figures, "fragment_rows", broken)  # after fragments.png and .pdf
    with pytest.raises(OutputError, match="broken rows"):
        figures.plot([bonded], tmp_path / "new", names={"fragments"})
    assert not (tmp_path / "new").exists()


def test_corrupted_fragment_labels_are_one_line(bonded, tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    shutil.copy(bonded, bad)
    with h5py.File(bad, "r+") as f:
        f["snapshots/fragment"][-1, 3] = 99
    assert cli(["plot", str(bad), "--out", str(tmp_path / "figs")]) == 2
    err = capsys.readouterr().err.strip()
    assert "/snapshots/fragment" in err and "\n" not in err, err
    assert not (tmp_path / "figs").exists()


# ---------------------------------------------------------------------------------------
# render


def test_render_draws_the_intact_bonds_on_their_faces(bonded):
    data = read_run(bonded)
    faces = render.BondFaces.read(bonded, data)
    bonds, snaps = data["bonds"], data["snapshots"]
    h = data["icebergs"]["thickness"]
    assert len(faces) == len(bonds["a"]) > 0
    for k, t in enumerate(snaps["time"]):
        x, z, th = snaps["x"][k], snaps["z"][k], snaps["theta"][k]
        seg = faces.segments(x, z, th, float(t))
        intact = np.isnan(bonds["break_time"]) | (bonds["break_time"] > t)
        assert len(seg) == intact.sum()
        # each segment is the shared face: its length the face's, its middle B's material
        # point of the bond (or the wall's point): independent of A's pose
        rest = bonds["rest"][intact]
        np.testing.assert_allclose(np.hypot(*(seg[:, 1] - seg[:, 0]).T), rest[:, REST.index("LEN")], rtol=1e-12)
        mid = seg.mean(axis=1)
        b = bonds["b"][intact].astype(int)
        ub, vb = rest[:, REST.index("UB")], rest[:, REST.index("VB")]
        c, s = np.cos(th[b]), np.sin(th[b])
        on_b = np.column_stack([x[b] + ub * c - vb * s, z[b] + ub * s + vb * c])
        pb = np.where((b >= 0)[:, None], on_b, np.column_stack([ub, vb]))  # a wall bond: UB, VB world
        np.testing.assert_allclose(mid, pb, atol=1e-3)
    # t = 0: the upright shelf's faces, vertical, one thickness long, between neighbours
    seg = faces.segments(snaps["x"][0], snaps["z"][0], snaps["theta"][0], 0.0)
    np.testing.assert_allclose(seg[:, 0, 0], seg[:, 1, 0], atol=1e-12)
    np.testing.assert_allclose(np.abs(seg[:, 1, 1] - seg[:, 0, 1]), h[0], rtol=1e-12)


@pytest.mark.parametrize("kept", ["TOUCHING", "TIP0"])
def test_render_reads_a_file_written_before_the_last_bond_columns(bonded, tmp_path, kept):
    """A run file written before the bond table kept ``TOUCHING`` (format 8) or the crack
    tips' columns ``TIP0`` ... ``GCL`` (format 9) has the columns before them in
    ``/bonds/rest``: drawn with the same faces."""
    old = tmp_path / "old.h5"
    shutil.copy(bonded, old)
    with h5py.File(old, "r+") as f:
        rest = f["bonds/rest"][()]
        del f["bonds/rest"]
        f["bonds/rest"] = rest[:, : REST.index(kept)]
    data, before = read_run(old), read_run(bonded)
    snaps = data["snapshots"]
    got = render.BondFaces.read(old, data).segments(snaps["x"][-1], snaps["z"][-1], snaps["theta"][-1], float(snaps["time"][-1]))
    want = render.BondFaces.read(bonded, before).segments(
        snaps["x"][-1], snaps["z"][-1], snaps["theta"][-1], float(snaps["time"][-1])
    )
    np.testing.assert_array_equal(got, want)


def test_a_frame_shows_its_bonds_and_not_the_broken_ones(bonded, tmp_path):
    """The same frame of the run with its bonds intact and with them all broken at t = 0
    differs, only in cyan (the bonds' colour); a run without bonds draws none."""
    broken = tmp_path / "broken.h5"
    shutil.copy(bonded, broken)
    with h5py.File(broken, "r+") as f:
        f["bonds/break_time"][...] = 0.0
    frames = []
    for path in (bonded, broken):
        run, scene = render.load_run(path)
        maker = render.FrameMaker(run, scene, False, np.array([0]))
        frames.append(maker.draw(0).astype(int))
        lines = [a.bond_lines for a in maker.artists]
        maker.close()
        assert all(len(lc.get_segments()) == (len(run["bonds"]["a"]) if path == bonded else 0) for lc in lines)
    diff = np.any(frames[0] != frames[1], axis=-1)
    assert diff.sum() > 50
    cyan = np.array([0x19, 0xD3, 0xF3])
    assert np.any(np.all(np.abs(frames[0][diff] - cyan) < 10, axis=-1))
    assert not np.any(np.all(np.abs(frames[1] - cyan) < 10, axis=-1))


def test_render_without_bonds_draws_none(unbonded, tmp_path):
    run, scene = render.load_run(unbonded)
    assert render.BondFaces.read(unbonded, run) is None
    maker = render.FrameMaker(run, scene, False, np.array([0, 1]))
    assert all(a.bond_lines is None for a in maker.artists)
    maker.close()
    assert cli(["render", str(unbonded), "--out", str(tmp_path / "frames"), "--every", "4"]) == 0


def test_a_corrupted_bond_table_is_refused_in_one_line(bonded, tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    shutil.copy(bonded, bad)
    with h5py.File(bad, "r+") as f:
        f["bonds/rest"][2, 2] = np.nan
    assert cli(["render", str(bad), "--out", str(tmp_path / "frames")]) == 2
    err = capsys.readouterr().err.strip()
    assert "/bonds/rest" in err and "\n" not in err, err
    assert not (tmp_path / "frames").exists()
