"""Analysis: ensemble statistics, the ``plot`` and ``render`` commands (SPEC sections 4 and 5).

Statistics are checked against hand-computed values on hand-made run files (written with
plain h5py following SPEC section 5); the commands run end to end on tiny real runs made
with the real command line.
"""

import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from melange_ti.analysis import stats
from melange_ti.cli import main as cli
from melange_ti.energy import total_energy
from melange_ti.io.hdf5 import RunWriter
from melange_ti.scene import DENSITY_RATIO, dumps_toml, from_dict

# ---------------------------------------------------------------------------------------
# Helpers


def scene_toml(count: int = 4, seed: int = 1, duration: float = 4.0, **shelf) -> str:
    doc = {
        "scene": {"name": "hand", "effects": ["gravity", "buoyancy", "drag", "collisions", "wall"]},
        "time": {"dt": 0.5, "duration": duration, "seed": seed},
        "output": {"snapshot_interval": 0.5, "diagnostic_interval": 0.5},
        "contacts": {"discs": 12},
        "shelf": {"count": count, **shelf},
    }
    return from_dict(doc).to_toml()


def write_run(path, *, diag: dict, snaps: dict, seed: int = 1, width=None, thickness=None, **shelf) -> str:
    """A run file by hand, following SPEC section 5 (missing diagnostics are zeros)."""
    t = np.asarray(diag["time"], dtype=float)
    n = np.asarray(snaps["x"]).shape[1]
    with h5py.File(path, "w") as f:
        f.attrs["scene_toml"] = scene_toml(count=n, seed=seed, duration=float(t[-1]), **shelf)
        f.attrs["format_version"] = 1
        f.attrs["seed"] = seed
        g = f.create_group("icebergs")
        g["width"] = np.ones(n) if width is None else width
        g["thickness"] = np.full(n, 1.4) if thickness is None else thickness
        g["mass"] = DENSITY_RATIO * g["width"][:] * g["thickness"][:]
        g["inertia"] = g["mass"][:] * (g["width"][:] ** 2 + g["thickness"][:] ** 2) / 12
        s = f.create_group("snapshots")
        s["time"] = np.asarray(snaps["time"], dtype=float)
        for k in ("x", "z", "theta", "vx", "vz", "omega"):
            s[k] = np.asarray(snaps.get(k, np.zeros_like(np.asarray(snaps["x"], dtype=float))), dtype=float)
        d = f.create_group("diagnostics")
        d["time"] = t
        for k in (
            "capsized_fraction",
            "leading_edge",
            "kinetic_energy",
            "potential_energy",
            "drag_dissipated",
            "collision_dissipated",
            "correction_work",
            "wall_force",
            "impulse_rate",
        ):
            d[k] = np.asarray(diag.get(k, np.zeros_like(t)), dtype=float)
        d["contacts"] = np.zeros(len(t), dtype=np.int64)
    return str(path)


# Two hand-made runs of different duration and diagnostic interval (A: dt 1 to t = 4,
# B: dt 0.5 to t = 3), so the common grid is B's.
T_A = np.arange(5.0)
F_A = np.array([0.0, 0.2, 0.4, 1.0, 1.0])
T_B = np.arange(7) * 0.5
F_B = np.array([0.0, 0.1, 0.2, 0.4, 0.6, 0.8, 1.0])
# By hand: A on B's grid, the mean and the population standard deviation.
A_ON_B = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.7, 1.0])
MEAN = np.array([0.0, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0])
STD = np.array([0.0, 0.0, 0.0, 0.05, 0.1, 0.05, 0.0])

# Snapshots at t = 0 and t = 2 of 4 icebergs; Fig. 5 bins [0,10), [10,20), [20,30).
SNAP_A = {"time": [0.0, 2.0], "x": [[1, 2, 3, 4], [3, 8, 14, 25]], "theta": [[0, 0, 0, 0], [0, 1.0, 0.2, 1.5]]}
SNAP_B = {"time": [0.0, 2.0], "x": [[1, 2, 3, 4], [2, 12, 13, 22]], "theta": [[0, 0, 0, 0], [1.2, 1.2, 0, 0]]}


