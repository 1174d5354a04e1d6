"""Waves: a moving sea surface coupled to the icebergs both ways (beyond the paper).

The sea surface ``eta(x, t)`` and the velocity potential at it ``phi(x, t)`` live on a 1-D
grid of cells from the wall (``wall_x``, reflecting) to ``wave_end``, over water of depth
``water_depth``, and obey linear water-wave theory::

    d eta / dt = G phi + q,        d phi / dt = -g eta,

with ``G`` the Dirichlet-to-Neumann operator of finite depth, ``k tanh(k H)`` on a wave of
wavenumber ``k``: every wave the grid resolves has the exact dispersion
``omega^2 = g k tanh(k H)`` (``G`` is applied through a cosine transform, which is also what
makes both ends reflecting). The grid has a power of two of cells, so its spacing is
between ``wave_dx / 2`` and ``wave_dx``. In the last ``wave_sponge`` widths before ``wave_end`` the
surface relaxes to rest at the rate ``SPONGE_RATE ((x - x_s) / wave_sponge)^2``, absorbing
what reaches it; the energy it removes is booked in ``wave_absorbed``.

**Coupling.** Let ``A_q`` be an iceberg's submerged area (below the still water line) in
strip q of the grid. As the iceberg moves, the water it displaces enters the surface where it
is: a sinking iceberg raises the surface around it, which spreads as waves. In turn it feels
the wave's pressure: with ``U = rho g sum_q eta^P_q A_q`` its force and torque are
``-grad U`` over its pose, the buoyancy of the part submerged under the local, sloping
surface to first order. ``eta^P = A eta`` is the surface filtered to the depth
``d = wave_pressure_depth`` where linear theory puts the wave's pressure: each cosine mode
times ``cosh(k (H - d)) / cosh(k H)``; and the displaced water enters through the same
filter (``A q``, the adjoint), as a source at that depth makes waves. ``d = 0`` is the
long-wave coupling (pressure uniform with depth), which over-couples waves shorter than
about twice the draft; ``d`` about the icebergs' draft weighs their keels' pressure. The pair
is Hamiltonian: with ``E_w = rho g / 2 int eta^2 dx + rho / 2 int phi G phi dx`` the
icebergs' energy (their potential energy taken in the still sea) plus ``E_w`` is conserved
but for what the sponge removes; ``wave_energy`` (a diagnostic) is ``E_w``.

**Discretely.** ``A_q`` is exact (the submerged polygon clipped to the strip, ``SUB`` strips
per cell), ``eta^P`` is read linearly between cell centres at the strip's centre, and the
change of ``A_q`` is spread to the cells with the same weights, so the energy the icebergs
give the water is the work of their force.

**The wave step.** The grid and the coupling advance once every ``K`` time steps: the wave
step is ``Dt = K dt``: by default (``wave_dt = 0``) ten time steps, or five, two or one where
the grid's shortest waves need a shorter one (:data:`AUTO_EVERY`), so that the wave step
shrinks with ``dt`` and divides the usual output intervals; with ``wave_dt > 0`` the largest
multiple of ``dt`` not above it (``dt`` itself when ``wave_dt < dt``). The waves are linear and slow next to the
icebergs' contacts, so the system is split as a multiple-time-step (impulse, r-RESPA)
method: the icebergs' own forces (gravity, buoyancy in still water, drag, contacts) kick
every step; the waves' part of the energy, ``rho g / 2 int eta^2 dx + rho / 2 int phi G
phi dx`` with ``eta`` holding the displaced water, kicks once per wave step with ``Dt``.
A wave step opens with that kick: each iceberg's velocity takes ``Dt`` times the wave's
pressure force at its pose then, ``phi -= Dt g eta``, and the iceberg's submerged area per
strip is taken out of the source column; it closes after the K-th step's overlap
correction: the iceberg's submerged area is put back in at its pose then less the overlap
correction's pushes since the opening (``PUSH_X``, ``PUSH_Z``: the pose its drifts alone
reached), so the water gets what its drifts displaced over the wave step; then ``eta += Dt
G phi + A q`` and the absorbing layer with ``Dt``. The correction's pushes move no water: the
water's volume changes by what they displace (small: they undo overlaps), and their energy
is booked in ``correction_work`` with the still-water potential energy, so the budget still
closes (were they to move water, their share of ``rho g sum eta^P A`` would go unbooked: a
drift of 0.15% of the released energy by t = 200 in the paper scene with waves). Both maps are symplectic and their
composition is the grid's symplectic Euler with ``Dt`` around the icebergs' with ``dt``;
with ``K = 1`` it is symplectic Euler of the whole system. Between a wave step's opening
and its close the grid (``eta``, ``wave_energy`` in the outputs) is the one of its opening;
output times that are multiples of ``Dt`` (from t = 0) see it whole. The cost of the waves
is about ``1 / K`` of what it is with ``K = 1``: the grid's transforms and the icebergs'
strips are taken once per wave step. What each iceberg displaces is added to the cells with
exact sums (rounded to a multiple of ``WAVE_Q`` first), so the result does not depend on the
order of the additions: the same bits in every form and on any thread count. The absorbing
layer's energy is summed the same way (each cell's share rounded to a multiple of
``SPONGE_Q``), so it too is a parallel loop over the cells.
"""

