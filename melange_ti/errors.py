"""Exceptions the command line turns into one-line messages (no heavy imports here)."""

from typing import Any


class RunError(RuntimeError):
    """A run that cannot start or continue (exit status 2)."""


class ArchError(RuntimeError):
    """The requested Taichi backend is not available (exit status 2)."""


class NumericalError(RuntimeError):
    """The state became non-finite or the energy ran away; output up to here is kept (exit 3)."""


class ContactOverflow(RuntimeError):
    """A body had more contact partners than slots; raised instead of dropping contacts (exit 3)."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) stopped a run at an output event, with a checkpoint written there; the
    message says how far it got and how to continue (exit status 130)."""


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
