"""Bonds that break (beyond the paper): icebergs glued into a shelf by elastic beams.

Two icebergs that share a face at t = 0 (a bonded ``[shelf]``, or a ``[[bond]]`` table) are
joined there by a **parallel bond** (Potyondy & Cundall 2004, in 2-D): a beam of the face's
length ``t`` and unit depth, between the two centres, with normal, shear and bending
stiffness from the Young's modulus ``E`` (``physics.bond_modulus``) and Poisson's ratio ``nu``
(``physics.poisson_ratio``) in plane strain (the shelf is long across the section)::

    k_n = E' t / L     k_s = G t / L     k_b = E' t^3 / (12 L)
    E' = E / (1 - nu^2)     G = E / (2 (1 + nu))

``L`` the distance between the centres along the bond's normal (for a bond to the wall, the
centre's distance from the face: a clamped end). A chain of blocks of length ``L`` so bonded
bends as an Euler-Bernoulli beam (a plate in plane strain) of stiffness
``D = E' I = E t^3 / (12 (1 - nu^2))``.

**Kinematics.** The bond keeps, from t = 0, its point in each body's frame (``UA, VA``,
``UB, VB``), its normal in A's frame and the bodies' relative tilt. At any later time
``d = p_B - p_A`` (the two material points that coincided) and ``dth = th_B - th_A - dth_0``
give the elastic energy ::

    U = k_n d_n^2 / 2 + k_s d_s^2 / 2 + k_b dth^2 / 2,   d_n = d . n,  d_s = d . s

with ``n`` the normal carried by A and ``s`` its left perpendicular. The forces and torques
are ``-grad U`` exactly (A: ``+G`` at ``p_A``, B: ``-G`` at ``p_B``, ``G = k_n d_n n + k_s d_s s``;
torques ``r_A x G - (k_n - k_s) d_n d_s + k_b dth`` on A and ``-r_B x G - k_b dth`` on B), so
a bond conserves momentum and angular momentum exactly and its energy is a potential of
the state: a rigid motion of the pair stores nothing.

**Dashpot.** ``c = 2 zeta sqrt(k m)`` on each of the three (``zeta = physics.bond_damping``;
``m`` the pair's reduced mass, or moment of inertia for bending) against the relative
velocity at the bond, applied after the forces at the midpoint of the two points (so it
too keeps angular momentum); the kinetic energy it removes from each
iceberg is booked exactly in that iceberg's ledger (``bond_damping_dissipated``).

**Breaking.** At the start of each step a bond breaks when its tensile stress
``F_n / t + 6 |M| / t^2`` (``F_n = k_n d_n``, tension +; ``M = k_b dth``) exceeds its tensile
strength, or its shear stress ``|k_s d_s| / t`` its shear strength. The energy it held goes
to ``fracture_released`` (half to each iceberg's ledger; the whole to a wall-bonded one's);
from then on the pair meets through the ordinary contacts. While it holds, the pair has no
contact (its contact is the bond's): the narrow phase skips it.

**Energy.** ``E`` holds the intact bonds' ``U - dt/2 dU/dt`` (the energy the kick-drift step
conserves for a linear spring); ``fracture_released``, ``bond_damping_dissipated``,
``bond_offset_work`` (that energy's move with every other velocity change) and
``bond_correction_work`` (what the overlap correction's pushes put into bonds) close the
budget (docs/bonds.md).

**Time step.** The bonds' stiffest mode bounds the step: Gershgorin's bounds on the bond
network's mass-weighted stiffness (``omega_max^2``) and dashpots (``gamma``) at t = 0, and the
kick-drift step with the dashpot is stable for ``h <= (sqrt(gamma^2 + 4 omega_max^2) -
gamma) / omega_max^2``; a larger ``time.dt / physics.bond_substeps`` is refused.

**Sub-steps** (``physics.bond_substeps = n``, multiple time stepping as in r-RESPA, Tuckerman
et al. 1992): the bonds' forces and dashpots kick with ``h = dt / n`` at the step's start, and
the drift is ``n`` sub-steps of ``h``, the bonds' forces and dashpots again at each (no
break check there: a bond breaks at a step's start); every other force, the contacts and the
correction act once a step. Every ``dt`` above that the bonds' energy and books use is then
``h`` (the bond's energy as the sub-step keeps it, ``U - h/2 dU/dt``). ``n = 1``: the step
above, to the bit.

Units: stresses and the modulus in the model's stress unit ``rho_w g w`` (703,868 Pa for
``w = 70 m``: :func:`pascals`).
"""

