"""The Model: the icebergs' arrays (Taichi ndarrays) and the compiled step for one effect set.

``Model`` owns one row per iceberg (``physics.layout``: state ``x, z, theta, vx, vz, omega``,
constants ``width, thickness, mass, inertia``, disc ``radius``, bounding radius ``bound``,
and scratch), the contact slots, the cell list and the scalar accumulators. The effect set
is fixed when the model is built; without contacts no contact array is allocated and no
contact kernel runs. The step's phases are in :mod:`melange_ti.physics.step`.

For small N one kernel call runs many steps with every loop serial (no launch cost, FACTS);
for large N each phase is its own parallel kernel. Both modes give the same bits.
"""

import math
from dataclasses import dataclass

import numpy as np
import taichi as ti

from .errors import ContactOverflow
from .physics import layout as L
from .physics import step as S
from .scene import Icebergs, Scene, disc_radius

# On the CPU at or below this N one kernel call runs many serial steps; above it each phase
# is a parallel kernel. Both give the same bits. On 2 cores (benchmarks/modes.py, five runs,
# README) the serial form was clearly faster at N = 10,000, the two were a wash from 40,000
# to 70,000, and the parallel form was level or faster at 100,000.
SERIAL_MAX_N = 50000

# The narrow phase's candidate lists (1 kB per iceberg) are kept at or below this N, in the
# serial form. Measured on 2 cores, active state: they cut the step by ~20% at N = 400 and
# 4000 (all in cache), but were level or slower at 40,000 (serial) and slower at 100,000
# (parallel: narrow phase 13.1 -> 14.3 ms), where their memory traffic costs more than the
# search they save.
LISTS_MAX_N = 20000


@dataclass(frozen=True)
class Totals:
    """Cumulative scalar counters since t = 0 (SPEC section 5 diagnostics)."""

    collision_dissipated: float
    correction_work: float
    wall_impulse: float
    impulse_sum: float
    contacts: int


