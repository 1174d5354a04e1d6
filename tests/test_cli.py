"""The command line end to end on a tiny scene (SPEC sections 4 and 5).

One real ``melange-ti run`` process (module fixture) makes the file that most tests read:
four icebergs, three at the wall with one pushed into the others, and one spinning freely
far away so that ``theta`` passes 2 pi (it must be stored continuous, not wrapped). It runs
with ``--set`` overrides and ``--overwrite`` over a junk file. The cheap refusals call
:func:`melange_ti.cli.main` in the pytest process.
"""

from __future__ import annotations

import hashlib
import math
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import tomllib

import melange_ti
from melange_ti import cli, scene
from melange_ti.scene import DENSITY_RATIO

THREADS = os.environ.get("MELANGE_TEST_THREADS", "2")  # as conftest: no Taichi re-init in-process

R = DENSITY_RATIO
Z0 = -R * 1.4 + 0.7  # hydrostatic equilibrium of an upright 1 x 1.4 iceberg
SPIN = 3  # index of the spinning iceberg
TINY = f"""
[scene]
name = "tiny"
effects = ["gravity", "buoyancy", "drag", "collisions", "wall"]
precision = "f64"

[physics]
density_ratio = {R}
restitution = 0.5

[contacts]
discs = 12

[time]
dt = 0.01
duration = 1.0
seed = 7

[output]
snapshot_interval = 0.25
diagnostic_interval = 0.05
checkpoint_interval = 0.5

[[iceberg]]
x = 0.6
z = {Z0!r}

[[iceberg]]
x = 1.7
z = {Z0!r}
theta = 0.02
vx = -0.3

[[iceberg]]
x = 2.8
z = {Z0!r}

[[iceberg]]
x = 12.0
z = {Z0!r}
omega = 4.0
"""
DURATION = 2.0  # set on the command line
RESTITUTION = 0.3  # set on the command line
SNAP, DIAG = 0.25, 0.05


def melange_ti_command() -> list[str]:
    """The installed console script if there is one next to this Python, else ``-m``."""
    script = Path(sys.executable).with_name("melange-ti")
    return [str(script)] if script.exists() else [sys.executable, "-m", "melange_ti"]


def error_lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if ln.startswith("melange-ti: error:")]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    (d / "tiny.toml").write_text(TINY)
    return d


@pytest.fixture(scope="module")
def tiny_run(tiny):
    """``melange-ti run tiny.toml --out run.h5 --overwrite --set ...`` over an existing junk file."""
    out = tiny / "run.h5"
    out.write_bytes(b"junk from an earlier attempt")
    cmd = melange_ti_command() + [
        "run",
        "tiny.toml",
        "--out",
        "run.h5",
        "--overwrite",
        "--threads",
        "1",
        "--set",
        f"time.duration={DURATION}",
        "--set",
        f"physics.restitution={RESTITUTION}",
    ]
    proc = subprocess.run(cmd, cwd=tiny, capture_output=True, text=True, timeout=600)
    return proc, out


@pytest.fixture(scope="module")
def run_file(tiny_run):
    proc, out = tiny_run
    assert proc.returncode == 0, proc.stderr
    with h5py.File(out, "r") as f:  # plain h5py, no SWMR flags
        data = {
            "attrs": dict(f.attrs),
            "groups": {g: sorted(f[g].keys()) for g in f.keys() if isinstance(f[g], h5py.Group)},
            **{f"{g}/{k}": f[g][k][()] for g in ("icebergs", "snapshots", "diagnostics") for k in f[g].keys()},
            "dtypes": {f"{g}/{k}": f[g][k].dtype for g in ("icebergs", "snapshots", "diagnostics") for k in f[g].keys()},
        }
    return data


# ----------------------------------------------------------------------------- run
def test_run_succeeds_and_prints_summary(tiny_run):
    proc, out = tiny_run
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert not error_lines(proc.stderr)
    text = proc.stdout
    steps = round(DURATION / 0.01)
    assert f"simulated t = {DURATION:g} in {steps} steps" in text, text
    assert "capsized fraction" in text
    assert "leading edge" in text
    assert "released (potential, E_p(0) - E_p(t))" in text and "lost (E(0) - E(t))" in text and "residual" in text
    assert "run.h5" in text


