"""A time step above the icebergs' stability limit is refused; effects are added or removed
one at a time; a scene whose icebergs cannot float says so; a budget too far off to trust
says so (issue 32, points 10 and 12).

The limit is checked against the exact hydrostatics (``melange_ti.geometry``, independent
of the formula the check uses) and against real runs: a lone capsizing iceberg, the stiffest
case measured (docs/model.md, Time stepping), stays bounded at the largest accepted time
step and runs away at twice it.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

import melange_ti as mt
from melange_ti import cli
from melange_ti import scene as scn
from melange_ti.energy import RESIDUAL_PROMISED, budget_series, total_energy
from melange_ti.geometry import potential_energy
from melange_ti.io.hdf5 import read_run
from melange_ti.scene import DENSITY_RATIO as R
from melange_ti.scene.initial import DT_SAFETY, time_step_limit
from melange_ti.simulation import RESIDUAL_TRUSTED, RunSummary

from .conftest import RUNS


def _errors(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if ln.startswith("melange-ti: error:")]


def _check(capsys, *sets: str) -> tuple[int, str, str]:
    rc = cli.main(["check", *[a for s in sets for a in ("--set", s)]])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return rc, out, err


# ----------------------------------------------------------------------------- the time step
def _flat_heave_omega(width: float, thickness: float) -> float:
    """The heave frequency of a block floating flat, from the exact hydrostatic potential's
    curvature (finite differences of ``geometry.potential_energy``), not from a formula."""
    a, b = max(width, thickness), min(width, thickness)
    z0 = 0.5 * b - R * b  # flat: the shorter side vertical, draft r b
    e = 1e-4
    u = [float(potential_energy(np.array([z0 + d]), np.array([0.0]), a, b, R)[0]) for d in (-e, 0.0, e)]
    return math.sqrt((u[0] - 2 * u[1] + u[2]) / e**2 / (R * a * b))


@pytest.mark.parametrize("sets", [(), ("shelf.thickness=0.6",), ("shelf.width=2.5", "shelf.thickness=3.0")])
def test_limit_is_the_flat_heave_of_the_scenes_icebergs(sets):
    sc = scn.load(None, scn.parse_overrides(list(sets)))
    limit, _ = time_step_limit(sc)
    w, h = sc.shelf.width, sc.shelf.thickness
    assert limit == pytest.approx(2.0 / _flat_heave_omega(w, h), rel=1e-6)


def test_the_thinnest_iceberg_sets_the_limit():
    bergs = [{"x": 0.0, "z": -0.55, "thickness": 1.4}, {"x": 5.0, "z": -0.2, "width": 1.5, "thickness": 0.5}]
    sc = scn.from_dict({"scene": {"effects": ["gravity", "buoyancy"]}, "iceberg": bergs})
    limit, which = time_step_limit(sc)
    assert which == 1 and limit == pytest.approx(2.0 / _flat_heave_omega(1.5, 0.5), rel=1e-6)


def test_too_large_dt_is_refused_in_one_line_naming_the_limit_and_the_largest_accepted(capsys):
    rc, out, err = _check(capsys, "time.dt=3")
    lines = _errors(err)
    assert rc == 2 and len(lines) == 1 and not out, err
    line = lines[0]
    assert "time.dt = 3" in line and "max_partners" not in line and "interval" not in line, line
    limit = 2.0 / _flat_heave_omega(1.0, 1.4)
    assert f"{limit:.3g}" in line, line
    largest = float(re.search(r"use at most ([0-9.]+)", line).group(1))
    assert largest <= DT_SAFETY * limit < largest * 1.01
    rc, out, err = _check(capsys, f"time.dt={largest}")
    assert rc == 0 and not _errors(err), err
    rc, out, err = _check(capsys, f"time.dt={largest * 1.02}")
    assert rc == 2 and len(_errors(err)) == 1, err


def test_allow_unstable_and_no_buoyancy_let_a_large_dt_through():
    sc = scn.load(None, [("time.dt", 3.0), ("time.allow_unstable", True), ("output.diagnostic_interval", 3.0)])
    assert sc.time.dt == 3.0
    falling = scn.load(None, [("scene.effects", ["gravity", "drag"]), ("time.dt", 3.0), ("output.diagnostic_interval", 3.0)])
    assert time_step_limit(falling) is None


def test_every_shipped_scene_is_far_below_the_limit():
    for path in [None, *sorted(RUNS.glob("*.toml"))]:
        sc = scn.load(path)
        limit = time_step_limit(sc)
        assert limit is not None and sc.time.dt < 0.1 * DT_SAFETY * limit[0], path


def _capsize_gain(dt: float, duration: float = 500.0) -> float:
    """The largest energy a lone capsizing iceberg (1 x 1.4, drag off) gains over its start,
    as a fraction of the capsize energy; inf when the state stops being finite."""
    from melange_ti.model import Model

    doc = {
        "scene": {"name": "limits", "effects": ["gravity", "buoyancy"]},
        "time": {"dt": dt, "duration": duration, "allow_unstable": True},
        "output": {"snapshot_interval": duration, "diagnostic_interval": duration, "checkpoint_interval": duration},
        "iceberg": [{"x": 0.0, "z": 0.7 - R * 1.4, "theta": 0.01, "width": 1.0, "thickness": 1.4}],
    }
    m = Model(scn.from_dict(doc), mode="serial")
    e0, gain = total_energy(m.sample()), 0.0
    capsize = 0.5 * R * (1 - R) * 1.4 * 0.4
    for _ in range(int(round(duration / dt))):
        m.advance(1)
        e = total_energy(m.sample())
        if not math.isfinite(e):
            return math.inf
        gain = max(gain, (e - e0) / capsize)
    return gain


def test_largest_accepted_dt_is_stable_and_twice_it_runs_away():
    """Measured (docs/model.md): at the largest accepted dt the undamped capsize's energy error
    stays below half the capsize energy (checked here over 500 time units; measured to 3000);
    at twice it, it grows without bound (1.9 capsize energies by t = 500, 8 by t = 3000)."""
    largest = DT_SAFETY * time_step_limit(scn.load(None))[0]
    assert _capsize_gain(largest) < 0.5
    assert _capsize_gain(2 * largest) > 1.0


# ----------------------------------------------------------------------------- the budget's warning
def _summary(
    released: float,
    residual: float,
    largest: float | None = None,
    dissipated: float = 0.0,
    energy: float = 0.0,
    precision: str = "f64",
) -> list[str]:
    """A summary whose budget ended at ``residual`` and reached ``largest`` (default: the end's)."""
    values = {f.name: 0 for f in dataclasses.fields(RunSummary)}
    values.update(path="r.h5", steps=10, wall_seconds=1.0, startup_seconds=0.5, startup_steps=5, steps_per_second=10.0)
    values.update(compiled=False, backend="x64", energy_released=released, energy_residual=residual, dt=0.01)
    values.update(residual_largest=residual if largest is None else largest, released_largest=released)
    values.update(dissipated_largest=dissipated, residual_largest_time=7.0, dt_accepted=float("nan"), energy_largest=energy)
    values.update(precision=precision)
    return RunSummary(**values).lines()


def test_summary_warns_when_the_residual_is_too_large_to_trust():
    warn = [ln for ln in _summary(8.0, -3.9) if ln.startswith("warning:")]
    assert len(warn) == 1 and "-49%" in warn[0] and "time.dt = 0.01" in warn[0] and "does not close" in warn[0], warn
    assert any(ln.startswith("warning:") for ln in _summary(2.0, 1.01 * RESIDUAL_TRUSTED * 2.0))
    for released, residual in ((2.0, -0.99 * RESIDUAL_TRUSTED * 2.0), (8.0, 0.0024), (0.0, 0.0)):
        assert not any(ln.startswith("warning:") for ln in _summary(released, residual))
    # judged by the largest residual over the run, not by the end's
    warn = [ln for ln in _summary(2.0, 0.0, largest=-0.1) if ln.startswith("warning:")]
    assert len(warn) == 1 and "-5%" in warn[0] and "t = 7" in warn[0], warn
    # against what the ledgers booked, where that is larger (a struck iceberg releases little)
    assert not any(ln.startswith("warning:") for ln in _summary(0.1, 0.01, dissipated=1.0))
    assert any(ln.startswith("warning:") for ln in _summary(0.1, float("nan"), dissipated=1.0))
    # a still scene (icebergs floated at rest): everything at rounding, judged against E's scale
    assert not any(ln.startswith("warning:") for ln in _summary(1e-16, -1e-16, dissipated=1e-16, energy=0.8))
    # nothing released or dissipated, yet E moved far past rounding: told
    assert any(ln.startswith("warning:") for ln in _summary(0.0, 5.0, energy=0.8))
    # in f32 rounding is larger: a quiet scene's residual of 3.8 ulps of |E| (16 icebergs of the
    # paper's shelf, t = 10) is rounding there, and was flagged while the f64 floor judged it
    quiet = dict(released=1.4e-5, residual=6.7e-7, dissipated=6.6e-7, energy=1.48)
    assert any(ln.startswith("warning:") for ln in _summary(**quiet))
    assert not any(ln.startswith("warning:") for ln in _summary(**quiet, precision="f32"))
    assert any(ln.startswith("warning:") for ln in _summary(1.0, 0.1, energy=2.0, precision="f32"))


def test_summary_says_how_the_run_kept_the_budgets_promise():
    """The line ``budget:`` compares the largest residual over the run with the promise
    (``RESIDUAL_PROMISED`` of the largest energy released: docs/model.md, "What the budget
    promises"), judged by the same scale as the warning, so the two never disagree: a struck
    iceberg by what the ledgers booked, a still scene by its energy's rounding."""

    def said(**kw) -> str:
        (line,) = [ln for ln in _summary(**kw) if ln.startswith("budget:")]
        return line

    assert "within the 0.1%" in said(released=2.0, residual=0.0, largest=0.99 * RESIDUAL_PROMISED * 2.0)
    line = said(released=2.0, residual=0.0, largest=-1.01 * RESIDUAL_PROMISED * 2.0)
    assert "past the 0.1%" in line and "0.101% of the largest energy released (t = 7)" in line, line
    # a struck iceberg: little released, much booked; within, as the warning is silent
    line = said(released=0.1, residual=5e-4, dissipated=1.0)
    assert (
        "within" in line
        and "dissipated" in line
        and not any(ln.startswith("warning:") for ln in _summary(0.1, 5e-4, dissipated=1.0))
    )
    # a still scene at rounding: within, judged against its energy's rounding
    line = said(released=1e-16, residual=-1e-16, dissipated=1e-16, energy=0.8)
    assert "within" in line and "rounding" in line, line
    assert "nothing released" in said(released=0.0, residual=0.0)
    # past the promise but short of the warning: said, not warned
    lines = _summary(2.0, 0.0, largest=0.005 * 2.0)
    assert any("past the 0.1%" in ln for ln in lines) and not any(ln.startswith("warning:") for ln in lines)


def test_a_run_near_its_time_step_limit_is_flagged_in_the_summary_and_the_plot(tmp_path, capsys):
    """The new user's case (issue 47): a lone capsize at time.dt = 0.5, accepted (its limit is
    0.567), ran with a budget far from closed and no word. Its summary and `plot` now say that
    the budget does not close, when, and what to change; the same capsize at the default step
    is not flagged."""
    text = scn.bundled_scene_text("single_capsize")
    flagged = {}
    for dt in (0.5, 0.01):
        path = tmp_path / f"dt{dt}.h5"
        sc = scn.loads(text, [("time.dt", dt), ("time.duration", 100.0)])
        summary = mt.run(sc, path)
        warn = [ln for ln in summary.lines() if ln.startswith("warning:")]
        flagged[dt] = warn
        if warn:  # the largest residual over the run is what it says
            b = budget_series(read_run(path)["diagnostics"])
            k = int(np.argmax(np.abs(b["residual"])))
            assert summary.residual_largest == b["residual"][k] and summary.residual_largest_time == b["time"][k]
    assert len(flagged[0.5]) == 1 and "does not close" in flagged[0.5][0] and "time.dt = 0.5" in flagged[0.5][0]
    assert "accept up to 0.567" in flagged[0.5][0], flagged[0.5]
    assert flagged[0.01] == []
    capsys.readouterr()
    assert cli.main(["plot", str(tmp_path / "dt0.5.h5"), str(tmp_path / "dt0.01.h5"), "--out", str(tmp_path / "figs")]) == 0
    said = [ln for ln in capsys.readouterr().out.splitlines() if "does not close" in ln]
    assert len(said) == 1 and said[0].startswith(str(tmp_path / "dt0.5.h5")), said


# ----------------------------------------------------------------------------- effects
PAPER = ["gravity", "buoyancy", "drag", "collisions", "wall"]


def test_effects_added_and_removed_one_at_a_time():
    assert mt.load_scene(overrides={"scene.effects+": "waves"}).effects.names() == [*PAPER, "waves"]
    sc = scn.load(None, scn.parse_overrides(["scene.effects-=drag,wall", "scene.effects+=friction,friction"]))
    assert sc.effects.names() == ["gravity", "buoyancy", "collisions", "friction"]
    assert scn.load(None, [("scene.effects-", ["wall"]), ("scene.effects+", ["wall"])]).effects.names() == PAPER
    text = scn.bundled_scene_text("single_capsize")
    assert scn.loads(text, scn.parse_overrides(["scene.effects+=form_drag"])).effects.names() == [
        "gravity",
        "buoyancy",
        "drag",
        "form_drag",
    ]


def test_adding_on_the_command_line_keeps_gravity_and_buoyancy(capsys):
    rc, out, err = _check(capsys, "scene.effects+=waves", "shelf.count=3")
    assert rc == 0 and "gravity, buoyancy, drag, collisions, wall, waves" in out and not err, (out, err)


@pytest.mark.parametrize(
    "item, named",
    [
        ("scene.effects+=wavs", ["scene.effects +=", "'wavs'", "known:"]),
        ("scene.effects-=magnet", ["scene.effects -=", "'magnet'"]),
        ("scene.effects-=gravity,buoyancy,drag,collisions,wall", ["scene.effects -=", "scene.effects=[]"]),
        ("scene.effects=", ["scene.effects", "[]"]),
        ("time.dt+=0.1", ["time.dt +=", "scene.effects"]),
    ],
)
def test_bad_effect_edits_are_one_line(capsys, item, named):
    rc, out, err = _check(capsys, item)
    lines = _errors(err)
    assert rc == 2 and len(lines) == 1, err
    for word in named:
        assert word in lines[0], lines[0]


def test_replacing_the_list_without_gravity_or_buoyancy_warns(capsys):
    rc, out, err = _check(capsys, "scene.effects=waves")
    warn = [ln for ln in err.splitlines() if ln.startswith("melange-ti: warning:")]
    assert rc == 0 and len(warn) == 1, err
    assert "gravity" in warn[0] and "buoyancy" in warn[0] and "scene.effects+=" in warn[0], warn
    rc, out, err = _check(capsys, "scene.effects=[]")
    assert rc == 0 and "melange-ti: warning:" in err, err
    sinking = scn.load(None, [("scene.effects", ["gravity", "drag"])]).warnings()
    assert len(sinking) == 1 and "no buoyancy" in sinking[0] and "sink" in sinking[0]
    assert scn.load(None).warnings() == []
    rc, out, err = _check(capsys)
    assert rc == 0 and not err, err


def test_a_still_scene_is_not_flagged(tmp_path):
    """Icebergs floated at rest (z left out: their draft) release and dissipate nothing but
    rounding; the budget's verdict judges that against the scale of E and says nothing."""
    text = '[scene]\neffects = ["gravity", "buoyancy", "drag"]\n[time]\nduration = 5.0\n'
    text += "".join(f"[[iceberg]]\nx = {3.0 * k}\n" for k in range(3))
    summary = mt.run(scn.loads(text), tmp_path / "still.h5")
    assert abs(summary.released_largest) < 1e-12 and summary.energy_largest > 0.1
    assert not any(ln.startswith("warning:") for ln in summary.lines()), summary.lines()
