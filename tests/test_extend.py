"""Extending a run to a later time (issue 32, point 8): ``melange-ti run --out RUN.h5 --resume
--set time.duration=LATER`` and ``mt.extend``. The file grows from the checkpoint a finished run
keeps, with the physics of its stored scene (here with friction), into exactly the file of one
run straight to the later time: every dataset bit for bit, and the stored scene. The first end
(t = 31.25) is off the snapshot and the diagnostic grids, so the rows written there only because
the run ended there must go, and the diagnostics' rates must go on from the last row on the grid."""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
from pathlib import Path

import h5py
import numpy as np
import pytest

from melange_ti import api, cli, scene
from melange_ti.errors import Interrupted, RunError
from melange_ti.io.checkpoint import checkpoint_path
from melange_ti.scene import stored_scene
from melange_ti.simulation import Simulation

THREADS = os.environ.get("MELANGE_TEST_THREADS", "2")  # as conftest: no Taichi re-init in-process
T1, T_MID, T2 = 31.25, 46.0, 60.0
SNAP, DIAG = 2.0, 0.5  # T1 on neither grid (their last times before it differ: 30, 31), T_MID on both
SETS = [
    "shelf.count=40",
    "shelf.tilt=0.1",  # capsizes and contacts early
    "scene.effects=gravity,buoyancy,drag,collisions,wall,friction",  # the effect set of tests/physics/test_friction.py
    "physics.friction=0.3",
    f"output.snapshot_interval={SNAP}",
    f"output.diagnostic_interval={DIAG}",
    "output.checkpoint_interval=7",
]


def run(*argv: str) -> int:
    return cli.main(["run", "--threads", THREADS, *argv])


def with_sets(*more: str) -> list[str]:
    return [arg for s in (*SETS, *more) for arg in ("--set", s)]


def datasets(path) -> dict[str, np.ndarray]:
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
        out["scene_toml"] = f.attrs["scene_toml"]
    return out


def assert_same(path, ref: dict) -> None:
    got = datasets(path)
    assert sorted(got) == sorted(ref)
    for k, v in ref.items():
        if k == "scene_toml":
            assert got[k] == v, "the stored scene must be the long run's"
        else:
            assert got[k].dtype == v.dtype and got[k].shape == v.shape, f"{k}: {got[k].shape} against {v.shape}"
            assert got[k].tobytes() == v.tobytes(), f"{k} differs from one run straight to t = {T2:g}"


def digests(folder) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir()}


