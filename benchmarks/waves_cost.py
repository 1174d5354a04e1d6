"""What the waves effect costs per step: the paper scene (400 icebergs, the active state
t = 45-55) without and with waves, side by side in one process, alternating; then what each
part of a wave step costs.

    python benchmarks/waves_cost.py --csv benchmarks/results/waves/waves_cost.csv

Each configuration: the shelf advanced to t = 45 in its own model, then ``--repeats`` timed
blocks of ``--steps`` steps (a whole number of wave steps), the configurations alternating
block by block. With waves: the defaults (``wave_dx`` 0.25: 4,096 cells over 600 widths;
the default wave step: every ten time steps), ``wave_dx`` 0.3 (2,048 cells), and
``wave_dt`` 0.01 (the grid and the coupling every time step, as before wave steps). Then the
parts of a wave step, on the default grid's model with a wave step every time step (so every
part runs at every call), at t = 45: each part alone in a kernel that runs it
``--part-reps`` times, serial as the step's serial form, alternating with a block of the
paper's steps (best of ``--repeats``). A run's waves cost about the parts' sum over the time
steps per wave step. Writes the CSV, ``waves_parts.csv`` beside it and a PNG of both.
"""

import argparse
import csv
import time
from pathlib import Path


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=500)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--part-reps", type=int, default=200)
    p.add_argument("--csv", default="benchmarks/results/waves/waves_cost.csv")
    a = p.parse_args()
    import taichi as ti

    from melange_ti import runtime

    runtime.init("cpu", threads=1, precision="f64")
    from melange_ti.model import Model
    from melange_ti.scene import load

    paper = ["gravity", "buoyancy", "drag", "collisions", "wall"]
    waves = [*paper, "waves"]
    configs = {
        "paper": [("scene.effects", paper)],
        "paper + waves (defaults: wave_dx 0.25, a wave step of ten steps)": [("scene.effects", waves)],
        "paper + waves, wave_dx 0.3": [("scene.effects", waves), ("physics.wave_dx", 0.3)],
        "paper + waves, wave_dt 0.01 (every step)": [("scene.effects", waves), ("physics.wave_dt", 0.01)],
    }
    models = {}
    for name, sets in configs.items():
        m = Model(load(None, sets), mode="serial")
        m.advance(4500)
        models[name] = m
        cells = m.effect("waves").cells if m.fx.waves else 0
        print(f"{name}: {cells} wave cells", flush=True)
    times = {name: [] for name in configs}
    for _ in range(a.repeats):
        for name, m in models.items():
            times[name].append(_block(ti, m, a.steps))
    out = Path(a.csv)
    out.parent.mkdir(parents=True, exist_ok=True)
    base = min(times["paper"])
    with open(out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["config", "wave_cells", "steps_per_wave_step", "ms_per_step_best", "ms_per_step_median", "ratio_to_paper"])
        for name, ts in times.items():
            ts = sorted(ts)
            w.writerow(
                [
                    name,
                    models[name].effect("waves").cells if models[name].fx.waves else 0,
                    models[name].effect("waves").every if models[name].fx.waves else 0,
                    f"{ts[0]:.4f}",
                    f"{ts[len(ts) // 2]:.4f}",
                    f"{ts[0] / base:.2f}",
                ]
            )
            print(f"{name}: best {ts[0]:.3f} ms/step, median {ts[len(ts) // 2]:.3f}, {ts[0] / base:.2f}x the paper's")

    parts = _parts(ti, models["paper"], models["paper + waves, wave_dt 0.01 (every step)"], a)
    with open(out.with_name("waves_parts.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["part", "ms_per_step_best", "ratio_to_paper_step"])
        for name, t in parts.items():
            w.writerow([name, f"{t:.4f}", f"{t / parts['paper step']:.2f}"])
            print(f"{name}: {t:.4f} ms, {t / parts['paper step']:.2f}x the paper's step")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(10, 6.5), layout="constrained", height_ratios=(4, 7))
    names = list(times)
    ax.barh(names, [min(times[n]) for n in names], color=["0.5", "tab:blue", "tab:cyan", "tab:red"][: len(names)])
    ax.set_xlabel("ms per step (best of the alternating blocks; serial form, 1 thread)", fontsize=9)
    ax.set_title("paper scene, 400 icebergs, t = 45-55: the cost of the waves effect", fontsize=9)
    names = list(parts)
    bx.barh(names, [parts[n] for n in names], color=["0.5"] + ["tab:blue"] * (len(names) - 1))
    bx.set_xlabel("ms per call (best of the alternating repeats)", fontsize=9)
    bx.set_title("a wave step part by part (wave_dx 0.25), against the paper's whole step", fontsize=9)
    for axis in (ax, bx):
        axis.invert_yaxis()
    fig.savefig(out.with_suffix(".png"), dpi=120)


def _block(ti, m, steps: int) -> float:
    """ms per step of ``steps`` steps of model ``m``."""
    ti.sync()
    t0 = time.perf_counter()
    m.advance(steps)
    ti.sync()
    return (time.perf_counter() - t0) / steps * 1e3


def _parts(ti, paper, waves, a) -> dict[str, float]:
    """ms per call of each part of a wave step on ``waves`` (a wave step every time step:
    each part runs at every call; its state is restored after), with the paper's step
    (``paper``) timed between them."""
    from melange_ti.physics.data.schema import Arrays, Body
    from melange_ti.physics.effects.waves import coupling, grid

    arr = ti.types.ndarray()

    def kernel(body):
        @ti.kernel
        def run(n: ti.i32, b: arr, bi: arr, cd: arr, cp: arr, nl: arr, nr: arr, cells: arr, par: arr, scr: arr,
                cfg: arr, cnt: arr, acc: arr, red: arr, own: arr):  # fmt: skip
            a = ti.static(Arrays(b, bi, cd, cp, nl, nr, cells, par, scr, cfg, cnt, acc, red, own))
            ti.loop_config(serialize=True)
            for _ in range(1):
                for _r in range(n):
                    body(a)

        return run

    @ti.func
    def force(a: ti.template()):
        for i in range(a.b.shape[0]):
            f = coupling.pressure(a, i)
            a.b[i, Body.MOTION] += 0.0 * (f[0] + f[1] + f[2])  # kept: the force is used

    @ti.func
    def displace(a: ti.template()):
        for i in range(a.b.shape[0]):
            coupling.displace(a, i, a.b[i, Body.X], a.b[i, Body.Z], 1.0)

    @ti.func
    def update(a: ti.template()):
        grid._update(a, False)

    @ti.func
    def pressure(a: ti.template()):
        grid._pressure_surface(a, False)

    @ti.func
    def sponge(a: ti.template()):
        grid._sponge_serial(a)

    @ti.func
    def kick(a: ti.template()):
        grid.kick_grid(None, a)

    kernels = {
        "opening: the wave's pressure on each iceberg": kernel(force),
        "opening and close: each iceberg's area per strip, once each": kernel(displace),
        "grid: G phi and the displaced water (a pair of filters)": kernel(update),
        "grid: the pressure surface (one filter)": kernel(pressure),
        "grid: the absorbing layer": kernel(sponge),
        "grid: phi's kick": kernel(kick),
    }
    assert waves.effect("waves").every == 1
    own = waves.arrays.own.to_numpy()
    bodies = waves.arrays.b.to_numpy()
    order = list(kernels)
    for name in order:
        kernels[name](1, *waves.arrays)
    waves.arrays.own.from_numpy(own)
    waves.arrays.b.from_numpy(bodies)
    best = {"paper step": 1e9, **{name: 1e9 for name in order}}
    for _ in range(a.repeats):
        best["paper step"] = min(best["paper step"], _block(ti, paper, a.steps))
        for name in order:
            ti.sync()
            t0 = time.perf_counter()
            kernels[name](a.part_reps, *waves.arrays)
            ti.sync()
            best[name] = min(best[name], (time.perf_counter() - t0) / a.part_reps * 1e3)
        waves.arrays.own.from_numpy(own)
        waves.arrays.b.from_numpy(bodies)
    return {"paper step": best["paper step"], **{name: best[name] for name in kernels}}


if __name__ == "__main__":
    main()