from __future__ import annotations

import math

from ...data.columns import Column, E, Table
from ..base import ENERGY_PER_AREA, G_SI, RHO_W_SI, STRESS, Dataset, Effect, Key, Quantity, pascals  # noqa: F401  (G_SI, RHO_W_SI: this module's names)

MAX_BONDS = 4  # bonds per iceberg (body columns BOND_1 ...): one per face of a rectangle
POISSON = 0.3  # Poisson's ratio of ice: the default of physics.poisson_ratio
MIN_OVERLAP = 1e-6  # w: two faces sharing less than this do not bond
TOUCH = 1e-2  # w: faces farther apart than this at t = 0 do not touch


def model_stress(pa: float, width_m: float = 70.0) -> float:
    """``pa`` pascals in the model's stress unit."""
    return pa / pascals(width_m)


class Bond:
    """Columns of the bond table (its rows of ``a.own`` with the bonds effect, from
    ``Config.BONDS_ROW0``): one row per bond."""


TABLE = Table(
    "bonds",
    "own",
    "real",
    "(bonds, Bond.SIZE)",
    "one row per bond: the pair, its rest geometry and stiffness, its state, and what the step computed",
    (
        Column("A", "constant", "1", "iceberg A (the lower index)"),
        Column("B", "constant", "1", "iceberg B, or -1: the wall"),
        Column("UA", "constant", "w", "the bond's point in A's body frame, u"),
        Column("VA", "constant", "w", "the bond's point in A's body frame, v"),
        Column("UB", "constant", "w", "the bond's point in B's body frame, u (the wall: world x)"),
        Column("VB", "constant", "w", "the bond's point in B's body frame, v (the wall: world z)"),
        Column("NU", "constant", "1", "the bond's normal (from A to B) in A's body frame, u"),
        Column("NV", "constant", "1", "the bond's normal in A's body frame, v"),
        Column("DTH", "constant", "rad", "tilt of B minus tilt of A at rest (the wall: minus A's tilt)"),
        Column("LEN", "constant", "w", "t, length of the shared face"),
        Column("SPAN", "constant", "w", "L, distance between the centres along the normal (the wall: centre to face)"),
        Column("KN", "constant", "rho_w g w", "normal stiffness E' t / L, E' = E / (1 - nu^2)"),
        Column("KS", "constant", "rho_w g w", "shear stiffness G t / L"),
        Column("KB", "constant", "rho_w g w^3", "bending stiffness E' t^3 / (12 L)"),
        Column("CN", "constant", "rho_w w sqrt(g w)", "normal dashpot 2 zeta sqrt(k_n m)"),
        Column("CS", "constant", "rho_w w sqrt(g w)", "shear dashpot 2 zeta sqrt(k_s m)"),
        Column("CB", "constant", "rho_w w^3 sqrt(g w)", "bending dashpot 2 zeta sqrt(k_b I)"),
        Column("ST", "constant", "rho_w g w", "tensile strength of this bond"),
        Column("SS", "constant", "rho_w g w", "shear strength of this bond"),
        Column(
            "TOUCHING",
            "constant",
            "1",
            "1: the pair's faces beside the bond touch through contacts while it holds (a crevassed joint's walls)",
        ),
        Column(
            "TIP0",
            "constant",
            "1",
            "1: at t = 0 its face ends at a crevasse's edge inside its joint (it is a crack's tip from the start)",
        ),
        Column("NB1", "constant", "1", "the bond next to it along its face's line, one way (row in the bond table; -1: none)"),
        Column("NB2", "constant", "1", "the bond next to it along its face's line, the other way (-1: none)"),
        Column("BR1", "constant", "1", "the bond that joins its ice to NB1's where their faces meet (-1: none)"),
        Column("BR2", "constant", "1", "the bond that joins its ice to NB2's where their faces meet (-1: none)"),
        Column("GCL", "constant", "rho_w g w^2", "G_c times its face length: the energy that breaks it at a tip (0: off)"),
        Column("INTACT", "state", "1", "1 while the bond holds, 0 once broken"),
        Column("TIP", "state", "1", "1 while it is a crack's tip: TIP0, or a bond next to it has broken (a step before)"),
        Column("AGE", "state", "1", "steps taken while intact (at a break: the step it broke at)"),
        Column("BREAK_SIG", "state", "rho_w g w", "tensile stress when it broke (0: intact)"),
        Column("BREAK_TAU", "state", "rho_w g w", "shear stress when it broke (0: intact)"),
        Column(
            "PEAK_SIG",
            "state",
            "rho_w g w",
            "the largest tensile stress the break check has seen (each step's start while intact, the breaking "
            "one's too; 0 at t = 0)",
        ),
        Column("PEAK_TAU", "state", "rho_w g w", "the largest shear stress the break check has seen (0 at t = 0)"),
        Column("GX", "scratch", "rho_w g w^2", "elastic force on A this step, x (on B: minus it)"),
        Column("GZ", "scratch", "rho_w g w^2", "elastic force on A this step, z"),
        Column("TA", "scratch", "rho_w g w^3", "elastic torque on A this step"),
        Column("TB", "scratch", "rho_w g w^3", "elastic torque on B this step"),
        Column("DX", "scratch", "rho_w g w^2", "dashpot force on A this step, x (on B: minus it)"),
        Column("DZ", "scratch", "rho_w g w^2", "dashpot force on A this step, z"),
        Column("DA", "scratch", "rho_w g w^3", "dashpot torque on A this step"),
        Column("DB", "scratch", "rho_w g w^3", "dashpot torque on B this step"),
        Column("REL", "scratch", E, "elastic energy it held when it broke, this step (0 otherwise)"),
        Column("CORR", "scratch", E, "with contacts: its energy before the overlap correction, then what the correction put in"),
    ),
    Bond,
)
# the columns fixed at t = 0, in the file's bonds/rest; a [start] from a bonded run takes the
# geometry back (a bond stays at rest in the state it formed in) and the material from its own keys
REST = tuple(c.name for c in TABLE.columns if c.role == "constant")
GEOMETRY = REST[: REST.index("SPAN") + 1]

