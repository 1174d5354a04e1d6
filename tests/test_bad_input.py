"""Bad input on the command line: every refusal is one line naming the key and the value,
exit status 2, no traceback and no output file (SPEC section 3, foundation issue).

Most cases call :func:`melange_ti.cli.main` in the pytest process (validation happens before
Taichi is touched); a few run ``python -m melange_ti`` in a subprocess to check what a user
actually sees: the exit status and stderr of a real process.
"""

from __future__ import annotations

import copy
import hashlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from melange_ti import cli
from melange_ti.scene import DENSITY_RATIO, dumps_toml

THREADS = os.environ.get("MELANGE_TEST_THREADS", "2")  # as conftest: no Taichi re-init in-process

BASE = {
    "scene": {"name": "bad", "effects": ["gravity", "buoyancy", "drag", "collisions", "wall"], "precision": "f64"},
    "physics": {"density_ratio": DENSITY_RATIO, "restitution": 0.5, "drag": 0.01, "angular_drag": 0.01},
    "contacts": {"discs": 12},
    "time": {"dt": 0.01, "duration": 0.1, "seed": 1},
    "output": {"snapshot_interval": 0.05, "diagnostic_interval": 0.05},
    "shelf": {"count": 3, "width": 1.0, "thickness": 1.4, "gap": 0.1, "tilt": 0.01},
}
BERGS = [
    {"x": 1.0, "z": -0.55, "width": 1.0, "thickness": 1.4},
    {"x": 3.0, "z": -0.55, "width": 1.0, "thickness": 1.4},
]


def scene_with(changes: dict | None = None, bergs: list[dict] | None = None) -> str:
    """BASE with ``{"section.key": value}`` changes (``None`` deletes); ``bergs`` replaces [shelf]."""
    doc = copy.deepcopy(BASE)
    if bergs is not None:
        del doc["shelf"]
        doc["iceberg"] = copy.deepcopy(bergs)
    for dotted, value in (changes or {}).items():
        sec, key = dotted.split(".", 1)
        table = doc.setdefault(sec, {})
        if value is None:
            table.pop(key, None)
        else:
            table[key] = value
    return dumps_toml(doc)