class Model:
    """Icebergs as Taichi ndarrays plus the step for one fixed effect set."""

    def __init__(self, scene: Scene, icebergs: Icebergs | None = None, mode: str = "auto"):
        bergs = icebergs if icebergs is not None else scene.icebergs()
        self.scene = scene
        self.fx = scene.effects
        self.n = n = bergs.count
        self.real = ti.f32 if scene.precision == "f32" else ti.f64
        self.np_real = np.float32 if scene.precision == "f32" else np.float64
        if mode == "auto":
            on_cpu = ti.lang.impl.current_cfg().arch in (ti.x64, ti.arm64)
            mode = "serial" if on_cpu and n <= SERIAL_MAX_N else "parallel"
        if mode not in ("serial", "parallel"):
            raise ValueError(f"mode must be 'auto', 'serial' or 'parallel', not {mode!r}")
        self.mode = mode
        self.contacts = self.fx.collisions or self.fx.wall
        slots = scene.contacts.max_partners if self.fx.collisions else 1
        ncells = 1 << max(2, math.ceil(math.log2(max(n, 4)))) if self.fx.collisions else 4

        self.b = ti.ndarray(self.real, shape=(n, L.NB))
        self.bi = ti.ndarray(ti.i32, shape=(n, L.NI))
        self.cd = ti.ndarray(self.real, shape=(slots, n if self.contacts else 1, L.NC))
        self.cp = ti.ndarray(ti.i32, shape=(slots, n if self.contacts else 1))
        # candidate lists for the narrow phase (step.narrow), used where they were measured
        # to pay: see LISTS_MAX_N. Contacts are bit-for-bit the same with and without them.
        self.lists = self.fx.collisions and mode == "serial" and n <= LISTS_MAX_N
        lists = n if self.lists else 1
        self.nl = ti.ndarray(ti.i32, shape=(lists, L.ENTRIES * (2 + L.PAIRS)))
        self.nr = ti.ndarray(self.real, shape=(lists, L.ENTRIES, 5))
        self.cells = ti.ndarray(ti.i32, shape=(ncells + 1, 3))
        self.par = ti.ndarray(self.real, shape=(L.NP,))
        self.acc = ti.ndarray(ti.f64, shape=(L.NA,))
        self.ipar = ti.ndarray(ti.i64, shape=(L.NQ,))

        p = scene.physics
        rows = np.zeros((n, L.NB), dtype=np.float64)
        mass = p.density_ratio * bergs.width * bergs.thickness
        bound = 0.5 * np.hypot(bergs.width, bergs.thickness)
        for name, value in (
            ("width", bergs.width),
            ("thickness", bergs.thickness),
            ("mass", mass),
            ("inertia", mass * (bergs.width**2 + bergs.thickness**2) / 12.0),
            ("radius", disc_radius(bergs.width, bergs.thickness, scene.contacts.discs, scene.contacts.disc_spacing)),
            ("bound", bound),
        ):
            rows[:, L.CONST_COLS[name]] = value
        for name, col in L.STATE_COLS.items():
            rows[:, col] = getattr(bergs, name)
        m_real = mass.astype(self.np_real)
        rows[:, L.INV_MASS] = self.np_real(1.0) / m_real  # as the device would round it
        self.b.from_numpy(rows.astype(self.np_real))
        self.bi.from_numpy(np.zeros((n, L.NI), dtype=np.int32))
        self.cells.from_numpy(np.zeros((ncells + 1, 3), dtype=np.int32))
        self.clear_candidate_lists()

        par = np.zeros(L.NP)
        par[[L.DT, L.RESTITUTION, L.DRAG_LIN, L.DRAG_ANG, L.WATER, L.WALL_X, L.BOUND_MAX]] = (
            scene.time.dt,
            p.restitution,
            p.drag,
            p.angular_drag,
            p.water_level,
            p.wall_x,
            float(bound.max()),
        )
        par[L.EPS] = float(np.finfo(self.np_real).eps)
        self.par.from_numpy(par.astype(self.np_real))
        self.acc.from_numpy(np.zeros(L.NA))
        ipar = np.zeros(L.NQ, dtype=np.int64)
        ipar[[L.N, L.K, L.SLOTS, L.PASSES, L.NCELLS, L.DISCS]] = (
            n,
            scene.contacts.discs // 4,
            slots,
            scene.contacts.contact_passes,
            ncells,
            scene.contacts.discs,
        )
        ipar[L.LISTS] = int(self.lists)
        self.ipar.from_numpy(ipar)

    # ------------------------------------------------------------------ host side
    def _rows(self) -> np.ndarray:
        return self.b.to_numpy()

    def constants(self) -> dict[str, np.ndarray]:
        """Per-iceberg constants ``width, thickness, mass, inertia``, arrays of shape (N,)."""
        rows = self._rows()
        return {k: rows[:, L.CONST_COLS[k]].copy() for k in ("width", "thickness", "mass", "inertia")}

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        """Load ``x, z, theta, vx, vz, omega`` (arrays of shape (N,))."""
        rows = self._rows()
        for name, col in L.STATE_COLS.items():
            rows[:, col] = state[name]
        self.b.from_numpy(rows)

    def state(self) -> dict[str, np.ndarray]:
        """Current state, arrays of shape (N,)."""
        rows = self._rows()
        return {k: rows[:, c].copy() for k, c in L.STATE_COLS.items()}

    def sample(self) -> dict[str, np.ndarray]:
        """State plus per-body ``kinetic``, ``potential`` energy and ``drag_work``, one transfer."""
        S.energies(self.fx, self.b, self.par)
        rows = self._rows()
        out = {k: rows[:, c].copy() for k, c in L.STATE_COLS.items()}
        out["kinetic"] = rows[:, L.KINETIC].copy()
        out["potential"] = rows[:, L.POTENTIAL].copy()
        out["drag_work"] = rows[:, L.DRAG_WORK].copy()
        return out

    def totals(self) -> Totals:
        acc = self.acc.to_numpy()
        return Totals(
            collision_dissipated=float(acc[L.ACC_COLLISION]),
            correction_work=float(acc[L.ACC_CORRECTION]),
            wall_impulse=float(acc[L.ACC_WALL_IMPULSE]),
            impulse_sum=float(acc[L.ACC_IMPULSE]),
            contacts=int(self.ipar.to_numpy()[L.CONTACTS]),
        )

    def accumulators(self) -> dict[str, np.ndarray]:
        """The cumulative counters besides the state (for checkpoints): per-body drag work,
        the scalar energy and impulse sums, and the impulse count."""
        return {
            "drag_work": self._rows()[:, L.DRAG_WORK].copy(),
            "acc": self.acc.to_numpy(),
            "contacts": np.array(self.ipar.to_numpy()[L.CONTACTS]),
        }

    def set_accumulators(self, acc: dict[str, np.ndarray]) -> None:
        rows = self._rows()
        rows[:, L.DRAG_WORK] = acc["drag_work"]
        self.b.from_numpy(rows)
        self.acc.from_numpy(np.asarray(acc["acc"], dtype=np.float64))
        ipar = self.ipar.to_numpy()
        ipar[L.CONTACTS] = int(acc["contacts"])
        self.ipar.from_numpy(ipar)

    def clear_candidate_lists(self) -> None:
        """Forget the narrow phase's candidate lists (``step.narrow``): the next detection
        searches every pair afresh. Contacts are bit-for-bit the same either way; only
        speed differs."""
        self.nl.from_numpy(np.full(self.nl.shape, -1, dtype=np.int32))
        self.nr.from_numpy(np.zeros(self.nr.shape, dtype=self.np_real))
        ints = self.bi.to_numpy()
        ints[:, L.NEXT_ENTRY] = 0
        self.bi.from_numpy(ints)

    def prepare(self) -> None:
        """Refresh what a step caches from the state (cos and sin of every tilt). ``advance``
        and ``contact_pairs`` call it; call it before driving ``_step_parallel`` directly
        after ``set_state``."""
        S.orient_all(self.b)

    def advance(self, steps: int) -> None:
        """Advance ``steps`` time steps (no I/O; one small read of the overflow flag)."""
        if steps <= 0:
            return
        if self.mode == "serial":
            S.steps_serial(
                self.fx, steps, self.b, self.bi, self.cd, self.cp, self.nl, self.nr, self.cells, self.par, self.acc, self.ipar
            )
        else:
            self.prepare()  # the state may have been set from the host since the last call
            for _ in range(steps):
                self._step_parallel()
        if self.fx.collisions and self.ipar[L.OVERFLOW]:
            raise ContactOverflow(
                f"contacts.max_partners = {self.scene.contacts.max_partners}: an iceberg had more contact partners "
                "than slots; raise contacts.max_partners"
            )

    def _detect(self) -> None:
        S.speed_all(self.b, self.par)
        S.reach_all(self.b, self.par)
        if self.fx.collisions:
            S.bin_count(self.b, self.bi, self.cells, self.par, self.ipar)
            S.bin_scan(self.cells, self.ipar)
            S.bin_fill(self.bi, self.cells)
        S.detect_all(self.fx, self.b, self.bi, self.cd, self.cp, self.nl, self.nr, self.cells, self.par, self.ipar)

    def _step_parallel(self) -> None:
        S.kick_all(self.fx, self.b, self.par)
        if self.contacts:
            redetect = True
            for _ in range(L.MAX_DETECT):
                if redetect:
                    self._detect()
                S.impulses(self.fx, self.b, self.bi, self.cd, self.cp, self.par, self.acc, self.ipar)
                S.check_reach(self.fx, self.b, self.bi, self.cd, self.cp, self.par, self.ipar)
                again = int(self.ipar[L.AGAIN])  # the one device read per step
                redetect = again == 2
                if again == 0:
                    break
        S.drift_all(self.b, self.par)
        if self.contacts:
            S.correct(self.fx, self.b, self.bi, self.cd, self.cp, self.par, self.acc, self.ipar)

    def contact_pairs(self) -> tuple[list[tuple[int, int]], list[int]]:
        """Contacts the next step would consider, without changing the state.

        Returns ``(pairs, wall)``: body pairs ``(i, j)``, ``i < j``, in the order the impulse
        pass visits them, and the bodies touching the wall. Velocities count (speculative
        contacts), so call it on the state whose velocities you mean.
        """
        if not self.contacts:
            return [], []
        self.prepare()
        self._detect()
        bi = self.bi.to_numpy()
        cp = self.cp.to_numpy()
        pairs = []
        if self.fx.collisions:
            pairs = [(i, int(cp[s, i])) for i in range(self.n) for s in range(bi[i, L.NCONTACT])]
        wall = [int(i) for i in np.flatnonzero(bi[:, L.WALL_ON])] if self.fx.wall else []
        return pairs, wall
