"""A new user's sharp edges around ensembles and packaging (issue 32, point 13): the time
estimate, an unreachable ``--scheduler``, an interrupted ensemble's output, the full-disk
message, the Pythons the package installs on. Issue 47, item 10: the cluster stops with the
command however it ends (SIGTERM as the cluster starts, while a run goes, while the worker
compiles, twice; a run failing in its worker): no process below the command is left.

Those tests start real ensembles as commands (one spawned worker, the tiny scene of
test_ensemble.py, whose kernels other tests have compiled; one compiles without the cache)
and watch the processes below them with psutil; the rest run in this process.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import psutil
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
    plan line and the interrupt's line, none of Dask's shutdown warnings; status 130. Dask's
    dashboard port (8787) is held meanwhile, as a second ensemble beside this one holds it:
    Dask then warned that it was in use (a test run's two processes met it by chance)."""
    import socket

    (tmp_path / "tiny.toml").write_text(TINY.replace("duration = 5.0", "duration = 2000.0"))
    held = socket.socket()
    try:
        held.bind(("", 8787))
        held.listen()
    except OSError:  # already taken (by another ensemble): the same situation
        pass
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
        held.close()
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    assert p.returncode == 130, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 2, err
    assert lines[0].startswith("ensemble: 1 run to do") and lines[1].startswith("melange-ti: interrupted"), err
    assert (tmp_path / "ens" / "ensemble.json").exists()


