"""``python -m tests.device_forms ARCH OUT.npz``: a row of 16 icebergs whose neighbours
approach each other, advanced in the parallel form with islands on and off (the sequential
order) and in the coloured order, each form's final state and totals in OUT.npz (used by tests/test_device.py: Taichi runs one
backend per process)."""

import sys

import numpy as np

STEPS = 100  # the neighbours meet by step ~35; a step costs ~0.1 s on lavapipe


def main(arch: str, out: str) -> None:
    from melange_ti import runtime
    from melange_ti.model import Model
    from melange_ti.scene import loads

    runtime.init(arch, precision="f64")
    h, r = 1.4, 0.8946
    bergs = "".join(
        f"[[iceberg]]\nx = {0.8 + 1.2 * q}\nz = {-r * h + h / 2}\nthickness = {h}\n"
        f"vx = {0.3 * (-1) ** q}\ntheta = {0.05 * (-1) ** q}\n"
        for q in range(16)
    )
    text = '[scene]\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall"]\n[time]\ndt = 0.01\nduration = 10.0\n'
    result = {}
    forms = {"0": {"islands": False, "order": "sequential"}, "1": {"islands": True, "order": "sequential"}}
    forms["c"] = {"order": "coloured"}
    for tag, kw in forms.items():
        m = Model(loads(text + bergs), mode="parallel", **kw)
        m.advance(STEPS)
        for k, v in m.state().items():
            result[f"{tag}_{k}"] = v
        t = m.totals()
        result[f"{tag}_totals"] = np.array([t.collision_dissipated, t.correction_work, t.impulse_sum, t.impulses])
    np.savez(out, **result)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
