"""``python -m melange_ti.probe ARCH PRECISION``: start Taichi on ``ARCH`` and run one small
kernel in ``PRECISION``, printing ``BACKEND name`` and ``KERNEL ok``.

Run in a child process by :func:`melange_ti.runtime.probe`: Taichi's start-up on a device
can kill the process that tries it (a missing ``libcuda.so``, or a Vulkan loader pointed at
a missing driver, segfaults), and a device without f64 fails only when a kernel compiles.
"""

import sys

import taichi as ti


@ti.kernel
def _fill(x: ti.types.ndarray()):
    for i in range(x.shape[0]):
        x[i] = ti.sqrt(1.0 + i) * 3.0


def main(arch: str, precision: str) -> int:
    fp = ti.f32 if precision == "f32" else ti.f64
    ti.init(arch=getattr(ti, arch), default_fp=fp, log_level=ti.ERROR)
    name = str(ti.lang.impl.current_cfg().arch).split(".")[-1]
    print("BACKEND", name, flush=True)
    if name in ("x64", "arm64"):
        return 0
    x = ti.ndarray(fp, shape=(4,))
    _fill(x)
    ok = abs(float(x.to_numpy()[1]) - 3.0 * 2.0**0.5) < 1e-5
    print("KERNEL", "ok" if ok else "wrong", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