# (id, scene text, substrings the one-line message must contain)
CASES = [
    # unknown keys and effects
    ("unknown-key", scene_with({"physics.densty_ratio": 0.9}), ["physics.densty_ratio", "0.9"]),
    ("unknown-section", scene_with() + "\n[physic]\ndrag = 0.1\n", ["physic"]),
    ("unknown-iceberg-key", scene_with(bergs=[{**BERGS[0], "spin": 1.0}]), ["iceberg[0].spin", "1.0"]),
    ("unknown-effect", scene_with({"scene.effects": ["gravity", "magnetism"]}), ["scene.effects", "magnetism"]),
    # wrong types
    ("type-dt-string", scene_with({"time.dt": "0.01"}), ["time.dt", "0.01"]),
    ("type-discs-float", scene_with({"contacts.discs": 12.5}), ["contacts.discs", "12.5"]),
    ("type-count-bool", scene_with({"shelf.count": True}), ["shelf.count", "true"]),
    ("type-restitution-list", scene_with({"physics.restitution": [0.5]}), ["physics.restitution", "0.5"]),
    ("type-precision-int", scene_with({"scene.precision": 64}), ["scene.precision", "64"]),
    ("order-spelling", scene_with({"contacts.order": "colored"}), ["contacts.order", "colored", '"coloured"']),
    ("type-effects-string", scene_with({"scene.effects": "gravity"}), ["scene.effects", "gravity"]),
    ("type-section-scalar", "physics = 3\n" + dumps_toml({k: v for k, v in BASE.items() if k != "physics"}), ["physics", "3"]),
    # non-finite numbers
    ("nan-dt", scene_with({"time.dt": float("nan")}), ["time.dt", "nan"]),
    ("inf-drag", scene_with({"physics.drag": float("inf")}), ["physics.drag", "inf"]),
    ("-inf-density", scene_with({"physics.density_ratio": float("-inf")}), ["physics.density_ratio", "-inf"]),
    ("nan-iceberg-x", scene_with(bergs=[{**BERGS[0], "x": float("nan")}]), ["iceberg[0].x", "nan"]),
    ("inf-water-level", scene_with({"physics.water_level": float("inf")}), ["physics.water_level", "inf"]),
    # sizes
    ("width-zero", scene_with({"shelf.width": 0.0}), ["shelf.width", "0"]),
    ("thickness-negative", scene_with({"shelf.thickness": -1.4}), ["shelf.thickness", "-1.4"]),
    ("width-spread-negative", scene_with({"shelf.width_std": -0.1}), ["shelf.width_std", "-0.1"]),
    ("width-spread-too-wide", scene_with({"shelf.width_std": 5.0}), ["shelf.width_std", "5", "5% of shelf.width"]),
    ("iceberg-width-zero", scene_with(bergs=[BERGS[0], {**BERGS[1], "width": 0.0}]), ["iceberg[1].width", "0"]),
    ("iceberg-thickness-negative", scene_with(bergs=[{**BERGS[0], "thickness": -0.5}]), ["iceberg[0].thickness", "-0.5"]),
    # physics ranges
    ("density-zero", scene_with({"physics.density_ratio": 0.0}), ["physics.density_ratio", "0"]),
    ("density-one", scene_with({"physics.density_ratio": 1.0}), ["physics.density_ratio", "1"]),
    ("density-above", scene_with({"physics.density_ratio": 1.2}), ["physics.density_ratio", "1.2"]),
    ("density-negative", scene_with({"physics.density_ratio": -0.3}), ["physics.density_ratio", "-0.3"]),
    ("restitution-negative", scene_with({"physics.restitution": -0.1}), ["physics.restitution", "-0.1"]),
    ("restitution-above", scene_with({"physics.restitution": 1.5}), ["physics.restitution", "1.5"]),
    # time
    ("dt-zero", scene_with({"time.dt": 0.0}), ["time.dt", "0"]),
    ("dt-negative", scene_with({"time.dt": -0.01}), ["time.dt", "-0.01"]),
    ("duration-below-dt", scene_with({"time.duration": 0.005}), ["time.duration", "0.005"]),
    ("duration-zero", scene_with({"time.duration": 0.0}), ["time.duration", "0"]),
    ("duration-negative", scene_with({"time.duration": -1.0}), ["time.duration", "-1"]),
    # discs
    ("discs-not-multiple", scene_with({"contacts.discs": 10}), ["contacts.discs", "10"]),
    ("discs-below-8", scene_with({"contacts.discs": 4}), ["contacts.discs", "4"]),
    ("discs-zero", scene_with({"contacts.discs": 0}), ["contacts.discs", "0"]),
    ("discs-negative", scene_with({"contacts.discs": -8}), ["contacts.discs", "-8"]),
    ("discs-aspect-shelf", scene_with({"contacts.discs": 8, "shelf.thickness": 4.0}), ["contacts.discs", "8"]),
    (
        "discs-aspect-iceberg",
        scene_with({"contacts.discs": 12}, bergs=[{"x": 3.0, "z": -0.1, "width": 5.0, "thickness": 1.0}]),
        ["contacts.discs", "12"],
    ),
    # overlaps at t = 0
    ("overlap-icebergs", scene_with(bergs=[BERGS[0], {**BERGS[1], "x": 1.5}]), ["iceberg[1].x", "1.5"]),
    ("overlap-wall", scene_with(bergs=[{**BERGS[0], "x": 0.3}]), ["iceberg[0].x", "0.3"]),
    (
        "overlap-tilted-shelf",
        scene_with({"scene.effects": ["gravity", "buoyancy", "collisions"], "shelf.gap": 0.0, "shelf.tilt": 0.5}),
        ["shelf.gap = 0.0", "shelf.tilt = 0.5", "overlaps iceberg", "use shelf.gap >="],
    ),
    ("overlap-wall-moved", scene_with({"physics.wall_x": 2.0}, bergs=BERGS), ["iceberg[0].x", "1.0"]),
    # TOML syntax (line and column)
    ("toml-double-equals", scene_with().replace("dt = 0.01", "dt = = 0.01"), ["line", "column"]),
    ("toml-unterminated-string", '[scene]\nname = "bad\n', ["line 2", "column"]),
    ("toml-duplicate-key", scene_with().replace("dt = 0.01", "dt = 0.01\ndt = 0.02"), ["line", "column"]),
    ("toml-bad-table", "[time\ndt = 0.01\n", ["line 1", "column"]),
]
SYNTAX_LINE = {  # where the error is, for the TOML cases: "line N"
    "toml-double-equals": scene_with().replace("dt = 0.01", "dt = = 0.01").splitlines().index("dt = = 0.01") + 1,
    "toml-duplicate-key": scene_with().replace("dt = 0.01", "dt = 0.01\ndt = 0.02").splitlines().index("dt = 0.02") + 1,
}