def test_summary_of_a_run_that_released_nothing_says_so():
    """A scene whose icebergs release no potential energy (waves alone, resting icebergs)
    prints its residual without a 'nan%' share."""
    import dataclasses

    from melange_ti.simulation import RunSummary

    values = {f.name: 0 for f in dataclasses.fields(RunSummary)}
    values.update(path="r.h5", steps=10, wall_seconds=1.0, startup_seconds=0.5, startup_steps=5, steps_per_second=10.0)
    values.update(compiled=False, backend="x64", energy_residual=0.0, energy_released=0.0, dt_accepted=float("nan"))
    values.update(precision="f64")
    text = "\n".join(RunSummary(**values).lines())
    assert "none released" in text and "nan" not in text, text
    values.update(energy_released=2.0, energy_residual=-0.001)
    assert "(-0.05% of released)" in "\n".join(RunSummary(**values).lines())


def test_overwrite_replaces_the_old_file(tiny_run):
    proc, out = tiny_run
    assert proc.returncode == 0, proc.stderr
    assert h5py.is_hdf5(out)


def test_finished_run_leaves_its_file_and_last_checkpoint(tiny_run, tiny):
    """The checkpoint at the end is kept, so the run can be extended (docs/reliability.md);
    no temporary file is left."""
    proc, out = tiny_run
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in tiny.iterdir() if p.name.startswith("run.h5")) == ["run.h5", "run.h5.ckpt"]


def test_file_attributes(run_file):
    attrs = run_file["attrs"]
    for key in ("scene_toml", "format_version", "melange_ti_version", "taichi_version", "arch", "precision", "seed"):
        assert key in attrs, f"missing root attribute {key}"
    as_text = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in attrs.items()}
    assert as_text["melange_ti_version"] == melange_ti.__version__
    import taichi as ti

    assert as_text["taichi_version"] == ".".join(map(str, ti.__version__))
    assert as_text["arch"] == "cpu"
    assert as_text["precision"] == "f64"
    assert int(as_text["seed"]) == 7
    assert int(as_text["format_version"]) >= 1


def test_scene_toml_is_the_resolved_scene_with_overrides(run_file):
    text = run_file["attrs"]["scene_toml"]
    text = text.decode() if isinstance(text, bytes) else text
    doc = tomllib.loads(text)
    assert doc["time"]["duration"] == DURATION
    assert doc["physics"]["restitution"] == RESTITUTION
    assert doc["scene"]["name"] == "tiny"
    assert len(doc["iceberg"]) == 4
    # The stored text is a valid scene that reloads to the same scene.
    again = scene.loads(text)
    assert again.to_toml() == text


def test_layout_shapes_and_dtypes(run_file):
    n = 4
    s = round(DURATION / SNAP) + 1
    d = round(DURATION / DIAG) + 1
    assert run_file["groups"]["icebergs"] == sorted(["width", "thickness", "mass", "inertia"])
    assert set(run_file["groups"]["snapshots"]) >= {"time", "x", "z", "theta", "vx", "vz", "omega"}
    assert set(run_file["groups"]["diagnostics"]) >= {
        "time",
        "capsized_fraction",
        "leading_edge",
        "kinetic_energy",
        "potential_energy",
        "drag_dissipated",
        "collision_dissipated",
        "correction_work",
        "contacts",
    }
    for k in ("width", "thickness", "mass", "inertia"):
        assert run_file[f"icebergs/{k}"].shape == (n,)
        assert run_file["dtypes"][f"icebergs/{k}"] == np.float64
    assert run_file["snapshots/time"].shape == (s,)
    for k in ("x", "z", "theta", "vx", "vz", "omega"):
        assert run_file[f"snapshots/{k}"].shape == (s, n), k
        assert run_file["dtypes"][f"snapshots/{k}"] == np.float64, k
    for k in run_file["groups"]["diagnostics"]:
        assert run_file[f"diagnostics/{k}"].shape == (d,), k
    assert np.issubdtype(run_file["dtypes"]["diagnostics/contacts"], np.integer)