import math

from ...data.columns import Column, E, Table
from ..base import Dataset, Effect, Key, Quantity

SUB = 2  # sample points per grid cell for the coupling integrals
SPONGE_RATE = 0.5  # largest relaxation rate of the absorbing layer, 1 / sqrt(w/g)
MAX_CELLS = 1 << 16  # largest wave grid (cells)
# what the absorbing layer removes from each cell is rounded to a multiple of this (E) before the
# cells' shares are added up in any order: exact while a step's total stays below 2^53 of them (8 E)
SPONGE_Q = 2.0**-50


class Wave:
    """Columns of the wave grid's table (the first rows of ``a.own`` with the waves effect:
    ``rows_first``)."""


TABLE = Table(
    "waves",
    "own",
    "real",
    "(M, Wave.SIZE)",
    "the wave grid: cell j's surface at row j, the cosine transform's work on the same rows (grid.py)",
    (
        Column("ETA", "state", "w", "sea surface height above the still water line at the cell's centre", "eta"),
        Column("PHI", "state", "w sqrt(g w)", "velocity potential at the surface"),
        Column(
            "GPHI",
            "cache",
            "w / sqrt(w/g)",
            "G phi, the surface's vertical velocity without sources "
            "(set when a wave step closes: of phi before the next opening's kick)",
        ),
        Column(
            "SRC",
            "state",
            "w",
            "water the icebergs displaced into the cell over the wave step under way (their area taken out at its "
            "opening, put back at its close)",
        ),
        Column("SPONGE", "constant", "1 / sqrt(w/g)", "relaxation rate of the absorbing layer"),
        Column("KT", "constant", "1 / w", "row m: k_m tanh(k_m H) of cosine mode m, with the transform's scale (1 / M)"),
        Column(
            "AT",
            "constant",
            "1",
            "row m: cosh(k_m (H - d)) / cosh(k_m H), the wave's pressure at depth d (wave_pressure_depth), with the "
            "transform's scale (1 / M)",
        ),
        Column("ETA_P", "cache", "w", "the surface filtered to the depth of the icebergs' pressure, A eta"),
        Column("SRC_P", "scratch", "w", "the displaced water filtered the same way, A q"),
        Column("CR", "constant", "1", "row m: cos(pi m / 2M), the cosine transform's twist"),
        Column("CI", "constant", "1", "row m: sin(pi m / 2M)"),
        Column("TWR", "constant", "1", "row k < M / 2: cos(2 pi k / M), the FFT's twiddles"),
        Column("TWI", "constant", "1", "row k < M / 2: -sin(2 pi k / M)"),
        Column("REV", "constant", "1", "row n: n with its log2(M) bits reversed (the FFT's load order)"),
        Column("RE", "scratch", "1", "the forward transform, real part"),
        Column("IM", "scratch", "1", "the forward transform, imaginary part"),
        Column("QR", "scratch", "1", "the inverse transform, real part"),
        Column("QI", "scratch", "1", "the inverse transform, imaginary part"),
        Column("PHASE", "state", "1", "row 0: time steps since the last wave step closed (0 to K - 1)"),
    ),
    Wave,
)