def _one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}:\n{err}"
    assert "Traceback" not in err
    assert lines[0].startswith("melange-ti: error: "), lines[0]
    return lines[0]


def _contains_all(line: str, needles: list[str]) -> None:
    for needle in needles:
        assert needle.lower() in line.lower(), f"{needle!r} not in message: {line}"


@pytest.mark.parametrize("command", ["run", "check"])
@pytest.mark.parametrize("case_id, text, needles", CASES, ids=[c[0] for c in CASES])
def test_invalid_scene(tmp_path, capsys, command, case_id, text, needles):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    out = tmp_path / "out.h5"
    argv = [command, str(path)] + (["--out", str(out), "--threads", THREADS] if command == "run" else [])
    rc = cli.main(argv)
    cap = capsys.readouterr()
    assert rc == 2, f"exit status {rc}; stdout={cap.out!r} stderr={cap.err!r}"
    line = _one_error_line(cap.err)
    _contains_all(line, needles)
    if case_id in SYNTAX_LINE:
        assert f"line {SYNTAX_LINE[case_id]}" in line, line
    assert not out.exists(), "a refused scene must not leave an output file"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"], "nothing besides the scene may be written"


@pytest.mark.parametrize(
    "changes, bergs",
    [
        ({"physics.restitution": 0.0}, None),
        ({"physics.restitution": 1.0}, None),
        ({"physics.density_ratio": 0.5}, None),
        ({"contacts.discs": 8}, None),  # aspect 1.4 <= 8/4 + 1
        ({"time.duration": 0.01}, None),  # duration == dt
        ({"shelf.gap": 0.0, "shelf.tilt": 0.0}, None),  # touching is not overlapping
        ({}, [{"x": 0.5, "z": -0.55, "width": 1.0, "thickness": 1.4}, {"x": 1.5, "z": -0.55, "width": 1.0, "thickness": 1.4}]),
    ],
    ids=["restitution-0", "restitution-1", "density-0.5", "discs-8", "duration-eq-dt", "gap-0", "touching-bergs"],
)
def test_boundary_values_are_accepted(tmp_path, capsys, changes, bergs):
    """The closed ends of the ranges are valid: the checks must not be off by one."""
    path = tmp_path / "scene.toml"
    path.write_text(scene_with(changes, bergs))
    rc = cli.main(["check", str(path)])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "ok" in cap.out


def test_missing_scene_file(tmp_path, capsys):
    missing = tmp_path / "no_such_scene.toml"
    out = tmp_path / "out.h5"
    for argv in (["run", str(missing), "--out", str(out), "--threads", THREADS], ["check", str(missing)]):
        rc = cli.main(argv)
        cap = capsys.readouterr()
        assert rc == 2
        _contains_all(_one_error_line(cap.err), ["no_such_scene.toml", "not found"])
    assert not out.exists()


