"""The readers (``plot``, ``render``) on corrupted run files, and how ``plot`` groups and labels
runs (issue 32, points 11 and 13).

One tiny real run (6 icebergs, paper effects) is made once; every other file is a copy of it,
with NaNs written into a dataset, or its stored scene changed (a changed key changes only the
labels and groups, which is what these tests read).
"""

import csv
import shutil

import h5py
import numpy as np
import pytest

from melange_ti.analysis import figures, render, runs
from melange_ti.cli import main as cli
from melange_ti.io.hdf5 import OutputError
from melange_ti.scene import loads

PAPER = ["gravity", "buoyancy", "drag", "collisions", "wall"]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    path = tmp_path_factory.mktemp("tiny") / "tiny.h5"
    argv = ["run", "--out", str(path), "--set", "shelf.count=6", "--set", "time.duration=20"]
    assert cli([*argv, "--set", "output.snapshot_interval=5"]) == 0
    return path


def corrupt(src, dst, name: str, value: float = np.nan, index=(-1,)):
    """A copy of ``src`` with ``value`` written into dataset ``name`` at ``index``."""
    shutil.copy(src, dst)
    with h5py.File(dst, "r+") as f:
        data = f[name][...]
        data[index] = value
        f[name][...] = data
    return dst


def variant(src, dst, overrides):
    """A copy of ``src`` whose stored scene has ``overrides`` (the data are ``src``'s; the
    diagnostics of an effect the overrides add, which a real run of it would hold, as zeros)."""
    from melange_ti.diagnostics import fields

    shutil.copy(src, dst)
    with h5py.File(dst, "r+") as f:
        sc = loads(f.attrs["scene_toml"], overrides, geometry=False)
        f.attrs["scene_toml"] = sc.to_toml()
        g = f["diagnostics"]
        for field in fields(sc.effects):
            if field.name not in g:
                g.create_dataset(field.name, data=np.zeros(g["time"].shape[0], dtype=field.dtype))
    return dst


