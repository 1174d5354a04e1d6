"""``melange-ti ensemble``: keys that move together (issue 47, item 9).

``--set K1,K2=V1,V2,...`` gives the listed keys each value at once (tensile = shear
strength), ``--zip K1,K2`` pairs the i-th values of the keys' own ``--set`` lists; separate
``--set`` lists still give every combination. Planning runs in this process; one end-to-end
ensemble sweeps a bonded tiny shelf's strengths on one spawned worker.
"""

from __future__ import annotations

import json

import h5py
import pytest

from melange_ti import cli, ensemble, scene

from .test_ensemble import TINY

STRENGTHS = "physics.tensile_strength,physics.shear_strength"


def _files(sets, zips=None, seeds=1):
    return [r.file for r in ensemble.plan(ensemble.parse_sweep(sets, zips), seeds)]


# ---------------------------------------------------------------------------- planning
def test_keys_listed_together_take_each_value_at_once():
    axes = ensemble.parse_sweep([f"{STRENGTHS}=0.1,0.15,0.2", "time.duration=100"])
    runs = ensemble.plan(axes, 2)
    assert len(runs) == 3 * 2  # not 3 x 3 x 2
    assert [r.file for r in runs] == [
        f"tensile-strength={s}_shear-strength={s}_seed{seed}.h5" for s in ("0.1", "0.15", "0.2") for seed in (1, 2)
    ]
    for r in runs:
        over = dict(r.overrides)
        assert over["physics.tensile_strength"] == over["physics.shear_strength"] and over["time.duration"] == 100
        assert [k for k, _ in r.overrides] == ["physics.tensile_strength", "physics.shear_strength", "time.duration"]
    assert ensemble.describe(axes, 2) == "physics.tensile_strength = physics.shear_strength = 0.1, 0.15, 0.2 x seeds 1-2"


def test_zip_pairs_the_ith_values_and_the_rest_is_the_product():
    """a and c move together (their rows may repeat a value), b varies on its own: 3 x 2 runs,
    outermost in --set order (the group sits at its first key, a)."""
    sets = ["contacts.discs=12,12,28", "shelf.thickness=1.3,1.4", "physics.drag=0.01,0.02,0.02"]
    axes = ensemble.parse_sweep(sets, ["contacts.discs,physics.drag"])
    runs = ensemble.plan(axes, 1)
    combos = [tuple(v for _, v in r.overrides) for r in runs]
    assert combos == [(d, t, c) for d, c in ((12, 0.01), (12, 0.02), (28, 0.02)) for t in (1.3, 1.4)]
    names = [r.file for r in runs]
    assert names[0] == "discs=12_thickness=1.3_drag=0.01_seed1.h5" and len(set(names)) == 6
    assert ensemble.describe(axes, 1) == (
        "(contacts.discs, physics.drag) = (12, 0.01), (12, 0.02), (28, 0.02) x shelf.thickness = 1.3, 1.4 x seed 1"
    )
    # the same lists without --zip: every combination, 3 x 2 x 3 would repeat values: refused
    with pytest.raises(scene.SceneError, match="listed twice"):
        ensemble.parse_sweep(sets)


def test_the_product_and_its_file_names_are_unchanged():
    """Separate --set lists are every combination, named as before --zip existed."""
    assert _files(["contacts.discs=12,28", "shelf.thickness=1.3,1.4"]) == [
        "discs=12_thickness=1.3_seed1.h5",
        "discs=12_thickness=1.4_seed1.h5",
        "discs=28_thickness=1.3_seed1.h5",
        "discs=28_thickness=1.4_seed1.h5",
    ]
    axes = ensemble.parse_sweep(["contacts.discs=12,28", "time.dt=0.005"])
    assert all(a.together == () for a in axes)
    assert ensemble.describe(axes, 3) == "contacts.discs = 12, 28 x seeds 1-3"
    assert ensemble.describe(ensemble.parse_sweep([]), 1) == "seed 1"


def test_a_long_list_is_cut_in_the_plan_line():
    values = ",".join(f"0.{i:02d}" for i in range(10, 24))
    line = ensemble.describe(ensemble.parse_sweep([f"{STRENGTHS}={values}"]), 4)
    assert line == (
        "physics.tensile_strength = physics.shear_strength = 0.10, 0.11, 0.12, 0.13, 0.14, ..., 0.23 (14 values) x seeds 1-4"
    )


