"""Scene errors: one line naming the key the user wrote, its value and what would be accepted."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import Any

from ..errors import SceneError, error, fmt, one_line  # noqa: F401 (the scene's words; kept below the scene, which host code may raise)


def unit_words(units: str) -> str:
    """A key's declared ``units`` as a refusal says them after a bound: ``"1"`` is
    ``(dimensionless)``, ``1 / X`` is ``per X``, any other unit as declared (``w``, ``rad``)."""
    if units == "1":
        return "(dimensionless)"
    if units.startswith("1 / "):
        return "per " + units.removeprefix("1 / ")
    return units


def with_units(accepts: str, units: str, value: Any = None, rule: Callable[[Any], bool] | None = None) -> str:
    """``accepts`` (``must be in [-0.5, 0.5]``) naming the key's ``units`` right after the range,
    before a remark in parentheses (``must be in (0, 2] disc radii (above 2 ...)``). An angle in
    radians refused for a ``value`` that reads as degrees (``1 < |value| <= 360``, of a sign the
    range takes) gets its conversion: ``(radians: 15 degrees is 0.262)``."""
    if not accepts or not units:
        return accepts
    bound, remark = re.match(r"(.*?)((?: \([a-z].*)?)$", accepts).groups()
    hint = ""
    if units == "rad" and isinstance(value, (int, float)) and 1.0 < abs(value) <= 360.0:
        if rule is None or rule(math.copysign(1e-9, value)):
            hint = f" (radians: {value:g} degrees is {math.radians(value):.3f})"
    return f"{bound} {unit_words(units)}{hint}{remark}"