EFFECT = Effect(
    name="waves",
    doc="beyond the paper: a moving sea surface eta(x, t) over water of depth water_depth (linear waves, "
    "omega^2 = g k tanh(k H)), from the wall to wave_end with an absorbing layer; the icebergs displace the "
    "water and feel its pressure; wave_energy and wave_absorbed in the budget",
    keys=(
        Key.positive("water_depth", 6.0, "w", "H, depth of the water (used with the waves effect)"),
        Key.positive("wave_dx", 0.25, "w", "largest spacing of the wave grid (used with the waves effect)"),
        Key("wave_end", 600.0, "w", "x where the wave domain ends (used with the waves effect)", None, ""),
        Key.nonnegative("wave_sponge", 50.0, "w", "width of the absorbing layer before wave_end (used with the waves effect)"),
        Key.nonnegative(
            "wave_dt",
            0.0,
            "sqrt(w/g)",
            "the wave step: the grid and the icebergs' coupling to it advance once per wave step, the largest "
            "multiple of time.dt not above wave_dt; 0: ten time steps, or five, two or one where the grid's "
            "shortest waves need it (used with the waves effect)",
        ),
        Key.nonnegative(
            "wave_pressure_depth",
            1.0,
            "w",
            "depth at which the icebergs feel the wave's pressure and displace the water, about their draft "
            "(0: at the surface, the long-wave limit; used with the waves effect)",
        ),
    ),
    params=(
        Column("WAVE_DEPTH", "constant", "w", "water depth H", source="physics.water_depth"),
        Column("WAVE_START", "constant", "w", "x where the wave grid starts (the wall)", source="physics.wall_x"),
        Column("WAVE_DX", "constant", "w", "wave grid spacing (between wave_dx / 2 and wave_dx: a power of two of cells)"),
        Column("WAVE_Q", "constant", "w", "what each iceberg adds to a cell is rounded to a multiple of this"),
    ),
    body_columns=(
        Column(
            "PUSH_X", "state", "w", "waves: the overlap correction's pushes since the wave step opened, x (they move no water)"
        ),
        Column("PUSH_Z", "state", "w", "waves: the same, z"),
        Column("WAVE_FX", "state", "rho_w g w^2", "waves: the wave's pressure force at the wave step's opening, x"),
        Column("WAVE_FZ", "state", "rho_w g w^2", "waves: the same, z"),
        Column("WAVE_TAU", "state", "rho_w g w^3", "waves: the same, its torque"),
    ),
    terms=("force", "offset_kick"),
    torque=True,
    horizontal=True,
    beyond_paper=True,
    rows_first=True,  # the grid's kernels index its cells from row 0
    table=TABLE,
    config=(
        Column("WAVE_CELLS", "config", "1", "waves: cells of the wave grid, M (a power of 2)"),
        Column("WAVE_LOG", "config", "1", "waves: log2 of the transform's length M"),
        Column("WAVE_EVERY", "config", "1", "waves: time steps per wave step, K (from wave_dt)"),
    ),
    run_ledgers=(
        Column(
            "WAVE_ABSORBED",
            "ledger",
            E,
            "wave energy removed by the absorbing layer at the open end (0 without the waves effect)",
            "wave_absorbed",
            budget=True,
            since=5,
        ),
    ),
    held=(
        Quantity(
            "wave_energy",
            E,
            "energy of the waves, rho g / 2 int eta^2 dx + rho / 2 int phi G phi dx, phi at the time of the grid's "
            "last step (half a wave step's kick from the stored one; 0 without the waves effect)",
            since=5,
        ),
    ),
    dims=(("wave_cell", "index of the wave grid's cell, from the wall"),),
    datasets=(
        Dataset("waves/x", ("wave_cell",), "w", "centre of the wave grid's cell", coordinate="wave_x"),
        Dataset(
            "snapshots/eta",
            ("wave_cell",),
            "w",
            "sea surface height above the still water line at the cell's centre (waves effect)",
        ),
    ),
    check=lambda physics, dt: check(physics, dt),
)


