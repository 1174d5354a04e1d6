"""Minimal TOML writing for resolved scenes, and ``--set`` value parsing (reading is tomllib)."""

from __future__ import annotations

from typing import Any

import tomllib


def parse_value(text: str) -> Any:
    """A ``--set`` value: TOML syntax (``0.005``, ``true``, ``["gravity"]``), else a bare string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(float(v))  # a numpy float too (numpy 2 writes np.float64(...) as its repr)
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
