"""Bit-identical results: serial vs parallel kernels, run to run, and across thread counts.

The scene is paper-like (40 icebergs 1 x 1.4, gaps 0.1, all effects, restitution 0.5) with
seeded random initial spins so that icebergs capsize and collide within 2000 steps
(contacts, wall impulses and corrections all happen). Thread counts need separate processes
(Taichi is initialised once per process), so those runs go through the command line and the
HDF5 outputs are compared dataset by dataset, byte for byte.
"""

from __future__ import annotations

import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

from melange_ti import scene as scene_mod
from melange_ti.model import Model
from melange_ti.scene import DENSITY_RATIO, dumps_toml

STEPS = 2000
R = DENSITY_RATIO


def scene_text() -> str:
    rng = np.random.default_rng(7)
    h = 1.4
    bergs = [
        {"x": 0.1 + 0.5 + k * 1.1, "z": -R * h + h / 2, "omega": float(rng.uniform(-0.3, 0.3)), "width": 1.0, "thickness": h}
        for k in range(40)
    ]
    doc = {
        "scene": {"name": "determinism", "effects": ["gravity", "buoyancy", "drag", "collisions", "wall"]},
        "physics": {"density_ratio": R, "restitution": 0.5, "drag": 0.01, "angular_drag": 0.01},
        "contacts": {"discs": 12, "contact_passes": 2},
        "time": {"dt": 0.01, "duration": STEPS * 0.01, "seed": 1},
        "output": {"snapshot_interval": 1.0, "diagnostic_interval": 0.5},
        "iceberg": bergs,
    }
    return dumps_toml(doc)


def run_model(sc, mode, islands=None, groups=None):
    m = Model(sc, mode=mode, islands=islands, groups=groups)
    assert m.mode == mode
    if groups is not None:
        assert m.groups == groups
    m.advance(STEPS)
    return m.sample(), m.totals()


def assert_bitwise(a: dict, b: dict, what: str):
    assert a.keys() == b.keys()
    bad = []
    for k in a:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        assert x.dtype == y.dtype and x.shape == y.shape, f"{what}: {k} dtype/shape differ"
        if x.tobytes() != y.tobytes():
            diff = np.asarray(x != y)
            size = np.max(np.abs(x - y)) if x.dtype.kind == "f" else "-"
            bad.append(f"{k} ({int(diff.sum())} of {diff.size} values, max |diff| {size})")
    assert not bad, f"{what}: not bit-identical: " + ", ".join(bad)


@pytest.fixture(scope="module")
def serial_result():
    sc = scene_mod.loads(scene_text())
    return run_model(sc, "serial")


def test_scene_is_not_trivial(serial_result):
    from melange_ti.diagnostics import capsized_fraction

    s, tot = serial_result
    assert tot.impulses > 200 and tot.wall_impulse > 0 and capsized_fraction(s["theta"]) > 0


from melange_ti.physics.data.schema import STATE_NAMES as STATE  # noqa: E402


@pytest.fixture(scope="module")
def other_runs():
    sc = scene_mod.loads(scene_text())
    runs = (
        ("parallel", "parallel", False, 1),
        ("parallel 2 groups", "parallel", False, 2),
        ("parallel 3 groups", "parallel", False, 3),
        ("parallel islands", "parallel", True, None),
        ("parallel again", "parallel", None, None),
        ("serial again", "serial", None, None),
    )
    return {name: run_model(sc, mode, islands, groups) for name, mode, islands, groups in runs}


OTHERS = ["parallel", "parallel 2 groups", "parallel 3 groups", "parallel islands", "parallel again", "serial again"]


def test_groups_split_where_no_contact_crosses():
    """The groups' bounds (physics/forms/groups.py) after a detection: ascending, each at or after
    its share of the bodies, and no contact joins two groups; the scene does split."""
    from melange_ti.physics.data.schema import BodyInt

    sc = scene_mod.loads(scene_text())
    m = Model(sc, mode="parallel", islands=False, groups=3)
    split = 0
    for _ in range(40):
        m.advance(50)
        bi = m.arrays.bi.to_numpy()
        starts = bi[:4, BodyInt.ISLAND_START]
        assert starts[0] == 0 and starts[3] == m.n and np.all(np.diff(starts) >= 0), starts
        cp = m.arrays.cp.to_numpy()  # the last detection's contacts, which the bounds were cut from
        group = np.searchsorted(starts, np.arange(m.n), side="right") - 1
        for g in (1, 2):
            if starts[g] < m.n:
                split += 1
                assert starts[g] >= g * m.n // 3, starts
        for i in range(m.n):
            for s in range(bi[i, BodyInt.NCONTACT]):
                assert group[i] == group[cp[s, i]], (i, cp[s, i], starts)
    assert split > 0, "the scene never split: the test needs one that does"