def cells_and_spacing(wall_x: float, wave_end: float, wave_dx: float) -> tuple[int, float]:
    """The wave grid's cells ``M`` (the power of 2 that gives a spacing of at most
    ``wave_dx``) and its spacing, for a domain from ``wall_x`` to ``wave_end``."""
    length = wave_end - wall_x
    cells = 1
    while cells * wave_dx < length * (1 - 1e-12):
        cells *= 2
    return max(cells, 2), length / max(cells, 2)


AUTO_EVERY = (10, 5, 2, 1)  # time steps per wave step with wave_dt = 0: the first the shortest waves allow


def shortest_omega(physics) -> float:
    """``omega_max``: the frequency of the grid's shortest wave (``k = pi / dx``)."""
    _, dx = cells_and_spacing(physics.wall_x, physics.wave_end, physics.wave_dx)
    k = math.pi / dx
    return math.sqrt(k * math.tanh(k * physics.water_depth))


def steps_per_wave(physics, dt: float) -> int:
    """K, the time steps per wave step: with ``wave_dt > 0`` the largest whole number with
    ``K dt <= wave_dt`` (to a relative 1e-9, so that 0.1 / 0.01 is 10), at least 1; with 0,
    the first of :data:`AUTO_EVERY` whose step the grid's shortest waves can follow
    (``omega_max K dt <= 1``), else 1."""
    if physics.wave_dt > 0:
        return max(1, math.floor(physics.wave_dt / dt * (1 + 1e-9)))
    omega = shortest_omega(physics)
    return next((k for k in AUTO_EVERY if omega * k * dt <= 1.0), 1)


def check(physics, dt: float) -> tuple[str, float, str] | None:
    """``(key, value, what would be accepted)`` if the waves keys of ``physics`` cannot make
    a grid, or make one whose shortest wave the wave step (:func:`steps_per_wave` times dt) cannot follow
    (symplectic Euler needs ``omega_max Dt < 2``, ``omega_max^2 = g k tanh(k H)`` at ``k = pi /
    dx``; kept below 1 for accuracy), else ``None``."""
    u = {k.name: k.units for k in EFFECT.keys}  # each bound said in its key's declared units
    length = physics.wave_end - physics.wall_x
    if length <= 0:
        wall = f"physics.wall_x = {physics.wall_x:g} {u['wave_end']}"
        return "physics.wave_end", physics.wave_end, f"must be beyond the wall ({wall})"
    if physics.wave_pressure_depth >= physics.water_depth:
        return (
            "physics.wave_pressure_depth",
            physics.wave_pressure_depth,
            f"must be less than physics.water_depth = {physics.water_depth:g} {u['wave_pressure_depth']} (set a smaller "
            "wave_pressure_depth or deeper water)",
        )
    if physics.wave_sponge >= length:
        return "physics.wave_sponge", physics.wave_sponge, f"must be less than wave_end - wall_x = {length:g} {u['wave_sponge']}"
    cells, dx = cells_and_spacing(physics.wall_x, physics.wave_end, physics.wave_dx)
    if cells > MAX_CELLS:
        most = length / MAX_CELLS
        return (
            "physics.wave_dx",
            physics.wave_dx,
            f"makes more than {MAX_CELLS} wave cells; use at least {most:.4g} {u['wave_dx']}",
        )
    k = math.pi / dx
    omega = math.sqrt(k * math.tanh(k * physics.water_depth))
    step = steps_per_wave(physics, dt) * dt
    if omega * step > 1.0:
        if omega * dt <= 1.0:
            return (
                "physics.wave_dt",
                physics.wave_dt,
                f"makes the wave step {step:g} too long for the grid's shortest waves (spacing {dx:.4g}: their "
                f"period {2 * math.pi / omega:.3g} needs a step <= {1.0 / omega:.3g} {u['wave_dt']}); use a smaller "
                "wave_dt or a larger wave_dx",
            )
        return (
            "physics.wave_dx",
            physics.wave_dx,
            f"makes waves too short for time.dt = {dt:g} (grid spacing {dx:.4g}: their period "
            f"{2 * math.pi / omega:.3g} needs dt <= {1.0 / omega:.3g} {u['wave_dt']}); use a larger wave_dx or a smaller dt",
        )
    return None
