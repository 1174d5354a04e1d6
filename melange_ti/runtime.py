"""Taichi initialisation, once per process (``ti.init`` again would invalidate every field)."""

from __future__ import annotations

import contextlib
import io
import os
import re

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


ARCHS = ("cpu", "gpu", "cuda", "vulkan")
CPU_ARCHS = ("x64", "arm64")

_probed: dict[tuple[str, str], str] = {}
_software: dict[str, str] = {}  # arch -> name of the software device it runs on (a CPU posing as a GPU)


def probe(arch: str, precision: str = "f64") -> str:
    """The backend ``--arch arch`` gets here (``"cuda"``, ``"vulkan"``, ...), found by
    starting Taichi on it in a child process and running one small kernel in
    ``precision``; :class:`ArchError` (one line) where there is no usable device, the driver
    crashes, or the device cannot run ``precision`` (f64 on a device without it).

    A Vulkan device of type CPU (Mesa's lavapipe: a CPU pretending to be a GPU, slower than
    the CPU backend) is no GPU: ``"gpu"`` refuses it as it does a machine without one, and
    ``"vulkan"`` takes it (:func:`software_device` names it, for a note)."""
    if (arch, precision) in _probed:
        return _probed[(arch, precision)]
    import subprocess
    import sys

    flag = f"--arch {arch}"
    try:
        # the probe's Taichi keeps the kernel cache's cap too (Taichi trims the cache to its cap
        # when a process ends: at its own 100 MiB, the probe dropped a quarter of the kernels)
        env = {**os.environ, **taichi_defaults()}
        p = subprocess.run(
            [sys.executable, "-m", "melange_ti.probe", arch, precision], capture_output=True, text=True, timeout=600, env=env
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise ArchError(f"{flag}: could not probe for a device ({exc.__class__.__name__}); use --arch cpu") from None
    lines = dict(line.split(" ", 1) for line in p.stdout.splitlines() if line.startswith(("BACKEND ", "KERNEL ", "DEVICE ")))
    backend = lines.get("BACKEND", "").strip()
    if p.returncode < 0 or (p.returncode != 0 and not backend):
        why = f"signal {-p.returncode}" if p.returncode < 0 else f"status {p.returncode}"
        raise ArchError(f"{flag}: Taichi's start-up on the device failed ({why}: no device, or a broken driver); use --arch cpu")
    if backend in CPU_ARCHS or not backend:
        raise ArchError(
            f"{flag}: no {'GPU' if arch == 'gpu' else arch} device on this machine (Taichi fell back to the CPU); use --arch cpu"
        )
    kind, _, device = lines.get("DEVICE", "").strip().partition(" ")
    if kind == "cpu" and arch == "gpu":
        raise ArchError(
            f"{flag}: no GPU on this machine: Taichi's Vulkan device, {device}, is a CPU in software, slower than the "
            "CPU backend (--arch vulkan runs on it anyway); use --arch cpu"
        )
    if p.returncode != 0 or lines.get("KERNEL", "").strip() != "ok":
        last = (p.stderr.strip().splitlines() or ["no message"])[-1][:160]
        hint = " (try --set scene.precision=f32)" if precision == "f64" else ""
        raise ArchError(f"{flag}: the {backend} device cannot run a {precision} kernel{hint}: {last}")
    _probed[(arch, precision)] = backend
    if kind == "cpu":
        _software[arch] = device
    return backend


def software_device(arch: str) -> str | None:
    """The name of the software device (a CPU posing as a GPU, e.g. ``"llvmpipe (LLVM ...)"``)
    that ``arch`` was found to run on by :func:`probe`, or None (a GPU, the CPU, or not probed)."""
    return _software.get(arch)


def software_note(arch: str) -> str:
    """One line on :func:`software_device` for the command line's note."""
    return f"{_software[arch]} is a software device (a CPU posing as a GPU), slower than --arch cpu"


# Taichi's offline cache of compiled kernels holds at most this many bytes; past it, Taichi
# drops the least recently used quarter when a process ends. Taichi's own cap (100 MiB) is
# smaller than the kernels of the effect sets one user's scenes and the test suite compile
# (each effect set compiles its own): past it, kernels compiled minutes ago were dropped and
# compiled again (measured: the bonded row in waves of tests/test_resume_every_scene.py builds
# in 381 s compiling and in 9 s from the cache, and after the whole test suite on a 100 MiB
# cache it was compiling again). The cap is 1 GiB of disk instead. The environment variable
# TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES (bytes) overrides it.
OFFLINE_CACHE_BYTES = 1 << 30

# Taichi's own store-to-load forwarding and dead-store passes over a kernel's control-flow
# graph (``cfg_optimization``) take time that grows faster than the kernel: the serial form
# puts a whole step in one kernel, and for bonds in waves that one kernel took 191 s to
# compile, 3.1 minutes of it in these passes. Off, LLVM's own passes (which run either way) do
# that work: the scene's 5 kernels compile in 34 s instead of 206 s, the paper scene's in
# 11 s instead of 90 s, and every result is the same bits (the regression hashes). The step
# may be about 5% slower (side by side: 0.93-1.13x per pair, docs/performance.md): for long
# runs of kernels already cached, Taichi's own TI_CFG_OPTIMIZATION=1 turns the passes back on
# (the same bits either way).
CFG_OPTIMIZATION = False


def taichi_defaults() -> dict[str, str]:
    """Our defaults for Taichi's settings, as the environment variables Taichi reads
    (``TI_<KEY>``), less those the user has set: the kernel cache's cap and the control-flow
    passes. :func:`init` passes them to ``ti.init``; the device probe's process gets them in
    its environment, so its Taichi trims the cache to the same cap when it ends."""
    ours = {"TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES": str(OFFLINE_CACHE_BYTES), "TI_CFG_OPTIMIZATION": str(int(CFG_OPTIMIZATION))}
    return {k: v for k, v in ours.items() if not os.environ.get(k)}


def init(arch: str = "cpu", threads: int | None = None, precision: str = "f64", debug: bool = False) -> str:
    """Initialise Taichi for ``arch`` (one of :data:`ARCHS`: ``"cpu"``; ``"gpu"``, Taichi's
    choice of device, CUDA first, then Vulkan, ...; or ``"cuda"``, ``"vulkan"``) and return
    the backend's name (``"x64"``, ``"cuda"``, ``"vulkan"``, ...). A device is probed first
    (:func:`probe`): no usable device is an :class:`ArchError`, never a crash.

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
    mine = taichi_defaults()  # the user's own TI_ settings stand (Taichi reads them itself)
    if "TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES" in mine:
        kwargs["offline_cache_max_size_of_files"] = OFFLINE_CACHE_BYTES
    if "TI_CFG_OPTIMIZATION" in mine:
        kwargs["cfg_optimization"] = CFG_OPTIMIZATION
    if arch not in ARCHS:
        raise ArchError(f"--arch {arch!r}: must be one of {', '.join(ARCHS)}")
    target = ti.cpu if arch == "cpu" else getattr(ti, probe(arch, precision))
    with contextlib.redirect_stdout(io.StringIO()):  # ti.init prints its backend on stdout
        ti.init(arch=target, **kwargs)
    name = str(ti.lang.impl.current_cfg().arch).split(".")[-1]
    if arch != "cpu" and name in CPU_ARCHS:
        raise ArchError(f"--arch {arch}: no device on this machine (Taichi fell back to the CPU); use --arch cpu")
    _current = (key, name)
    return name


def backend() -> str | None:
    """The backend Taichi runs on (``"x64"``, ``"vulkan"``, ...), or None before :func:`init`."""
    return None if _current is None else _current[1]


def arch_family(backend: str) -> str:
    """What a run file's ``arch`` attribute says for a backend: ``"cpu"`` for Taichi's CPU
    backends (``"x64"``, ``"arm64"``; the file's ``taichi_arch`` names which), else the
    device backend's own name (``"vulkan"``, ``"cuda"``, ``"metal"``, ...)."""
    return "cpu" if backend in CPU_ARCHS else backend


# Without Taichi's own word (its debug log, below), a kernel whose compile call takes longer
# than this was compiled (measured, the paper scene's serial step: compiled in 16.8 s, loaded
# from the offline cache in 0.018 s; small kernels compile in 0.02-0.13 s)
COMPILED_SECONDS = 0.25
# Taichi 1.7's debug lines for a kernel compiled and stored in its offline cache, and for one
# made from it (kernel_compilation_manager.cpp)
_COMPILED_LINE = re.compile(r"\] Cache kernel '")
_LOADED_LINE = re.compile(r"\] Create kernel '.*' from cache")


class Compiling:
    """What :func:`watch_compiling` saw: ``kernels`` compiled (not loaded from Taichi's
    offline cache), ``loaded`` from it, and the ``seconds`` the compiling calls took."""

    def __init__(self) -> None:
        self.kernels = 0
        self.loaded = 0
        self.seconds = 0.0


@contextlib.contextmanager
def watch_compiling():
    """Yield a :class:`Compiling` that tells, after the block, which kernels Taichi compiled
    in it and which it loaded from its offline cache: so a run says what happened, not what
    a marker foretold. Taichi says it itself at its debug level (on file descriptor 2, led
    through a pipe for the block to a thread that counts those lines and passes every other on
    to stderr at once);
    each compile call (``Program.compile_kernel``: compiles a kernel or loads it, a lookup
    once it ran in this process) is also timed, for a Taichi that says nothing
    (:data:`COMPILED_SECONDS`)."""
    import sys
    import threading
    import time

    from taichi.lang import impl

    seen = Compiling()
    slow = Compiling()
    program = type(impl.get_runtime().prog)
    original = getattr(program, "compile_kernel", None)

    def compile_kernel(self, *args):
        start = time.perf_counter()
        try:
            return original(self, *args)
        finally:
            took = time.perf_counter() - start
            seen.seconds += took
            if took > COMPILED_SECONDS:
                slow.kernels += 1

    # Taichi's lines go through a pipe to a thread that counts the markers and passes every other
    # line on to stderr at once (so a crash's message is not held back), not to a file read after
    words = {"compiled": 0, "loaded": 0}
    read_end, write_end = os.pipe()
    sys.stderr.flush()
    saved = os.dup(2)

    def pump() -> None:
        with os.fdopen(read_end, "rb") as lines:
            for line in lines:
                text = line.decode(errors="replace")
                if _COMPILED_LINE.search(text):
                    words["compiled"] += 1
                elif _LOADED_LINE.search(text):
                    words["loaded"] += 1
                if not text.startswith(("[D ", "[T ", "[I ")):
                    os.write(saved, line)

    reader = threading.Thread(target=pump, name="melange-ti-compile-log", daemon=True)
    reader.start()
    try:
        os.dup2(write_end, 2)
        ti.set_logging_level(ti.DEBUG)
        if original is not None:
            program.compile_kernel = compile_kernel
        yield seen
    finally:
        if original is not None:
            program.compile_kernel = original
        ti.set_logging_level(ti.WARN)  # runtime.init's level
        sys.stderr.flush()
        os.dup2(saved, 2)
        os.close(write_end)  # the pipe's last writer: the reader sees its end
        reader.join(timeout=10)
        os.close(saved)
        seen.kernels, seen.loaded = words["compiled"], words["loaded"]
        if not seen.kernels and not seen.loaded:  # no word from Taichi: by the time the calls took
            seen.kernels = slow.kernels
