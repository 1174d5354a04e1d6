"""Command line: argument parsing and error reporting only (docs/cli.md).

Every expected failure prints one line ``melange-ti: error: ...`` and exits with status 2
(bad input) or 3 (a run that stopped on a numerical guard); never a traceback.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .version import __version__

EXIT_INPUT = 2
EXIT_RUNTIME = 3


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, status 2
        self.exit(EXIT_INPUT, f"melange-ti: error: {message}\n")


def _common_run_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        default=[],
        help="override a scene key, e.g. time.dt=0.005; scene.effects+=waves adds an effect to the scene's list, "
        "scene.effects-=drag removes one (scene.effects=... replaces the whole list)",
    )
    p.add_argument(
        "--arch",
        choices=("cpu", "gpu", "cuda", "vulkan"),
        default="cpu",
        help="Taichi backend: cpu (bit-for-bit reproducible), gpu (Taichi's choice: CUDA, then Vulkan), cuda or vulkan; "
        "a device is probed first and refused in one line if it cannot run the scene (docs/devices.md)",
    )


SCENE_HELP = "scene TOML file (default: the bundled paper scene; keys: docs/scenes.md)"


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="melange-ti",
        description="Simulate capsizing icebergs and ice-melange expansion (Guttenberg et al. 2011). "
        "Units: lengths in iceberg widths w, time in sqrt(w/g). Docs: docs/ in the repository.",
    )
    p.add_argument("--version", action="version", version=f"melange-ti {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    r = sub.add_parser("run", help="run one scene into an HDF5 (netCDF-4) file", description="Run one scene into a run file.")
    r.add_argument("scene", nargs="?", help=SCENE_HELP)
    r.add_argument(
        "--out", help="output file (default: NAME_seedSEED.h5 with _KEY=VALUE for each --set, e.g. paper_seed1_duration=1000.h5)"
    )
    r.add_argument("--overwrite", action="store_true", help="replace an existing output file")
    r.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted run from its checkpoint, with the scene stored in --out; with --set "
        "time.duration=LATER, extend a run (finished or not) to that time: the file grows as if it had run there at once",
    )
    r.add_argument(
        "--threads",
        type=int,
        help="CPU threads (default: all; results do not depend on it). More threads help only above a few thousand "
        "icebergs: a paper-size run (400) steps on one core; run seeds side by side with `melange-ti ensemble`",
    )
    r.add_argument("--mode", choices=("auto", "serial", "parallel"), default="auto", help=argparse.SUPPRESS)
    _common_run_args(r)

    c = sub.add_parser("check", help="validate a scene without running it", description="Validate a scene; print what would run.")
    c.add_argument("scene", nargs="?", help=SCENE_HELP)
    c.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        default=[],
        help="override a scene key (scene.effects+=NAME / -=NAME add or remove one effect)",
    )

    e = sub.add_parser(
        "ensemble",
        help="seeds x parameter values on a Dask cluster, one file per run",
        description="Run seeds 1..K of a scene for every combination of the values listed with --set, one HDF5 "
        "file per run in --out (named by the swept values and the seed, e.g. discs=12_seed3.h5), on a local Dask "
        "cluster (or --scheduler). Keys can move together instead of through every combination: --set "
        "physics.tensile_strength,physics.shear_strength=0.1,0.2 gives both keys each value at once (2 runs per "
        "seed), and --zip KEY1,KEY2 pairs the i-th values of the keys' own --set lists of equal length. Finished "
        "runs in --out are skipped and unfinished ones resumed. However the command ends (done, an error, Ctrl-C, "
        "SIGTERM), its local cluster stops with it (a second Ctrl-C or SIGTERM kills the workers at once). Exit "
        "status: 0 done; 2 bad input (nothing run); 3 a run failed (the others finish); 130 Ctrl-C and 143 SIGTERM "
        "(the finished runs kept: the same command again resumes the rest).",
    )
    e.add_argument("scene", nargs="?", help=SCENE_HELP)
    e.add_argument("--seeds", type=int, required=True, help="run seeds 1..K")
    e.add_argument("--out", required=True, help="output directory")
    e.add_argument("--workers", type=int, help="local worker processes (default: CPU count)")
    e.add_argument("--scheduler", help="address of an existing Dask scheduler")
    e.add_argument(
        "--set",
        action="append",
        metavar="KEY=V1,V2,...",
        default=[],
        help="override; a comma list is swept (every combination with the other swept keys); "
        "KEY1,KEY2=V1,V2,... gives the listed keys each value together; scene.effects+=NAME adds an effect",
    )
    e.add_argument(
        "--zip",
        action="append",
        metavar="KEY1,KEY2,...",
        default=[],
        help="keys given with --set lists of equal length that move together: the i-th values go into one run "
        "(repeat for another group)",
    )
    e.add_argument(
        "--arch", choices=("cpu", "gpu", "cuda", "vulkan"), default="cpu", help="Taichi backend of every worker (as for run)"
    )

    pl = sub.add_parser(
        "plot",
        help="the paper's figures and the energy budget from run files",
        description="The paper's figures 2-5, the energy budget and summary.csv from run files. Runs are grouped "
        "by every scene key whose value differs between them (not the seed, duration or output schedule); every "
        "group is drawn and its label names those values (a single run: its scene and the values changed from the "
        "defaults). A NaN in a file is refused in one line (docs/validation.md).",
    )
    pl.add_argument("runs", nargs="+", help="run files, or folders of them (e.g. the one ensemble wrote)")
    pl.add_argument("--out", required=True, help="output directory for PNG/PDF files")
    pl.add_argument("--overwrite", action="store_true", help="replace figures already in --out")
    pl.add_argument("--times", help="comma-separated times for the snapshot and position figures (default: spread over the run)")
    pl.add_argument(
        "--width-m", type=float, help="iceberg width in metres for the physical axes (default: the run's scene.width_m)"
    )

    rd = sub.add_parser("render", help="frames (PNG) and an MP4 movie of a run, headless")
    rd.add_argument("run")
    rd.add_argument("--out", required=True, help="FILE.mp4 or a directory for PNG frames")
    rd.add_argument("--overwrite", action="store_true", help="replace an existing movie or frames")
    rd.add_argument("--discs", action="store_true", help="draw the collision discs")
    rd.add_argument(
        "--fragments",
        action="store_true",
        help="colour each body by its piece of ice (the bodies held together by intact bonds; one colour a piece) "
        "instead of by its capsize angle; without the bonds effect each body is its own piece",
    )
    rd.add_argument("--every", type=int, default=1, help="use every k-th snapshot (default 1)")
    rd.add_argument("--fps", type=int, default=20, help="frames per second of the movie (default 20)")
    rd.add_argument("--width-m", type=float, help="iceberg width in metres for the time label (default: the run's scene.width_m)")

    sub.add_parser(
        "devices",
        help="the Taichi backends this machine can run melange_ti on",
        description="Probe each backend (cpu, cuda, vulkan) in a child process with a small f64 and f32 kernel and say "
        "which --arch values work here, and what --arch gpu picks (docs/devices.md).",
    )

    b = sub.add_parser("bench", help="benchmarks: scaling, accuracy, effects, peers")
    b.add_argument("which", choices=("scaling", "accuracy", "effects", "peers"))
    b.add_argument("--out", default="benchmarks/results", help="directory for CSV and PNG results (default: benchmarks/results)")
    b.add_argument("--overwrite", action="store_true", help="replace results already in --out")
    b.add_argument("--quick", action="store_true", help="a tiny smoke run")
    return p


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def _cmd_check(args) -> int:
    from . import scene

    sc = scene.load(args.scene, scene.parse_overrides(args.set))
    name = args.scene or "paper scene (bundled)"
    print(
        f"{name}: ok ({_plural(sc.icebergs().count, 'iceberg')}, effects {', '.join(sc.effects.names()) or 'none'}, "
        f"{_plural(sc.time.steps, 'step')} of dt = {sc.time.dt:g})"
    )
    for warning in sc.warnings():
        print(f"melange-ti: warning: {warning}", file=sys.stderr)
    for note in sc.notes():
        print(f"note: {note}")
    return 0


def default_out(sc, overrides: list[tuple[str, object]]) -> Path:
    """``NAME_seedSEED.h5``, with the --set values (other than the seed) in the name."""
    import re

    extra = "".join(f"_{k.split('.')[-1]}={v}" for k, v in overrides if k != "time.seed")
    extra = re.sub(r"[^A-Za-z0-9.=+_-]+", "-", extra)[:80]
    return Path(f"{sc.name}_seed{sc.time.seed}{extra}.h5")


def _resume_scene(args, overrides):
    """With --resume the run file's own scene, and that scene as stored. --set applies to it
    (or to SCENE, if given); the result must equal it but for time.duration, which may move the
    end (a later one extends the run: docs/reliability.md)."""
    from . import scene
    from .errors import RunError
    from .simulation import EXTENDABLE, scene_changes

    if not args.out:
        raise scene.SceneError("--resume: give --out RUN.h5, the file to continue")
    out = Path(args.out)
    if not out.exists():
        raise RunError(f"--resume: {out} does not exist")
    stored = scene.stored_scene(out)
    if args.scene is None and not overrides:
        return stored, stored
    given = (
        scene.load(args.scene, overrides) if args.scene is not None else scene.loads(stored.to_toml(), overrides, geometry=False)
    )
    changed = [k for k in scene_changes(stored.to_toml(), given.to_toml()) if k != EXTENDABLE]
    if changed:
        raise RunError(
            f"--resume: {out} was made by another scene than the one given ({', '.join(changed)} differ); leave SCENE "
            f"and --set out to use its own (--set {EXTENDABLE}=LATER extends it)"
        )
    return given, stored


def _finished(out: Path) -> bool:
    from .io.hdf5 import consistent_lengths

    return consistent_lengths(out, complete=True)[1]


def _cmd_run(args) -> int:
    from . import runtime, scene
    from .simulation import Simulation

    if args.threads is not None and args.threads < 1:
        raise scene.SceneError(f"--threads = {args.threads}: must be >= 1")
    overrides = scene.parse_overrides(args.set)
    sc, stored = _resume_scene(args, overrides) if args.resume else (scene.load(args.scene, overrides), None)
    if args.resume and _finished(Path(args.out)) and sc.time.steps == stored.time.steps:
        print(
            f"{args.out}: the run has finished (t = {sc.time.duration:g}); nothing to resume "
            "(--set time.duration=LATER extends it)"
        )
        return 0
    out = Path(args.out) if args.out else default_out(sc, overrides)
    history = "melange-ti " + " ".join(sys.argv[1:])
    sim = Simulation(sc, out, overwrite=args.overwrite, resume=args.resume, arch=args.arch, mode=args.mode, history=history)
    for warning in sc.warnings():
        print(f"melange-ti: warning: {warning}", file=sys.stderr)
    for note in sc.notes():
        print(f"note: {note}")
    runtime.init(args.arch, args.threads, sc.precision)
    if runtime.software_device(args.arch):
        print(f"melange-ti: note: --arch {args.arch}: {runtime.software_note(args.arch)}", file=sys.stderr)
    summary = sim.run()
    for line in summary.lines():
        print(line)
    return 0


def _cmd_devices(args) -> int:
    from . import runtime
    from .errors import ArchError

    print("cpu: usable, f64 and f32 (bit-for-bit reproducible)")
    for arch in ("cuda", "vulkan", "gpu"):
        works = []
        for precision in ("f64", "f32"):
            try:
                works.append((precision, runtime.probe(arch, precision)))
            except ArchError as exc:
                why = str(exc).split(": ", 1)[-1]
        if works:
            backend = works[0][1]
            soft = f"; {runtime.software_note(arch)}" if runtime.software_device(arch) else ""
            print(f"{arch}: usable on Taichi's {backend} backend, {' and '.join(p for p, _ in works)}{soft}")
        else:
            print(f"{arch}: not usable ({why})")
    return 0


def _cmd_other(args) -> int:
    if args.command == "ensemble":
        from .ensemble import main as run
    elif args.command == "plot":
        from .analysis.figures import main as run
    elif args.command == "render":
        from .analysis.render import main as run
    else:
        from .bench import main as run
    return run(args)


def main(argv: list[str] | None = None) -> int:
    from .errors import ArchError, ContactOverflow, NumericalError, RunError
    from .io.hdf5 import OutputError
    from .scene import SceneError

    args = build_parser().parse_args(argv)
    handlers = {"run": _cmd_run, "check": _cmd_check, "devices": _cmd_devices}
    try:
        return handlers.get(args.command, _cmd_other)(args)
    except (SceneError, RunError, OutputError, ArchError) as exc:
        print(f"melange-ti: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except (NumericalError, ContactOverflow) as exc:
        print(f"melange-ti: error: {exc}", file=sys.stderr)
        return EXIT_RUNTIME
    except KeyboardInterrupt as exc:  # simulation.Interrupted says where and how to continue
        print(f"melange-ti: {exc or 'interrupted; resume with --resume'}", file=sys.stderr)
        return 130
