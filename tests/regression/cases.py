"""Regression cases: short runs whose every output dataset is pinned by a SHA-256 hash.

The hashes in ``hashes.json`` were recorded at commit 9cd40e0 (the engine before the
architecture rewrite) and must not change under a refactor or an optimisation. A deliberate
change of the default physics regenerates them, with the reason in the commit message::

    python -m tests.regression.cases --record            # short cases
    python -m tests.regression.cases --record --slow     # also the long ones

Each case is a scene (a dict of TOML tables) plus the kernel form to run it in. They cover
the paper scene in f64 and f32 with 12, 28 and 60 discs, a subset of the effects, the hard
cases (a row driven into the wall, a fast projectile into a packed row) and the parallel
form (forced at small N; above the serial limit in the slow case), and a bonded shelf that
breaks (recorded with the plane-strain bonds, issue 50). Runs go through
:class:`melange_ti.simulation.Simulation`, so the whole path to the HDF5 file is covered.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from melange_ti.scene import DENSITY_RATIO

HERE = Path(__file__).resolve().parent
HASHES = HERE / "hashes.json"
R = DENSITY_RATIO
FULL = ["gravity", "buoyancy", "drag", "collisions", "wall"]


def _paper(count=30, tilt=0.15, gap=0.2, duration=40.0, discs=28, precision="f64", effects=FULL, seed=3):
    return {
        "scene": {"name": "regression", "effects": list(effects), "precision": precision},
        "contacts": {"discs": discs},
        "time": {"dt": 0.01, "duration": duration, "seed": seed},
        "output": {"snapshot_interval": 2.0, "diagnostic_interval": 0.5},
        "shelf": {"count": count, "tilt": tilt, "gap": gap},
    }


def _row(speed_all=0.0, projectile=None, n=20, gap=0.1, duration=10.0):
    h = 1.4
    bergs = [
        {"x": gap + 0.5 + q * (1 + gap), "z": -R * h + h / 2, "vx": speed_all, "width": 1.0, "thickness": h} for q in range(n)
    ]
    if projectile is not None:
        bergs.append({"x": bergs[-1]["x"] + 1.0 + 0.05, "z": -R * h + h / 2, "vx": -projectile, "width": 1.0, "thickness": h})
    return {
        "scene": {"name": "regression_hard", "effects": FULL},
        "physics": {"density_ratio": R, "restitution": 0.5},
        "contacts": {"discs": 28},
        "time": {"dt": 0.01, "duration": duration},
        "output": {"snapshot_interval": 0.5, "diagnostic_interval": 0.1},
        "iceberg": bergs,
    }


def _bonded(count=30, strength=0.01, duration=40.0):
    """An intact shelf bonded to the wall, its free front block tilted: weak enough that the
    front's capsize breaks bonds within the run (docs/bonds.md)."""
    doc = _paper(count=count, tilt=0.01, gap=0.1, duration=duration, effects=[*FULL, "bonds"], seed=1)
    doc["physics"] = {"tensile_strength": strength, "shear_strength": strength, "strength_modulus": 5.0}
    doc["shelf"] = {**doc["shelf"], "bonded": True, "bonded_wall": True, "front": 1}
    return doc


# name: (scene document, kernel form, slow?)
CASES: dict[str, tuple[dict, str, bool]] = {
    "paper_f64_d28": (_paper(), "auto", False),
    "paper_f64_d12": (_paper(discs=12), "auto", False),
    "paper_f64_d60": (_paper(discs=60), "auto", False),
    "paper_f32_d28": (_paper(precision="f32"), "auto", False),
    "paper_parallel_d28": (_paper(), "parallel", False),
    "no_wall_no_drag": (_paper(effects=["gravity", "buoyancy", "collisions"], duration=20.0), "auto", False),
    "row_into_wall": (_row(speed_all=-5.0, duration=5.0), "auto", False),
    "projectile": (_row(projectile=100.0, gap=0.01, duration=2.0), "auto", False),
    "bonded_shelf": (_bonded(), "auto", False),
    "paper_f64_long": (_paper(count=400, tilt=0.01, gap=0.1, duration=600.0, seed=1), "auto", True),
    "parallel_large_n": (_paper(count=50_500, tilt=0.05, gap=0.1, duration=0.5), "auto", True),
}


def dataset_hashes(path: str | Path) -> dict[str, str]:
    """SHA-256 of every dataset's values (dtype, shape and bytes) in a run file."""
    import h5py

    out = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name.split("/")[0] in ("icebergs", "snapshots", "diagnostics"):
                a = np.ascontiguousarray(obj[()])
                h = hashlib.sha256(f"{a.dtype.str}{a.shape}".encode())
                h.update(a.tobytes())
                out[name] = h.hexdigest()

        f.visititems(visit)
    return out