@pytest.mark.parametrize(
    "sets, zips, fragment",
    [
        # lists of unequal length: both keys and their lengths named
        (
            ["physics.tensile_strength=0.1,0.2,0.3", "physics.shear_strength=0.1,0.2"],
            [STRENGTHS],
            f"--zip '{STRENGTHS}': physics.tensile_strength has 3 values, physics.shear_strength has 2 values; "
            "keys that move together need lists of equal length",
        ),
        (["physics.tensile_strength=0.1,0.2"], [STRENGTHS], "physics.shear_strength is not given with --set"),
        (["physics.tensile_strength=0.1,0.2"], ["physics.tensile_strength"], "name two or more keys"),
        (["physics.drag=0.01,0.02"], ["physics.drag,time.seed"], "time.seed is not given with --set (the seeds are --seeds)"),
        (
            ["physics.tensile_strength=0.1,0.1", "physics.shear_strength=0.2,0.2"],
            [STRENGTHS],
            "row 2 (physics.tensile_strength=0.1, physics.shear_strength=0.2) is listed twice",
        ),
        ([f"{STRENGTHS}=0.1,0.2", "physics.drag=0.01,0.02"], ["physics.drag,physics.shear_strength"], "already moves with"),
        (["physics.tensile_strength,,physics.shear_strength=0.1"], [], "empty key"),
        ([f"{STRENGTHS}=0.1,0.1"], [], "value 0.1 is listed twice"),
        ([f"{STRENGTHS}=0.1", "physics.shear_strength=0.2"], [], "physics.shear_strength is given more than once"),
        ([f"{STRENGTHS}=0.1,-0.2"], [], "(in the run with physics.tensile_strength=-0.2, physics.shear_strength=-0.2)"),
        (
            ["physics.drag=0.01", "physics.angular_drag=0.01,0.02"],
            ["physics.drag,physics.angular_drag"],
            "physics.drag has 1 value, physics.angular_drag has 2 values",
        ),
    ],
)
def test_bad_groups_are_one_line_exit_2_and_no_files(tmp_path, capsys, sets, zips, fragment):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    out = tmp_path / "out"
    argv = ["ensemble", str(path), "--seeds", "2", "--out", str(out), "--set", "scene.effects+=bonds"]
    argv += ["--set", "shelf.bonded=true"]
    for s in sets:
        argv += ["--set", s]
    for z in zips:
        argv += ["--zip", z]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("melange-ti: error:") and fragment in err[0], err
    assert not out.exists()


# ---------------------------------------------------------------------------- end to end
def test_strength_sweep_of_a_bonded_shelf(tmp_path, capsys):
    """The breakup recipe of docs/bonds.md in small: a bonded tiny shelf, tensile = shear
    strength over two values, one seed, on one worker. Each file holds its own strengths
    (both keys the same), the manifest says which keys moved together, the plan line lists
    the combinations; a second call with --zip over the same lists is the same plan and
    finds every run complete."""
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    out = tmp_path / "breakup"
    base = ["ensemble", str(path), "--seeds", "1", "--out", str(out), "--workers", "1"]
    base += ["--set", "scene.effects+=bonds", "--set", "shelf.bonded=true", "--set", "time.duration=2"]
    assert cli.main([*base, "--set", f"{STRENGTHS}=0.05,0.5"]) == 0
    captured = capsys.readouterr()
    assert (
        f"ensemble: 2 runs to do into {out}, on 1 local worker "
        "(physics.tensile_strength = physics.shear_strength = 0.05, 0.5 x seed 1)" in captured.err
    ), captured.err
    assert "2 ran, 0 already complete, 0 failed" in captured.out
    for s in (0.05, 0.5):
        with h5py.File(out / f"tensile-strength={s}_shear-strength={s}_seed1.h5", "r") as f:
            assert f.attrs["complete"] == True  # noqa: E712 (numpy bool)
            stored = scene.loads(f.attrs["scene_toml"])
            assert stored.physics.tensile_strength == stored.physics.shear_strength == s
            assert "bonds" in stored.effects.names() and "bonds" in f
    manifest = json.loads((out / "ensemble.json").read_text())
    assert manifest["together"] == [["physics.tensile_strength", "physics.shear_strength"]]
    assert manifest["sweep"] == {"physics.tensile_strength": [0.05, 0.5], "physics.shear_strength": [0.05, 0.5]}

    zipped = [*base, "--set", "physics.tensile_strength=0.05,0.5", "--set", "physics.shear_strength=0.05,0.5"]
    assert cli.main([*zipped, "--zip", STRENGTHS]) == 0
    assert "0 ran, 2 already complete, 0 failed" in capsys.readouterr().out
