"""Scene files: TOML -> a frozen, validated :class:`Scene`.

Every problem with a scene raises :class:`SceneError` whose message is one line naming the
key the user wrote and its value, and what would be accepted; the command line turns it into
exit status 2. The keys, their units and checks are in :mod:`.keys`.
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

from ..geometry import outline_problem
from ..io.hdf5 import read_group
from ..physics.effects import BY_NAME as EFFECT_DECLS
from ..physics.effects import NAMES as EFFECTS
from ..physics.effects import PAPER_EFFECTS, Effects, Key, hosts
from ..physics.effects.base import SI_TWINS
from . import keys as K
from .errors import SceneError, error, fmt, one_line, unit_words, with_units
from .initial import (
    FLOAT,
    Icebergs,
    check_geometry,
    check_time_step,
    floated,
    from_run,
    generate_shelf,
    partitioned,
    with_outlines,
)
from .toml import dumps_toml, parse_value


def _default(value: Any) -> Any:
    """A section field's default (a list key's: a fresh copy each time)."""
    return field(default_factory=lambda: list(value)) if isinstance(value, list) else field(default=value)


def _section_class(name: str, keys: tuple[Key, ...], namespace: dict | None = None) -> type:
    cls = dataclasses.make_dataclass(
        name,
        [(k.name, type(k.default), _default(k.default)) for k in keys],
        frozen=True,
        namespace={"__doc__": f"The [{name.lower()}] table (see melange_ti.scene.keys).", **(namespace or {})},
    )
    cls.__module__ = __name__
    return cls


def _steps(self) -> int:
    """Steps of the run: ``round(duration / dt)``."""
    return int(round(self.duration / self.dt))


Physics = _section_class("Physics", K.PHYSICS)
Contacts = _section_class("Contacts", K.CONTACTS)
Time = _section_class("Time", K.TIME, {"steps": property(_steps)})
Output = _section_class("Output", K.OUTPUT)


Shelf = _section_class("Shelf", K.SHELF, {"intact": property(K.shelf_intact)})
Start = _section_class("Start", K.START)
CLASSES: dict[str, type] = {"physics": Physics, "contacts": Contacts, "time": Time, "output": Output, "shelf": Shelf}
ICEBERG_DEFAULTS = {k.name: k.default for k in K.ICEBERG if not isinstance(k.default, list)}  # numbers, per iceberg
ONE_CELL = [1, 1]
# the effects a polygon outline (``[[iceberg]] vertices``) runs with so far; every other
# effect takes rectangles only (issue 33)
INTERVALS = ("output.snapshot_interval", "output.diagnostic_interval", "output.checkpoint_interval")


@dataclass(frozen=True)
class Scene:
    """A validated scene. Change it with :func:`dataclasses.replace`; :func:`melange_ti.run`
    validates the changed scene again and stores it in the output exactly as run."""

    name: str
    effects: Effects
    precision: str
    physics: Physics
    contacts: Contacts
    time: Time
    output: Output
    shelf: Shelf | None = None
    iceberg_table: tuple[dict, ...] | None = None
    start: Start | None = None
    width_m: float = 70.0
    tables: tuple[tuple[str, tuple[dict, ...]], ...] = ()  # effects' arrays of tables ([[NAME]]), with [[iceberg]]

    def icebergs(self) -> Icebergs:
        """The initial state: from ``[shelf]``, ``[[iceberg]]`` or ``[start]``."""
        if self.shelf is not None:
            bergs = generate_shelf(self.shelf, self.physics, self.time.seed)
            return partitioned(bergs, [tuple(self.shelf.cells)] * bergs.count)
        if self.start is not None:
            return from_run(self.start)
        cols = {k: np.array([float(b.get(k, d)) for b in self.iceberg_table]) for k, d in ICEBERG_DEFAULTS.items() if k != "z"}
        floats = np.array([b.get("z", FLOAT) == FLOAT for b in self.iceberg_table])
        cols["z"] = np.array([0.0 if f else float(b["z"]) for f, b in zip(floats, self.iceberg_table, strict=True)])
        bergs = with_outlines([b.get("vertices") for b in self.iceberg_table], cols)
        if floats.any():  # each at its floating draft (given or left out as "float")
            bergs = floated(bergs, floats, self.physics.density_ratio, self.physics.water_level)
        return partitioned(bergs, [tuple(b.get("cells", ONE_CELL)) for b in self.iceberg_table])

    def start_group(self, name: str) -> tuple[dict, Any] | None:
        """The group ``name`` an effect wrote to the run ``[start]`` begins from, as
        ``({dataset: values}, snapshot times)``, or ``None`` (for an effect's host code, which
        stands below the run files and reads them through the scene)."""
        return read_group(self.start.file, name)

    @property
    def source(self) -> dict:
        """The resolved scene as a TOML document (dict), from the fields as they are now."""
        doc = {
            "scene": {"name": self.name, "effects": self.effects.names(), "precision": self.precision, "width_m": self.width_m},
            **{key: dataclasses.asdict(getattr(self, key)) for key in ("physics", "contacts", "time", "output")},
        }
        if self.shelf is not None:
            doc["shelf"] = dataclasses.asdict(self.shelf)
        elif self.start is not None:
            doc["start"] = dataclasses.asdict(self.start)
        else:
            doc["iceberg"] = [
                {**{k: v for k, v in ICEBERG_DEFAULTS.items() if "vertices" not in b or k not in ("width", "thickness")}, **b}
                for b in self.iceberg_table
            ]
        for name, entries in self.tables:
            doc[name] = [dict(t) for t in entries]
        return doc

    def to_toml(self) -> str:
        """The resolved scene as TOML text (stored in every output file)."""
        return dumps_toml(self.source)

    def warnings(self) -> list[str]:
        """What the icebergs miss to float, said in one line (``check`` and ``run`` print it):
        a scene without gravity or buoyancy is legitimate (a free fall, a drag decay) but is
        far more often a ``--set scene.effects=friction`` that meant ``scene.effects+=friction``."""
        names = self.effects.names()
        missing = [e for e in ("gravity", "buoyancy") if not getattr(self.effects, e)]
        if not missing:
            return []
        what = {
            ("gravity",): "nothing pulls the icebergs down: they rise out of the water",
            ("buoyancy",): "nothing holds the icebergs up: they sink",
            ("gravity", "buoyancy"): "the icebergs neither fall nor float, and no potential energy is released",
        }[tuple(missing)]
        if not names:
            what = "nothing acts on the icebergs but their initial velocities"
        return [
            f"scene.effects = {names} has no {' and no '.join(missing)}: {what}; to add an effect to the scene's "
            "list instead of replacing it: --set scene.effects+=NAME"
        ]

    def notes(self) -> list[str]:
        """Values the run rounds to whole steps, each said in one line."""
        dt = self.time.dt
        out = []
        for key in ("time.duration", *INTERVALS):
            value = _get(self, key)
            used = dt * max(1, round(value / dt))
            if not math.isclose(used, value, rel_tol=1e-9, abs_tol=1e-12 * dt):
                out.append(f"{key} = {value:g} runs as {used:.10g} ({round(used / dt)} steps of time.dt = {dt:g})")
        return out


def _get(scene: Scene, key: str) -> Any:
    section, name = key.split(".")
    return getattr(getattr(scene, section), name)


def _check_type(key: str, value: Any, default: Any) -> Any:
    """Coerce ``value`` to the type of ``default`` or refuse it."""
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise error(key, value, "must be true or false")
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            raise error(key, value, "must be an integer")
        return value
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise error(key, value, "must be a number")
        value = float(value)
        if not math.isfinite(value):
            raise error(key, value, "must be finite")
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise error(key, value, "must be a string")
        return value
    if isinstance(default, list):
        return value
    raise AssertionError(key)


def _checked(prefix: str, raw: dict, keys: tuple[Key, ...]) -> dict:
    """The values of one table ``raw`` whose keys are ``keys``, each of the right type and
    passing its rule (named ``prefix.key`` in a refusal)."""
    by_name = {k.name: k for k in keys}
    values = {}
    for key, value in raw.items():
        full = f"{prefix}.{key}"
        if key not in by_name:
            raise error(full, value, f"unknown key (known: {', '.join(by_name)})")
        values[key] = _check_type(full, value, by_name[key].default)
        rule = by_name[key]
        if rule.rule is not None and not rule.rule(values[key]):
            raise error(full, values[key], _accepts(rule, values[key]))
    return values


def _accepts(key: Key, value: Any) -> str:
    """What ``key`` accepts, a number's range naming its declared units (``must be in [-0.5, 0.5] rad``)."""
    numeric = isinstance(key.default, (int, float)) and not isinstance(key.default, bool)
    return with_units(key.accepts, key.units, value, key.rule) if numeric else key.accepts