@pytest.fixture(scope="module")
def hand_runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("hand")
    a = write_run(
        d / "a.h5",
        seed=1,
        snaps=SNAP_A,
        diag={
            "time": T_A,
            "capsized_fraction": F_A,
            "leading_edge": T_A,
            "kinetic_energy": [0.0, 0.5, 0.25, 0.125, 0.0],
            "potential_energy": [10.0, 9.0, 8.0, 7.5, 7.0],
            "drag_dissipated": [0.0, 0.25, 0.5, 1.0, 1.5],
            "collision_dissipated": [0.0, 0.125, 1.0, 1.25, 1.25],
            "correction_work": [0.0, 0.0, 0.125, 0.125, 0.25],
            "wall_force": [0, 1, 2, 1, 0],
            "impulse_rate": [0, 2, 4, 2, 0],
        },
    )
    b = write_run(
        d / "b.h5",
        seed=2,
        snaps=SNAP_B,
        diag={
            "time": T_B,
            "capsized_fraction": F_B,
            "leading_edge": 2 * T_B,
            "kinetic_energy": np.linspace(0, 0.3, 7),
            "potential_energy": np.linspace(10, 9, 7),
        },
    )
    return a, b


@pytest.fixture(scope="module")
def real_runs(tmp_path_factory):
    """Two tiny real runs (12 icebergs, 12 and 28 discs) made with the real command line."""
    d = tmp_path_factory.mktemp("real")
    scene = d / "tiny.toml"
    scene.write_text(
        dumps_toml(
            {
                "scene": {"name": "tiny", "effects": ["gravity", "buoyancy", "drag", "collisions", "wall"]},
                "physics": {"density_ratio": DENSITY_RATIO, "restitution": 0.5, "drag": 0.01, "angular_drag": 0.01},
                "time": {"dt": 0.02, "duration": 8.0, "seed": 1},
                "output": {"snapshot_interval": 1.0, "diagnostic_interval": 0.5},
                "shelf": {"count": 12, "width": 1.0, "thickness": 1.4, "gap": 0.6, "tilt": 0.3},
            }
        )
    )
    paths = []
    for discs in (12, 28):
        out = d / f"run_d{discs}.h5"
        assert cli(["run", str(scene), "--out", str(out), "--set", f"contacts.discs={discs}"]) == 0
        paths.append(str(out))
    return paths


def assert_png(path, min_kb: float = 10.0, min_px: int = 300) -> None:
    from matplotlib.image import imread

    assert path.exists(), path
    assert path.stat().st_size > min_kb * 1024, (path, path.stat().st_size)
    img = imread(path)
    assert img.ndim == 3 and img.shape[0] >= min_px // 2 and img.shape[1] >= min_px, img.shape


# ---------------------------------------------------------------------------------------
# Pure statistics


def test_mean_std_exact():
    values = np.array([[1.0, 2.0, np.nan], [3.0, 6.0, np.nan], [5.0, 7.0, 4.0]])
    mean, std = stats.mean_std(values)
    np.testing.assert_array_equal(mean, [3.0, 5.0, 4.0])
    np.testing.assert_allclose(std, [math.sqrt(8 / 3), math.sqrt(14 / 3), 0.0], rtol=1e-15)
    _, std1 = stats.mean_std(values, ddof=1)
    np.testing.assert_allclose(std1[:2], [2.0, math.sqrt(7.0)], rtol=1e-15)
    assert math.isnan(std1[2])  # one run: no sample spread


def test_ensemble_on_grid_of_shortest_run():
    ens = stats.ensemble([(T_A, F_A), (T_B, F_B)])
    np.testing.assert_array_equal(ens.time, T_B)
    np.testing.assert_allclose(ens.values[0], A_ON_B, atol=1e-15)
    np.testing.assert_allclose(ens.mean, MEAN, atol=1e-15)
    np.testing.assert_allclose(ens.std, STD, atol=1e-15)
    assert ens.runs == 2


