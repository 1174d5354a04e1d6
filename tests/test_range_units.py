"""Every refusal of a number out of its range names the key's unit (issue 47, item 5): a user
who writes ``shelf.cut_tilt = 15`` meaning degrees is told the range is in radians, and what
15 degrees is in them.

The walk covers every declared numeric key with a range: the scene's tables (the effects'
``[physics]`` keys among them), ``[[iceberg]]`` and the effects' arrays of tables; the units
it looks for are the declarations' own (:mod:`melange_ti.scene.keys`).
"""

from __future__ import annotations

import math
import re

import pytest

from melange_ti import cli
from melange_ti import scene as scn
from melange_ti.scene import core
from melange_ti.scene import keys as K

# tried in turn: the first the key's rule refuses is its out-of-range value
CANDIDATES = (-1.0e9, -1.0, -0.25, 0.0, 0.25, 1.0, 1.5, 3.0, 7.0, 1.0e9, 2.0**63, 1.0e12)
BERGS = [{"x": 1.0, "width": 1.0, "thickness": 1.4}, {"x": 3.0, "width": 1.0, "thickness": 1.4}]


def _numeric(key) -> bool:
    return isinstance(key.default, (int, float)) and not isinstance(key.default, bool)


def _out_of_range(key):
    cast = int if isinstance(key.default, int) else float
    for v in CANDIDATES:
        if math.isfinite(v) and not key.rule(cast(v)):
            return cast(v)
    raise AssertionError(f"{key.name}: no candidate out of its range ({key.accepts})")


def _ranged_keys():
    """``(where, key)`` for every numeric key with a rule: ``where`` is its table (a
    ``SECTIONS`` name, or an effect's array of tables)."""
    out = [(section, k) for section, ks in K.SECTIONS.items() for k in ks if _numeric(k) and k.rule is not None]
    out += [(name, k) for name, ks in core.EFFECT_TABLES.items() for k in ks if _numeric(k) and k.rule is not None]
    return out


RANGED = _ranged_keys()


def _refusal(where: str, key, value) -> tuple[str, str]:
    """The key as the user wrote it, and the message refusing ``value`` there."""
    if where == "iceberg":
        full, doc = f"iceberg[1].{key.name}", {"iceberg": [BERGS[0], {**BERGS[1], key.name: value}]}
    elif where in core.EFFECT_TABLES:  # an effect's [[NAME]] entries index [[iceberg]] tables
        entry = {k.name: 0 if k.name == key.name else 1 for k in core.EFFECT_TABLES[where] if k.required}  # indices
        full, doc = f"{where}[0].{key.name}", {"iceberg": BERGS, where: [{**entry, key.name: value}]}
    else:
        full, doc = f"{where}.{key.name}", {where: {key.name: value}}
    with pytest.raises(scn.SceneError) as exc:
        scn.from_dict(doc, geometry=False)
    return full, str(exc.value)


def _says_unit(message: str, units: str) -> bool:
    """``units`` (``"1"``: dimensionless) stands as a word of its own in what the message accepts."""
    if units == "1":
        return "(dimensionless)" in message
    unit = units.removeprefix("1 / ")  # "1 / sqrt(w/g)" reads "per sqrt(w/g)"
    return re.search(rf"(?<![\w.]){re.escape(unit)}(?![\w])", message) is not None


def test_the_walk_covers_the_keys_of_every_kind():
    names = {f"{where}.{k.name}" for where, k in RANGED}
    assert {"shelf.cut_tilt", "shelf.tilt", "physics.density_ratio", "contacts.disc_spacing", "time.dt"} <= names
    assert {"physics.drag", "physics.bond_modulus", "physics.wave_dx", "iceberg.width"} <= names  # effects', [[iceberg]]
    assert any(where in core.EFFECT_TABLES for where, _ in RANGED)  # an effect's array of tables ([[bond]])
    assert {k.units for _, k in RANGED} >= {"1", "w", "rad", "sqrt(w/g)", "rho_w g w", "1 / sqrt(w/g)", "disc radii", "m"}


