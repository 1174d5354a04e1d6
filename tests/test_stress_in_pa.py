"""Stresses given in Pa, fracture energies in J/m^2 (issue 50, item 6, the units part): a
``[physics]`` key in the model's stress unit ``rho_w g w`` may be written in Pa as
``NAME_pa``, one in ``rho_w g w^2`` in J/m^2 as ``NAME_jm2``, converted with ``scene.width_m``;
both forms of one key are refused together, in one line naming the key."""

from __future__ import annotations

import pytest

from melange_ti import cli, scene
from melange_ti.scene import SceneError

BONDED = {"scene": {"name": "pa", "effects": ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]}}


def _physics(physics: dict, width_m: float | None = None, overrides=None):
    doc = {**BONDED, "scene": {**BONDED["scene"]}, "physics": physics, "shelf": {"count": 4, "bonded": True}}
    if width_m is not None:
        doc["scene"]["width_m"] = width_m
    return scene.from_dict(doc, overrides=overrides).physics


@pytest.mark.parametrize("width_m", [70.0, 140.0, 250.0])
def test_a_stress_in_pa_is_the_stress_in_the_models_unit(width_m):
    """``tensile_strength_pa``, ``shear_strength_pa`` and ``bond_modulus_pa`` at ``width_m``
    give ``Pa / (1025 * 9.81 * width_m)`` (what the model's unit is in Pa), from a scene file
    and from ``--set`` alike; the same Pa at twice the width is half the model's value."""
    unit = 1025.0 * 9.81 * width_m
    p = _physics({"tensile_strength_pa": 2.5e5, "shear_strength_pa": 1.0e5, "bond_modulus_pa": 5.0e8}, width_m)
    assert (p.tensile_strength, p.shear_strength, p.bond_modulus) == (2.5e5 / unit, 1.0e5 / unit, 5.0e8 / unit)
    q = _physics({}, width_m, overrides=[("physics.tensile_strength_pa", 2.5e5)])
    assert q.tensile_strength == p.tensile_strength
    assert _physics({"tensile_strength_pa": 2.5e5}, 2 * width_m).tensile_strength == pytest.approx(p.tensile_strength / 2)


def test_the_stored_scene_holds_the_models_unit():
    """The resolved scene (what a run file keeps) writes the converted key alone: read back, it
    is the same scene."""
    doc = {**BONDED, "physics": {"tensile_strength_pa": 1.2e5}, "shelf": {"count": 4, "bonded": True}}
    sc = scene.from_dict(doc)
    text = sc.to_toml()
    assert "tensile_strength_pa" not in text and "tensile_strength =" in text
    assert scene.loads(text).physics == sc.physics


@pytest.mark.parametrize(
    ("physics", "key", "words"),
    [
        (
            {"tensile_strength": 0.2, "tensile_strength_pa": 1.0e5},
            "physics.tensile_strength_pa",
            "given with physics.tensile_strength",
        ),
        ({"bond_modulus_pa": -1.0}, "physics.bond_modulus_pa", "must be > 0"),
        ({"shear_strength_pa": "high"}, "physics.shear_strength_pa", "must be a number"),
        ({"drag_pa": 1.0}, "physics.drag_pa", "unknown key"),
        (
            {"fracture_energy": 1e-7, "fracture_energy_jm2": 5.0},
            "physics.fracture_energy_jm2",
            "given with physics.fracture_energy",
        ),
        ({"fracture_energy_jm2": -1.0}, "physics.fracture_energy_jm2", "must be >= 0 J/m^2"),
        ({"tensile_strength_jm2": 1.0}, "physics.tensile_strength_jm2", "unknown key"),
    ],
)
def test_a_bad_stress_in_pa_or_energy_in_joules_is_refused_naming_the_key(physics, key, words):
    with pytest.raises(SceneError) as err:
        _physics(physics)
    message = str(err.value)
    assert "\n" not in message and key in message and words in message, message


def test_both_forms_from_the_command_line_exit_with_status_2(tmp_path, capsys):
    """``--set physics.tensile_strength_pa=...`` beside a scene that gives ``tensile_strength``:
    one line on stderr naming both, exit status 2, no output file."""
    text = (
        '[scene]\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]\n'
        "[physics]\ntensile_strength = 0.2\n[shelf]\ncount = 4\nbonded = true\n[time]\nduration = 0.1\n"
    )
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "s.h5"
    code = cli.main(["run", str(tmp_path / "s.toml"), "--out", str(out), "--set", "physics.tensile_strength_pa=1e5"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "physics.tensile_strength_pa" in err and "physics.tensile_strength" in err and "Traceback" not in err
    assert not out.exists()


@pytest.mark.parametrize("width_m", [70.0, 250.0])
def test_a_fracture_energy_in_joules_per_square_metre_is_the_models_unit(width_m):
    """``fracture_energy_jm2`` (an energy per unit crack area, J/m^2) at ``width_m`` gives
    ``J/m^2 / (1025 * 9.81 * width_m^2)``: the model's unit ``rho_w g w^2`` in J/m^2."""
    unit = 1025.0 * 9.81 * width_m**2
    assert _physics({"fracture_energy_jm2": 9.1}, width_m).fracture_energy == 9.1 / unit
    q = _physics({}, width_m, overrides=[("physics.fracture_energy_jm2", 9.1)])
    assert q.fracture_energy == 9.1 / unit