def one_line_error(capsys, argv) -> str:
    assert cli(argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("melange-ti: error: ") and "\n" not in err and "Traceback" not in captured.err, err
    return err


# ---------------------------------------------------------------------------------------
# Point 11: corrupted data


@pytest.mark.parametrize(
    "name, value, index",
    [
        ("snapshots/theta", np.nan, (2, 3)),  # the case
        ("snapshots/x", np.inf, (-1, 0)),
        ("icebergs/thickness", np.nan, (1,)),
    ],
)
def test_plot_and_render_refuse_non_finite_data_in_one_line(tiny, tmp_path, capsys, name, value, index):
    bad = corrupt(tiny, tmp_path / "bad.h5", name, value, index)
    figs, movie, frames = tmp_path / "new" / "figs", tmp_path / "movie.mp4", tmp_path / "frames"
    for argv in (["plot", str(bad), "--out", str(figs)], ["render", str(bad), "--out", str(movie)]):
        err = one_line_error(capsys, argv)
        assert str(bad) in err and f"/{name} " in err, err
    err = one_line_error(capsys, ["render", str(bad), "--out", str(frames)])
    assert f"/{name} " in err
    # nothing left behind: no folder, no 0-byte movie, no frames
    assert not (tmp_path / "new").exists() and not movie.exists() and not frames.exists()


def test_plot_refuses_a_non_finite_diagnostic(tiny, tmp_path, capsys):
    bad = corrupt(tiny, tmp_path / "bad.h5", "diagnostics/kinetic_energy", np.nan, (4,))
    err = one_line_error(capsys, ["plot", str(tiny), str(bad), "--out", str(tmp_path / "figs")])
    assert "/diagnostics/kinetic_energy " in err and "row 4" in err
    assert not (tmp_path / "figs").exists()


def test_an_empty_movie_does_not_block_a_render(tiny, tmp_path):
    """A 0-byte movie (left by a render that failed before its first frame) holds nothing:
    a render replaces it without --overwrite; a movie with frames in it is still refused."""
    movie = tmp_path / "movie.mp4"
    movie.write_bytes(b"")
    assert cli(["render", str(tiny), "--out", str(movie), "--every", "4"]) == 0
    assert movie.stat().st_size > 0
    assert cli(["render", str(tiny), "--out", str(movie), "--every", "4"]) == 2


def test_a_failed_render_leaves_nothing(tiny, tmp_path, monkeypatch):
    """A render that fails after its output was opened leaves no movie, no frames and no
    directory of its own (the user's files in an existing one are kept)."""

    def broken_init(self, *args, **kwargs):
        raise OutputError("broken figure")

    with monkeypatch.context() as m:  # fails before the first frame, with the movie's file open
        m.setattr(render.FrameMaker, "__init__", broken_init)
        with pytest.raises(OutputError, match="broken figure"):
            render.render(tiny, tmp_path / "movie.mp4")
    assert not (tmp_path / "movie.mp4").exists()

    draw = render.FrameMaker.draw
    calls = []

    def draw_then_fail(self, k):
        calls.append(k)
        if len(calls) == 3:
            raise OutputError("disk full")
        return draw(self, k)

    monkeypatch.setattr(render.FrameMaker, "draw", draw_then_fail)
    with pytest.raises(OutputError, match="disk full"):
        render.render(tiny, tmp_path / "new" / "frames")
    assert not (tmp_path / "new").exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    calls.clear()
    with pytest.raises(OutputError, match="disk full"):
        render.render(tiny, mine)
    assert sorted(p.name for p in mine.iterdir()) == ["notes.txt"]


def test_a_failed_plot_leaves_nothing(tiny, tmp_path, monkeypatch):
    """A figure failing half way removes the figures written before it and the folder the
    plot made; a folder that was there keeps what it held."""

    def broken(*args, **kwargs):
        raise OutputError("broken figure")

    monkeypatch.setattr(figures, "fig_energy_budget", broken)  # written after Fig. 3
    names = {"fig3_capsized_fraction", "energy_budget"}
    with pytest.raises(OutputError, match="broken figure"):
        figures.plot([tiny], tmp_path / "new" / "figs", names=names)
    assert not (tmp_path / "new").exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    with pytest.raises(OutputError, match="broken figure"):
        figures.plot([tiny], mine, names=names)
    assert sorted(p.name for p in mine.iterdir()) == ["notes.txt"]


# ---------------------------------------------------------------------------------------
# Point 13: every group drawn, labels that name what changed


def test_fig2_draws_every_group(tiny, tmp_path):
    """Four values of a key: four columns of Fig. 2 (it drew the first three only)."""
    drags = (0.005, 0.01, 0.02, 0.04)
    paths = [variant(tiny, tmp_path / f"d{i}.h5", [("physics.drag", d)]) for i, d in enumerate(drags)]
    groups = runs.make_groups([runs.load_run(p) for p in paths])
    assert [g.label for g in groups] == [f"physics.drag = {d:g}" for d in drags]
    fig = figures.fig_snapshots(groups, figures.Units(), [0.0, 20.0])
    titles = [ax.get_title().replace("\n", " ") for ax in fig.axes if ax.get_title()]
    assert [t.split(",")[0] for t in titles] == [g.label for g in groups]


def test_labels_name_an_effects_changed_key(tiny, tmp_path):
    """A key only some runs have (an effect's) is named where it is not its default; an
    effect's keys at their defaults are left to the effect's name."""
    effects = [*PAPER, "form_drag"]
    paths = [
        tiny,
        variant(tiny, tmp_path / "fd8.h5", [("scene.effects", effects), ("physics.form_drag", 8.0)]),
        variant(tiny, tmp_path / "waves.h5", [("scene.effects", [*PAPER, "waves"])]),
    ]
    labels = {g.runs[0].path.name: g.label for g in runs.make_groups([runs.load_run(p) for p in paths])}
    assert labels == {
        "tiny.h5": "the paper's effects",
        "fd8.h5": "the paper's effects + form_drag, physics.form_drag = 8",
        "waves.h5": "the paper's effects + waves",
    }
    # two form-drag coefficients: both named, the default one too
    fd1 = variant(tiny, tmp_path / "fd1.h5", [("scene.effects", effects)])
    labels = [g.label for g in runs.make_groups([runs.load_run(p) for p in (tiny, fd1, paths[1])])]
    assert "the paper's effects + form_drag, physics.form_drag = 1" in labels
    assert "the paper's effects + form_drag, physics.form_drag = 8" in labels


def test_a_single_run_is_labelled_by_its_scene_and_changes(tiny, tmp_path):
    figures.plot([tiny], tmp_path, names={"fig3_capsized_fraction"})
    with open(tmp_path / "summary.csv") as fh:
        [row] = list(csv.DictReader(fh))
    # time.duration and output.snapshot_interval are not parameters (stats.NON_PARAMETER_KEYS)
    assert row["group"] == "paper, shelf.count = 6"  # was "all runs"
    fd8 = variant(tiny, tmp_path / "fd8.h5", [("scene.effects", [*PAPER, "form_drag"]), ("physics.form_drag", 8.0)])
    [group] = runs.make_groups([runs.load_run(fd8)])
    assert group.label == "paper, the paper's effects + form_drag, physics.form_drag = 8, shelf.count = 6"