@pytest.mark.parametrize("where, key", RANGED, ids=[f"{w}.{k.name}" for w, k in RANGED])
def test_a_value_out_of_range_is_refused_naming_key_value_and_unit(where, key):
    value = _out_of_range(key)
    full, message = _refusal(where, key, value)
    assert "\n" not in message, message
    assert message.startswith(f"{full} = {value}: "), message
    accepts = message.split(": ", 1)[1]
    assert accepts.startswith(key.accepts.split(" (")[0]), message  # the range as declared, then its unit
    assert _says_unit(accepts, key.units), f"{key.units!r} not named: {message}"


def test_an_angle_given_in_degrees_is_converted():
    full, message = _refusal("shelf", next(k for k in K.SHELF if k.name == "cut_tilt"), 15.0)
    assert message == "shelf.cut_tilt = 15.0: must be in [-0.5, 0.5] rad (radians: 15 degrees is 0.262)"
    _, message = _refusal("shelf", next(k for k in K.SHELF if k.name == "tilt"), 120.0)
    assert message == "shelf.tilt = 120.0: must be in [0, pi] rad (radians: 120 degrees is 2.094)"
    # not for a value no angle in degrees would mend: a sign the range refuses, or too small to be degrees
    for name, value in (("cut_tilt_std", -10.0), ("tilt", -5.0), ("cut_tilt", 0.6)):
        _, message = _refusal("shelf", next(k for k in K.SHELF if k.name == name), value)
        assert "degrees" not in message and message.endswith(" rad"), message


def test_a_remark_stays_after_the_unit():
    _, message = _refusal("contacts", next(k for k in K.CONTACTS if k.name == "disc_spacing"), 3.0)
    assert message == "contacts.disc_spacing = 3.0: must be in (0, 2] disc radii (above 2 the discs leave holes)"


def test_the_command_line_says_it_in_one_line_with_exit_status_2(capsys):
    rc = cli.main(["check", "--set", "shelf.cut_tilt=15"])
    out, err = capsys.readouterr()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == 2 and not out and "Traceback" not in err, err
    assert lines == ["melange-ti: error: shelf.cut_tilt = 15.0: must be in [-0.5, 0.5] rad (radians: 15 degrees is 0.262)"]


def test_a_time_too_short_for_one_step_names_the_unit():
    with pytest.raises(scn.SceneError, match=r"^time\.duration = 0\.004: .*use at least 0\.01 sqrt\(w/g\)$"):
        scn.load(None, [("time.duration", 0.004)])


@pytest.mark.parametrize(
    "sets, needle",
    [
        ({"physics.wave_end": -5.0}, "physics.wall_x = 0 w)"),
        ({"physics.wave_pressure_depth": 7.0}, "physics.water_depth = 6 w "),
        ({"physics.wave_sponge": 700.0}, "wave_end - wall_x = 600 w"),
        ({"physics.wave_dx": 1e-5}, "use at least 0.009155 w"),
        ({"physics.wave_dt": 5.0}, "needs a step <= 0.216 sqrt(w/g))"),
        ({"physics.wave_dx": 0.01, "time.dt": 0.1}, "needs dt <= 0.054 sqrt(w/g))"),
    ],
    ids=["end", "pressure_depth", "sponge", "dx-cells", "dt", "dx-short"],
)
def test_the_waves_bounds_name_their_units(sets, needle):
    """An effect's checks across its keys (``Effect.check``) say their bounds in the keys' units."""
    with pytest.raises(scn.SceneError) as exc:
        scn.load(None, [("scene.effects+", "waves"), *sets.items()])
    message = str(exc.value)
    assert "\n" not in message and message.startswith(f"{next(iter(sets))} = "), message
    assert needle in message, message
