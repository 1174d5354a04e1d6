"""Scene errors: one line naming the key the user wrote, its value and what would be accepted."""

from __future__ import annotations

from typing import Any


class SceneError(ValueError):
    """A scene that cannot be run; the message is one line naming key and value."""


def fmt(value: Any) -> str:
    """A value as an error message shows it: strings quoted, one line."""
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, dict):
        return "{...}"
    return one_line(str(value))


def one_line(text: str) -> str:
    """``text`` with line breaks and other control characters escaped."""
    return text if text.isprintable() else repr(text)[1:-1]


def error(key: str, value: Any, why: str) -> SceneError:
    return SceneError(f"{one_line(key)} = {fmt(value)}: {one_line(why)}")