def _table(doc: dict, name: str, keys: tuple[Key, ...]) -> dict:
    raw = doc.get(name, {})
    if not isinstance(raw, dict):
        raise error(name, raw, "must be a table")
    return _checked(name, raw, keys)


def _si_twins(doc: dict, width_m: float) -> None:
    """``[physics] NAME_pa`` (a stress in Pa) or ``NAME_jm2`` (an energy per unit area in
    J/m^2), a key given in SI, becomes ``NAME`` in the model's unit (``rho_w g w``, ``rho_w g
    w^2``) at ``scene.width_m`` (in place); both forms of one key are refused together."""
    raw = doc.get("physics")
    if not isinstance(raw, dict):
        return
    for key in K.PHYSICS:
        if key.units not in SI_TWINS:
            continue
        suffix, unit, per = SI_TWINS[key.units]
        si = key.name + suffix
        if si not in raw:
            continue
        full = f"physics.{si}"
        if key.name in raw:
            raise error(
                full,
                raw[si],
                f"given with physics.{key.name}: give one ({key.name} in {key.units}, or {si} in {unit} at scene.width_m)",
            )
        value = _check_type(full, raw[si], float(key.default))
        if key.rule is not None and not key.rule(value):
            raise error(full, value, f"{key.accepts} {unit}")
        raw[key.name] = value / per(width_m)
        del raw[si]