@pytest.mark.parametrize("other", OTHERS)
def test_state_bit_identical(serial_result, other_runs, other):
    """State and cumulative totals after 2000 steps: serial == parallel, run 1 == run 2."""
    s_ser, t_ser = serial_result
    s_oth, t_oth = other_runs[other]
    assert_bitwise({k: s_ser[k] for k in STATE}, {k: s_oth[k] for k in STATE}, f"state, serial vs {other}")
    assert t_ser == t_oth, (t_ser, t_oth)


@pytest.mark.parametrize("other", OTHERS)
def test_energy_diagnostics_bit_identical(serial_result, other_runs, other):
    """Per-body kinetic and potential energy and drag work (what the HDF5 diagnostics sum)."""
    s_ser, _ = serial_result
    s_oth, _ = other_runs[other]
    keys = ("kinetic", "potential", "drag_dissipated")
    assert_bitwise({k: s_ser[k] for k in keys}, {k: s_oth[k] for k in keys}, f"energies, serial vs {other}")


def read_all(path):
    out = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                out[name] = obj[()]

        f.visititems(visit)
        attrs = {k: f.attrs[k] for k in f.attrs}
    return out, attrs


def test_thread_counts_give_identical_files(tmp_path, serial_result):
    """`melange_ti run --threads N` for N = 1, 2, 4 (parallel kernels): identical datasets."""
    scene_file = tmp_path / "det.toml"
    scene_file.write_text(scene_text())
    env = {k: v for k, v in os.environ.items() if k != "TI_CPU_MAX_NUM_THREADS"}
    procs = {}
    for n in (1, 2, 4):
        out = tmp_path / f"t{n}.h5"
        cmd = [sys.executable, "-m", "melange_ti", "run", str(scene_file), "--out", str(out)]
        cmd += ["--threads", str(n), "--mode", "parallel"]
        procs[n] = (out, subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env))
    files = {}
    for n, (out, p) in procs.items():
        stdout, stderr = p.communicate(timeout=600)
        assert p.returncode == 0, f"--threads {n} failed ({p.returncode}): {stderr[-2000:]}"
        files[n] = read_all(out)
    ref, ref_attrs = files[1]
    assert "snapshots/x" in ref and ref["snapshots/x"].shape[0] == 21
    for n in (2, 4):
        data, attrs = files[n]
        assert data.keys() == ref.keys()
        assert_bitwise(ref, data, f"--threads 1 vs --threads {n}")
        # history says when and by which command each file was made: it differs by nature
        same = {k: str(v) for k, v in attrs.items() if k != "history"}
        assert same == {k: str(v) for k, v in ref_attrs.items() if k != "history"}
    # and the command-line runs end exactly where the in-process serial model does
    s_ser, _ = serial_result
    for key in STATE:
        assert ref[f"snapshots/{key}"][-1].tobytes() == s_ser[key].tobytes(), f"CLI vs in-process serial: {key} differs"


@pytest.mark.parametrize("mode", ["serial", "parallel"])
def test_set_state_refreshes_cached_tilt(mode):
    """A step caches cos/sin of every tilt; a state loaded from the host mid-run (resume,
    ensembles, benchmarks) must be stepped exactly like a model built from that state."""
    sc = scene_mod.loads(scene_text())
    used = Model(sc, mode=mode)
    used.advance(300)  # its cached tilts now belong to another state
    target = {k: v.copy() for k, v in used.state().items()}
    target["theta"] = target["theta"] + 0.2  # a state the model never was in
    target["x"] = target["x"] + np.arange(target["x"].size) * 0.5  # room to turn
    used.set_state(target)
    fresh = Model(sc, mode=mode)
    fresh.set_state(target)
    used.advance(200)
    fresh.advance(200)
    a, b = used.sample(), fresh.sample()
    assert_bitwise({k: a[k] for k in STATE}, {k: b[k] for k in STATE}, f"{mode}: reused vs fresh model")


