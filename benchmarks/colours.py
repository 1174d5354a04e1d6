"""Coloured contact passes in a jammed melange: the colours, and what each form costs.

    python benchmarks/colours.py --out benchmarks/results/colours
    python benchmarks/colours.py --out benchmarks/results/colours --states paper,row10k --vulkan

Jammed states (each made once, on the CPU, and saved in ``--work``):

- ``paper``: the paper scene (400 icebergs) at t = 1,000, where one island holds 90-100%
  of the icebergs (``benchmarks/results/islands``);
- ``row10k``, ``row100k``: 10,000 or 100,000 of the paper's icebergs upright in a row
  0.001 w apart, the whole row pushed against the wall at 0.1 w / sqrt(w/g), 20 steps on:
  every neighbour pair a contact, one island of every iceberg, the impulses where the row
  meets the wall.

For each state: the contacts, the colours, the largest colour's contacts and the largest
island's share (``colours.csv``); on the CPU, ms/step of the sequential forms (serial at
N = 400; islands off on 1 group and on one group per thread above) and of the coloured
form (serial and parallel at N = 400), at 1 and 2 threads, each thread count in its own child process with the forms
alternating block by block (``cpu.csv``); with ``--vulkan``, the device's profile
(``Model.profile(parts=True)``, a sync after every kernel) of the island form and of the
coloured form, and the share of the step that runs on one device thread: the parts that
are sequential, and in the island form the island-parallel parts too when one island
holds more than half the icebergs (``vulkan.csv``; lavapipe is a software device: its
milliseconds are not a GPU's). Plots ``colours.png``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

STATES = {"paper": 400, "row10k": 10_000, "row100k": 100_000}
PAPER_T = 1000.0


def _scene(name: str, order: str | None = None):
    from melange_ti import scene

    sets = [("contacts.order", order)] if order else []
    if name == "paper":
        return scene.load(None, sets)
    return scene.load(None, [("shelf.count", STATES[name]), ("shelf.tilt", 0.0), ("shelf.gap", 0.001), *sets])


def make_state(name: str, path: Path) -> None:
    """The jammed state ``name`` (module docstring) in ``path`` (npz of Model.state())."""
    from melange_ti import runtime

    runtime.init("cpu", precision="f64")
    from melange_ti.model import Model

    m = Model(_scene(name, "sequential"))
    if name == "paper":
        m.advance(int(round(PAPER_T / m.scene.time.dt)))
    else:
        s = m.state()
        s["vx"] = np.full(m.n, -0.1)
        m.set_state(s)
        m.advance(20)
    np.savez(path, **m.state())


def describe(name: str, path: Path) -> dict:
    """Contacts, colours and islands of the state's next detection (coloured, CPU)."""
    from melange_ti import runtime

    runtime.init("cpu", precision="f64")
    from melange_ti.model import Model
    from melange_ti.physics.data.schema import BodyInt, Contact, Counter

    m = Model(_scene(name, "coloured"), mode="parallel")
    m.set_state(dict(np.load(path)))
    m.advance(1)
    bi, cd, cp = m.arrays.bi.to_numpy(), m.arrays.cd.to_numpy(), m.arrays.cp.to_numpy()
    slots = cp.shape[0]
    colours = []
    pairs = []
    for i in np.flatnonzero(bi[:, BodyInt.WALL_ON]):
        colours.append(int(cd[slots, i, Contact.COLOUR]))
    for s in range(slots):
        rows = np.flatnonzero(bi[:, BodyInt.NCONTACT] > s)
        colours += [int(c) for c in cd[s, rows, Contact.COLOUR]]
        pairs += [(int(i), int(cp[s, i])) for i in rows]
    count = int(m.arrays.cnt.to_numpy()[Counter.COLOURS])
    per = np.bincount(colours, minlength=count)
    sys.path.insert(0, str(Path(__file__).parent))
    from islands import islands

    lab = islands(m.n, pairs)
    big = np.bincount(lab).max()
    return {
        "state": name,
        "n": m.n,
        "contacts": len(colours),
        "colours": count,
        "largest_colour": int(per.max()) if per.size else 0,
        "smallest_colour": int(per.min()) if per.size else 0,
        "largest_island_share": round(float(big / m.n), 4),
    }


