"""Every scene key: default, units, meaning and the check its value must pass.

The scene reference in ``docs/scenes.md`` is generated from these tables (and the effects'
own keys, :mod:`melange_ti.physics.effects`), so the docs cannot drift from the code; a test
fails when a key has no description. Units are non-dimensional: lengths in iceberg widths
``w``, time in ``sqrt(w/g)``, densities in ``rho_w``.
"""

from __future__ import annotations

import math

from ..physics.effects import REGISTRY, Key

# rho_ice / rho_water = 917 / 1025 rounded as the paper and SPEC give it (the default; the
# regression hashes are pinned to this value)
DENSITY_RATIO = 0.8946
# The largest time step accepted, as a fraction of the linear stability limit 2 / omega of the
# icebergs' stiffest hydrostatic oscillation (docs/model.md, Time stepping): real runs go
# unstable from 0.37 of it (a lone undamped capsize), the paper scene from 0.62.
DT_SAFETY = 0.3
ORDERS = ("auto", "sequential", "coloured")  # contacts.order

SCENE = (
    Key("name", "scene", "", "a name for the run; it starts the default output file's name (docs/scenes.md, Output name)"),
    Key(
        "effects",
        ["gravity", "buoyancy", "drag", "collisions", "wall"],
        "",
        "the physical terms simulated (see the effects table); an effect not named costs nothing. In TOML "
        '`effects = ["gravity", "buoyancy", "drag"]`; on the command line `--set scene.effects=gravity,buoyancy,drag` '
        "replaces the list, `--set scene.effects+=waves` adds to it and `--set scene.effects-=drag` removes from it "
        '(in Python `overrides={"scene.effects+": "waves"}`). A list without gravity or buoyancy (icebergs that '
        "do not float) runs with a warning line, and so does an empty list written as `[]`; `--set scene.effects=` "
        "with nothing after it, or a `-=` that removes every effect, is refused",
        None,
        f"must be a list of: {', '.join(e.name for e in REGISTRY)}",
    ),
    Key("precision", "f64", "", "floating point of the state and the kernels", None, 'must be "f64" or "f32"'),
    Key(
        "width_m",
        70.0,
        "m",
        "the iceberg width w in metres: sets the physical axes of figures and movies (time unit "
        "sqrt(w/g), energy unit rho_w g w^3 per metre) and converts a stress given in Pa (a [physics] key "
        "in rho_w g w written NAME_pa); the model itself stays non-dimensional",
        lambda v: v > 0.0,
        "must be > 0",
    ),
)

BASE_PHYSICS = (
    Key("density_ratio", DENSITY_RATIO, "1", "rho_ice / rho_water (917 / 1025)", lambda v: 0.0 < v < 1.0, "must be in (0, 1)"),
    Key(
        "restitution",
        0.5,
        "1",
        "Newton coefficient of restitution on the normal relative velocity, iceberg and wall contacts (the paper's 0.5)",
        lambda v: 0.0 <= v <= 1.0,
        "must be in [0, 1]",
    ),
    Key("water_level", 0.0, "w", "height z of the flat sea surface"),
)
PHYSICS = (*BASE_PHYSICS, *(k for e in REGISTRY for k in e.keys))

CONTACTS = (
    Key(
        "discs",
        28,
        "1",
        "collision discs per iceberg, spread evenly over its four faces (the paper used 12, 28, 60)",
        lambda v: v >= 8 and v % 4 == 0,
        "must be a multiple of 4 and at least 8",
    ),
    Key("contact_passes", 1, "1", "Gauss-Seidel repetitions of the impulse pass per step", lambda v: v >= 1, "must be >= 1"),
    Key(
        "order",
        "auto",
        "",
        "the order of the impulse pass and the overlap correction: `sequential` (body by body, in index order) or "
        "`coloured` (the contacts coloured so that no two of a colour share an iceberg, a colour's contacts side by "
        "side, the colours in turn: every thread of a device or of many cores at work in a jammed melange); `auto`: "
        "sequential on the CPU, coloured on a device. The two orders are different Gauss-Seidel sweeps of the same "
        "contact law: their runs part ways as any two roundings do, with the same statistics (docs/performance.md, "
        "Coloured passes); the run file's attribute `contact_order` says which ran",
        lambda v: v in ORDERS,
        'must be "auto", "sequential" or "coloured"',
    ),
    Key(
        "max_partners",
        32,
        "1",
        "contact slots per iceberg; a run that needs more stops with a message instead of dropping contacts",
        lambda v: 1 <= v <= 1024,
        "must be in [1, 1024]",
    ),
    Key(
        "disc_spacing",
        2.0,
        "disc radii",
        "centre spacing of the discs on the longest face (2: just touching, the paper's rule; less: smoother faces)",
        lambda v: 0.0 < v <= 2.0,
        "must be in (0, 2] (above 2 the discs leave holes)",
    ),
)