def test_auto_mode_calibrates_between_the_thresholds_and_keeps_the_bits():
    """With several threads and CALIBRATE_MIN_N <= N <= SERIAL_MAX_N, ``mode="auto"`` times
    both forms on the run's first steps and keeps the faster; whichever it keeps, the
    state is the serial form's, bit for bit. Below CALIBRATE_MIN_N it does not measure."""
    import taichi as ti

    from melange_ti.model import CALIBRATE_MIN_N, CALIBRATE_STEPS

    assert ti.lang.impl.current_cfg().cpu_max_num_threads > 1, "run with MELANGE_TEST_THREADS > 1"
    n = CALIBRATE_MIN_N
    sc = scene_mod.load(None, overrides=[("shelf.count", n), ("shelf.tilt", 0.2), ("shelf.gap", 0.3), ("contacts.discs", 12)])
    steps = 2 * (CALIBRATE_STEPS + 1) + 30
    auto = Model(sc, mode="auto")
    auto.advance(steps)
    assert auto.calibration is not None and set(auto.calibration) == {"serial", "parallel"}
    assert auto.mode == min(auto.calibration, key=auto.calibration.get)
    assert all(v > 0 for v in auto.calibration.values())
    serial = Model(sc, mode="serial")
    serial.advance(steps)
    assert serial.calibration is None
    assert_bitwise(serial.sample(), auto.sample(), f"auto ({auto.mode}) vs serial")
    assert serial.totals() == auto.totals()
    small = Model(scene_mod.load(None, overrides=[("shelf.count", n - 1)]), mode="auto")
    small.advance(steps)
    assert small.calibration is None and small.mode == "serial"


@pytest.mark.parametrize("islands,groups", [(False, None), (True, None), (False, 2)])
def test_profile_times_every_part_and_keeps_the_bits(serial_result, islands, groups):
    """``Model.profile(parts=True)`` (the benchmarks' per-kernel table) times each kernel a
    stage launches inside that stage's time, and steps exactly as ``advance`` does."""
    from melange_ti.physics import stages

    sc = scene_mod.loads(scene_text())
    m = Model(sc, mode="parallel", islands=islands, groups=groups)
    m.advance(STEPS - 20)
    prof = m.profile(20, parts=True)
    parts = {k: v for k, v in prof.items() if "." in k}
    for st in stages.STAGES:
        grouped = not islands and m.groups > 1 and st.groups is not None
        if (st.islands_only and not islands and not grouped) or not st.needs(m.fx):
            continue  # (a stage the scene does not need, e.g. the waves': not launched)
        launched = st.groups if grouped else st.without_islands if (not islands and st.without_islands) else st.parallel
        names = {f"{st.name}.{p.func.__name__}" for p in launched if p.needs(m.fx)}
        assert names <= parts.keys(), (st.name, names - parts.keys())
        assert all(parts[k] > 0 for k in names)
        assert prof[st.name] >= sum(parts[k] for k in names)
    s, tot = serial_result
    assert_bitwise(s, m.sample(), f"profiled parallel (islands {islands}, groups {groups}) vs serial")
    assert tot == m.totals()


def test_sampled_advance_in_one_launch_keeps_the_bits(serial_result):
    """``Model.advance_sampled`` (a run's output events between two writes, in one launch
    of the serial form) gives each sample and total exactly as ``advance`` and
    ``sample_with_totals`` in turn, and leaves the model where ``advance`` would."""
    sc = scene_mod.loads(scene_text())
    segments = [1, 299, 200, 500, 0, 1000]
    batched, stepped = Model(sc, mode="serial"), Model(sc, mode="serial")
    got = batched.advance_sampled(segments)
    assert len(got) == len(segments)
    for k, steps in enumerate(segments):
        stepped.advance(steps)
        s, tot = stepped.sample_with_totals()
        assert_bitwise(s, got[k][0], f"sample {k}")
        assert tot == got[k][1]
        assert_bitwise(s, stepped.sample(), f"sample_with_totals vs sample, {k}")
    s, tot = serial_result
    assert_bitwise(s, batched.sample(), "batched vs advance(STEPS)")
    assert tot == batched.totals() == got[-1][1]
