"""A new user's sharp edges around ensembles and packaging (issue 32, point 13): the time
estimate, an unreachable ``--scheduler``, an interrupted ensemble's output, the full-disk
message, the Pythons the package installs on.

One test starts a real ensemble (one spawned worker, the tiny scene of test_ensemble.py,
whose kernels other tests have compiled); the rest run in this process without a cluster.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from melange_ti import cli, ensemble
from melange_ti.io.hdf5 import OutputError, RunWriter
from melange_ti.physics.data.schema import STATE_NAMES

from .test_ensemble import TINY

ROOT = Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------------------- the estimate
@pytest.mark.parametrize(
    "left, workers, expect",
    [
        (23, 2, "about 11 min (1 running now, then 11 rounds of ~60 s)"),
        (3, 2, "about 60 s (1 running now, then 1 round of ~60 s)"),
        (3, 4, "finish about now"),
        (7, 8, "finish about now"),
        (5, 1, "about 5 min (5 rounds of ~60 s)"),
        (23, 8, "about 2 min (7 running now, then 2 rounds of ~60 s)"),
        (9, 4, "about 2 min (3 running now, then 2 rounds of ~60 s)"),
    ],
)
def test_estimate_counts_the_runs_already_going(left, workers, expect):
    """When the first run (60 s) ends, the other ``workers - 1`` of its round are nearly done
    too: what is left is the remaining runs, ``workers`` at a time (worked out by hand: 23 left
    on 2 workers is 1 running and 22 in 11 rounds)."""
    line = ensemble.estimate(60.0, left, workers)
    assert expect in line, line


# ---------------------------------------------------------------------------- --scheduler
def test_unreachable_scheduler_fails_fast_and_creates_nothing(tmp_path, capsys):
    import distributed  # noqa: F401  (imported before the clock starts: its import is slow on a loaded machine)

    scene_path = tmp_path / "tiny.toml"
    scene_path.write_text(TINY)
    out = tmp_path / "ens"
    t0 = time.perf_counter()
    code = cli.main(["ensemble", str(scene_path), "--seeds", "1", "--out", str(out), "--scheduler", "tcp://127.0.0.1:1"])
    took = time.perf_counter() - t0
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith("melange-ti: error: --scheduler tcp://127.0.0.1:1: cannot connect"), err
    assert not out.exists()  # no directory, no ensemble.json
    assert took < 15, took  # Dask's client alone retries for 30 s


# ---------------------------------------------------------------------------- an interrupt
def test_interrupted_ensemble_prints_no_dask_warnings(tmp_path):
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) while the runs go: the
    plan line and the interrupt's line, none of Dask's shutdown warnings; status 130."""
    (tmp_path / "tiny.toml").write_text(TINY.replace("duration = 5.0", "duration = 2000.0"))
    env = {**os.environ, "MELANGE_TEST_THREADS": "1"}
    p = subprocess.Popen(
        [sys.executable, "-m", "melange_ti", "ensemble", "tiny.toml", "--seeds", "1", "--out", "ens"],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        deadline = time.monotonic() + 600
        while not list((tmp_path / "ens").glob("*.ckpt")) and time.monotonic() < deadline and p.poll() is None:
            time.sleep(0.5)
        assert p.poll() is None, p.communicate()
        os.killpg(p.pid, signal.SIGINT)
        out, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    assert p.returncode == 130, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 2, err
    assert lines[0].startswith("ensemble: 1 run to do") and lines[1].startswith("melange-ti: interrupted"), err
    assert (tmp_path / "ens" / "ensemble.json").exists()


# ---------------------------------------------------------------------------- a full disk
def _writer(path: Path) -> RunWriter:
    constants = {"mass": np.ones(2), "width": np.ones(2)}
    return RunWriter(path, {"scene_name": "t"}, constants, np.float64)


def _state() -> dict:
    return {k: np.zeros(2) for k in STATE_NAMES}


def test_disk_full_message_says_what_is_left(tmp_path, monkeypatch):
    """Before the first snapshot nothing was recorded (and the run removes the file); after
    it, the file holds everything up to the last write. The message says which."""
    import shutil

    from melange_ti.io import hdf5

    full = shutil.disk_usage(tmp_path)._replace(free=0)
    first = _writer(tmp_path / "new.h5")
    monkeypatch.setattr(hdf5.shutil, "disk_usage", lambda p: full)
    with pytest.raises(OutputError) as none_kept:
        first.snapshot(0.0, _state())
    first.close()
    monkeypatch.undo()

    second = _writer(tmp_path / "going.h5")
    second.snapshot(0.0, _state())
    monkeypatch.setattr(hdf5.shutil, "disk_usage", lambda p: full)
    with pytest.raises(OutputError) as kept:
        second.snapshot(0.5, _state())
    second.close()

    assert "no space left" in str(none_kept.value) and "no space left" in str(kept.value)
    assert "holds everything" not in str(none_kept.value) and "no file is left" in str(none_kept.value)
    assert "holds everything up to the last write" in str(kept.value)
    with h5py.File(tmp_path / "going.h5", "r") as f:
        assert f["snapshots/time"].shape == (1,)


# ---------------------------------------------------------------------------- packaging
def _python_range() -> tuple[tuple[int, int], tuple[int, int]]:
    spec = re.search(r'^requires-python = "(.*)"$', (ROOT / "pyproject.toml").read_text(), flags=re.M).group(1)
    low = re.search(r">=\s*3\.(\d+)", spec)
    high = re.search(r"<\s*3\.(\d+)", spec)
    assert low and high, f"requires-python = {spec!r}: give both ends (taichi has wheels for a range of Pythons)"
    return (3, int(low.group(1))), (3, int(high.group(1)))


def test_requires_python_is_what_taichi_has_wheels_for():
    """pip refuses a Python outside requires-python in one line naming it; within the range
    taichi 1.7 must have a wheel (3.14 has none: a user there got "no matching
    distribution"), and the README says which Pythons work."""
    (lo, hi) = _python_range()
    assert hi <= (3, 14) and lo >= (3, 10)
    assert lo <= sys.version_info[:2] < hi  # this one, where the tests run
    readme = (ROOT / "README.md").read_text()
    assert f"Python {lo[0]}.{lo[1]} to {hi[0]}.{hi[1] - 1}" in readme