def test_read_run_round_trip(tiny_run, run_file):
    """The package's own reader gives the same arrays and attributes as plain h5py."""
    from melange_ti.io.hdf5 import read_run

    proc, out = tiny_run
    data = read_run(out)
    for group in ("icebergs", "snapshots", "diagnostics"):
        assert sorted(data[group]) == run_file["groups"][group]
        for k, v in data[group].items():
            assert v.dtype == run_file[f"{group}/{k}"].dtype and v.tobytes() == run_file[f"{group}/{k}"].tobytes(), k
    assert data["attrs"]["scene_toml"] == run_file["attrs"]["scene_toml"]


def test_iceberg_constants(run_file):
    w, h = run_file["icebergs/width"], run_file["icebergs/thickness"]
    np.testing.assert_array_equal(w, 1.0)
    np.testing.assert_array_equal(h, 1.4)
    m = R * w * h
    np.testing.assert_allclose(run_file["icebergs/mass"], m, rtol=1e-14)
    np.testing.assert_allclose(run_file["icebergs/inertia"], m * (w**2 + h**2) / 12, rtol=1e-14)


def test_times_first_zero_last_duration(run_file):
    for group, every in (("snapshots", SNAP), ("diagnostics", DIAG)):
        t = run_file[f"{group}/time"]
        assert t[0] == 0.0, group
        assert math.isclose(t[-1], DURATION, rel_tol=1e-12), (group, t[-1])
        np.testing.assert_allclose(t, np.arange(len(t)) * every, rtol=1e-12, atol=1e-12)
        assert np.all(np.diff(t) > 0), group


def test_first_snapshot_is_the_initial_state(run_file):
    doc = tomllib.loads(TINY)
    init = {k: np.array([float(b.get(k, 0.0)) for b in doc["iceberg"]]) for k in ("x", "z", "theta", "vx", "vz", "omega")}
    for k, v in init.items():
        np.testing.assert_array_equal(run_file[f"snapshots/{k}"][0], v, err_msg=k)


def test_theta_is_continuous_not_wrapped(run_file):
    theta = run_file["snapshots/theta"][:, SPIN]
    # omega = 4 for 2 time units: the spinner turns more than a full revolution ...
    assert theta[-1] > 2 * math.pi, theta
    # ... and never jumps by a wrap (about 1 rad between snapshots here)
    assert np.all(np.diff(theta) > 0), theta
    assert np.all(np.abs(np.diff(run_file["snapshots/theta"], axis=0)) < math.pi)


def test_state_is_finite_and_physical(run_file):
    for k in ("x", "z", "theta", "vx", "vz", "omega"):
        assert np.all(np.isfinite(run_file[f"snapshots/{k}"])), k
    # the wall holds: no centre of mass left of it
    assert np.all(run_file["snapshots/x"] > 0.0)
    # the pushed iceberg hit its neighbour: contacts were counted
    assert run_file["diagnostics/contacts"].sum() > 0
    assert run_file["diagnostics/contacts"].min() >= 0
    cf = run_file["diagnostics/capsized_fraction"]
    assert np.all((cf >= 0) & (cf <= 1))
    assert np.all(run_file["diagnostics/kinetic_energy"] >= 0)
    for k in ("drag_dissipated", "collision_dissipated"):
        v = run_file[f"diagnostics/{k}"]
        assert v[0] == 0.0 and np.all(np.diff(v) >= 0), k
    assert run_file["diagnostics/collision_dissipated"][-1] > 0


def test_leading_edge_definition(run_file):
    x = run_file["snapshots/x"]
    t_snap = run_file["snapshots/time"]
    t_diag = run_file["diagnostics/time"]
    le = run_file["diagnostics/leading_edge"]
    for i, t in enumerate(t_snap):
        j = int(np.argmin(np.abs(t_diag - t)))
        assert math.isclose(le[j], x[i].max() - x[0].max(), rel_tol=1e-12, abs_tol=1e-12)


