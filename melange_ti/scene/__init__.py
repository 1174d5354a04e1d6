"""Scenes: TOML -> a frozen, validated :class:`Scene` (keys in :mod:`.keys`)."""

from ..geometry import disc_radius
from ..physics.effects import NAMES as EFFECTS
from ..physics.effects import Effects
from .core import (
    CLASSES,
    ICEBERG_DEFAULTS,
    Contacts,
    Icebergs,
    Output,
    Physics,
    Scene,
    SceneError,
    Shelf,
    Start,
    Time,
    bundled_scene_text,
    from_dict,
    load,
    loads,
    parse_overrides,
)
from .initial import equilibrium_z
from .keys import DENSITY_RATIO
from .stored import stored_scene
from .toml import dumps_toml, parse_value

__all__ = [
    "CLASSES",
    "DENSITY_RATIO",
    "EFFECTS",
    "ICEBERG_DEFAULTS",
    "Contacts",
    "Effects",
    "Icebergs",
    "Output",
    "Physics",
    "Scene",
    "SceneError",
    "Shelf",
    "Start",
    "Time",
    "bundled_scene_text",
    "disc_radius",
    "dumps_toml",
    "equilibrium_z",
    "from_dict",
    "load",
    "loads",
    "parse_overrides",
    "parse_value",
    "stored_scene",
]