def forms_for(n: int) -> dict[str, dict]:
    """The forms timed at N = n: keyword arguments of Model."""
    if n <= 2000:  # the serial form is the CPU's there (mode "auto"); the parallel one for comparison
        return {
            "sequential serial": {"mode": "serial"},
            "coloured serial": {"mode": "serial", "order": "coloured"},
            "coloured parallel": {"mode": "parallel", "order": "coloured"},
        }
    return {
        "sequential, 1 group": {"mode": "parallel", "islands": False, "groups": 1},
        "sequential, groups": {"mode": "parallel", "islands": False},
        "coloured": {"mode": "parallel", "order": "coloured"},
    }


def child_cpu(name: str, path: Path, steps: int, repeats: int) -> None:
    """Time every form of :func:`forms_for` on this process's threads, alternating."""
    import time

    import taichi as ti

    from melange_ti import runtime

    runtime.init("cpu", threads=int(os.environ.get("TI_CPU_MAX_NUM_THREADS", "0")) or None, precision="f64")
    from melange_ti.model import Model

    state = dict(np.load(path))
    models = {}
    for form, kw in forms_for(STATES[name]).items():
        order = kw.get("order", "sequential")
        m = Model(_scene(name, order), **{k: v for k, v in kw.items() if k != "order"})
        m.set_state(state)
        m.advance(2)  # compile, first touches
        models[form] = m
    times = {form: [] for form in models}
    for _ in range(repeats):
        for form, m in models.items():
            m.set_state(state)
            m.advance(1)
            ti.sync()
            t0 = time.perf_counter()
            m.advance(steps)
            ti.sync()
            times[form].append((time.perf_counter() - t0) / steps * 1e3)
    print("RESULT " + json.dumps({f: min(v) for f, v in times.items()}), flush=True)


def child_vulkan(name: str, path: Path, steps: int) -> None:
    """The device's per-kernel profile of the island form and the coloured form."""
    from melange_ti import runtime

    runtime.init("vulkan", precision="f64")
    from melange_ti.model import Model
    from melange_ti.physics import stages
    from melange_ti.physics.data.schema import BodyInt

    sequential = {
        f"{st.name}.{part.func.__name__}": part.sequential
        for st in stages.STAGES
        for parts in (st.device or st.parallel, st.coloured_device or st.coloured or ())
        for part in parts
    }
    island_parts = {"impulses.impulse_spans", "correction.correct_spans"}
    state = dict(np.load(path))
    out = {}
    for form, order in (("islands", "sequential"), ("coloured", "coloured")):
        m = Model(_scene(name, order), mode="parallel", islands=True)
        m.set_state(state)
        m.advance(3)
        prof = m.profile(steps, parts=True)
        step = sum(v for k, v in prof.items() if "." not in k)
        roots = m.arrays.bi.to_numpy()[:, BodyInt.ISLAND] if form == "islands" else None
        big = float(np.bincount(roots).max() / m.n) if roots is not None else 0.0
        one = sum(v for k, v in prof.items() if sequential.get(k, False))
        if form == "islands" and big > 0.5:
            one += sum(v for k, v in prof.items() if k in island_parts)
        out[form] = {
            "ms_per_step": step * 1e3,
            "one_thread_ms": one * 1e3,
            "one_thread_share": one / step,
            "largest_island_share": big,
            "parts": {k: v * 1e3 for k, v in prof.items() if "." in k},
        }
    print("RESULT " + json.dumps(out), flush=True)


