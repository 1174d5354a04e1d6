"""Scenes of a few explicit icebergs for the physics tests, built as a user would write them."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

from melange_ti import scene as scene_mod
from melange_ti.physics.schema import STATE_NAMES as STATE
from melange_ti.scene import dumps_toml


def make_scene(
    effects: Iterable[str],
    bergs: Iterable[Mapping[str, float]],
    physics: Mapping | None = None,
    *,
    contacts: Mapping | None = None,
    dt: float = 0.01,
    name: str = "physics",
) -> scene_mod.Scene:
    """A validated scene of the ``[[iceberg]]`` tables ``bergs`` (one step long; every output
    interval one step), with ``[physics]`` and ``[contacts]`` values as given."""
    doc = {
        "scene": {"name": name, "effects": list(effects)},
        "physics": dict(physics or {}),
        "contacts": dict(contacts or {}),
        "time": {"dt": dt, "duration": dt},
        "output": {"snapshot_interval": dt, "diagnostic_interval": dt, "checkpoint_interval": dt},
        "iceberg": [{k: float(v) for k, v in b.items()} for b in bergs],
    }
    return scene_mod.loads(dumps_toml(doc))


def initial(sc: scene_mod.Scene) -> dict[str, np.ndarray]:
    """The scene's initial state, ``{x, z, theta, vx, vz, omega}`` as float arrays (N,)."""
    b = sc.icebergs()
    return {k: np.array(getattr(b, k), dtype=float) for k in STATE}


# The kernel forms that must give the same bits: (mode, islands, groups) for Model
KERNEL_FORMS = (("serial", None, None), ("parallel", False, 1), ("parallel", False, 3), ("parallel", True, None))
