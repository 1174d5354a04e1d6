"""A run continued is the run that never stopped, whatever its scene holds (issue 47, point 1).

Every body shape and every effect that carries state beyond the icebergs' rows: polygons
given by their corners beside a rectangle (with friction), a shelf cut by leaning faces and
bonded across them (bonds breaking: the bonds' table; and again with added mass, its bonds'
forces in sub-steps of the drift), rectangles bonded into a shelf (on
their own, and in waves: both tables side by side), polygons in waves (the waves' grid
and the wave step's phase), and a row whose contacts crush (the overlap they keep). Each scene is run three ways:
straight to ``T2``; to ``T1`` (off the snapshot and diagnostic grids) and then extended to
``T2`` with :func:`melange_ti.extend`; and stopped by Ctrl-C on the way to ``T2``, then
resumed. Both continued files must equal the straight one in every dataset, bit for bit.
Before the checkpoints kept the outlines, a resumed polygon was rebuilt as the rectangle of
its extents, and these tests failed on the polygon scenes (its energies, state and capsized
fraction differed after the first checkpoint).
"""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest

from melange_ti import api, scene
from melange_ti.errors import Interrupted, RunError
from melange_ti.io.checkpoint import checkpoint_path
from melange_ti.simulation import Simulation

from .test_extend import datasets

T1, T2 = 1.27, 3.0  # T1 on neither output grid (0.5, 0.1)
STOP_STEP = 230  # the Ctrl-C, between two checkpoints (every 0.7)
COMMON = (
    "[time]\ndt = 0.01\nduration = 3.0\nseed = 4\n"
    "[output]\nsnapshot_interval = 0.5\ndiagnostic_interval = 0.1\ncheckpoint_interval = 0.7\n"
)
PENTAGON = [[0.0, 0.0], [1.2, 0.1], [1.1, 0.9], [0.4, 1.4], [-0.2, 0.5]]
TRIANGLE = [[0.0, 0.0], [1.0, 0.0], [0.5, 0.8]]

SCENES = {
    # polygons (given by their corners) and a rectangle driven together, with friction
    "polygons_friction": (
        '[scene]\nname = "polygons"\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "friction"]\n'
        "[physics]\nfriction = 0.3\n" + COMMON + f"[[iceberg]]\nx = 1.0\nz = -0.3\ntheta = 0.3\nvx = 0.6\nvertices = {PENTAGON}\n"
        f"[[iceberg]]\nx = 2.6\nz = -0.2\ntheta = -0.2\nvertices = {TRIANGLE}\n"
        "[[iceberg]]\nx = 4.0\nz = -0.55\ntheta = 0.1\nvx = -0.5\nwidth = 1.0\nthickness = 1.4\n"
    ),
    # a shelf cut by leaning faces, bonded across them; the free leaning front breaks bonds
    "cut_shelf_bonds": (
        '[scene]\nname = "cut_shelf"\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]\n'
        "[physics]\ntensile_strength = 0.15\nshear_strength = 0.15\nstrength_modulus = 5.0\n" + COMMON + "[shelf]\n"
        "count = 12\nbonded = true\nbonded_wall = true\nfront = 3\ntilt = 0.2\ngap = 0.3\ncut_tilt = 0.25\ncut_tilt_std = 0.05\n"
    ),
    # a row of rectangles bonded to each other, struck by a free one: its bonds break at the blow
    "bonded_row": (
        '[scene]\nname = "bonded_row"\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]\n'
        "[physics]\ntensile_strength = 0.08\nshear_strength = 0.08\n"
        + COMMON
        + "".join(f"[[iceberg]]\nx = {x}\nz = -0.55\nwidth = 1.0\nthickness = 1.4\n" for x in (1.0, 2.0, 3.0, 4.0))
        + "[[iceberg]]\nx = 5.8\nz = -0.55\ntheta = 0.2\nvx = -1.0\nwidth = 1.0\nthickness = 1.4\n"
        + "".join(f"[[bond]]\na = {a}\nb = {a + 1}\n" for a in range(3))
    ),
    # a free row struck into the wall, its contacts crushing (the overlap they keep goes on
    # across the checkpoint), with friction
    "crushing_friction": (
        '[scene]\nname = "crushing"\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "friction", "crushing"]\n'
        "[physics]\nfriction = 0.3\n"
        + COMMON
        + "".join(f"[[iceberg]]\nx = {x}\nz = -0.55\nwidth = 1.0\nthickness = 1.4\n" for x in (1.0, 2.05, 3.1))
        + "[[iceberg]]\nx = 4.9\nz = -0.55\ntheta = 0.2\nvx = -1.0\nwidth = 1.0\nthickness = 1.4\n"
    ),
    # the bonded row struck apart in waves: two owners' tables side by side (the grid's rows,
    # then the bonds')
    "bonded_row_waves": None,  # below: the bonded row with the waves' keys
    # polygons in waves: the grid's surface and potential, and the wave step's phase
    "polygons_waves": (
        '[scene]\nname = "waves"\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "waves"]\n'
        "[physics]\nwater_depth = 4.0\nwave_dx = 0.25\nwave_end = 30.0\nwave_sponge = 8.0\n"
        + COMMON
        + f"[[iceberg]]\nx = 2.0\nz = -0.3\ntheta = 0.5\nvertices = {PENTAGON}\n"
        "[[iceberg]]\nx = 4.0\nz = -0.55\ntheta = 0.3\nwidth = 1.0\nthickness = 1.4\n"
    ),
}
# the cut shelf with added mass, its bonds' forces in 3 sub-steps of the drift (the sub-steps
# keep no state across a step: the checkpoint holds the step's own)
SCENES["cut_shelf_bonds_substeps"] = (
    SCENES["cut_shelf_bonds"]
    .replace('"bonds"]', '"added_mass", "bonds"]')
    .replace("strength_modulus = 5.0\n", "strength_modulus = 5.0\nbond_substeps = 3\n")
)
SCENES["bonded_row_waves"] = (
    SCENES["bonded_row"]
    .replace('"bonds"]', '"bonds", "waves"]')
    .replace("[physics]\n", "[physics]\nwater_depth = 4.0\nwave_dx = 0.25\nwave_end = 30.0\nwave_sponge = 8.0\n")
)