def _scene_table(doc: dict) -> dict:
    t = _table(doc, "scene", K.SCENE)
    effects = t.get("effects", list(PAPER_EFFECTS))
    if not isinstance(effects, list) or not all(isinstance(e, str) for e in effects):
        raise error("scene.effects", effects, "must be a list of effect names")
    for e in effects:
        if e not in EFFECTS:
            raise error("scene.effects", e, f"unknown effect (known: {', '.join(EFFECTS)})")
    for e in effects:  # what an effect needs named with it (Effect.requires)
        needs = EFFECT_DECLS[e].requires
        if needs and not set(needs) & set(effects):
            raise error("scene.effects", effects, f"{EFFECT_DECLS[e].requires_doc}: name {' or '.join(needs)} too")
    precision = t.get("precision", "f64")
    if precision not in ("f32", "f64"):
        raise error("scene.precision", precision, 'must be "f32" or "f64"')
    return {
        "name": t.get("name", "scene"),
        "effects": Effects(**{e: True for e in effects}),
        "precision": precision,
        "width_m": t.get("width_m", 70.0),
    }


def _iceberg_table(doc: dict) -> tuple[dict, ...] | None:
    raw = doc.get("iceberg")
    if raw is None:
        return None
    if not isinstance(raw, list) or not raw:
        raise error("iceberg", raw, "must be a non-empty array of tables ([[iceberg]])")
    out = []
    for k, berg in enumerate(raw):
        if not isinstance(berg, dict):
            raise error(f"iceberg[{k}]", berg, "must be a table")
        z = berg.get("z", FLOAT)  # a number, or "float" (also when left out): floated at its tilt (initial.floated)
        if z != FLOAT:
            if isinstance(z, bool) or not isinstance(z, int | float):
                raise error(f"iceberg[{k}].z", z, f'must be a number (w) or "{FLOAT}" (floating at its tilt in still water)')
            z = _check_type(f"iceberg[{k}].z", z, 0.0)
        values = {**_checked(f"iceberg[{k}]", {q: v for q, v in berg.items() if q != "z"}, K.ICEBERG), "z": z}
        if "vertices" in values:
            bad = outline_problem(values["vertices"])
            if bad is None and ("width" in values or "thickness" in values):
                bad = "gives the outline; leave out width and thickness (they follow from the corners)"
            if bad is not None:
                raise error(f"iceberg[{k}].vertices", values["vertices"], bad)
            values["vertices"] = [[float(x), float(z)] for x, z in values["vertices"]]
        cells = values.get("cells", ONE_CELL)
        if cells != ONE_CELL and len(values.get("vertices", [[0, 0]] * 4)) != 4:
            raise error(
                f"iceberg[{k}].cells",
                cells,
                "divides a rectangle or an outline of 4 corners; this outline has "
                f"{len(values['vertices'])}: leave cells out or give 4 vertices",
            )
        out.append(values)
    return tuple(out)


