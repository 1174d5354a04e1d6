"""Taichi initialisation, once per process (``ti.init`` again would invalidate every field)."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import taichi as ti

from .errors import ArchError

_current: tuple | None = None


def memoize_source_positions() -> bool:
    """Make Taichi's front end reuse the source-position text it attaches to every AST node.

    Taichi 1.7 transforms a kernel's Python AST again in every process, even when the
    compiled code comes from its offline cache, and a ``ti.func`` again at every call site.
    For each node it formats a message of the node's source lines with ``textwrap``, for
    error reports: half of a warm start's transform time (docs/performance.md, start-up).
    The text depends only on the node's place in its function's source, so it is cached on
    that place; kernels, their cache keys and error messages are unchanged. Returns False
    (and changes nothing) on a Taichi whose front end does not look as expected."""
    try:
        from taichi.lang.ast.ast_transformer_utils import ASTTransformerContext
    except ImportError:
        return False
    original = getattr(ASTTransformerContext, "get_pos_info", None)
    if original is None or getattr(original, "_melange_memoized", False):
        return original is not None

    cache: dict[tuple, str] = {}

    def get_pos_info(self, node):
        body = getattr(node, "body", None)
        first = body[0].lineno if isinstance(body, list) and body and hasattr(body[0], "lineno") else None
        key = (
            self.file,
            self.lineno_offset,
            self.indent,
            self.func.func.__name__,
            len(self.src),
            type(node).__name__,
            node.lineno,
            getattr(node, "end_lineno", None),
            getattr(node, "col_offset", None),
            getattr(node, "end_col_offset", None),
            first,
        )
        text = cache.get(key)
        if text is None:
            text = cache[key] = original(self, node)
        return text

    get_pos_info._melange_memoized = True
    ASTTransformerContext.get_pos_info = get_pos_info
    return True


memoize_source_positions()


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


def kernels_stamp(key: str) -> Path | None:
    """A marker beside Taichi's offline cache for kernels compiled once for ``key`` (the
    effect set, precision, kernel form and the physics sources): present, the next run loads
    them from the cache instead of compiling. ``None`` when the offline cache is off. A
    cleared cache takes its markers with it."""
    import hashlib

    from taichi.lang import impl

    cfg = impl.current_cfg()
    if not cfg.offline_cache:
        return None
    here = Path(__file__).resolve().parent
    h = hashlib.sha256(f"{key}|{ti.__version__}|{cfg.arch}".encode())
    for src in sorted([here / "model.py", *(here / "physics").rglob("*.py")]):
        h.update(src.read_bytes())
    return Path(cfg.offline_cache_file_path) / "melange_ti" / h.hexdigest()[:32]