def differing(path, ref: dict) -> list[str]:
    got = datasets(path)
    keys = sorted(set(got) | set(ref))
    return [k for k in keys if k not in got or k not in ref or np.asarray(got[k]).tobytes() != np.asarray(ref[k]).tobytes()]


def load(text: str, duration: float):
    return scene.loads(text, [("time.duration", duration)])


@pytest.fixture(scope="module", params=sorted(SCENES))
def straight(request, tmp_path_factory):
    """The scene run straight to T2, once per scene."""
    name = request.param
    d = tmp_path_factory.mktemp(name)
    api.run(load(SCENES[name], T2), d / "straight.h5")
    return name, d, datasets(d / "straight.h5")


def test_the_scenes_hold_what_they_are_meant_to(straight):
    """Each scene exercises what it stands for: outlines in the file, bonds broken before T1
    and after it (the table changes on both sides of the checkpoint), waves raised."""
    name, _, ref = straight
    if "polygons" in name or "cut" in name:
        assert "icebergs/corners" in ref and ref["icebergs/corners"].max() >= 4
    if "polygons" in name:  # not all the rectangle of their extents
        assert sorted(set(ref["icebergs/corners"].tolist())) != [4]
    if "bond" in name:  # broken before T1: a broken bond must stay broken when the run goes on
        breaks = ref["bonds/break_time"]
        assert np.nanmin(breaks) < T1, breaks
        if "cut" in name:  # and breaking after it, from the loads the checkpoint carried
            assert np.nanmax(breaks) > T1, breaks
    if "waves" in name:
        assert np.abs(ref["snapshots/eta"][-1]).max() > 1e-4
    if "friction" in name:
        assert ref["diagnostics/friction_dissipated"][-1] > 0
    if "crushing" in name:  # contacts that crush pass an impulse step after step
        assert ref["diagnostics/contacts"].sum() > 200, ref["diagnostics/contacts"].sum()


def test_extended_is_the_run_that_never_stopped(straight):
    name, d, ref = straight
    path = d / "extended.h5"
    api.run(load(SCENES[name], T1), path)
    api.extend(path, T2)
    assert differing(path, ref) == [], f"{name}: extended from t = {T1} differs from one run to t = {T2}"


def test_resumed_after_ctrl_c_is_the_run_that_never_stopped(straight):
    name, d, ref = straight
    path = d / "resumed.h5"
    sent = []

    def ctrl_c(step: int) -> None:
        if step >= STOP_STEP and not sent:
            sent.append(step)
            os.kill(os.getpid(), signal.SIGINT)

    sc = load(SCENES[name], T2)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(Interrupted):
            Simulation(sc, path, progress=False, on_event=ctrl_c, interface="api").run()
    finally:
        signal.signal(signal.SIGINT, previous)
    assert sent and sent[0] < round(T2 / 0.01)
    api.run(sc, path, resume=True)
    assert differing(path, ref) == [], f"{name}: resumed from step {sent[0]} differs from one run to t = {T2}"


@pytest.mark.parametrize("name", [k for k in sorted(SCENES) if "polygons" in k])
def test_a_checkpoint_that_kept_no_outlines_is_refused_for_polygons(name, tmp_path):
    """A checkpoint of the format before the outlines (7) would continue a run of rectangles
    as before, but a run with polygons is refused in one line rather than rebuilt as rectangles."""
    path = tmp_path / "old.h5"
    api.run(load(SCENES[name], T1), path)
    ck = checkpoint_path(path)
    with np.load(ck) as z:
        old = {k: z[k] for k in z.files if k not in ("outline", "corners", "format_version")}
    np.savez(open(ck, "wb"), format_version=7, **old)
    before = path.read_bytes()
    with pytest.raises(RunError, match="kept no outlines"):
        api.extend(path, T2)
    assert path.read_bytes() == before
