"""The scenes the studies run: the bundled paper scene at any ``dt``, and a few explicit
icebergs with the drag and the density ratio as given."""

from __future__ import annotations

from ..scene.keys import DENSITY_RATIO


def dt_overrides(dt: float, duration: float) -> list[tuple[str, object]]:
    """Scene overrides for an arbitrary ``dt``: every interval a whole number of steps; a
    ``dt`` past the scene's refusal is let through (the stability scans look for it)."""
    steps = max(1, int(round(duration / dt)))

    def whole(interval: float) -> float:
        return dt * max(1, int(round(interval / dt)))

    return [
        ("time.dt", float(dt)),
        ("time.allow_unstable", True),
        ("time.duration", dt * steps),
        ("output.snapshot_interval", whole(10.0)),
        ("output.diagnostic_interval", whole(1.0)),
        ("output.checkpoint_interval", whole(500.0)),
    ]


def paper_scene(
    n: int,
    *,
    precision: str = "f64",
    dt: float = 0.01,
    duration: float | None = None,
    discs: int = 28,
    passes: int = 1,
    seed: int = 1,
    extra: list | None = None,
):
    """The bundled paper scene with ``[shelf] count = n`` and the given settings (and
    overrides ``extra``); ``duration`` defaults to ``max(dt, 1)``."""
    from .. import scene

    ov = [
        ("shelf.count", int(n)),
        ("scene.precision", precision),
        ("contacts.discs", int(discs)),
        ("contacts.contact_passes", int(passes)),
        ("time.seed", int(seed)),
        *dt_overrides(dt, max(dt, 1.0) if duration is None else duration),
        *(extra or []),
    ]
    return scene.load(None, ov)


def single_scene(
    precision: str,
    dt: float,
    duration: float,
    bergs: list[dict],
    effects: list[str],
    drag: float = 0.01,
    density_ratio: float = DENSITY_RATIO,
):
    """The ``[[iceberg]]`` tables ``bergs`` alone (no wall unless ``effects`` names it), at
    ``dt`` for ``duration``."""
    from .. import scene

    doc = {
        "scene": {"name": "single_iceberg", "effects": effects, "precision": precision},
        "physics": {"density_ratio": density_ratio, "drag": drag, "angular_drag": drag},
        "iceberg": bergs,
    }
    return scene.from_dict(doc, dt_overrides(dt, duration))
