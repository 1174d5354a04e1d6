"""Fuzzing the scene loader (issue "Nothing lost"): whatever TOML text, parsed values or
``--set`` overrides it is given, :mod:`melange_ti.scene` returns a valid :class:`Scene` or
raises a :class:`SceneError` whose message is one line, never any other exception.

A scene that loads must also survive the trip through its resolved TOML text (the text a run
file stores in ``scene_toml`` and ``--resume`` compares): ``loads(scene.to_toml())`` must give
the same resolved scene.

No Taichi here: the loader is pure Python, so these run in the pytest process.
"""

from __future__ import annotations

import datetime as dt
import math
import string

import pytest
import tomllib
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from melange_ti import scene as scn
from melange_ti.scene import DENSITY_RATIO, SceneError

FUZZ = settings(
    max_examples=100,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)

# A small valid scene that the structured strategies mutate, so that most examples get past
# the type checks and reach the range, multiple-of-dt and geometry checks.
BASE = {
    "scene": {"name": "fuzz", "effects": ["gravity", "buoyancy", "drag", "collisions", "wall"], "precision": "f64"},
    "physics": {
        "density_ratio": DENSITY_RATIO,
        "restitution": 0.5,
        "drag": 0.01,
        "angular_drag": 0.01,
        "water_level": 0.0,
        "wall_x": 0.0,
    },
    "contacts": {"discs": 12, "contact_passes": 1},
    "time": {"dt": 0.01, "duration": 1.0, "seed": 1},
    "output": {"snapshot_interval": 0.5, "diagnostic_interval": 0.1},
    "shelf": {"count": 3, "width": 1.0, "thickness": 1.4, "gap": 0.1, "tilt": 0.01},
}
BERGS = [
    {"x": 1.0, "z": -0.55, "theta": 0.0, "width": 1.0, "thickness": 1.4},
    {"x": 3.0, "z": -0.55, "theta": 0.1, "vx": -0.2, "width": 1.0, "thickness": 1.4},
]
KNOWN_KEYS = {
    "scene": ["name", "effects", "precision"],
    "physics": ["density_ratio", "restitution", "drag", "angular_drag", "water_level", "wall_x"],
    "contacts": ["discs", "contact_passes", "max_partners"],
    "time": ["dt", "duration", "seed"],
    "output": ["snapshot_interval", "diagnostic_interval", "checkpoint_interval"],
    "shelf": ["count", "width", "thickness", "gap", "tilt", "thickness_std", "width_std"],
    "iceberg": ["x", "z", "theta", "vx", "vz", "omega", "width", "thickness"],
}


# ----------------------------------------------------------------------------- helpers
def _outcome(fn, *args):
    """Call the loader; return the Scene or the SceneError; let anything else propagate."""
    try:
        return fn(*args)
    except SceneError as exc:
        msg = str(exc)
        assert msg.strip(), "empty SceneError message"
        assert "\n" not in msg and "\r" not in msg, f"SceneError message is not one line: {msg!r}"
        return exc


def _check_roundtrip(sc) -> None:
    """A loadable scene reloads from its own resolved TOML text to the same scene."""
    text = sc.to_toml()
    try:
        again = scn.loads(text)
    except SceneError as exc:  # pragma: no cover - reported as a failure below
        pytest.fail(f"resolved scene text does not reload ({exc}); text:\n{text}")
    assert again.to_toml() == text
    assert again.source == sc.source


def _toml_key(k: str) -> str:
    if k and all(c in string.ascii_letters + string.digits + "_-" for c in k):
        return k
    return _toml_str(k)


def _toml_str(s: str) -> str:
    out = ['"']
    for ch in s:
        o = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif o < 0x20 or o == 0x7F:
            out.append(f"\\u{o:04x}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan" if math.copysign(1.0, v) > 0 else "-nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, (dt.datetime, dt.date, dt.time)):
        return v.isoformat()
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def dumps(doc: dict) -> str:
    """TOML text for a document of tables (dicts), arrays of tables (lists of dicts) or scalars."""
    head, tables = [], []
    for sec, body in doc.items():
        if isinstance(body, dict):
            tables.append(f"[{_toml_key(sec)}]")
            tables += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in body.items()]
            tables.append("")
        elif isinstance(body, list) and body and all(isinstance(b, dict) for b in body):
            for b in body:
                tables.append(f"[[{_toml_key(sec)}]]")
                tables += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in b.items()]
                tables.append("")
        else:
            head.append(f"{_toml_key(sec)} = {_toml_value(body)}")
    return "\n".join(head + [""] + tables)