PHYSICAL = (
    "HiDEM's Young's modulus of ice 1 GPa (Astrom et al. 2013); tensile and shear strength 0.25 MPa "
    "(HiDEM's ~0.2 MPa at a strain of 1.8e-4; Subzero.jl's 0.25 MPa)"
)


BOND_KEYS = (
    Key("a", -1, "1", "0-based index of an [[iceberg]] table", lambda v: v >= 0, "must be >= 0", required=True),
    Key(
        "b",
        -1,
        "1",
        "0-based index of another [[iceberg]] table that touches it at t = 0",
        lambda v: v >= 0,
        "must be >= 0",
        required=True,
    ),
    Key(
        "crevasse_depth",
        0.0,
        "1",
        "the fraction of the shared face's height open from its top at t = 0 (a surface crevasse at this joint; "
        "the bond holds the ligament below it), with basal_crevasse_depth less than 1 in all",
        lambda v: 0.0 <= v < 1.0,
        "must be in [0, 1) (a joint cut through is no bond: leave the [[bond]] out)",
    ),
    Key(
        "basal_crevasse_depth",
        0.0,
        "1",
        "the fraction of the shared face's height open from its base at t = 0 (a basal crevasse at this joint)",
        lambda v: 0.0 <= v < 1.0,
        "must be in [0, 1) (a joint cut through is no bond: leave the [[bond]] out)",
    ),
)

