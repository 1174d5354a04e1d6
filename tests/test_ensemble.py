"""``melange-ti ensemble``: planning, validation, and end-to-end runs on real Dask clusters.

The end-to-end tests start spawned worker processes (their own Taichi, one thread each) on a
scene of 8 icebergs for 5 time units, so each run takes well under a second once compiled.
"""

from __future__ import annotations

import json
import os

import h5py
import numpy as np
import pytest

from melange_ti import cli, ensemble, scene
from melange_ti.io.checkpoint import checkpoint_path
from melange_ti.simulation import Simulation

TINY = """
[scene]
name = "tiny"
effects = ["gravity", "buoyancy", "drag", "collisions", "wall"]
precision = "f64"

[time]
dt = 0.01
duration = 5.0
seed = 1

[output]
snapshot_interval = 1.0
diagnostic_interval = 0.5
checkpoint_interval = 1.0

[shelf]
count = 8
width = 1.0
thickness = 1.4
gap = 0.1
tilt = 0.01
"""

TEST_THREADS = os.environ.get("MELANGE_TEST_THREADS", "2")  # as conftest: no Taichi re-init


class _Stop(Exception):
    pass


@pytest.fixture
def tiny(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return path


def _interrupted(scene_path, out, overrides, at_step):
    """A real unfinished run: stopped from the event hook after a checkpoint."""

    def stop(step):
        if step == at_step:
            raise _Stop

    sc = scene.load(scene_path, overrides)
    with pytest.raises(_Stop):
        Simulation(sc, out, progress=False, on_event=stop).run()
    assert checkpoint_path(out).exists()


def _assert_identical(a, b):
    """Every attribute (but history: when and how each file was made) and every dataset
    bit-for-bit equal."""
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        assert set(fa.attrs) == set(fb.attrs)
        for k in set(fa.attrs) - {"history"}:
            va, vb = fa.attrs[k], fb.attrs[k]
            assert np.array_equal(np.asarray(va), np.asarray(vb)), k
        names_a, names_b = [], []
        fa.visititems(lambda n, o: names_a.append(n) if isinstance(o, h5py.Dataset) else None)
        fb.visititems(lambda n, o: names_b.append(n) if isinstance(o, h5py.Dataset) else None)
        assert sorted(names_a) == sorted(names_b) and names_a
        for n in names_a:
            da, db = fa[n][()], fb[n][()]
            assert da.dtype == db.dtype and da.shape == db.shape, n
            assert da.tobytes() == db.tobytes(), n


# ---------------------------------------------------------------------------- planning
def test_split_values_respects_lists_and_quotes():
    assert ensemble.split_values("12,28,60") == ["12", "28", "60"]
    assert ensemble.split_values('["gravity", "drag"]') == ['["gravity", "drag"]']
    assert ensemble.split_values('"a,b"') == ['"a,b"']
    assert ensemble.split_values('["gravity"],["gravity","drag"]') == ['["gravity"]', '["gravity","drag"]']
    assert ensemble.split_values("0.005") == ["0.005"]


def test_plan_is_the_product_with_deterministic_names():
    axes = ensemble.parse_sweep(["contacts.discs=12,28", "time.dt=0.005", "shelf.thickness=1.3,1.4,1.5"])
    assert [a.swept for a in axes] == [True, False, True]
    runs = ensemble.plan(axes, 2)
    assert len(runs) == 2 * 3 * 2
    names = [r.file for r in runs]
    assert len(set(names)) == len(names)
    assert names[0] == "discs=12_thickness=1.3_seed1.h5"
    assert names[-1] == "discs=28_thickness=1.5_seed2.h5"
    r = runs[-1]
    assert r.seed == 2 and r.overrides == [("contacts.discs", 28), ("time.dt", 0.005), ("shelf.thickness", 1.5)]
    assert [r.file for r in ensemble.plan(ensemble.parse_sweep([]), 3)] == ["seed1.h5", "seed2.h5", "seed3.h5"]
    # values that would clash or escape DIR are sanitised, still distinct
    odd = ensemble.plan(ensemble.parse_sweep(['scene.name="a/b","a b",c']), 1)
    assert all("/" not in r.file and " " not in r.file for r in odd)
    assert len({r.file for r in odd}) == 3


@pytest.mark.parametrize(
    "sets, seeds, fragment",
    [
        (["contacts.discs=8,10"], 2, "contacts.discs = 10"),
        (["contacts.dics=8"], 2, "contacts.dics"),
        (["time.seed=3"], 2, "--seeds"),
        (["contacts.discs=8,,12"], 2, "empty value"),
        (["contacts.discs=8,8"], 2, "listed twice"),
        (["contacts.discs=8", "contacts.discs=12"], 2, "more than once"),
        (["physics.drag=1,1.0"], 1, "same scene"),
        (["contactsdiscs=8"], 1, "SECTION.KEY"),
        # only one cell of the product is bad: 8 discs cannot cover an aspect ratio of 3.5
        (["contacts.discs=8,16", "shelf.thickness=1.4,3.5"], 1, "contacts.discs = 8"),
        ([], 0, "--seeds = 0"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_no_files(tiny, tmp_path, capsys, sets, seeds, fragment):
    out = tmp_path / "out"
    argv = ["ensemble", str(tiny), "--seeds", str(seeds), "--out", str(out)]
    for s in sets:
        argv += ["--set", s]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("melange-ti: error:") and fragment in err[0], err
    assert not out.exists()


def test_workers_with_scheduler_and_a_file_as_out_are_refused(tiny, tmp_path, capsys):
    base = ["ensemble", str(tiny), "--seeds", "1"]
    assert cli.main([*base, "--out", str(tmp_path / "a"), "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"]) == 2
    (tmp_path / "file").write_text("x")
    assert cli.main([*base, "--out", str(tmp_path / "file")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "--scheduler" in err[0] and "not a directory" in err[1]
    assert not (tmp_path / "a").exists()


# ---------------------------------------------------------------------------- end to end
def test_sweep_resume_overwrite_skip_and_identity(tiny, tmp_path, capsys):
    """4 runs on a 2-worker LocalCluster: 2 fresh, 1 resumed, 1 overwritten; bit-identical
    to ``melange-ti run``; a second call skips them all; a changed scene is refused."""
    out = tmp_path / "ens"
    out.mkdir()
    # discs=8 seed 2: unfinished with a checkpoint (t = 2) and rows up to t = 2.5 -> resumed
    _interrupted(tiny, out / "discs=8_seed2.h5", [("contacts.discs", 8), ("time.seed", 2)], at_step=250)
    # discs=12 seed 1: unfinished without its checkpoint -> cannot resume -> run again
    _interrupted(tiny, out / "discs=12_seed1.h5", [("contacts.discs", 12), ("time.seed", 1)], at_step=150)
    checkpoint_path(out / "discs=12_seed1.h5").unlink()

    argv = ["ensemble", str(tiny), "--seeds", "2", "--out", str(out), "--set", "contacts.discs=8,12", "--workers", "2"]
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    assert "4 ran, 0 already complete, 0 failed" in captured.out
    assert "total wall time" in captured.out
    # the plan before it starts, and an estimate once the first run is done
    plan_line = f"ensemble: 4 runs to do into {out}, on 2 local workers (contacts.discs = 8, 12 x seeds 1-2)"
    assert plan_line in captured.err, captured.err
    assert "the other 3 should take about" in captured.err and "(1 running now, then 1 round of ~" in captured.err, captured.err

    manifest = json.loads((out / "ensemble.json").read_text())
    runs = {r["file"]: r for r in manifest["runs"]}
    assert set(runs) == {f"discs={d}_seed{s}.h5" for d in (8, 12) for s in (1, 2)}
    assert manifest["sweep"] == {"contacts.discs": [8, 12]} and manifest["seeds"] == [1, 2]
    assert runs["discs=8_seed2.h5"]["summary"]["resumed"] is True
    assert runs["discs=12_seed1.h5"]["summary"]["resumed"] is False
    assert all(r["summary"]["worker_pid"] != os.getpid() for r in runs.values())  # ran in workers
    for name, r in runs.items():
        assert r["status"] == "complete"
        path = out / name
        assert checkpoint_path(path).exists()  # kept at the end: the run can be extended
        with h5py.File(path, "r") as f:
            assert f.attrs["complete"] == True  # noqa: E712 (numpy bool)
            assert f.attrs["seed"] == r["seed"]
            stored = scene.loads(f.attrs["scene_toml"])
            assert stored.time.seed == r["seed"] and stored.contacts.discs == r["overrides"]["contacts.discs"]
            assert f["snapshots/time"][-1] == 5.0

    # the identity property, for a fresh, a resumed and an overwritten run
    for discs, seed in ((8, 1), (8, 2), (12, 1)):
        ref = tmp_path / f"ref_{discs}_{seed}.h5"
        assert (
            cli.main(
                [
                    "run",
                    str(tiny),
                    "--out",
                    str(ref),
                    "--threads",
                    TEST_THREADS,
                    "--set",
                    f"contacts.discs={discs}",
                    "--set",
                    f"time.seed={seed}",
                ]
            )
            == 0
        )
        _assert_identical(out / f"discs={discs}_seed{seed}.h5", ref)
    capsys.readouterr()

    # a second call finds every run complete and touches none (no cluster is started)
    mtimes = {p.name: p.stat().st_mtime_ns for p in out.glob("*.h5")}
    assert cli.main(argv) == 0
    assert "0 ran, 4 already complete, 0 failed" in capsys.readouterr().out
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.h5")} == mtimes

    # finished files of another scene are never skipped as if they were this one's
    assert cli.main([*argv, "--set", "time.duration=4.0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "different scene" in err[0]
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.h5")} == mtimes


def _make_probe():
    """A function for ``client.run``, pickled by value (importing this module would import
    pytest): a forked child of this process would already hold pytest and Taichi."""

    def probe():
        import os
        import sys

        return {"pytest": "_pytest" in sys.modules, "pid": os.getpid()}

    return probe


def test_failed_run_is_reported_others_complete_on_existing_scheduler(tiny, tmp_path, capsys):
    """--scheduler: connect to a running cluster. A directory where seed 2's file belongs
    makes that run fail inside its worker; seeds 1 and 3 still finish; exit status 3."""
    import dask
    from distributed import Client, LocalCluster

    out = tmp_path / "ens"
    (out / "seed2.h5").mkdir(parents=True)
    with dask.config.set({"distributed.worker.multiprocessing-method": "spawn"}):
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            with Client(cluster) as client:
                probes = client.run(_make_probe())
                assert all(not p["pytest"] and p["pid"] != os.getpid() for p in probes.values())
            code = cli.main(["ensemble", str(tiny), "--seeds", "3", "--out", str(out), "--scheduler", cluster.scheduler_address])
    captured = capsys.readouterr()
    assert code == 3
    failures = [line for line in captured.err.splitlines() if line.startswith("melange-ti: error:")]
    assert len(failures) == 1 and "run seed2.h5 (seed 2) failed" in failures[0], captured.err
    assert "2 ran, 0 already complete, 1 failed" in captured.out
    for seed in (1, 3):
        with h5py.File(out / f"seed{seed}.h5", "r") as f:
            assert f.attrs["complete"] == True  # noqa: E712
    runs = {r["file"]: r for r in json.loads((out / "ensemble.json").read_text())["runs"]}
    assert runs["seed2.h5"]["status"] == "failed" and runs["seed2.h5"]["error"] and runs["seed2.h5"]["traceback"]
    assert (out / "seed2.h5").is_dir()  # left as it was
    assert runs["seed1.h5"]["status"] == runs["seed3.h5"]["status"] == "complete"


def test_local_cluster_workers_are_spawned():
    """The ensemble's own cluster: worker processes are spawned (fork after ti.init hangs)."""
    with ensemble._cluster(None, 1) as (client, where):
        assert where == "1 local worker"
        probes = client.run(_make_probe())
    assert len(probes) == 1
    assert all(not p["pytest"] and p["pid"] != os.getpid() for p in probes.values())