# the arrays of tables effects read from a scene (Effect.tables): name -> keys
EFFECT_TABLES = {name: keys for e in EFFECT_DECLS.values() for name, keys, _ in e.tables}


def _effect_tables(doc: dict, icebergs: bool) -> tuple[tuple[str, tuple[dict, ...]], ...]:
    """The effects' ``[[NAME]]`` entries, each key checked; they index ``[[iceberg]]`` tables."""
    out = []
    for name, keys in EFFECT_TABLES.items():
        raw = doc.get(name)
        if raw is None:
            continue
        if not isinstance(raw, list) or not all(isinstance(t, dict) for t in raw):
            raise error(name, raw, f"must be an array of tables ([[{name}]])")
        if not icebergs:
            raise error(name, raw, f"[[{name}]] tables index [[iceberg]] tables; give the icebergs as [[iceberg]] tables")
        entries = []
        for k, t in enumerate(raw):
            clean = _checked(f"{name}[{k}]", t, keys)
            missing = [q.name for q in keys if q.required and q.name not in clean]
            if missing:
                names = " and ".join(q.name for q in keys if q.required)
                raise error(f"{name}[{k}]", t, f"missing {', '.join(missing)} (give {names})")
            entries.append(clean)
        out.append((name, tuple(entries)))
    return tuple(out)


def _start_table(doc: dict, base: Path | None) -> Start | None:
    if "start" not in doc:
        return None
    t = _table(doc, "start", K.START)
    if not t.get("file"):
        raise error("start.file", t.get("file", ""), "must name a run file (.h5) whose snapshot starts the scene")
    path = Path(t["file"]).expanduser()
    if not path.is_absolute():
        path = (base or Path.cwd()) / path
    return Start(file=str(path.resolve()), time=t.get("time", 0.0))


def _whole_steps(key: str, value: float, dt: float) -> None:
    """Refuse a time that rounds to no step, or to more than 1e13."""
    ratio = value / dt
    if not math.isfinite(ratio) or ratio > 1e13:
        raise error(key, value, f"is more than 1e13 steps of time.dt = {dt:g}")
    if round(ratio) < 1:
        raise error(key, value, f"rounds to 0 steps of time.dt = {dt:g}; use at least {dt:g} {unit_words(_units(key))}")


def _units(key: str) -> str:
    """The declared units of scene key ``SECTION.KEY``."""
    section, name = key.split(".")
    return next(k.units for k in K.SECTIONS[section] if k.name == name)


def _names(key: str, value: Any) -> list:
    """A list key's value given as a bare ``a,b,c`` (as ``--set contacts.discs=12,28,60`` lists
    values) or as a list; an empty ``--set scene.effects=`` is refused (``[]`` says it meant it)."""
    if isinstance(value, str):
        value = [v.strip() for v in value.split(",") if v.strip()]
        if not value:
            raise error(key, "", "names nothing; write [] for an empty list")
    return value