# ---------------------------------------------------------------------------- the cluster stops with it
def _start(tmp_path, *args, duration=None, env=None):
    """``melange-ti ensemble tiny.toml --out ens --workers 1 ARGS`` in a session of its own."""
    (tmp_path / "tiny.toml").write_text(TINY if duration is None else TINY.replace("duration = 5.0", f"duration = {duration}"))
    return subprocess.Popen(
        [sys.executable, "-m", "melange_ti", "ensemble", "tiny.toml", "--out", "ens", "--workers", "1", *args],
        cwd=tmp_path,
        env={**os.environ, "MELANGE_TEST_THREADS": "1", **(env or {})},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


class _Family:
    """Every process seen below ``pid`` (psutil), gathered each time it is looked at: a
    worker a nanny restarts while the cluster shuts down is seen too."""

    def __init__(self, pid: int):
        self.root = psutil.Process(pid)
        self.seen: dict[int, psutil.Process] = {}
        self.cmd: dict[int, str] = {}

    def look(self) -> list:
        with contextlib.suppress(psutil.NoSuchProcess):
            for p in self.root.children(recursive=True):
                # read each time: a child caught between fork and exec still shows its parent's command
                with contextlib.suppress(psutil.NoSuchProcess, psutil.AccessDenied):
                    line = " ".join(p.cmdline())
                    if "spawn_main" in line or p.pid not in self.cmd:
                        self.cmd[p.pid] = line
                    self.seen.setdefault(p.pid, p)
        return list(self.seen.values())

    def workers(self) -> list:
        """The Dask workers seen (spawned by multiprocessing; the other child is its resource tracker)."""
        self.look()
        return [p for p in self.seen.values() if "spawn_main" in self.cmd[p.pid]]

    def alive(self) -> list:
        out = []
        for p in self.seen.values():
            with contextlib.suppress(psutil.NoSuchProcess):
                if p.is_running() and p.status() != psutil.STATUS_ZOMBIE:  # is_running: the same process, not a reused pid
                    out.append(p)
        return out

    def kill_all(self) -> None:
        for p in [self.root, *self.alive()]:
            with contextlib.suppress(psutil.NoSuchProcess):
                p.kill()


def _wait(until, proc, family, limit=300.0) -> None:
    deadline = time.monotonic() + limit
    while not until() and time.monotonic() < deadline and proc.poll() is None:
        family.look()
        time.sleep(0.2)


def _ended(proc, family, limit: float, after: float = 10.0) -> tuple[str, str]:
    """Wait up to ``limit`` s for ``proc`` to exit (watching its family meanwhile), then up to
    ``after`` s for every process seen below it to be gone; kill what is left and fail."""
    deadline = time.monotonic() + limit
    while proc.poll() is None and time.monotonic() < deadline:
        family.look()
        time.sleep(0.1)
    ended = proc.poll() is not None
    deadline = time.monotonic() + after
    while ended and family.alive() and time.monotonic() < deadline:
        time.sleep(0.2)
    left = family.alive()
    family.kill_all()  # then the pipes close (a worker holds them too) and the output can be read
    out, err = proc.communicate(timeout=30)
    assert ended, f"still running {limit:.0f} s after the signal\n{err}"
    assert not left, f"left running {after:.0f} s after the command ended: {[family.cmd[p.pid] for p in left]}\n{err}"
    return out, err


def test_sigterm_stops_the_cluster_and_keeps_the_finished_runs(tmp_path, capsys):
    """SIGTERM to the ensemble (not its group: the worker gets nothing) while its second run
    goes: within seconds it exits with 143 and one line, and no process below it is left;
    the finished run is intact, the unfinished one resumes with the same command."""
    sets = ["--set", "time.duration=20,3000"]
    p = _start(tmp_path, "--seeds", "1", *sets)
    family = _Family(p.pid)
    long_ckpt = tmp_path / "ens" / "duration=3000_seed1.h5.ckpt"
    _wait(lambda: long_ckpt.exists() and family.workers(), p, family)
    running = p.poll() is None
    if running:
        workers = family.workers()
        p.send_signal(signal.SIGTERM)
    out, err = _ended(p, family, limit=60)
    assert running, err
    assert workers and all(w.pid != p.pid for w in workers)
    assert p.returncode == 143, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert "Traceback" not in err and len(lines) == 3, err  # the plan, the first run's line, the stop
    assert lines[0].startswith("ensemble: 2 runs to do") and "time.duration = 20, 3000 x seed 1" in lines[0], err
    assert lines[1].startswith("[1/2] duration=20_seed1.h5: done"), err
    assert lines[2].startswith("melange-ti: terminated (SIGTERM)") and "run the same command again" in lines[2], err

    ens = tmp_path / "ens"
    runs = {r["file"]: r for r in json.loads((ens / "ensemble.json").read_text())["runs"]}
    assert runs["duration=20_seed1.h5"]["status"] == "complete" and runs["duration=3000_seed1.h5"]["status"] == "pending"
    with h5py.File(ens / "duration=20_seed1.h5", "r") as f:
        assert f.attrs["complete"] == True  # noqa: E712 (numpy bool)
    with h5py.File(ens / "duration=3000_seed1.h5", "r") as f:
        assert not f.attrs["complete"]
    finished = (ens / "duration=20_seed1.h5").stat().st_mtime_ns

    argv = ["ensemble", str(tmp_path / "tiny.toml"), "--seeds", "1", "--out", str(ens), "--workers", "1", *sets]
    assert cli.main(argv) == 0
    assert "1 ran, 1 already complete, 0 failed" in capsys.readouterr().out
    runs = {r["file"]: r for r in json.loads((ens / "ensemble.json").read_text())["runs"]}
    assert runs["duration=3000_seed1.h5"]["summary"]["resumed"] is True
    assert runs["duration=3000_seed1.h5"]["summary"]["time"] == 3000.0
    assert (ens / "duration=20_seed1.h5").stat().st_mtime_ns == finished


def test_sigterm_as_the_cluster_starts_leaves_no_worker(tmp_path):
    """SIGTERM as soon as the worker process exists, while the local cluster starts (the
    worker has yet to import Dask and register): the cluster is stopped once it is up, not
    left half-started; status 143, nothing below the process left, no run file begun."""
    p = _start(tmp_path, "--seeds", "2", duration=2000.0)
    family = _Family(p.pid)
    _wait(family.workers, p, family, limit=60)
    running = p.poll() is None
    if running:
        p.send_signal(signal.SIGTERM)
    out, err = _ended(p, family, limit=60)
    assert running, err
    assert p.returncode == 143, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert "Traceback" not in err and len(lines) == 2, err
    assert lines[0].startswith("ensemble: 2 runs to do") and lines[1].startswith("melange-ti: terminated (SIGTERM)"), err
    assert json.loads((tmp_path / "ens" / "ensemble.json").read_text())["runs"][0]["status"] == "pending"


def test_sigterm_while_the_worker_compiles_leaves_no_worker(tmp_path):
    """Issue 47: SIGTERM while the worker compiles its kernels (the offline cache off: ~20 s
    of compiling, the GIL held), where Dask's own watch of the parent (a thread of the
    worker) cannot run: the worker once went on alone until the compile ended. The ensemble
    now shuts its cluster down (the worker killed within seconds) before it exits."""
    p = _start(tmp_path, "--seeds", "1", duration=2000.0, env={"TI_OFFLINE_CACHE": "0"})
    family = _Family(p.pid)
    _wait(lambda: (tmp_path / "ens" / "seed1.h5.ckpt").exists(), p, family)  # written at t = 0, before the step compiles
    _wait(lambda: False, p, family, limit=3.0)  # into the step's compile: before this commit the worker outlived it by ~20 s
    running = p.poll() is None
    if running:
        p.send_signal(signal.SIGTERM)
    out, err = _ended(p, family, limit=30, after=5)
    assert running and family.workers(), err
    assert p.returncode == 143 and "Traceback" not in err, err
    assert err.strip().splitlines()[-1].startswith("melange-ti: terminated (SIGTERM)"), err


def test_a_second_sigterm_stops_at_once_and_leaves_no_worker(tmp_path):
    """A second SIGTERM while the first one's shutdown waits for the busy worker (Dask gives
    it 4 s): the worker is killed and the command exits at once, still with 143."""
    p = _start(tmp_path, "--seeds", "1", duration=2000.0)
    family = _Family(p.pid)
    _wait(lambda: (tmp_path / "ens" / "seed1.h5.ckpt").exists() and family.workers(), p, family)
    running = p.poll() is None
    if running:
        p.send_signal(signal.SIGTERM)
        _wait(lambda: False, p, family, limit=0.5)
        p.send_signal(signal.SIGTERM)
        _wait(lambda: False, p, family, limit=3.0)  # the shutdown alone would wait 4 s for the worker
    quick = p.poll() is not None
    out, err = _ended(p, family, limit=30, after=5)
    assert running, err
    assert quick, f"still running 3 s after the second SIGTERM\n{err}"
    assert p.returncode == 143 and "Traceback" not in err, err
    assert "melange-ti: SIGTERM again: worker processes killed; run the same command again" in err, err


def test_a_run_failing_in_its_worker_leaves_no_worker(tmp_path):
    """A run that fails inside its worker (a directory where its file belongs): the other
    run finishes, status 3, and the cluster's processes are gone with the command."""
    (tmp_path / "ens" / "seed2.h5").mkdir(parents=True)
    p = _start(tmp_path, "--seeds", "2")
    family = _Family(p.pid)
    _wait(lambda: False, p, family)
    out, err = _ended(p, family, limit=30)
    assert p.returncode == 3, err
    assert family.workers(), "no worker was seen"
    assert "1 ran, 0 already complete, 1 failed" in out, out + err
    assert "melange-ti: error: run seed2.h5 (seed 2) failed" in err and "Traceback" not in err, err


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
