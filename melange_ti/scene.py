"""Scene files: TOML -> a frozen, validated :class:`Scene`.

Every problem with a scene raises :class:`SceneError` whose message is one line naming the
key and the offending value; the command line turns it into exit status 2.
All quantities are non-dimensional (SPEC section 1): lengths in iceberg widths ``w``,
time in ``sqrt(w/g)``, densities in ``rho_water``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import tomllib

from .physics.effects import NAMES as EFFECTS
from .physics.effects import REGISTRY, Effects, Key


class SceneError(ValueError):
    """A scene that cannot be run; the message is one line naming key and value."""


# [physics] keys of the model itself; each effect adds its own (physics.effects).
BASE_PHYSICS_KEYS = (
    Key("density_ratio", 0.8946, "1", "rho_ice / rho_water", lambda v: 0.0 < v < 1.0, "must be in (0, 1)"),
    Key(
        "restitution",
        0.5,
        "1",
        "Newton coefficient of restitution on the normal relative velocity (iceberg and wall contacts)",
        lambda v: 0.0 <= v <= 1.0,
        "must be in [0, 1]",
    ),
    Key("water_level", 0.0, "w", "z of the flat sea surface"),
)
PHYSICS_KEYS: tuple[Key, ...] = (*BASE_PHYSICS_KEYS, *(k for e in REGISTRY for k in e.keys))

Physics = dataclasses.make_dataclass(
    "Physics",
    [(k.name, type(k.default), field(default=k.default)) for k in PHYSICS_KEYS],
    frozen=True,
    namespace={"__doc__": "The [physics] table: the model's keys and those of every registered effect."},
)
Physics.__module__ = __name__


@dataclass(frozen=True)
class Contacts:
    discs: int = 28  # discs per iceberg, a multiple of 4, >= 8
    contact_passes: int = 1  # Gauss-Seidel repetitions of the impulse pass
    max_partners: int = 32  # contact slots per iceberg; overflow stops the run loudly
    disc_spacing: float = 2.0  # centre spacing on the longest face, in disc radii (2: just touching)


@dataclass(frozen=True)
class Time:
    dt: float = 0.01
    duration: float = 8000.0
    seed: int = 1

    @property
    def steps(self) -> int:
        return int(round(self.duration / self.dt))


@dataclass(frozen=True)
class Output:
    snapshot_interval: float = 10.0  # time between full-state snapshots
    diagnostic_interval: float = 1.0  # time between scalar diagnostics
    checkpoint_interval: float = 500.0  # time between restart checkpoints


@dataclass(frozen=True)
class Shelf:
    count: int = 400
    width: float = 1.0
    thickness: float = 1.4
    gap: float = 0.1
    tilt: float = 0.01  # amplitude of the uniform random initial tilt, radians
    thickness_std: float = 0.0  # standard deviation of a normal thickness spread


@dataclass(frozen=True)
class Icebergs:
    """Initial state of every iceberg, arrays of shape (N,)."""

    x: np.ndarray
    z: np.ndarray
    theta: np.ndarray
    vx: np.ndarray
    vz: np.ndarray
    omega: np.ndarray
    width: np.ndarray
    thickness: np.ndarray

    @property
    def count(self) -> int:
        return int(self.x.shape[0])


@dataclass(frozen=True)
class Scene:
    name: str
    effects: Effects
    precision: str
    physics: Physics
    contacts: Contacts
    time: Time
    output: Output
    shelf: Shelf | None
    iceberg_table: tuple[dict, ...] | None
    source: dict = field(repr=False, compare=False, hash=False)

    def icebergs(self) -> Icebergs:
        """The initial state: generated from ``[shelf]`` or read from ``[[iceberg]]``."""
        if self.shelf is not None:
            return _generate_shelf(self.shelf, self.physics, self.time.seed)
        cols = {k: np.array([float(b.get(k, d)) for b in self.iceberg_table]) for k, d in ICEBERG_DEFAULTS.items()}
        return Icebergs(**cols)

    def to_toml(self) -> str:
        """The resolved scene as TOML text (stored in every output file)."""
        return dumps_toml(self.source)


ICEBERG_DEFAULTS = {
    "x": 0.0,
    "z": 0.0,
    "theta": 0.0,
    "vx": 0.0,
    "vz": 0.0,
    "omega": 0.0,
    "width": 1.0,
    "thickness": 1.4,
}

SECTIONS: dict[str, type] = {
    "physics": Physics,
    "contacts": Contacts,
    "time": Time,
    "output": Output,
    "shelf": Shelf,
}

# Each checked key: (predicate on the value, the rule in words).
_RULES: dict[str, tuple[Any, str]] = {
    **{f"physics.{k.name}": (k.rule, k.accepts) for k in PHYSICS_KEYS if k.rule is not None},
    "contacts.discs": (lambda v: v >= 8 and v % 4 == 0, "must be a multiple of 4 and at least 8"),
    "contacts.contact_passes": (lambda v: v >= 1, "must be >= 1"),
    "contacts.max_partners": (lambda v: 1 <= v <= 1024, "must be in [1, 1024]"),
    "contacts.disc_spacing": (lambda v: 0.0 < v <= 2.0, "must be in (0, 2] (above 2 the discs leave holes)"),
    "time.dt": (lambda v: v > 0.0, "must be > 0"),
    "time.seed": (lambda v: 0 <= v < 2**63, "must be in [0, 2**63)"),
    "output.snapshot_interval": (lambda v: v > 0.0, "must be > 0"),
    "output.diagnostic_interval": (lambda v: v > 0.0, "must be > 0"),
    "output.checkpoint_interval": (lambda v: v > 0.0, "must be > 0"),
    "shelf.count": (lambda v: 1 <= v <= 10_000_000, "must be in [1, 10000000]"),
    "shelf.width": (lambda v: v > 0.0, "must be > 0"),
    "shelf.thickness": (lambda v: v > 0.0, "must be > 0"),
    "shelf.gap": (lambda v: v >= 0.0, "must be >= 0"),
    "shelf.tilt": (lambda v: 0.0 <= v <= math.pi, "must be in [0, pi]"),
    "shelf.thickness_std": (lambda v: v >= 0.0, "must be >= 0"),
    "iceberg.width": (lambda v: v > 0.0, "must be > 0"),
    "iceberg.thickness": (lambda v: v > 0.0, "must be > 0"),
}


def _fmt(value: Any) -> str:
    if isinstance(value, str):
        return repr(value)
    return _one_line(str(value))


def _one_line(text: str) -> str:
    """``text`` with line breaks and other control characters escaped."""
    return text if text.isprintable() else repr(text)[1:-1]


def _error(key: str, value: Any, why: str) -> SceneError:
    return SceneError(f"{_one_line(key)} = {_fmt(value)}: {_one_line(why)}")


def _check_type(key: str, value: Any, default: Any) -> Any:
    """Coerce ``value`` to the type of ``default`` or refuse it."""
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise _error(key, value, "must be true or false")
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise _error(key, value, "must be an integer")
        return value
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _error(key, value, "must be a number")
        value = float(value)
        if not math.isfinite(value):
            raise _error(key, value, "must be finite")
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise _error(key, value, "must be a string")
        return value
    raise AssertionError(key)


def _check_rule(key: str, value: Any) -> None:
    rule = _RULES.get(key)
    if rule is not None and not rule[0](value):
        raise _error(key, value, rule[1])


def _section(doc: dict, name: str, cls: type) -> Any:
    raw = doc.get(name, {})
    if not isinstance(raw, dict):
        raise _error(name, raw, "must be a table")
    defaults = {f.name: f.default for f in dataclasses.fields(cls)}
    values = {}
    for key, value in raw.items():
        full = f"{name}.{key}"
        if key not in defaults:
            raise _error(full, value, f"unknown key (known: {', '.join(defaults)})")
        values[key] = _check_type(full, value, defaults[key])
        _check_rule(full, values[key])
    return cls(**values)


def _scene_table(doc: dict) -> tuple[str, Effects, str]:
    raw = doc.get("scene", {})
    if not isinstance(raw, dict):
        raise _error("scene", raw, "must be a table")
    known = ("name", "effects", "precision")
    for key, value in raw.items():
        if key not in known:
            raise _error(f"scene.{key}", value, f"unknown key (known: {', '.join(known)})")
    name = _check_type("scene.name", raw.get("name", "scene"), "")
    effects = raw.get("effects", list(EFFECTS))
    if not isinstance(effects, list) or not all(isinstance(e, str) for e in effects):
        raise _error("scene.effects", effects, "must be a list of effect names")
    for e in effects:
        if e not in EFFECTS:
            raise _error("scene.effects", e, f"unknown effect (known: {', '.join(EFFECTS)})")
    precision = _check_type("scene.precision", raw.get("precision", "f64"), "")
    if precision not in ("f32", "f64"):
        raise _error("scene.precision", precision, 'must be "f32" or "f64"')
    return name, Effects(**{e: True for e in effects}), precision


def _iceberg_table(doc: dict) -> tuple[dict, ...] | None:
    raw = doc.get("iceberg")
    if raw is None:
        return None
    if not isinstance(raw, list) or not raw:
        raise _error("iceberg", raw, "must be a non-empty array of tables ([[iceberg]])")
    out = []
    for k, berg in enumerate(raw):
        if not isinstance(berg, dict):
            raise _error(f"iceberg[{k}]", berg, "must be a table")
        clean = {}
        for key, value in berg.items():
            full = f"iceberg[{k}].{key}"
            if key not in ICEBERG_DEFAULTS:
                raise _error(full, value, f"unknown key (known: {', '.join(ICEBERG_DEFAULTS)})")
            clean[key] = _check_type(full, value, ICEBERG_DEFAULTS[key])
            rule = _RULES.get(f"iceberg.{key}")
            if rule is not None and not rule[0](clean[key]):
                raise _error(full, clean[key], rule[1])
        out.append(clean)
    return tuple(out)


def _multiple_of(key: str, value: float, dt: float) -> None:
    ratio = value / dt
    if not math.isfinite(ratio) or ratio > 1e13:
        raise _error(key, value, f"is more than 1e13 steps of time.dt = {dt}")
    if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-6 * max(1.0, ratio):
        raise _error(key, value, f"must be a whole multiple of time.dt = {dt}")


def equilibrium_z(thickness: np.ndarray | float, density_ratio: float, water_level: float) -> Any:
    """Centre height of an upright iceberg floating in hydrostatic equilibrium (draft r*h)."""
    return water_level - density_ratio * thickness + 0.5 * thickness


def _generate_shelf(shelf: Shelf, physics: Physics, seed: int) -> Icebergs:
    """The paper's initial state: a row from the wall, upright, floating, slightly tilted.

    Random numbers are drawn on the host from ``numpy.random.default_rng(seed)``: first the
    tilts, then (only when ``thickness_std > 0``) the thicknesses, so a spread never changes
    the tilts of a scene.
    """
    rng = np.random.default_rng(seed)
    n = shelf.count
    theta = rng.uniform(-shelf.tilt, shelf.tilt, n) if shelf.tilt > 0 else np.zeros(n)
    thickness = np.full(n, shelf.thickness)
    if shelf.thickness_std > 0:
        thickness = rng.normal(shelf.thickness, shelf.thickness_std, n)
        if np.any(thickness <= 0.05 * shelf.thickness):
            raise _error(
                "shelf.thickness_std", shelf.thickness_std, "draws thicknesses <= 5% of shelf.thickness; use a smaller spread"
            )
    width = np.full(n, shelf.width)
    x = physics.wall_x + shelf.gap + 0.5 * shelf.width + np.arange(n) * (shelf.width + shelf.gap)
    z = equilibrium_z(thickness, physics.density_ratio, physics.water_level)
    zeros = np.zeros(n)
    return Icebergs(x=x, z=z, theta=theta, vx=zeros, vz=zeros.copy(), omega=zeros.copy(), width=width, thickness=thickness)


def _rect_corners(b: Icebergs) -> np.ndarray:
    """World corners, shape (N, 4, 2)."""
    c, s = np.cos(b.theta), np.sin(b.theta)
    hu, hv = 0.5 * b.width, 0.5 * b.thickness
    out = np.empty((b.count, 4, 2))
    for k, (su, sv) in enumerate(((1, -1), (1, 1), (-1, 1), (-1, -1))):
        out[:, k, 0] = b.x + su * hu * c - sv * hv * s
        out[:, k, 1] = b.z + su * hu * s + sv * hv * c
    return out


def _separated(pa: np.ndarray, pb: np.ndarray) -> bool:
    """Separating-axis test for two convex quadrilaterals (4, 2); touching counts as apart."""
    for poly in (pa, pb):
        for k in range(4):
            e = poly[(k + 1) % 4] - poly[k]
            axis = np.array([-e[1], e[0]])
            a, b = pa @ axis, pb @ axis
            if a.max() <= b.min() or b.max() <= a.min():
                return True
    return False


def _check_geometry(scene: Scene) -> None:
    b = scene.icebergs()
    for name, arr in (("x", b.x), ("z", b.z), ("theta", b.theta)):
        if not np.all(np.isfinite(arr)):
            raise _error(f"iceberg.{name}", arr[~np.isfinite(arr)][0], "must be finite")
    if scene.effects.contacts:
        # The radius may not exceed half the shortest face: L / (k s + 2) <= l / 2.
        spacing = scene.contacts.disc_spacing
        aspect = np.maximum(b.width, b.thickness) / np.minimum(b.width, b.thickness)
        k = scene.contacts.discs // 4
        worst = int(np.argmax(aspect))
        if 2.0 * aspect[worst] > k * spacing + 2.0 + 1e-12:
            need = 4 * max(2, math.ceil((2.0 * aspect[worst] - 2.0) / spacing - 1e-12))
            raise _error(
                "contacts.discs",
                scene.contacts.discs,
                f"too few for iceberg {worst} of aspect ratio {aspect[worst]:.3g}: disc spacing on its long face "
                f"would exceed 2*radius (holes); use at least {need}",
            )
    corners = _rect_corners(b)
    if scene.effects.wall:
        left = corners[:, :, 0].min(axis=1)
        bad = np.flatnonzero(left < scene.physics.wall_x)
        if bad.size:
            i = int(bad[0])
            raise _error(f"iceberg[{i}].x", float(b.x[i]), f"overlaps the wall at x = {scene.physics.wall_x} at t = 0")
    if scene.effects.collisions and b.count > 1:
        bound = 0.5 * np.hypot(b.width, b.thickness)
        order = np.argsort(b.x, kind="stable")
        xs = b.x[order]
        reach = 2.0 * bound.max()
        for a in range(b.count):
            hi = np.searchsorted(xs, xs[a] + reach, side="right")
            for c in range(a + 1, hi):
                i, j = int(order[a]), int(order[c])
                if np.hypot(b.x[i] - b.x[j], b.z[i] - b.z[j]) >= bound[i] + bound[j]:
                    continue
                if not _separated(corners[i], corners[j]):
                    i, j = min(i, j), max(i, j)
                    raise _error(f"iceberg[{j}].x", float(b.x[j]), f"iceberg {j} overlaps iceberg {i} at t = 0")


def _set_path(doc: dict, key: str, value: Any) -> None:
    parts = key.split(".")
    if len(parts) != 2 or not all(parts):
        raise _error(key, value, "--set needs SECTION.KEY=VALUE (e.g. time.dt=0.005)")
    section, name = parts
    if section == "iceberg":
        raise _error(key, value, "[[iceberg]] entries cannot be set from the command line")
    table = doc.setdefault(section, {})
    if not isinstance(table, dict):
        raise _error(section, table, "must be a table")
    table[name] = value


def parse_value(text: str) -> Any:
    """A ``--set`` value: TOML syntax (``0.005``, ``true``, ``["gravity"]``), else a bare string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def parse_overrides(items: list[str] | None) -> list[tuple[str, Any]]:
    """``["time.dt=0.005", ...]`` -> ``[("time.dt", 0.005), ...]``."""
    out = []
    for item in items or []:
        if "=" not in item:
            raise SceneError(f"--set {item!r}: expected SECTION.KEY=VALUE")
        key, text = item.split("=", 1)
        out.append((key.strip(), parse_value(text.strip())))
    return out