def copy_run(src, dst) -> None:
    shutil.copy2(src, dst)
    shutil.copy2(checkpoint_path(src), checkpoint_path(dst))


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A run to T1 (kept as it finished, with its checkpoint) and one straight to T2."""
    d = tmp_path_factory.mktemp("extend")
    assert run("--out", str(d / "first.h5"), *with_sets(f"time.duration={T1}")) == 0
    assert run("--out", str(d / "long.h5"), *with_sets(f"time.duration={T2}")) == 0
    return d, datasets(d / "long.h5")


def test_a_finished_run_keeps_its_checkpoint_and_its_end_rows(runs):
    d, long = runs
    assert checkpoint_path(d / "first.h5").exists(), "a finished run must keep its last checkpoint (to be extended)"
    first = datasets(d / "first.h5")
    # every output at the end, on its grid or not: the rows an extension must drop
    assert first["snapshots/time"][-1] == T1 and first["diagnostics/time"][-1] == T1
    assert T1 not in long["snapshots/time"] and T1 not in long["diagnostics/time"]
    assert long["diagnostics/friction_dissipated"][-1] > 0  # friction acts in the test's scene


def test_extend_on_the_command_line_equals_one_long_run(runs, capsys):
    d, long = runs
    path = d / "cli.h5"
    copy_run(d / "first.h5", path)
    # the command: --resume with only the later duration; the rest from the stored scene
    assert run("--out", str(path), "--resume", "--set", f"time.duration={T2}") == 0, capsys.readouterr().err
    assert_same(path, long)
    with h5py.File(path, "r") as f:
        assert f.attrs["complete"]
        history = f.attrs["history"].splitlines()
    assert len(history) == 2 and f"time.duration {T1:g} -> {T2:g} from t = {T1:g}" in history[1], history
    assert stored_scene(path).effects.friction  # the physics came from the stored scene
    # finished at T2: nothing more to do, and the file stays as it is
    before = digests(d)
    assert run("--out", str(path), "--resume") == 0
    assert "nothing to resume" in capsys.readouterr().out
    assert digests(d) == before


def test_extend_twice_from_python_equals_one_long_run(runs):
    d, long = runs
    path = d / "api.h5"
    copy_run(d / "first.h5", path)
    api.extend(path, T_MID)  # an end on both grids: its rows stay
    with h5py.File(path, "r") as f:
        assert f["snapshots/time"][-1] == T_MID
    summary = api.extend(path, T2)
    assert summary.time == T2
    assert_same(path, long)


def test_an_end_on_one_grid_only_keeps_that_grids_row(runs):
    """Ended at t = 31 (on the diagnostics' grid, off the snapshots'), the extension drops the
    end snapshot and keeps the end diagnostic row, as one long run has them."""
    d, long = runs
    path = d / "half.h5"
    assert run("--out", str(path), *with_sets("time.duration=31.0")) == 0
    first = datasets(path)
    assert first["snapshots/time"][-1] == 31.0 and 31.0 not in long["snapshots/time"]
    assert 31.0 in long["diagnostics/time"]
    api.extend(path, T2)
    assert_same(path, long)


def test_an_interrupted_extension_keeps_the_file_and_goes_on(runs):
    """Stopped on the way (Ctrl-C here), the file still opens with every row up to the first
    end that a long run has, and says its new end; a plain resume then finishes it."""
    d, long = runs
    path = d / "stopped.h5"
    copy_run(d / "first.h5", path)
    sent = []

    def ctrl_c(step: int) -> None:
        if step >= 4000 and not sent:
            sent.append(step)
            os.kill(os.getpid(), signal.SIGINT)

    ext = scene.loads(stored_scene(path).to_toml(), [("time.duration", T2)], geometry=False)
    # SIGINT as in a terminal, also where the session inherited it ignored (a background job)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(Interrupted):
            Simulation(ext, path, resume=True, progress=False, on_event=ctrl_c, interface="api").run()
    finally:
        signal.signal(signal.SIGINT, previous)
    got = datasets(path)
    with h5py.File(path, "r") as f:
        assert not f.attrs["complete"]
    assert stored_scene(path).time.duration == T2
    for g in ("snapshots", "diagnostics"):
        n = len(got[f"{g}/time"])
        assert T1 < got[f"{g}/time"][-1] < T2
        for k in [k for k in long if k.startswith(g + "/")]:
            assert got[k].tobytes() == long[k][:n].tobytes(), k
    api.run(ext, path, resume=True)
    assert_same(path, long)


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--set", "time.duration=20"], "time.duration"),  # earlier than the end
        (["--set", "time.duration=70", "--set", "time.seed=2"], "time.seed"),  # another scene
        (["--set", "time.duration=70", "--set", "physics.friction=0.2"], "physics.friction"),
    ],
)
def test_a_refused_extension_changes_nothing(runs, tmp_path, capsys, argv, named):
    d, _ = runs
    copy_run(d / "first.h5", tmp_path / "run.h5")
    before = digests(tmp_path)
    assert run("--out", str(tmp_path / "run.h5"), "--resume", *argv) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and err[0].startswith("melange-ti: error:") and named in err[0], err
    if named == "time.duration":
        with pytest.raises(RunError, match="time.duration = 20 is not later"):
            api.extend(tmp_path / "run.h5", 20.0)
    assert digests(tmp_path) == before


def test_extension_without_a_checkpoint_is_refused(runs, tmp_path, capsys):
    """A run finished by an earlier melange_ti kept no checkpoint: one line, nothing changed."""
    d, _ = runs
    shutil.copy2(d / "first.h5", tmp_path / "run.h5")
    before = digests(tmp_path)
    assert run("--out", str(tmp_path / "run.h5"), "--resume", "--set", f"time.duration={T2}") == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and "no checkpoint" in err[0], err
    with pytest.raises(RunError, match="no checkpoint"):
        api.extend(tmp_path / "run.h5", T2)
    assert digests(tmp_path) == before


def test_a_new_run_over_a_finished_one_drops_its_checkpoint(runs, tmp_path, monkeypatch):
    """--overwrite of a finished run (whose checkpoint is kept): stopped before its own first
    checkpoint, the new file must not be resumable from the old run's end."""
    d, _ = runs
    path = tmp_path / "run.h5"
    copy_run(d / "first.h5", path)

    def stop(self, step, first=False, sampled=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(Simulation, "_events", stop)
    with pytest.raises(KeyboardInterrupt):
        Simulation(stored_scene(path), path, overwrite=True, progress=False).run()
    assert not checkpoint_path(path).exists()


def test_an_extension_stopped_before_its_first_checkpoint(runs, capsys):
    """Killed early (here: an error at its first event), an extension has only the old end's
    checkpoint, and the rows at that end are gone: going back to that end is refused (it would
    mark a file without them finished); --resume alone goes on to the new end."""
    d, long = runs
    path = d / "early.h5"
    copy_run(d / "first.h5", path)

    def fail(step: int) -> None:
        raise RuntimeError("stopped")

    ext = scene.loads(stored_scene(path).to_toml(), [("time.duration", T2)], geometry=False)
    with pytest.raises(RuntimeError, match="stopped"):
        Simulation(ext, path, resume=True, progress=False, on_event=fail, interface="api").run()
    before = digests(d)
    assert run("--out", str(path), "--resume", "--set", f"time.duration={T1}") == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and f"time.duration = {T1:g} is not later" in err[0], err
    assert digests(d) == before
    assert run("--out", str(path), "--resume") == 0
    assert_same(path, long)


def test_a_key_newer_than_the_stored_scene_counts_at_its_default():
    """A run begun by an earlier version stored no ``time.allow_unstable``: resuming it is no
    change of scene, unless the key is set to something other than its default."""
    from melange_ti.simulation import scene_changes

    text = scene.load(None).to_toml()
    older = "\n".join(line for line in text.splitlines() if not line.startswith("allow_unstable"))
    assert older != text and scene_changes(older, text) == []
    assert scene_changes(older, text.replace("allow_unstable = false", "allow_unstable = true")) == ["time.allow_unstable"]


def test_a_run_of_a_format_before_the_step_time_reading_is_refused_and_left_alone(tmp_path):
    """``tests/data/format6.h5`` (and its checkpoint, format 7) were written by an earlier
    version (07070fe: a 5-iceberg shelf with friction to t = 2.05), whose diagnostics read the
    kinetic energy of the velocities a step leaves; from run-file format 8 they read it at the
    step time (docs/model.md, "What the budget promises"). Extending it would join the two
    readings in one file, its budget jumping where they meet: the extension is refused in one
    line naming the format and what to do, and the file and its checkpoint are left as they were."""
    data = Path(__file__).parent / "data"
    path = tmp_path / "format6.h5"
    shutil.copy2(data / "format6.h5", path)
    shutil.copy2(data / "format6.h5.ckpt", checkpoint_path(path))
    before = (path.read_bytes(), checkpoint_path(path).read_bytes())
    with pytest.raises(RunError) as err:
        api.extend(path, 4.0)
    message = str(err.value)
    assert "\n" not in message and "run-file format 6" in message and "start it again" in message, message
    assert (path.read_bytes(), checkpoint_path(path).read_bytes()) == before
