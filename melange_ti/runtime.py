"""Taichi initialisation, once per process (``ti.init`` again would invalidate every field)."""

from __future__ import annotations

import os

import taichi as ti

from .errors import ArchError

_current: tuple | None = None


def init(arch: str = "cpu", threads: int | None = None, precision: str = "f64", debug: bool = False) -> str:
    """Initialise Taichi for ``arch`` ("cpu" or "gpu") and return the backend's name.

    ``threads`` caps the CPU backend's threads (default: all hardware threads). Results do
    not depend on it. A second call with the same settings does nothing; with other
    settings it re-initialises Taichi, invalidating every existing model.
    """
    global _current
    key = (arch, threads, precision, debug)
    if _current is not None and _current[0] == key:
        return _current[1]
    fp = ti.f32 if precision == "f32" else ti.f64
    kwargs = dict(default_fp=fp, default_ip=ti.i32, debug=debug, log_level=ti.WARN)
    if threads is not None:
        kwargs["cpu_max_num_threads"] = int(threads)
    if arch == "cpu":
        ti.init(arch=ti.cpu, **kwargs)
    elif arch == "gpu":
        ti.init(arch=ti.gpu, **kwargs)
        if ti.lang.impl.current_cfg().arch in (ti.x64, ti.arm64):
            raise ArchError("--arch gpu: no GPU backend is available on this machine (Taichi fell back to the CPU)")
    else:
        raise ArchError(f"--arch {arch!r}: must be cpu or gpu")
    name = str(ti.lang.impl.current_cfg().arch).split(".")[-1]
    _current = (key, name)
    return name


def default_threads() -> int:
    return os.cpu_count() or 1