@pytest.mark.parametrize("kind", ["directory", "not-utf8"])
def test_unreadable_scene_file(tmp_path, capsys, kind):
    path = tmp_path / "scene.toml"
    if kind == "directory":
        path.mkdir()
    else:
        path.write_bytes(b'[scene]\nname = "\xff\xfe"\n')
    rc = cli.main(["check", str(path)])
    cap = capsys.readouterr()
    assert rc == 2
    _contains_all(_one_error_line(cap.err), ["scene.toml"])


def test_existing_output_is_refused_and_untouched(tmp_path, capsys):
    path = tmp_path / "scene.toml"
    path.write_text(scene_with())
    out = tmp_path / "out.h5"
    out.write_bytes(b"precious results, not HDF5")
    before = (hashlib.sha256(out.read_bytes()).hexdigest(), out.stat().st_mtime_ns)
    rc = cli.main(["run", str(path), "--out", str(out), "--threads", THREADS])
    cap = capsys.readouterr()
    assert rc == 2
    _contains_all(_one_error_line(cap.err), ["out.h5", "--overwrite"])
    assert (hashlib.sha256(out.read_bytes()).hexdigest(), out.stat().st_mtime_ns) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5", "scene.toml"]


@pytest.mark.parametrize(
    "args, needles",
    [
        (["--set", "time.dt=abc"], ["time.dt", "abc"]),
        (["--set", "time.dt=nan"], ["time.dt", "nan"]),
        (["--set", "time.dt=-0.01"], ["time.dt", "-0.01"]),
        (["--set", "physics.densty_ratio=0.9"], ["physics.densty_ratio", "0.9"]),
        (["--set", "dt=0.1"], ["dt", "0.1"]),
        (["--set", "time.dt"], ["time.dt"]),
        (["--set", "iceberg.x=1.0"], ["iceberg.x", "1.0"]),
        (["--set", "contacts.discs=10"], ["contacts.discs", "10"]),
        (["--threads", "0"], ["--threads", "0"]),
        (["--arch", "tpu"], ["--arch", "tpu"]),
    ],
    ids=[
        "set-type",
        "set-nan",
        "set-range",
        "set-unknown-key",
        "set-no-section",
        "set-no-value",
        "set-iceberg",
        "set-discs",
        "threads-0",
        "arch-unknown",
    ],
)
def test_bad_command_line_values(tmp_path, capsys, args, needles):
    path = tmp_path / "scene.toml"
    path.write_text(scene_with())
    out = tmp_path / "out.h5"
    extra = [] if "--threads" in args else ["--threads", THREADS]
    with_exit = None
    try:
        rc = cli.main(["run", str(path), "--out", str(out), *args, *extra])
    except SystemExit as exc:  # argparse refusals
        with_exit = exc
        rc = exc.code
    cap = capsys.readouterr()
    assert rc == 2, (with_exit, cap.err)
    _contains_all(_one_error_line(cap.err), needles)
    assert not out.exists()


# ----------------------------------------------------------------------------- real processes
def _run_process(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "melange_ti", *args], cwd=cwd, capture_output=True, text=True, timeout=120)


def test_process_exit_status_and_stderr(tmp_path):
    """What a user sees: status 2 and exactly one stderr line, for a scene error and a syntax error."""
    bad_key = tmp_path / "bad_key.toml"
    bad_key.write_text(scene_with({"physics.densty_ratio": 0.9}))
    bad_syntax = tmp_path / "bad_syntax.toml"
    bad_syntax.write_text("[time]\ndt = = 0.01\n")
    out = tmp_path / "out.h5"
    # One process per command; the second also checks that `check` behaves like `run`.
    p1 = _run_process(["run", bad_key.name, "--out", out.name, "--threads", "1"], tmp_path)
    p2 = _run_process(["check", bad_syntax.name], tmp_path)
    assert p1.returncode == 2, p1.stderr
    _contains_all(_one_error_line(p1.stderr), ["physics.densty_ratio", "0.9"])
    assert p2.returncode == 2, p2.stderr
    _contains_all(_one_error_line(p2.stderr), ["line 2", "column"])
    assert re.search(r"line 2, column \d+", p2.stderr)
    assert "Traceback" not in p1.stdout + p2.stdout
    assert not out.exists()
