"""Smoke test of ``melange-ti bench ... --quick`` and of the benchmark helpers.

Each subcommand runs in its own process (the benchmarks initialise Taichi themselves, and the
accuracy benchmark starts f64 and f32 worker processes), all four at once, into a temporary
directory; the tests check the CSV columns and that the PNG files exist. Benchmarks never
assert a speed: only that the timings are finite and positive. The four runs start four
Taichi processes at once (and the accuracy benchmark more), so they are marked ``bench``
and left out of the default suite: run them with ``python -m pytest -m bench`` (the
helpers' tests below run by default).
"""

from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from melange_ti.bench import accuracy, common, effects, scaling
from melange_ti.bench.peers import PEERS_COLUMNS
from melange_ti.studies import have_pymunk

WHICH = ("scaling", "accuracy", "effects", "peers")
COLUMNS = {"accuracy": accuracy.ACCURACY_COLUMNS, "effects": effects.EFFECTS_COLUMNS, "peers": PEERS_COLUMNS}


def _columns(which: str) -> list[str]:
    # scaling's phase columns are the physics' stage names, imported when asked for
    return scaling.columns() if which == "scaling" else COLUMNS[which]


@pytest.fixture(scope="module")
def quick_runs(tmp_path_factory):
    """Start the four ``--quick`` benchmarks together; return ``(out, {which: (status, log)})``."""
    out = tmp_path_factory.mktemp("bench")
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    procs = {}
    for which in WHICH:
        log = open(out / f"{which}.log", "w")  # closed below
        cmd = [sys.executable, "-m", "melange_ti", "bench", which, "--quick", "--out", str(out)]
        procs[which] = (subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, env=env), log)
    done = {}
    for which, (proc, log) in procs.items():
        try:
            status = proc.wait(timeout=900)
        except subprocess.TimeoutExpired:
            proc.kill()
            status = "timeout"
        log.close()
        done[which] = (status, (out / f"{which}.log").read_text())
    return out, done


def _read(path: Path) -> tuple[list[str], list[dict]]:
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        return list(reader.fieldnames or []), list(reader)


def _positive(rows: list[dict], key: str) -> None:
    for r in rows:
        v = float(r[key])
        assert math.isfinite(v) and v > 0, (key, r)


@pytest.mark.bench
@pytest.mark.parametrize("which", WHICH)
def test_quick_run_writes_csv_and_png(quick_runs, which):
    out, done = quick_runs
    status, log = done[which]
    assert status == 0, f"bench {which} --quick exited with {status}:\n{log[-3000:]}"
    columns, rows = _read(out / f"{which}.csv")
    assert columns == _columns(which)
    assert rows
    png = out / f"{which}.png"
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000


@pytest.mark.bench
def test_quick_scaling_content(quick_runs):
    out, done = quick_runs
    assert done["scaling"][0] == 0
    _, rows = _read(out / "scaling.csv")
    assert {(int(r["n"]), r["state"]) for r in rows} == {(n, s) for n in (60, 240) for s in ("initial", "active")}
    for key in ("ms_per_step", "iceberg_steps_per_s", "phase_forces_ms", "phase_narrow_ms", "phase_output_ms", "phase_sum_ms"):
        _positive(rows, key)
    columns, fits = _read(out / "scaling_fit.csv")
    assert columns == ["state", "quantity", "exponent", "prefactor_ms"]
    assert any(f["quantity"] == "ms_per_step" and math.isfinite(float(f["exponent"])) for f in fits)


@pytest.mark.bench
def test_quick_accuracy_content(quick_runs):
    out, done = quick_runs
    assert done["accuracy"][0] == 0, done["accuracy"][1][-3000:]
    _, rows = _read(out / "accuracy.csv")
    assert sum(r["reference"] == "true" for r in rows) == 1
    assert {r["precision"] for r in rows} == {"f64", "f32"}  # the f32 worker process ran
    for r in rows:
        assert r["ok"] == "true", r
        assert math.isfinite(float(r["cost_s_per_time"])) and float(r["cost_s_per_time"]) > 0
        assert math.isfinite(float(r["roll_period_error"]))
    assert any(r["pareto_ensemble"] == "true" for r in rows)
    columns, stab = _read(out / "accuracy_stability.csv")
    assert columns[:3] == ["test", "dt", "stable"]
    assert {r["test"].split()[0] for r in stab} == {"single", "paper"}
    assert (out / "accuracy_curves.csv").exists()


@pytest.mark.bench
def test_quick_effects_content(quick_runs):
    out, done = quick_runs
    assert done["effects"][0] == 0
    _, rows = _read(out / "effects.csv")
    assert {"all", "none"} <= {r["config"] for r in rows}
    _positive(rows, "ms_per_step")


@pytest.mark.bench
def test_quick_peers_content(quick_runs):
    out, done = quick_runs
    assert done["peers"][0] == 0
    _, rows = _read(out / "peers.csv")
    engines = {r["engine"] for r in rows}
    assert "melange_ti" in engines
    if have_pymunk():
        assert "pymunk+numpy" in engines
        _positive([r for r in rows if r["engine"] == "pymunk+numpy"], "ratio_vs_melange_ti")
    _positive(rows, "ms_per_step")


# ---------------------------------------------------------------------------- helpers, no Taichi
def test_pareto_fit_and_tile():
    front = accuracy._pareto([(1.0, 5.0), (2.0, 1.0), (3.0, 3.0), (0.5, float("inf")), (2.0, 1.0)])
    assert front == [True, True, False, False, True]
    b, c = scaling.fit_exponent([10, 100, 1000], [2e-3, 2e-2, 2e-1])
    assert b == pytest.approx(1.0) and c == pytest.approx(2e-4)
    state = {
        "x": np.array([0.6, 1.7]),
        "z": np.zeros(2),
        "theta": np.zeros(2),
        "vx": np.zeros(2),
        "vz": np.zeros(2),
        "omega": np.zeros(2),
        "width": np.ones(2),
        "thickness": np.full(2, 1.4),
    }
    tiled = common.tile(state, 5)
    assert len(tiled["x"]) == 5 and np.all(np.diff(tiled["x"]) > 0)
    assert tiled["x"][2] - 0.5 == pytest.approx(1.7 + 0.5 + 0.1)  # the next copy starts one gap on
    state["theta"] = np.array([0.0, math.pi / 2])  # the second one lying flat: 1.4 wide
    tiled = common.tile(state, 4)
    assert tiled["x"][2] - 0.5 == pytest.approx(1.7 + 0.7 + 0.1)