# ----------------------------------------------------------------------------- strategies
def _ints():
    return st.one_of(
        st.integers(-10, 100),
        st.sampled_from([0, 1, 4, 8, 12, 28, 1024, 1025, 2**31, 2**63 - 1, -(2**63)]),
        st.integers(-(2**63), 2**63 - 1),
    )


def _floats():
    return st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.floats(-5.0, 5.0),
        st.sampled_from([0.0, -0.0, 1e-300, 5e-324, 1e300, 1.7976931348623157e308, 0.005, 0.01, 0.015, 0.5, 1.0, 1.4]),
    )


_scalars = st.one_of(
    _floats(),
    _ints(),
    st.booleans(),
    st.text(max_size=12),
    st.sampled_from(["gravity", "buoyancy", "drag", "collisions", "wall", "f32", "f64", "f16", ""]),
    st.datetimes(),
    st.dates(),
)
values = st.recursive(
    _scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(min_size=1, max_size=6), inner, max_size=3)),
    max_leaves=6,
)


@st.composite
def mutated_docs(draw):
    """BASE (with a shelf or explicit icebergs) with a few keys replaced, added or removed."""
    doc = {k: dict(v) for k, v in BASE.items()}
    if draw(st.booleans()):
        del doc["shelf"]
        doc["iceberg"] = [dict(b) for b in BERGS[: draw(st.integers(1, 2))]]
    for _ in range(draw(st.integers(1, 4))):
        sec = draw(st.sampled_from([*KNOWN_KEYS, "physic", "extra"]))
        key = draw(st.one_of(st.sampled_from(KNOWN_KEYS.get(sec, ["name"])), st.text(min_size=1, max_size=8)))
        action = draw(st.sampled_from(["set", "set", "set", "delete", "section"]))
        if action == "section":  # the whole section replaced by a value
            doc[sec] = draw(values)
            continue
        target = doc.setdefault(sec, {})
        if isinstance(target, list):
            target = target[draw(st.integers(0, len(target) - 1))] if target and isinstance(target[0], dict) else None
        if not isinstance(target, dict):
            continue
        if action == "delete":
            target.pop(key, None)
        else:
            v = draw(values)
            if key == "count" and isinstance(v, int) and not isinstance(v, bool):
                assume(v <= 2000)  # a valid 10-million-iceberg shelf is legal, just slow to check
            target[key] = v
    return doc


# ----------------------------------------------------------------------------- tests
@FUZZ
@given(st.text(max_size=300))
@example("")
@example("[time]\ndt = = 0.01\n")
@example("[physics\n")
@example('[physics]\n"bad\\nkey" = 1\n[shelf]\ncount = 2\n')
@example('[scene]\nname = "two\\nlines"\n[shelf]\ncount = 2\n')
@example("[time]\ndt = 1e-10\nduration = 1e300\n[shelf]\ncount = 2\n")
def test_arbitrary_text(text):
    """Any text at all: a scene or a one-line SceneError."""
    out = _outcome(scn.loads, text)
    if not isinstance(out, SceneError):
        _check_roundtrip(out)


@FUZZ
@given(
    st.lists(
        st.sampled_from(
            [
                "[scene]",
                "[physics]",
                "[contacts]",
                "[time]",
                "[output]",
                "[shelf]",
                "[[iceberg]]",
                "[scene.x]",
                'name = "s"',
                'effects = ["gravity", "wall"]',
                "effects = []",
                'precision = "f32"',
                "dt = 0.01",
                "dt = 0",
                "dt = nan",
                "duration = 0.5",
                "duration = 1e308",
                "seed = -3",
                "discs = 8",
                "discs = 10",
                "discs = 12.0",
                "count = 2",
                "count = 0",
                "width = 0.0",
                "thickness = 9.0",
                "gap = -1.0",
                "tilt = 4.0",
                "x = 0.1",
                "x = 3.0",
                "z = inf",
                "restitution = 1.0001",
                "density_ratio = 1",
                "snapshot_interval = 0.015",
                "water_level = 1e308",
                "max_partners = 0",
                "x = 1",
                "x = 1",
                "= 1",
                "[",
                '"',
                'x = "\\n"',
                "x = 1979-05-27T07:32:00Z",
                'x = [1, "a"]',
            ]
        ),
        max_size=12,
    )
)
def test_toml_fragments(lines):
    """Near-valid TOML assembled from scene-like fragments: a scene or a one-line SceneError."""
    out = _outcome(scn.loads, "\n".join(lines))
    if not isinstance(out, SceneError):
        _check_roundtrip(out)