def from_dict(doc: dict, overrides: list[tuple[str, Any]] | None = None) -> Scene:
    """Validate a parsed TOML document (plus ``--set`` overrides) into a :class:`Scene`."""
    doc = _deepcopy(doc)
    for key, value in overrides or []:
        _set_path(doc, key, value)
    for key, value in doc.items():
        if key not in SECTIONS and key not in ("scene", "iceberg"):
            raise _error(key, value, f"unknown section (known: scene, {', '.join(SECTIONS)}, iceberg)")
    name, effects, precision = _scene_table(doc)
    parts = {key: _section(doc, key, cls) for key, cls in SECTIONS.items()}
    table = _iceberg_table(doc)
    if table is not None and "shelf" in doc:
        raise _error("shelf", "[shelf]", "give either [shelf] or [[iceberg]] entries, not both")
    shelf = parts["shelf"] if table is None else None
    time = parts["time"]
    if time.duration < time.dt:
        raise _error("time.duration", time.duration, f"must be >= time.dt = {time.dt}")
    _multiple_of("time.duration", time.duration, time.dt)
    _multiple_of("output.snapshot_interval", parts["output"].snapshot_interval, time.dt)
    _multiple_of("output.diagnostic_interval", parts["output"].diagnostic_interval, time.dt)
    _multiple_of("output.checkpoint_interval", parts["output"].checkpoint_interval, time.dt)
    resolved = {
        "scene": {"name": name, "effects": effects.names(), "precision": precision},
        **{key: dataclasses.asdict(parts[key]) for key in ("physics", "contacts", "time", "output")},
    }
    if shelf is not None:
        resolved["shelf"] = dataclasses.asdict(shelf)
    else:
        resolved["iceberg"] = [{**ICEBERG_DEFAULTS, **b} for b in table]
    scene = Scene(
        name=name,
        effects=effects,
        precision=precision,
        physics=parts["physics"],
        contacts=parts["contacts"],
        time=time,
        output=parts["output"],
        shelf=shelf,
        iceberg_table=table,
        source=resolved,
    )
    _check_geometry(scene)
    return scene