def _edit_list(doc: dict, key: str, value: Any) -> None:
    """``KEY+=VALUE`` / ``KEY-=VALUE`` (override key ``KEY+`` / ``KEY-``): add names to a list key
    or remove them, starting from the scene's list (or the default), order kept, none twice."""
    op, key = key[-1], key[:-1].strip()

    def bad(v: Any, why: str) -> SceneError:
        return SceneError(f"{one_line(key)} {op}= {fmt(v)}: {one_line(why)}")

    section, _, name = key.partition(".")
    known = next((k for k in K.SECTIONS.get(section, ()) if k.name == name), None)
    if known is None or not isinstance(known.default, list):
        lists = ", ".join(f"{s}.{k.name}" for s, ks in K.SECTIONS.items() for k in ks if isinstance(k.default, list))
        raise bad(value, f"+= and -= add to or remove from a list key ({lists}); use {key}=VALUE")
    table = doc.setdefault(section, {})
    if not isinstance(table, dict):
        raise error(section, table, "must be a table")
    current = table.get(name, list(known.default))
    if not isinstance(current, list):
        raise error(key, current, "must be a list")
    names = [v.strip() for v in value.split(",") if v.strip()] if isinstance(value, str) else value
    if not names or not isinstance(names, list) or not all(isinstance(v, str) for v in names):
        raise bad(value, "must be a name or a list of names (e.g. friction or friction,form_drag)")
    if key == "scene.effects":
        for e in names:
            if e not in EFFECTS:
                raise bad(e, f"unknown effect (known: {', '.join(EFFECTS)})")
    if op == "+":
        table[name] = current + [v for k, v in enumerate(names) if v not in current and v not in names[:k]]
        return
    table[name] = [v for v in current if v not in names]
    if not table[name] and current:
        raise bad(value, f"removes every entry of {key} = {current}; write {key}=[] to mean none")


def _set_path(doc: dict, key: str, value: Any) -> None:
    if key[-1:] in ("+", "-"):
        _edit_list(doc, key, value)
        return
    parts = key.split(".")
    if len(parts) != 2 or not all(parts):
        raise error(key, value, "--set needs SECTION.KEY=VALUE (e.g. time.dt=0.005)")
    section, name = parts
    if section == "iceberg":
        raise error(key, value, "[[iceberg]] entries cannot be set from the command line")
    if section not in K.SECTIONS:
        raise error(key, value, f"unknown section {section!r} (known: {', '.join(s for s in K.SECTIONS if s != 'iceberg')})")
    table = doc.setdefault(section, {})
    if not isinstance(table, dict):
        raise error(section, table, "must be a table")
    known = next((k for k in K.SECTIONS[section] if k.name == name), None)
    if known is not None and isinstance(known.default, list):
        value = _names(key, value)
        if known.default and isinstance(known.default[0], int):  # numbers: --set shelf.cells=4,2
            value = [parse_value(v) if isinstance(v, str) else v for v in value]
    table[name] = value


def parse_overrides(items: list[str] | None) -> list[tuple[str, Any]]:
    """``["time.dt=0.005", ...]`` -> ``[("time.dt", 0.005), ...]``; ``scene.effects+=friction``
    (``-=``) -> ``("scene.effects+", "friction")``, the key written before ``=``."""
    out = []
    for item in items or []:
        if "=" not in item:
            raise SceneError(f"--set {item!r}: expected SECTION.KEY=VALUE")
        key, text = item.split("=", 1)
        out.append((key.strip(), parse_value(text.strip())))
    return out