# ----------------------------------------------------------------------------- refusals (in-process)
def test_refuses_existing_output_without_overwrite(tiny, tiny_run, capsys):
    proc, out = tiny_run
    before = (hashlib.sha256(out.read_bytes()).hexdigest(), out.stat().st_mtime_ns)
    rc = cli.main(["run", str(tiny / "tiny.toml"), "--out", str(out), "--threads", THREADS])
    cap = capsys.readouterr()
    assert rc == 2
    lines = [ln for ln in cap.err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("melange-ti: error:"), cap.err
    assert "run.h5" in lines[0] and "--overwrite" in lines[0]
    assert (hashlib.sha256(out.read_bytes()).hexdigest(), out.stat().st_mtime_ns) == before


def test_resume_of_a_finished_run_changes_nothing(tiny, tiny_run, capsys):
    """Nothing is left to continue: a clear refusal (or a no-op), never a changed file."""
    proc, out = tiny_run
    assert proc.returncode == 0, proc.stderr
    before = hashlib.sha256(out.read_bytes()).hexdigest()
    argv = [
        "run",
        str(tiny / "tiny.toml"),
        "--out",
        str(out),
        "--resume",
        "--threads",
        THREADS,
        "--set",
        f"time.duration={DURATION}",
        "--set",
        f"physics.restitution={RESTITUTION}",
    ]
    rc = cli.main(argv)
    cap = capsys.readouterr()
    assert rc in (0, 2), cap.err
    assert "Traceback" not in cap.err
    if rc == 2:
        assert len([ln for ln in cap.err.splitlines() if ln.strip()]) == 1, cap.err
    assert hashlib.sha256(out.read_bytes()).hexdigest() == before


def test_resume_without_a_file_is_refused(tiny, capsys):
    out = tiny / "never_started.h5"
    rc = cli.main(["run", str(tiny / "tiny.toml"), "--out", str(out), "--resume", "--threads", THREADS])
    cap = capsys.readouterr()
    assert rc == 2
    assert len(error_lines(cap.err)) == 1 and "never_started.h5" in cap.err
    assert not out.exists()


# ----------------------------------------------------------------------------- check
def test_check_valid_scene(tiny, capsys):
    rc = cli.main(["check", str(tiny / "tiny.toml")])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "ok" in cap.out and "4 icebergs" in cap.out and "100 steps" in cap.out
    assert not any(p.suffix == ".h5" and p.name != "run.h5" for p in tiny.iterdir())


def test_check_with_set(tiny, capsys):
    rc = cli.main(["check", str(tiny / "tiny.toml"), "--set", "time.dt=0.005", "--set", "output.diagnostic_interval=0.05"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "200 steps" in cap.out and "0.005" in cap.out


def test_check_with_bad_set(tiny, capsys):
    rc = cli.main(["check", str(tiny / "tiny.toml"), "--set", "time.dt=-0.003"])
    cap = capsys.readouterr()
    assert rc == 2
    assert len(error_lines(cap.err)) == 1, cap.err
    assert "time.dt = -0.003" in cap.err and "must be > 0" in cap.err


def test_check_reports_rounded_intervals(tiny, capsys):
    """A dt that does not divide the intervals is accepted; each rounded value is said."""
    rc = cli.main(["check", str(tiny / "tiny.toml"), "--set", "time.dt=0.003"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "note: output.snapshot_interval" in cap.out and "steps of time.dt = 0.003" in cap.out, cap.out


def test_bundled_paper_scene_checks(capsys):
    """``check`` of the bundled scene (what ``run`` uses with no SCENE) is valid."""
    sc = scene.load(None)
    assert sc.icebergs().count == 400
    assert sc.time.dt == 0.01 and sc.time.duration == 8000.0


def test_version_and_help(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--version"])
    assert exc.value.code == 0
    assert melange_ti.__version__ in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        cli.main(["run", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for flag in ("--out", "--set", "--overwrite", "--resume", "--arch", "--threads"):
        assert flag in out, flag


def test_no_command_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main([])
    assert exc.value.code == 2
    assert "Traceback" not in capsys.readouterr().err