def test_crossing_times():
    t = np.arange(5.0)
    y = np.array([0.0, 0.2, 0.4, 0.8, 1.0])
    assert stats.crossing_time(t, y, 0.5) == pytest.approx(2.25)
    assert stats.crossing_time(t, y, 0.9) == pytest.approx(3.5)
    assert stats.crossing_time(t, y, 0.0) == 0.0
    assert math.isnan(stats.crossing_time(t, y, 1.5))
    got = stats.capsize_times(T_B, MEAN)
    assert got[0.5] == pytest.approx(2.0)
    assert got[0.9] == pytest.approx(2.8)  # between 2.5 (0.75) and 3.0 (1.0)
    # first crossing, not a later one after a dip
    assert stats.crossing_time([0, 1, 2, 3], [0.0, 0.6, 0.4, 0.7], 0.5) == pytest.approx(5 / 6)


def test_leading_edge_at():
    le = stats.leading_edge_at(T_B, 1.5 * T_B, [1.0, 2.25, 5.0])
    np.testing.assert_allclose(le[:2], [1.5, 3.375])
    assert math.isnan(le[2])  # past the end of the run


def test_capsized_by_position_hand_values():
    edges = stats.position_edges(0.0, 25.0, 10.0)
    np.testing.assert_array_equal(edges, [0, 10, 20, 30])
    frac, count = stats.capsized_by_position(np.array([3, 8, 14, 25, 31.0]), np.array([0, 1.0, 0.2, 1.5, 0]), edges)
    np.testing.assert_array_equal(count, [2, 1, 1])
    np.testing.assert_array_equal(frac, [0.5, 0.0, 1.0])
    # phi >= pi/4 counts, theta beyond pi folds back (3 rad is 0.14 rad from upright)
    frac, _ = stats.capsized_by_position(np.array([1.0, 2, 3]), np.array([math.pi / 4, -math.pi / 2, 3.0]), edges[:2])
    assert frac[0] == pytest.approx(2 / 3)
    snaps = [{k: np.asarray(v, dtype=float) for k, v in s.items()} for s in (SNAP_A, SNAP_B)]
    mean, std, n = stats.capsized_by_position_ensemble(snaps, 1.9, edges)
    np.testing.assert_allclose(mean, [0.75, 0.25, 0.5])
    np.testing.assert_allclose(std, [0.25, 0.25, 0.5])
    np.testing.assert_array_equal(n, [2, 2, 2])
    frac, count = stats.capsized_by_position_history(snaps[1], edges)
    np.testing.assert_array_equal(frac, [[0.0, np.nan, np.nan], [1.0, 0.5, 0.0]])
    np.testing.assert_array_equal(count, [[4, 0, 0], [1, 2, 1]])


def test_energy_budget_terms_sum_to_total():
    rng = np.random.default_rng(3)
    diag = {
        "kinetic_energy": rng.random(20),
        "potential_energy": 5 - np.cumsum(rng.random(20)),
        "drag_dissipated": np.cumsum(rng.random(20)),
        "collision_dissipated": np.cumsum(rng.random(20)),
        "correction_work": np.cumsum(rng.random(20)) * 0.01,
    }
    b = stats.energy_budget(diag)
    energy = total_energy(diag)
    np.testing.assert_allclose(b["total_loss"], energy[0] - energy, atol=1e-14)
    np.testing.assert_allclose(b["drag"] + b["collision"] + b["correction"] + b["residual"], b["total_loss"], atol=1e-14)
    np.testing.assert_allclose(
        b["kinetic"] + b["drag"] + b["collision"] + b["correction"] + b["residual"], b["released"], atol=1e-14
    )
    np.testing.assert_allclose(b["released"], diag["potential_energy"][0] - diag["potential_energy"], atol=0)


def test_grouping_by_differing_keys():
    base = stats.flatten_scene(from_dict({"shelf": {"count": 3}}).source)
    other = {**base, "time.seed": 7, "time.duration": 5.0, "contacts.discs": 12}
    third = {**base, "shelf.thickness_std": 0.1}
    keys = stats.differing_keys([base, other, third])
    assert keys == ["contacts.discs", "shelf.thickness_std"]
    groups = stats.group_by_keys([base, other, third, dict(base)], keys)
    assert list(groups.values()) == [[1], [0, 3], [2]]  # sorted by value: discs 12 before 28
    assert stats.group_label((("contacts.discs", 12),)) == "contacts.discs = 12"
    assert stats.group_label(()) == "all runs"


