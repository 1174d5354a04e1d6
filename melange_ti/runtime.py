"""Taichi initialisation, once per process (``ti.init`` again would invalidate every field)."""

from __future__ import annotations

import contextlib
import io

import taichi as ti

from .errors import ArchError

_current: tuple | None = None


def _check_gpu() -> None:
    """Refuse ``--arch gpu`` in one line where no GPU backend works. Taichi's own attempt can
    kill the process (``libcuda.so`` missing, then a segmentation fault in the Vulkan
    probe), so a child process tries first."""
    import subprocess
    import sys

    probe = "import taichi as ti; ti.init(arch=ti.gpu, log_level=ti.ERROR); print(ti.lang.impl.current_cfg().arch)"
    try:
        p = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=300)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise ArchError(f"--arch gpu: could not probe for a GPU ({exc.__class__.__name__}); use --arch cpu") from None
    arch = p.stdout.strip().splitlines()[-1].split(".")[-1] if p.returncode == 0 and p.stdout.strip() else ""
    if p.returncode != 0:
        raise ArchError(
            f"--arch gpu: no usable GPU on this machine (Taichi's GPU start-up failed, status {p.returncode}); use --arch cpu"
        )
    if arch in ("x64", "arm64", ""):
        raise ArchError("--arch gpu: no GPU backend is available on this machine (Taichi fell back to the CPU); use --arch cpu")


def init(arch: str = "cpu", threads: int | None = None, precision: str = "f64", debug: bool = False) -> str:
    """Initialise Taichi for ``arch`` ("cpu" or "gpu") and return the backend's name.

    ``threads`` caps the CPU backend's threads (default: all hardware threads). Results do
    not depend on it. A second call with the same settings (or ``threads=None`` and the same
    others) does nothing; with other settings it re-initialises Taichi, invalidating every
    existing model.
    """
    global _current
    key = (arch, threads, precision, debug)
    if _current is not None:
        same = _current[0]
        if same == key or (threads is None and (same[0], same[2], same[3]) == (arch, precision, debug)):
            return _current[1]
    fp = ti.f32 if precision == "f32" else ti.f64
    # fast_math off: otherwise the serial and parallel kernels may round differently
    kwargs = dict(default_fp=fp, default_ip=ti.i32, debug=debug, log_level=ti.WARN, fast_math=False)
    if threads is not None:
        kwargs["cpu_max_num_threads"] = int(threads)
    if arch not in ("cpu", "gpu"):
        raise ArchError(f"--arch {arch!r}: must be cpu or gpu")
    if arch == "gpu":
        _check_gpu()
    with contextlib.redirect_stdout(io.StringIO()):  # ti.init prints its backend on stdout
        ti.init(arch=ti.cpu if arch == "cpu" else ti.gpu, **kwargs)
    if arch == "gpu":
        if ti.lang.impl.current_cfg().arch in (ti.x64, ti.arm64):
            raise ArchError("--arch gpu: no GPU backend is available on this machine (Taichi fell back to the CPU)")
    name = str(ti.lang.impl.current_cfg().arch).split(".")[-1]
    _current = (key, name)
    return name