def from_dict(
    doc: dict, overrides: list[tuple[str, Any]] | None = None, base: Path | None = None, geometry: bool = True
) -> Scene:
    """Validate a parsed TOML document (plus ``--set`` overrides) into a :class:`Scene`.
    ``base``: the directory a ``[start]`` file is relative to (default: the current one).
    ``geometry``: also check the initial state (builds it: a ``[start]`` file is read); off
    for a scene stored in a run file, which ran already (:func:`.stored.stored_scene`)."""
    doc = _deepcopy(doc)
    for key, value in overrides or []:
        _set_path(doc, key, value)
    for key in doc:
        if key not in K.SECTIONS and key not in EFFECT_TABLES:
            known = ", ".join(f"[{s}]" for s in K.SECTIONS if s != "iceberg")
            arrays = ", ".join(f"[[{s}]]" for s in ("iceberg", *EFFECT_TABLES))
            raise SceneError(f"[{one_line(str(key))}]: unknown section (known: {known}, {arrays})")
    head = _scene_table(doc)
    _si_twins(doc, head["width_m"])
    parts = {key: cls(**_table(doc, key, getattr(K, key.upper()))) for key, cls in CLASSES.items()}
    table = _iceberg_table(doc)
    start = _start_table(doc, base)
    sources = (("[shelf]", "shelf" in doc), ("[[iceberg]]", table is not None), ("[start]", start is not None))
    given = [name for name, there in sources if there]
    if len(given) > 1:
        raise error(given[1].strip("[]"), given[1], f"give one of [shelf], [[iceberg]] or [start], not {' and '.join(given)}")
    shelf = parts["shelf"] if table is None and start is None else None
    time = parts["time"]
    scene = Scene(
        **head,
        physics=parts["physics"],
        contacts=parts["contacts"],
        time=time,
        output=parts["output"],
        shelf=shelf,
        iceberg_table=table,
        start=start,
        tables=_effect_tables(doc, table is not None),
    )
    _check_cells(scene)
    if shelf is not None and (bad := K.shelf_problem(shelf)) is not None:
        raise error(*bad)
    # the time step's stability first: a dt far too large is not blamed on an interval
    icebergs = check_time_step(scene) if geometry else None
    _whole_steps("time.duration", time.duration, time.dt)
    for key in INTERVALS:
        _whole_steps(key, getattr(parts["output"], key.split(".")[1]), time.dt)
    for effect in scene.effects.named:  # the checks an effect's keys need together (Effect.check)
        bad = effect.check(scene.physics, time.dt) if effect.check is not None else None
        if bad is not None:
            raise error(*bad)
    if geometry:
        check_geometry(scene, icebergs)
        for effect in scene.effects.named:  # the checks an effect needs the initial state for
            bad = hosts.check_start(effect, scene, icebergs)
            if bad is not None:
                raise error(*bad)
    return scene


def _check_cells(scene: Scene) -> None:
    """Cells (``cells = [nx, nz]`` other than one) need an effect that joins them (Effect.joins)."""
    given = [("shelf.cells", scene.shelf.cells)] if scene.shelf is not None else []
    given += [(f"iceberg[{k}].cells", b["cells"]) for k, b in enumerate(scene.iceberg_table or ()) if "cells" in b]
    given = [(key, v) for key, v in given if list(v) != ONE_CELL]
    if given and not any(e.joins for e in scene.effects.named):
        joiners = " or ".join(e.name for e in EFFECT_DECLS.values() if e.joins)
        raise error(*given[0], f"cells are joined across their faces by the {joiners} effect: name it in scene.effects")


def loads(text: str, overrides: list[tuple[str, Any]] | None = None, base: Path | None = None, geometry: bool = True) -> Scene:
    """Parse and validate scene TOML text (``geometry``: see :func:`from_dict`)."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"TOML syntax error: {exc}") from None
    return from_dict(doc, overrides, base, geometry)


HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def load(path: str | Path | None, overrides: list[tuple[str, Any]] | None = None) -> Scene:
    """Load a scene file; ``None`` means the bundled paper scene."""
    if path is None:
        return loads(bundled_scene_text("paper"), overrides)
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise SceneError(f"scene file {str(path)!r}: not found") from None
    except (IsADirectoryError, PermissionError) as exc:
        raise SceneError(f"scene file {str(path)!r}: cannot be read ({exc.__class__.__name__})") from None
    if raw.startswith(HDF5_SIGNATURE):
        raise SceneError(
            f"scene file {str(path)!r}: is a run file (HDF5), not a scene; to continue it: melange-ti run --resume --out {path}; "
            f'to start from its state: a scene with [start] file = "{path.name}"'
        )
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise SceneError(f"scene file {str(path)!r}: not a text (TOML) file") from None
    try:
        return loads(text, overrides, base=path.resolve().parent)
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