TIME = (
    Key(
        "dt",
        0.01,
        "sqrt(w/g)",
        f"time step (the paper's 0.01); one above {DT_SAFETY:g} of the icebergs' stability limit 2 / omega is refused "
        f"({DT_SAFETY * 2.0 * math.sqrt(DENSITY_RATIO):.3f} for the paper's icebergs; docs/model.md, Time stepping)",
        lambda v: v > 0.0,
        "must be > 0",
    ),
    Key(
        "duration",
        8000.0,
        "sqrt(w/g)",
        "simulated time; the run takes round(duration / dt) steps (a rounded value is reported)",
        lambda v: v > 0.0,
        "must be > 0",
    ),
    Key("seed", 1, "1", "seed of the random initial tilts", lambda v: 0 <= v < 2**63, "must be in [0, 2**63)"),
    Key(
        "allow_unstable",
        False,
        "",
        "run a time step above the icebergs' stability limit, which is refused otherwise (docs/model.md, Time "
        "stepping): for tests of the numerical guard and benchmarks that look for the limit",
        None,
        "must be true or false",
    ),
)

OUTPUT = (
    Key(
        "snapshot_interval",
        10.0,
        "sqrt(w/g)",
        "time between snapshots of every iceberg's state (rounded to whole steps)",
        lambda v: v > 0.0,
        "must be > 0",
    ),
    Key(
        "diagnostic_interval",
        1.0,
        "sqrt(w/g)",
        "time between rows of the scalar diagnostics (rounded to whole steps)",
        lambda v: v > 0.0,
        "must be > 0",
    ),
    Key(
        "checkpoint_interval",
        500.0,
        "sqrt(w/g)",
        "time between restart checkpoints (RUN.h5.ckpt; rounded to whole steps)",
        lambda v: v > 0.0,
        "must be > 0",
    ),
)


def _cells(v) -> bool:
    return (
        isinstance(v, list) and len(v) == 2 and all(isinstance(q, int) and not isinstance(q, bool) and 1 <= q <= 1000 for q in v)
    )


def cells_key(where: str) -> Key:
    """``cells = [nx, nz]``: the iceberg (``where``) partitioned into cells joined across their faces."""
    return Key(
        "cells",
        [1, 1],
        "1",
        f"{where} as nx x nz cells, nx across the width and nz through the thickness (a quadrilateral outline: "
        "along its sides), each a body, joined across every shared face by an effect that joins them (docs/bonds.md, "
        "Cells); mass, inertia and buoyancy add up to the whole's; [1, 1]: one body",
        _cells,
        "must be [nx, nz], two integers in [1, 1000]",
    )


SHELF = (
    Key("count", 400, "1", "icebergs in the row", lambda v: 1 <= v <= 10_000_000, "must be in [1, 10000000]"),
    Key("width", 1.0, "w", "width of every iceberg (the mean width with `width_std`)", lambda v: v > 0.0, "must be > 0"),
    Key("thickness", 1.4, "w", "mean thickness (the paper's aspect ratio 1.4)", lambda v: v > 0.0, "must be > 0"),
    Key.nonnegative("gap", 0.1, "w", "gap between neighbours, and from the wall to the first iceberg"),
    Key(
        "tilt",
        0.01,
        "rad",
        "amplitude of the uniform random initial tilt",
        lambda v: 0.0 <= v <= math.pi,
        "must be in [0, pi]",
    ),
    Key.nonnegative("thickness_std", 0.0, "w", "standard deviation of a normal spread of thicknesses (0: all equal)"),
    Key.nonnegative(
        "width_std",
        0.0,
        "w",
        "standard deviation of a normal spread of widths (0: all equal), drawn after the tilts and thicknesses (it "
        "changes neither); neighbours keep `gap` (none inside a bonded shelf)",
    ),
    Key(
        "cut_tilt",
        0.0,
        "rad",
        "mean tilt of the cut faces from the vertical (positive: a cut's top leans seaward, +x); every cut leans "
        "alike, so equal icebergs are parallelograms; neighbours share each cut, `gap` apart horizontally, the "
        "shelf's two ends stay vertical (docs/model.md, Outlines)",
        lambda v: abs(v) <= 0.5,
        "must be in [-0.5, 0.5]",
    ),
    Key.nonnegative(
        "cut_tilt_std",
        0.0,
        "rad",
        "standard deviation of a normal spread of the cut faces' tilts about `cut_tilt` (0 with `cut_tilt = 0`: "
        "vertical cuts, rectangles), drawn after the widths; neighbours share each cut, `gap` apart horizontally, "
        "the shelf's two ends "
        "stay vertical: each iceberg a quadrilateral (docs/model.md, Outlines)",
    ),
    Key(
        "bonded",
        False,
        "",
        "an intact shelf: the row starts with no gaps, upright, every neighbour bonded (with the bonds effect; "
        "docs/bonds.md); the seaward `front` icebergs are free, with `gap` and `tilt`",
        None,
        "must be true or false",
    ),
    Key(
        "bonded_wall",
        False,
        "",
        "with bonded: the landward iceberg starts at the wall and is bonded to it (the grounding line)",
        None,
        "must be true or false",
    ),
    Key(
        "front",
        1,
        "1",
        "with bonded: icebergs at the seaward end that start free (pre-cut, the first calved), tilted by `tilt`",
        lambda v: v >= 0,
        "must be >= 0",
    ),
    Key(
        "crevasse_depth",
        0.0,
        "1",
        "with bonded: the fraction of the thickness open from the surface at every joint between two bonded pieces "
        "at t = 0 (a surface crevasse; the joint's bonds hold the intact ligament below it); 1, a crevasse through "
        "the whole thickness, is the paper's pre-cut shelf: free pieces with `gap` and `tilt` (docs/bonds.md, Crevasses)",
        lambda v: 0.0 <= v <= 1.0,
        "must be in [0, 1]",
    ),
    Key(
        "basal_crevasse_depth",
        0.0,
        "1",
        "with bonded: the fraction of the thickness open from the base at every joint (a basal crevasse), with "
        "`crevasse_depth` at most 1 in all (1: cut through, the pre-cut shelf)",
        lambda v: 0.0 <= v <= 1.0,
        "must be in [0, 1]",
    ),
    Key(
        "joint_strength",
        1.0,
        "1",
        "with bonded: the strength of the ice across a joint between pieces as a fraction of the ice's "
        "(`tensile_strength`, `shear_strength`; 1: as strong; with `cells`, the bonds inside a piece keep the ice's)",
        lambda v: v > 0.0,
        "must be > 0",
    ),
    cells_key("each piece of the shelf"),
)