def shortened(doc: dict, steps: int | None, every: int = 50) -> dict:
    """``doc`` ending after at most ``steps`` steps (outputs at least every ``every`` steps)."""
    if steps is None:
        return doc
    doc = {**doc, "time": dict(doc["time"]), "output": dict(doc["output"])}
    dt = doc["time"].get("dt", 0.01)
    doc["time"]["duration"] = min(doc["time"]["duration"], steps * dt)
    for key in ("snapshot_interval", "diagnostic_interval"):
        doc["output"][key] = min(doc["output"][key], every * dt)
    return doc


def perturbed(doc: dict) -> dict:
    """``doc`` with its initial positions moved by one ulp (every iceberg's ``x``; a shelf's
    tilt amplitude): a measure of how sensitive a case is to rounding."""
    doc = dict(doc)
    if "iceberg" in doc:
        doc["iceberg"] = [{**b, "x": float(np.nextafter(b["x"], np.inf))} for b in doc["iceberg"]]
    else:
        doc["shelf"] = {**doc["shelf"], "tilt": float(np.nextafter(doc["shelf"]["tilt"], np.inf))}
    return doc


def run_cases(
    names: list[str],
    outdir: Path,
    precision: str,
    arch: str = "cpu",
    steps: int | None = None,
    perturb: bool = False,
    order: str | None = None,
    every: int = 50,
) -> None:
    """Run ``names`` (all of one precision) in this process into ``outdir/NAME.h5`` on
    ``arch``, each cut to at most ``steps`` steps if given (outputs at least every ``every``
    steps) and :func:`perturbed` if asked, its ``contacts.order`` set to ``order`` if given."""
    from melange_ti import runtime
    from melange_ti.scene import dumps_toml, loads
    from melange_ti.simulation import Simulation

    runtime.init(arch, precision=precision)
    for name in names:
        doc, mode, _slow = CASES[name]
        doc = perturbed(doc) if perturb else doc
        if order is not None:
            doc = {**doc, "contacts": {**doc.get("contacts", {}), "order": order}}
        sc = loads(dumps_toml(shortened(doc, steps, every)))
        # on a device the model chooses its form (the parallel one); the CPU keeps the case's
        Simulation(sc, outdir / f"{name}.h5", overwrite=True, progress=False, mode=mode, arch=arch).run()


def run_in_subprocesses(
    names: list[str],
    outdir: Path,
    threads: int | None = None,
    arch: str = "cpu",
    steps: int | None = None,
    perturb: bool = False,
    order: str | None = None,
    every: int = 50,
) -> None:
    """Run the cases in fresh processes, one per precision (Taichi is initialised once per
    process), on ``arch``, cut to ``steps`` steps if given (outputs at least every ``every``
    steps), :func:`perturbed` if asked, with ``contacts.order`` set to ``order`` if given."""
    by_precision: dict[str, list[str]] = {}
    for name in names:
        by_precision.setdefault(CASES[name][0]["scene"].get("precision", "f64"), []).append(name)
    root = HERE.parents[1]
    for precision, group in by_precision.items():
        env = None
        if threads is not None:
            import os

            env = {**os.environ, "TI_CPU_MAX_NUM_THREADS": str(threads)}
        subprocess.run(
            [
                sys.executable,
                *("-m", "tests.regression.cases", "--run", str(outdir), "--precision", precision, "--arch", arch),
                *(("--steps", str(steps), "--every", str(every)) if steps is not None else ()),
                *(("--perturb",) if perturb else ()),
                *(("--order", order) if order is not None else ()),
                *group,
            ],
            check=True,
            cwd=root,
            env=env,
        )


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--record", action="store_true", help="run the cases and write hashes.json")
    p.add_argument("--slow", action="store_true", help="with --record: include the slow cases")
    p.add_argument("--run", metavar="DIR", help="(internal) run the named cases into DIR")
    p.add_argument("--precision", default="f64")
    p.add_argument("--arch", default="cpu")
    p.add_argument("--steps", type=int, default=None, help="(internal) cut each case to this many steps")
    p.add_argument("--every", type=int, default=50, help="(internal) with --steps: outputs at least this often")
    p.add_argument("--perturb", action="store_true", help="(internal) move one initial value by one ulp")
    p.add_argument("--order", default=None, help="(internal) the cases' contacts.order")
    p.add_argument("names", nargs="*")
    a = p.parse_args(argv)
    if a.run:
        run_cases(a.names, Path(a.run), a.precision, a.arch, a.steps, a.perturb, a.order, a.every)
        return
    if a.record:
        names = a.names or [n for n, c in CASES.items() if a.slow or not c[2]]
        stored = json.loads(HASHES.read_text()) if HASHES.exists() else {}
        with tempfile.TemporaryDirectory() as tmp:
            run_in_subprocesses(names, Path(tmp))
            for name in names:
                stored[name] = dataset_hashes(Path(tmp) / f"{name}.h5")
                print(f"{name}: {len(stored[name])} datasets")
        HASHES.write_text(json.dumps(stored, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