def _child(args: list[str], threads: int | None = None) -> dict:
    env = {**os.environ, **({"TI_CPU_MAX_NUM_THREADS": str(threads)} if threads else {})}
    p = subprocess.run([sys.executable, __file__, *args], check=True, capture_output=True, text=True, env=env)
    line = next(x for x in p.stdout.splitlines() if x.startswith("RESULT "))
    return json.loads(line[len("RESULT ") :])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="benchmarks/results/colours")
    p.add_argument("--work", default="/tmp/melange_colours", help="where the jammed states are kept")
    p.add_argument("--states", default="paper,row10k,row100k")
    p.add_argument("--steps", type=int, default=0, help="timed steps per block (0: 200 / 20 / 5 by N)")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--vulkan", action="store_true", help="also profile the device forms on Vulkan")
    p.add_argument("--child", nargs=3, metavar=("KIND", "STATE", "STEPS"), help=argparse.SUPPRESS)
    a = p.parse_args()
    work = Path(a.work)
    if a.child:
        kind, name, steps = a.child
        path = work / f"{name}.npz"
        if kind == "make":
            make_state(name, path)
        elif kind == "describe":
            print("RESULT " + json.dumps(describe(name, path)), flush=True)
        elif kind == "cpu":
            child_cpu(name, path, int(steps), a.repeats)
        else:
            child_vulkan(name, path, int(steps))
        return
    work.mkdir(parents=True, exist_ok=True)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    described, cpu_rows, vk_rows = [], [], []
    for name in a.states.split(","):
        n = STATES[name]
        steps = a.steps or (200 if n <= 400 else 20 if n <= 10_000 else 5)
        if not (work / f"{name}.npz").exists():
            subprocess.run([sys.executable, __file__, "--work", str(work), "--child", "make", name, "0"], check=True)
        d = _child(["--work", str(work), "--child", "describe", name, "0"])
        described.append(d)
        print(d, flush=True)
        for threads in (1, 2):
            r = _child(["--work", str(work), "--repeats", str(a.repeats), "--child", "cpu", name, str(steps)], threads)
            for form, ms in r.items():
                cpu_rows.append({"state": name, "n": n, "threads": threads, "form": form, "ms_per_step": round(ms, 4)})
                print(cpu_rows[-1], flush=True)
        if a.vulkan:
            r = _child(["--work", str(work), "--child", "vulkan", name, str(max(2, steps // 10))])
            for form, v in r.items():
                vk_rows.append(
                    {
                        "state": name,
                        "n": n,
                        "form": form,
                        "ms_per_step": round(v["ms_per_step"], 3),
                        "one_thread_ms": round(v["one_thread_ms"], 3),
                        "one_thread_share": round(v["one_thread_share"], 4),
                        "largest_island_share": round(v["largest_island_share"], 4),
                    }
                )
                print(vk_rows[-1], json.dumps({k: round(x, 3) for k, x in v["parts"].items()}), flush=True)
    for fname, rows in (("colours.csv", described), ("cpu.csv", cpu_rows), ("vulkan.csv", vk_rows)):
        if rows:
            with open(out / fname, "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=list(rows[0]))
                w.writeheader()
                w.writerows(rows)
    plot(out, cpu_rows, vk_rows)


def plot(out: Path, cpu_rows: list[dict], vk_rows: list[dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    states = list(dict.fromkeys(r["state"] for r in cpu_rows))
    fig, axes = plt.subplots(1, len(states) + (1 if vk_rows else 0), figsize=(4.2 * (len(states) + bool(vk_rows)), 3.6))
    axes = np.atleast_1d(axes)
    for ax, name in zip(axes, states, strict=False):
        rows = [r for r in cpu_rows if r["state"] == name]
        forms = list(dict.fromkeys(r["form"] for r in rows))
        for k, threads in enumerate((1, 2)):
            vals = [next(r["ms_per_step"] for r in rows if r["form"] == f and r["threads"] == threads) for f in forms]
            ax.bar(np.arange(len(forms)) + 0.4 * k, vals, 0.4, label=f"{threads} thread{'s' if threads > 1 else ''}")
        ax.set_xticks(np.arange(len(forms)) + 0.2, forms, rotation=20, ha="right", fontsize=7)
        ax.set_ylabel("ms / step (CPU)")
        ax.set_title(f"{name} (N = {rows[0]['n']:,})", fontsize=9)
        ax.legend(fontsize=7)
    if vk_rows:
        ax = axes[-1]
        labels = [f"{r['state']}\n{r['form']}" for r in vk_rows]
        ax.bar(range(len(vk_rows)), [100 * r["one_thread_share"] for r in vk_rows], color="C3")
        ax.axhline(10, color="k", lw=0.8, ls="--")
        ax.set_xticks(range(len(vk_rows)), labels, fontsize=7)
        ax.set_ylabel("% of the step on one device thread")
        ax.set_title("lavapipe (software Vulkan)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "colours.png", dpi=130)


if __name__ == "__main__":
    main()