def test_disc_layout_matches_the_model():
    """The numpy disc layout used for drawing is the Taichi one (physics.shape.discs.disc_local)."""
    import taichi as ti

    from melange_ti.geometry import disc_local, disc_radius
    from melange_ti.physics.shape.discs import disc_local as ti_disc_local

    discs, w, h = 28, 1.0, 1.4
    r = float(disc_radius(w, h, discs))
    out = ti.Vector.field(2, ti.f64, shape=discs)

    @ti.kernel
    def fill(k: ti.i32, hw: ti.f64, hh: ti.f64, rr: ti.f64):
        for a in range(discs):
            out[a] = ti_disc_local(a, k, hw, hh, rr)

    fill(discs // 4, 0.5 * w, 0.5 * h, r)
    local, radius = disc_local([w], [h], discs)
    np.testing.assert_allclose(local[0], out.to_numpy(), atol=1e-14)
    assert radius[0] == pytest.approx(r)
    # the union of discs is tangent to the faces
    assert np.max(local[0, :, 0]) + r == pytest.approx(0.5 * w)
    assert np.max(local[0, :, 1]) + r == pytest.approx(0.5 * h)


# ---------------------------------------------------------------------------------------
# Hand-made run files through the figure code


def test_hand_runs_ensemble_and_summary(hand_runs, tmp_path):
    from melange_ti.analysis import figures

    runs = [figures.load_run(p) for p in hand_runs]
    groups = figures.make_groups(runs)
    assert len(groups) == 1 and groups[0].label == "all runs"  # seeds and durations differ only
    ens = groups[0].series("capsized_fraction")
    np.testing.assert_allclose(ens.mean, MEAN, atol=1e-15)
    np.testing.assert_allclose(ens.std, STD, atol=1e-15)
    edge = groups[0].series("leading_edge")
    np.testing.assert_allclose(edge.mean, 1.5 * T_B, atol=1e-15)
    row = figures.summary_rows(groups)[0]
    assert row["runs"] == 2 and row["t_end"] == 3.0
    assert row["t_50"] == pytest.approx(2.0) and row["t_90"] == pytest.approx(2.8)
    assert row["leading_edge_end"] == pytest.approx(4.5) and row["leading_edge_end_std"] == pytest.approx(1.5)
    # energy terms of run A, by hand: E = [10, 9.5, 8.25, 7.625, 7]
    _, terms = figures.energy_terms(figures.Group((), "A", runs[:1]))
    np.testing.assert_allclose(terms["released"].mean, [0, 1, 2, 2.5, 3])
    np.testing.assert_allclose(terms["total_loss"].mean, [0, 0.5, 1.75, 2.375, 3])
    np.testing.assert_allclose(terms["residual"].mean, [0, 0.125, 0.125, 0.0, 0.0], atol=1e-15)


def test_thickness_spread_figure(hand_runs, tmp_path):
    from melange_ti.analysis import figures

    c = write_run(
        tmp_path / "c.h5",
        seed=3,
        snaps=SNAP_B,
        thickness_std=0.05,
        diag={"time": T_B, "capsized_fraction": F_B[::-1].copy(), "leading_edge": T_B},
    )
    out = tmp_path / "figs"
    written = figures.plot([*hand_runs, c], out, times=[0, 2], names={"capsized_fraction_by_thickness_std"})
    assert [p.name for p in written] == [
        "capsized_fraction_by_thickness_std.png",
        "capsized_fraction_by_thickness_std.pdf",
        "summary.csv",
    ]
    assert_png(out / "capsized_fraction_by_thickness_std.png")
    groups = [row.split(",")[:2] for row in (out / "summary.csv").read_text().splitlines()[1:]]
    assert groups == [["shelf.thickness_std = 0", "2"], ["shelf.thickness_std = 0.05", "1"]]
    # with one spread only, no such figure
    assert figures.plot(hand_runs, tmp_path / "one", names={"capsized_fraction_by_thickness_std"})[0].name == "summary.csv"


# ---------------------------------------------------------------------------------------
# Commands end to end on real runs


def test_plot_real_runs(real_runs, tmp_path, capsys):
    out = tmp_path / "figs"
    assert cli(["plot", *real_runs, "--out", str(out), "--width-m", "100"]) == 0
    text = capsys.readouterr().out
    assert "contacts.discs = 12: 1 run(s)" in text and "contacts.discs = 28: 1 run(s)" in text
    for name in (
        "fig2_snapshots",
        "fig3_capsized_fraction",
        "fig4_leading_edge",
        "fig5_capsized_by_position",
        "energy_budget",
        "impulse_rate_wall_force",
    ):
        assert_png(out / f"{name}.png")
        pdf = out / f"{name}.pdf"
        assert pdf.read_bytes()[:5] == b"%PDF-" and pdf.stat().st_size > 2000
    assert not (out / "capsized_fraction_by_thickness_std.png").exists()  # one spread only
    rows = (out / "summary.csv").read_text().splitlines()
    assert rows[0].startswith("group,runs,") and len(rows) == 3


def test_energy_terms_of_a_real_run_come_from_its_datasets(real_runs):
    from melange_ti.diagnostics import fields
    from melange_ti.io.hdf5 import read_run
    from melange_ti.physics.data.schema import ENERGY_LEDGERS
    from melange_ti.scene import stored_scene

    d = read_run(real_runs[0])["diagnostics"]
    b = stats.energy_budget(d)
    # every term from the file's own datasets, by hand (energy_budget defines the residual as
    # what the ledgers leave of the loss, so the sum of its own terms would hold by construction):
    # a ledger it misread (zeros) or a term of the wrong sign shows here
    named = {f.name for f in fields(stored_scene(real_runs[0]).effects)}
    held = [name for name in ENERGY_LEDGERS if name in named]
    assert set(held) <= set(d), "the run file must hold every ledger of the effects it names"
    assert not (set(ENERGY_LEDGERS) - named) & set(d), "and none of an effect it does not name"
    energy = total_energy(d)  # E as the API defines it (with wave_energy when the run has waves)
    np.testing.assert_allclose(b["released"], d["potential_energy"][0] - d["potential_energy"], atol=1e-15)
    np.testing.assert_allclose(b["kinetic"], d["kinetic_energy"] - d["kinetic_energy"][0], atol=1e-15)
    booked = sum(d[name] for name in held)
    np.testing.assert_allclose(b["residual"], energy[0] - energy - booked, atol=1e-15)
    assert sum(b[stats.ledger_term(name)] for name in ENERGY_LEDGERS) == pytest.approx(booked, abs=1e-15)
    assert b["released"][-1] > 0 and booked[-1] > 0  # the tilted icebergs do fall, and drag works on them


def test_render_mp4_and_frames(real_runs, tmp_path):
    movie = tmp_path / "run.mp4"
    assert cli(["render", real_runs[1], "--out", str(movie), "--discs", "--every", "2", "--fps", "10"]) == 0
    head = movie.read_bytes()[:12]
    assert movie.stat().st_size > 5000 and head[4:8] == b"ftyp"
    frames = tmp_path / "frames"
    assert cli(["render", real_runs[0], "--out", str(frames), "--every", "3"]) == 0
    names = sorted(p.name for p in frames.glob("*.png"))
    assert names == [f"frame_{k:05d}.png" for k in range(4)]  # snapshots 0, 3, 6 and the last (8)
    assert_png(frames / "frame_00000.png", min_kb=5)


def test_plot_a_folder_refuses_to_overwrite_and_names_a_partial_run(real_runs, tmp_path, capsys):
    """A folder stands for its run files (what ensemble writes); figures already in --out
    are kept unless --overwrite; a run stopped part way is named partial, with its end."""
    from melange_ti.scene import load
    from melange_ti.simulation import Simulation

    folder = tmp_path / "ens"
    folder.mkdir()
    for p in real_runs:
        (folder / Path(p).name).write_bytes(Path(p).read_bytes())

    class Stop(Exception):
        pass

    def stop(step):
        if step == 150:  # t = 3 of 8
            raise Stop

    with pytest.raises(Stop):
        Simulation(load(Path(real_runs[0]).parent / "tiny.toml"), folder / "stopped.h5", progress=False, on_event=stop).run()
    out = tmp_path / "figs"
    assert cli(["plot", str(folder), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert f"note: {folder / 'stopped.h5'} is a partial run (stopped, or still running): up to t = 3 of 8" in text, text
    assert "run_d12" not in text and text.count("run(s)") == 2 and "3 run" not in text  # 12 discs once, 28 twice
    assert_png(out / "fig3_capsized_fraction.png")
    before = (out / "summary.csv").read_bytes()
    (out / "summary.csv").write_bytes(b"mine")
    err = _one_line_error(capsys, ["plot", str(folder), "--out", str(out)])
    assert "--overwrite" in err and str(out) in err, err
    assert (out / "summary.csv").read_bytes() == b"mine"
    assert cli(["plot", str(folder), "--out", str(out), "--overwrite"]) == 0
    assert (out / "summary.csv").read_bytes() == before
    assert "no run files" in _one_line_error(capsys, ["plot", str(tmp_path / "figs" / ".."), "--out", str(tmp_path / "o")])


def test_labels_are_words_not_formulas():
    """Figure legends and the long_name xarray puts on its axes (e.g. tree["diagnostics"]
    .leading_edge.plot()) read as words: no max_i x_i(t), E_p(0), phi >= pi/4."""
    import re

    from melange_ti.analysis.figures import ENERGY_STYLE
    from melange_ti.diagnostics import ENERGY_LEDGERS, FIELDS

    labels = [label for label, *_ in ENERGY_STYLE.values()]
    labels += [f.long_name for f in FIELDS if f.name not in ENERGY_LEDGERS]  # ledgers: the schema's docs
    for label in labels:
        assert not re.search(r"_[a-z]\b|_[a-z]\(|\(t\)|>=|Σ|−|\bpi\b", label), label


def test_every_energy_term_has_its_own_style():
    """The budget figure draws each term of the budget (every ledger the code books) in a
    colour and line style of its own: a ledger without a style was drawn in matplotlib's
    first colour, the same as drag's."""
    from melange_ti.analysis.figures import ENERGY_STYLE
    from melange_ti.analysis.stats import ENERGY_TERMS

    assert set(ENERGY_TERMS) <= set(ENERGY_STYLE), sorted(set(ENERGY_TERMS) - set(ENERGY_STYLE))
    looks = [(color, ls) for _, color, ls, _ in ENERGY_STYLE.values()]
    assert len(set(looks)) == len(looks), looks


def test_bundled_summaries_follow_the_code():
    """Every runs/*/summary.csv has the columns plot writes now, and each energy residual in
    it was taken with every energy ledger the code books (a summary made from files that
    lacked one carried a residual 30-80 times too large); the residual is then within the
    budget's target. A row whose files could not be re-read
    says so and claims no residual."""
    import csv

    from melange_ti.analysis.figures import SUMMARY_COLUMNS
    from melange_ti.diagnostics import FIELDS
    from melange_ti.io.hdf5 import FORMAT_VERSION
    from melange_ti.physics.data.schema import ENERGY_LEDGERS

    since = {f.name: f.since for f in FIELDS}
    # every ledger the runs' files held: those of the format version they were written in
    # (a ledger added later, e.g. friction_dissipated in 4, belongs to an effect they lacked)
    complete = {" + ".join(n for n in ENERGY_LEDGERS if since[n] <= v) for v in range(3, FORMAT_VERSION + 1)}

    root = Path(__file__).resolve().parents[1] / "runs"
    summaries = sorted(root.glob("*/summary.csv"))
    assert len(summaries) >= 4, summaries
    checked = 0
    for path in summaries:
        with open(path) as fh:
            reader = csv.DictReader(fh)
            assert tuple(reader.fieldnames) == SUMMARY_COLUMNS, (path, reader.fieldnames)
            for row in reader:
                if row["budget"].startswith("not recomputed"):
                    assert row["energy_residual_end"] == "", (path, row["group"])
                    continue
                assert row["budget"] in complete, (path, row["group"], row["budget"])
                ratio = float(row["energy_residual_end"]) / float(row["energy_released_end"])
                # the budget's target, 0.25% of the released energy (docs/validation.md; the water
                # effects' runs reach 0.10%), where a ledger left out gave 0.5-2.4%
                assert abs(ratio) < 2.5e-3, (path, row["group"], ratio)
                checked += 1
    assert checked >= 3


# ---------------------------------------------------------------------------------------
# User errors: one line, exit status 2


def _one_line_error(capsys, argv) -> str:
    assert cli(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("melange-ti: error: ") and "\n" not in err, err
    return err


def test_errors_are_one_line(hand_runs, tmp_path, capsys):
    missing = str(tmp_path / "nope.h5")
    assert "not found" in _one_line_error(capsys, ["plot", missing, "--out", str(tmp_path / "o")])
    assert "not found" in _one_line_error(capsys, ["render", missing, "--out", str(tmp_path / "o.mp4")])
    text = tmp_path / "text.h5"
    text.write_text("hello")
    _one_line_error(capsys, ["plot", str(text), "--out", str(tmp_path / "o")])
    _one_line_error(capsys, ["render", str(text), "--out", str(tmp_path / "o")])
    empty = tmp_path / "empty.h5"  # a run that has not written anything yet
    RunWriter(empty, attrs={"scene_toml": scene_toml()}, constants={"width": np.ones(4), "thickness": np.ones(4)}).close()
    assert "no snapshots" in _one_line_error(capsys, ["render", str(empty), "--out", str(tmp_path / "o")])
    assert "no snapshots" in _one_line_error(capsys, ["plot", str(empty), "--out", str(tmp_path / "o")])
    bare = tmp_path / "bare.h5"  # HDF5, but not a run file
    with h5py.File(bare, "w") as f:
        f["data"] = np.zeros(3)
    assert "not a readable melange_ti run" in _one_line_error(capsys, ["plot", str(bare), "--out", str(tmp_path / "o")])
    assert "--times" in _one_line_error(capsys, ["plot", hand_runs[0], "--out", str(tmp_path / "o"), "--times", "1,x"])
    assert "after the last snapshot" in _one_line_error(
        capsys, ["plot", *hand_runs, "--out", str(tmp_path / "o"), "--times", "9"]
    )
    assert "--width-m" in _one_line_error(capsys, ["plot", hand_runs[0], "--out", str(tmp_path / "o"), "--width-m", "-3"])
    assert "FILE.mp4" in _one_line_error(capsys, ["render", hand_runs[0], "--out", str(tmp_path / "movie.gif")])
    assert "--every" in _one_line_error(capsys, ["render", hand_runs[0], "--out", str(tmp_path / "d"), "--every", "0"])
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert "cannot create" in _one_line_error(capsys, ["plot", hand_runs[0], "--out", str(blocker / "sub")])


def test_the_snapshot_figure_starts_at_t0_and_names_only_what_it_draws(real_runs, tmp_path):
    """Issue 47: Fig. 2 left out the start, and its title named collision discs also where it
    drew none (a polygon's discs are not drawn). Its rows now begin at t = 0; the discs are
    named where rectangles' are drawn, and not for a run of polygons."""
    import melange_ti as mt
    from melange_ti.analysis import figures
    from melange_ti.analysis.runs import default_times, load_run, make_groups

    assert default_times(8.0)[0][0] == 0.0 and default_times(8000.0)[0] == [0.0, 100.0, 200.0, 300.0, 400.0]
    tri = [[0.0, 0.0], [1.0, 0.0], [0.5, 0.8]]
    text = dumps_toml(
        {
            "scene": {"name": "polygons", "effects": ["gravity", "buoyancy", "drag"]},
            "time": {"duration": 4.0},
            "output": {"snapshot_interval": 1.0},
            "iceberg": [{"x": 2.0, "z": -0.3, "vertices": tri}, {"x": 4.0, "z": -0.3, "theta": 0.4, "vertices": tri}],
        }
    )
    poly = tmp_path / "poly.h5"
    mt.run(mt.scene.loads(text), poly)
    units = figures.Units(width_m=70.0)
    for path, discs in ((real_runs[0], True), (poly, False)):
        groups = make_groups([load_run(path)])
        times = default_times(float(groups[0].runs[0].snaps["time"][-1]))[0]
        fig = figures.fig_snapshots(groups, units, times)
        title = fig._suptitle.get_text()
        assert ("collision discs" in title) == discs, title
        first = [t.get_text() for t in fig.axes[0].texts]
        assert "t = 0" in first, first