EFFECT = Effect(
    name="bonds",
    joins=True,
    doc="beyond the paper: elastic beam bonds (normal, shear, bending) glue icebergs that touch at t = 0 "
    "([shelf] bonded = true, or [[bond]] tables); a bond breaks when F_n / t + 6 |M| / t^2 > tensile_strength "
    "or its shear stress exceeds shear_strength; bond_energy part of E, fracture_released and "
    "bond_damping_dissipated in the budget; a bonded pair's contact is the bond's while it holds",
    keys=(
        Key.positive(
            "bond_modulus",
            round(model_stress(1e9), 4),
            STRESS,
            "Young's modulus E of the bonds (1 GPa at w = 70 m; Pa = value * 1025 * 9.81 * width_m, or give "
            "bond_modulus_pa in Pa; used with the bonds effect)",
        ),
        Key(
            "poisson_ratio",
            POISSON,
            "1",
            "Poisson's ratio nu of the bonds' ice: plane strain, E' = E / (1 - nu^2) in the normal and bending "
            "stiffness, G = E / (2 (1 + nu)) in the shear (ice 0.29-0.33; used with the bonds effect)",
            lambda v: 0.0 <= v < 0.5,
            "must be in [0, 0.5)",
        ),
        Key(
            "bond_substeps",
            1,
            "1",
            "n: the step's drift in n sub-steps of dt / n, the bonds' forces and dashpots again at each (every other "
            "force, the contacts and the break check once a step), so the bonds' stable limit bounds dt / n, not dt "
            "(docs/bonds.md, The time step; used with the bonds effect)",
            lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 1,
            "must be an integer >= 1",
        ),
        Key.nonnegative(
            "bond_damping",
            0.05,
            "1",
            "zeta: each bond's dashpot as a fraction of its critical damping (used with the bonds effect)",
        ),
        Key.positive(
            "tensile_strength",
            round(model_stress(2.5e5), 4),
            STRESS,
            "a bond breaks when F_n / t + 6 |M| / t^2 exceeds it (0.25 MPa at w = 70 m, or give tensile_strength_pa "
            "in Pa; used with the bonds effect)",
        ),
        Key.positive(
            "shear_strength",
            round(model_stress(2.5e5), 4),
            STRESS,
            "a bond breaks when its shear force over t exceeds it (0.25 MPa at w = 70 m, or give shear_strength_pa "
            "in Pa; used with the bonds effect)",
        ),
        Key.nonnegative(
            "fracture_energy",
            0.0,
            ENERGY_PER_AREA,
            "G_c: a bond at a crack's tip (a crevasse's, or a broken neighbour's along its line) breaks in tension "
            "when the energy it holds reaches G_c times its face length, not by tensile_strength (0: off, every bond "
            "by its strength; J/m^2 = value * 1025 * 9.81 * width_m^2, or give fracture_energy_jm2 in J/m^2; used with "
            "the bonds effect)",
        ),
        Key.nonnegative(
            "strength_size",
            0.0,
            "w",
            "l_ref of a weakest-link size effect: each bond's strengths times (l / l_ref)^(-1/m), l its face length "
            "(the crack it would open), m = strength_modulus (0: off, every bond as strong whatever its size; used "
            "with the bonds effect and a strength_modulus)",
        ),
        Key.nonnegative(
            "strength_modulus",
            0.0,
            "1",
            "Weibull modulus m of a seeded spread of the bonds' strengths about their mean (0: every bond as strong; "
            "ice ~5; used with the bonds effect)",
        ),
    ),
    body_columns=(
        *(
            Column(
                f"BOND_{k + 1}", "constant", "1", f"bonds: row of its bond {k + 1} in the owners' table a.own, plus 1 (0: none)"
            )
            for k in range(MAX_BONDS)
        ),
        Column(
            "BOND_DAMPED",
            "ledger",
            E,
            "kinetic energy the bonds' dashpots removed from the iceberg since t = 0 (0 without the bonds effect)",
            "bond_damping_dissipated",
            budget=True,
            since=6,
        ),
        Column(
            "BOND_RELEASED",
            "ledger",
            E,
            "elastic energy its broken bonds held when they broke (half of each; a wall bond's whole; 0 without "
            "the bonds effect)",
            "fracture_released",
            budget=True,
            since=6,
        ),
        Column(
            "BOND_OFFSET",
            "ledger",
            E,
            "dt/2 times its bonds' force times the velocity changes made after the forces' kick (damping, "
            "impulses): their energy with their half kick, U + dt/2 F . v, moves by that; -> 0 as dt -> 0 (0 "
            "without the bonds effect)",
            "bond_offset_work",
            budget=True,
            since=6,
        ),
        Column(
            "BOND_CORRECTION",
            "ledger",
            E,
            "minus the energy the overlap correction's pushes put into its bonds (half of each; 0 without the bonds effect)",
            "bond_correction_work",
            budget=True,
            since=6,
        ),
        Column("BOND_V0X", "scratch", "w / sqrt(w/g)", "bonds: vx right after the forces' kick"),
        Column("BOND_V0Z", "scratch", "w / sqrt(w/g)", "bonds: vz right after the forces' kick"),
        Column("BOND_V0W", "scratch", "rad / sqrt(w/g)", "bonds: omega right after the forces' kick"),
    ),
    terms=(
        "force",
        "after_kick",
        "damp",
        "pre_drift",
        "post_drift",
        "substep_update",
        "substep_damp",
        "joined",
        "joined_wall",
        "kept",
    ),
    substeps="physics.bond_substeps",
    torque=True,
    horizontal=True,
    own_offset=True,  # bond_offset_work: its share of every velocity change, impulses' too
    beyond_paper=True,
    table=TABLE,
    held=(
        Quantity(
            "bond_energy",
            E,
            "elastic energy of the intact bonds (stretch, shear and bending) at the positions (0 without the bonds effect)",
            since=6,
            at_step="bond_energy_at_step",
        ),
    ),
    reports=(
        Quantity("bonds_intact", "1", "bonds that hold (0 without the bonds effect)", since=6),
        Quantity(
            "fragments",
            "1",
            "pieces of ice: connected components of the icebergs over intact bonds (without the bonds effect: the icebergs)",
            since=6,
            without=lambda sample: len(sample["x"]),  # each iceberg its own piece
        ),
    ),
    dims=(("bond", "index of the bond"), ("bond_rest", "the bond table's columns fixed at t = 0, in order")),
    datasets=(
        Dataset("bonds/a", ("bond",), "1", "iceberg A of the bond", dtype="i8"),
        Dataset("bonds/b", ("bond",), "1", "iceberg B of the bond (-1: the wall)", dtype="i8"),
        Dataset(
            "bonds/rest",
            ("bond", "bond_rest"),
            "",
            "the bond's rest geometry, stiffness, dashpot and strength, columns " + ", ".join(REST) + " (the bond "
            "table's, docs/bonds.md)",
        ),
        Dataset(
            "bonds/break_time",
            ("bond",),
            "sqrt(w/g)",
            "time the bond broke (NaN: intact at the last snapshot)",
            updated=True,
            dtype="f8",
        ),
        Dataset(
            "bonds/break_stress",
            ("bond",),
            "rho_w g w",
            "tensile stress F_n / t + 6 |M| / t^2 when it broke (NaN: intact)",
            updated=True,
        ),
        Dataset(
            "bonds/break_shear",
            ("bond",),
            "rho_w g w",
            "shear stress when it broke (NaN: intact)",
            updated=True,
        ),
        Dataset(
            "bonds/peak_stress",
            ("bond",),
            "rho_w g w",
            "the largest tensile stress F_n / t + 6 |M| / t^2 its break check saw up to the last snapshot (at each step's "
            "start while intact, the breaking step's included; 0 if never in tension): with the strengths, where a weaker "
            'shelf would have broken first (docs/bonds.md, "Which bond breaks first")',
            updated=True,
        ),
        Dataset(
            "bonds/peak_shear",
            ("bond",),
            "rho_w g w",
            "the largest shear stress its break check saw up to the last snapshot",
            updated=True,
        ),
        Dataset(
            "snapshots/fragment",
            ("iceberg",),
            "1",
            "the piece of ice the iceberg belongs to: the lowest iceberg index of its component over intact bonds",
            dtype="i8",
        ),
    ),
    tables=(("bond", BOND_KEYS, "two [[iceberg]] tables glued along the face they share at t = 0 (bonds effect)"),),
)


def weibull_scale(modulus: float) -> float:
    """``1 / Gamma(1 + 1/m)``: a Weibull spread of modulus ``m`` with this scale has mean 1."""
    return 1.0 / math.gamma(1.0 + 1.0 / modulus)