@FUZZ
@given(mutated_docs())
def test_mutated_documents(doc):
    """Parsed values of any TOML type in any key, via the text loader and via from_dict."""
    text = dumps(doc)
    try:
        parsed = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        parsed = None  # e.g. a key written twice; the loader must still give a SceneError
    out = _outcome(scn.loads, text)
    if parsed is not None:
        direct = _outcome(scn.from_dict, parsed)
        assert type(direct) is type(out)
    if not isinstance(out, SceneError):
        _check_roundtrip(out)


@FUZZ
@given(
    st.one_of(
        st.sampled_from([f"{s}.{k}" for s, ks in KNOWN_KEYS.items() for k in ks] + ["time", "a.b.c", ".dt", "time."]),
        st.text(max_size=15),
    ),
    st.one_of(
        st.text(max_size=20),
        st.sampled_from(
            [
                "0.005",
                "nan",
                "-inf",
                "1e400",
                "[1, 2]",
                '"x"',
                "true",
                "{a = 1}",
                "12",
                "12.0",
                "2.5",
                '["gravity"]',
                "1979-05-27",
                "0x10",
            ]
        ),
    ),
)
@example("time.d\rt", "0.01")  # a key with a carriage return: the message must stay one line
def test_set_overrides(key, value):
    """``--set KEY=VALUE`` with any key and value text: a scene or a one-line SceneError."""
    base = {k: dict(v) for k, v in BASE.items()}

    def load(item):
        return scn.from_dict(base, scn.parse_overrides([item]))

    out = _outcome(load, f"{key}={value}")
    if not isinstance(out, SceneError):
        _check_roundtrip(out)


@FUZZ
@given(st.binary(max_size=200))
def test_scene_file_bytes(tmp_path_factory, data):
    """A scene *file* with any bytes (invalid UTF-8 included): a scene or a one-line SceneError."""
    path = tmp_path_factory.mktemp("fuzz") / "scene.toml"
    path.write_bytes(data)
    _outcome(scn.load, path)


# ----------------------------------------------------------------------------- specific cases
# Minimal reproductions found by the fuzzers above, kept as plain tests so a failure names them.


def test_tiny_dt_with_long_duration_is_a_scene_error():
    """duration / dt overflows to inf: must be a SceneError, not OverflowError."""
    out = _outcome(scn.loads, "[time]\ndt = 1e-10\nduration = 1e300\n[shelf]\ncount = 2\n")
    assert isinstance(out, SceneError)
    assert "1e-10" in str(out) or "1e+300" in str(out) or "1e300" in str(out)


def test_denormal_dt_is_a_scene_error():
    out = _outcome(scn.loads, "[time]\ndt = 5e-324\n[shelf]\ncount = 2\n")
    assert isinstance(out, SceneError)
    assert "time." in str(out)


def test_key_with_newline_gives_one_line_message():
    """An unknown (quoted) key holding a newline escape still gives a one-line message."""
    out = _outcome(scn.loads, '[physics]\n"bad\\nkey" = 1\n[shelf]\ncount = 2\n')
    assert isinstance(out, SceneError)


def test_scene_name_with_newline_round_trips():
    """A name with an escaped newline is valid TOML; the resolved text stored in the run file
    (and compared by --resume) must load back."""
    out = _outcome(scn.loads, '[scene]\nname = "two\\nlines"\n[shelf]\ncount = 2\n')
    assert not isinstance(out, SceneError)
    _check_roundtrip(out)