def loads(text: str, overrides: list[tuple[str, Any]] | None = None) -> Scene:
    """Parse and validate scene TOML text."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"TOML syntax error: {exc}") from None
    return from_dict(doc, overrides)


def load(path: str | Path | None, overrides: list[tuple[str, Any]] | None = None) -> Scene:
    """Load a scene file; ``None`` means the bundled paper scene."""
    if path is None:
        return loads(bundled_scene_text("paper"), overrides)
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(f"scene file {str(path)!r}: not found") from None
    except (IsADirectoryError, PermissionError, UnicodeDecodeError) as exc:
        raise SceneError(f"scene file {str(path)!r}: cannot be read ({exc.__class__.__name__})") from None
    try:
        return loads(text, overrides)
    except SceneError as exc:
        raise SceneError(f"{path}: {exc}") from None


def bundled_scene_text(name: str) -> str:
    """Text of a scene shipped with the package (``paper``, ``single_capsize``)."""
    return resources.files("melange_ti").joinpath("scenes", f"{name}.toml").read_text(encoding="utf-8")


def _deepcopy(doc: Any) -> Any:
    if isinstance(doc, dict):
        return {k: _deepcopy(v) for k, v in doc.items()}
    if isinstance(doc, list):
        return [_deepcopy(v) for v in doc]
    return doc


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        out = []
        for ch in v:  # a TOML basic string: escape quotes, backslashes and control characters
            if ch in '"\\':
                out.append("\\" + ch)
            elif ord(ch) < 0x20 or ord(ch) == 0x7F:
                out.append(f"\\u{ord(ch):04x}")
            else:
                out.append(ch)
        return '"' + "".join(out) + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(type(v))


def dumps_toml(doc: dict) -> str:
    """Minimal TOML writer for resolved scenes (tables of scalars/lists, arrays of tables)."""
    lines = []
    for section, body in doc.items():
        if isinstance(body, list):
            for item in body:
                lines.append(f"[[{section}]]")
                lines += [f"{k} = {_toml_value(v)}" for k, v in item.items()]
                lines.append("")
        else:
            lines.append(f"[{section}]")
            lines += [f"{k} = {_toml_value(v)}" for k, v in body.items()]
            lines.append("")
    return "\n".join(lines)