def shelf_intact(shelf) -> bool:
    """An intact shelf: bonded, its joints not cut through by crevasses."""
    return bool(shelf.bonded and shelf.crevasse_depth + shelf.basal_crevasse_depth < 1.0)


def shelf_problem(shelf) -> tuple[str, object, str] | None:
    """What the shelf's keys get wrong together, as ``(key, value, accepts)``: crevasses on a
    shelf that is not bonded, or crevasses that overlap."""
    given = [
        (f"shelf.{k}", getattr(shelf, k), d)
        for k, d in (("crevasse_depth", 0.0), ("basal_crevasse_depth", 0.0), ("joint_strength", 1.0))
    ]
    given = [(k, v) for k, v, d in given if v != d]
    if given and not shelf.bonded:
        return (*given[0], "shapes the joints of a bonded shelf: set shelf.bonded = true too")
    if shelf.crevasse_depth + shelf.basal_crevasse_depth > 1.0:
        return (
            "shelf.basal_crevasse_depth",
            shelf.basal_crevasse_depth,
            f"with shelf.crevasse_depth = {shelf.crevasse_depth:g} the crevasses overlap; the two must add up to at most 1",
        )
    return None


START = (
    Key("file", "", "", "a run file (relative to the scene file) whose snapshot is the initial state"),
    Key.nonnegative("time", 0.0, "sqrt(w/g)", "the last snapshot at or before this time is used"),
)

ICEBERG = (
    Key("x", 0.0, "w", "centre of mass, horizontal (seaward +)"),
    Key(
        "z",
        "float",
        "w",
        'centre of mass, vertical (up +; the sea surface at water_level); "float", or left out: the height at which the '
        "outline, tilted by theta, floats in still water (it displaces density_ratio of its area: docs/model.md, Outlines)",
    ),
    Key("theta", 0.0, "rad", "tilt, counter-clockwise, 0 upright (thickness vertical)"),
    Key("vx", 0.0, "w / sqrt(w/g)", "velocity, horizontal"),
    Key("vz", 0.0, "w / sqrt(w/g)", "velocity, vertical"),
    Key("omega", 0.0, "rad / sqrt(w/g)", "angular velocity, counter-clockwise"),
    Key("width", 1.0, "w", "width (along the body u axis)", lambda v: v > 0.0, "must be > 0"),
    Key("thickness", 1.4, "w", "thickness (along the body v axis)", lambda v: v > 0.0, "must be > 0"),
    Key(
        "vertices",
        [],
        "w",
        "instead of width and thickness, any convex outline: its corners [[x, z], ...] in the body frame at theta = 0, "
        "counter-clockwise, 3 to 8; the outline is moved so that its centroid (the centre of mass) sits at x, z "
        "(docs/model.md, Outlines)",
    ),
    cells_key("the iceberg (a rectangle, or an outline of 4 corners)"),
)

# The tables of a scene file and their keys; [[iceberg]] is an array of tables.
SECTIONS: dict[str, tuple[Key, ...]] = {
    "scene": SCENE,
    "physics": PHYSICS,
    "contacts": CONTACTS,
    "time": TIME,
    "output": OUTPUT,
    "shelf": SHELF,
    "start": START,
    "iceberg": ICEBERG,
}
