"""The Model: Taichi fields for the icebergs and one time step as a list of named phases.

``Model`` owns constants (``width``, ``thickness``, ``mass``, ``inertia``, disc ``radius``,
bounding radius ``bound``; shape (N,)) and state (``x``, ``z``, ``theta``, ``vx``, ``vz``,
``omega``; shape (N,)). The effect set is fixed when the model is built: every term is
guarded by ``ti.static`` on a frozen :class:`~melange_ti.scene.Effects`, so an effect the
scene does not name is not compiled at all, and without contacts no contact field is
allocated and no contact kernel exists.

One step (semi-implicit Euler, velocities first):

1. ``kick``      v += dt F/m, omega += dt tau/I  (gravity, buoyancy), then drag as
                 v /= (1 + c dt) (backward Euler for the linear drag term: unconditionally
                 stable, never reverses a velocity); drag's energy loss is recorded per body.
2. ``reach``     per-body bound on how far any point of the body moves this step.
3. ``bin``       counting sort of body centres into hashed cells along x.
4. ``detect``    (parallel) bounding circles inflated by the reach, then discs of candidate
                 pairs; all disc pairs of one body pair merge into one contact. Contacts
                 are stored in per-body slots sorted by partner index, so the list does not
                 depend on the thread count. A contact is kept if the gap may close within
                 this step (speculative contacts: no tunnelling at any speed).
5. ``impulses``  (sequential, fixed order: body i ascending, its wall contact first, then
                 partners j > i ascending; repeated ``contact_passes`` times).
6. ``drift``     x += dt v, theta += dt omega.
7. ``correct``   (sequential, same order) overlap left after the drift, estimated from the
                 contact's gap and the final velocities, is removed along the normal, split
                 by inverse mass; its potential-energy change is booked as correction work.

For small N one kernel call runs many steps with every loop serial (no launch cost); for
large N each phase is its own parallel kernel. Both give the same bits.
"""



import math
from dataclasses import dataclass

import numpy as np
import taichi as ti

from .physics.contacts import cross2, disc_local, to_world
from .physics.hydrostatics import potential_energy, submerged_moments
from .scene import Icebergs, Scene, disc_radius

# Rows of the packed output buffer (one to_numpy per output event).
ROWS = ("x", "z", "theta", "vx", "vz", "omega", "kinetic", "potential", "drag_work")
STATE = ROWS[:6]

# Scalar accumulators (cumulative since t = 0).
ACC_COLLISION, ACC_CORRECTION, ACC_WALL_IMPULSE, ACC_IMPULSE = 0, 1, 2, 3

SERIAL_MAX_N = 3000  # below this one kernel call runs many serial steps (FACTS.md)


@dataclass(frozen=True)
class Totals:
    """Cumulative scalar counters read from the model (SPEC section 5 diagnostics)."""

    collision_dissipated: float
    correction_work: float
    wall_impulse: float
    impulse_sum: float
    contacts: int


class ContactOverflow(RuntimeError):
    """A body had more contact partners than slots; raised instead of dropping contacts."""


@ti.data_oriented
class Model:
    """Icebergs as Taichi fields plus the compiled step for one fixed effect set."""

    def __init__(self, scene: Scene, icebergs: Icebergs | None = None, mode: str = "auto"):
        bergs = icebergs if icebergs is not None else scene.icebergs()
        self.scene = scene
        self.fx = scene.effects
        self.n = bergs.count
        self.real = ti.f32 if scene.precision == "f32" else ti.f64
        p = scene.physics
        self.dt = scene.time.dt
        self.rho_i = p.density_ratio
        self.e = p.restitution
        self.c_lin = p.drag
        self.c_ang = p.angular_drag
        self.wl = p.water_level
        self.wall_x = p.wall_x
        self.passes = scene.contacts.contact_passes
        self.k = scene.contacts.discs // 4
        self.discs = scene.contacts.discs
        self.slots = scene.contacts.max_partners
        if mode == "auto":
            mode = "serial" if self.n <= SERIAL_MAX_N else "parallel"
        if mode not in ("serial", "parallel"):
            raise ValueError(f"mode must be 'auto', 'serial' or 'parallel', not {mode!r}")
        self.mode = mode

        n, real = self.n, self.real
        f = lambda dtype=real, shape=n: ti.field(dtype, shape=shape)  # noqa: E731
        self.x, self.z, self.theta = f(), f(), f()
        self.vx, self.vz, self.omega = f(), f(), f()
        self.width, self.thickness, self.mass, self.inertia = f(), f(), f(), f()
        self.radius, self.bound = f(), f()
        self.drag_work = f()
        self.out = ti.field(real, shape=(len(ROWS), n))
        self.acc = ti.field(ti.f64, shape=4)
        self.count = ti.field(ti.i64, shape=())
        if self.fx.contacts:
            self.ncells = 1 << max(2, math.ceil(math.log2(max(n, 4))))
            self.reach = f()
            self.reach_max = ti.field(real, shape=())
            self.cell_of = f(ti.i32)
            self.cell_count = f(ti.i32, self.ncells)
            self.cell_start = f(ti.i32, self.ncells + 1)
            self.cell_fill = f(ti.i32, self.ncells)
            self.sorted_ids = f(ti.i32)
            self.ncontact = f(ti.i32)
            self.partner = f(ti.i32, (n, self.slots))
            self.c_px, self.c_pz = f(real, (n, self.slots)), f(real, (n, self.slots))
            self.c_nx, self.c_nz = f(real, (n, self.slots)), f(real, (n, self.slots))
            self.c_gap = f(real, (n, self.slots))
            self.wall_on = f(ti.i32)
            self.wall_pz, self.wall_gap = f(), f()
            self.shift_x, self.shift_z = f(), f()
            self.overflow = ti.field(ti.i32, shape=())
        self._load_constants(bergs)
        self.set_state({k: getattr(bergs, k) for k in STATE})

    # ------------------------------------------------------------------ host side
    def _load_constants(self, b: Icebergs) -> None:
        dtype = np.float32 if self.real == ti.f32 else np.float64
        mass = self.rho_i * b.width * b.thickness
        bound = 0.5 * np.hypot(b.width, b.thickness)
        for name, value in (
            ("width", b.width),
            ("thickness", b.thickness),
            ("mass", mass),
            ("inertia", mass * (b.width**2 + b.thickness**2) / 12.0),
            ("radius", disc_radius(b.width, b.thickness, self.discs)),
            ("bound", bound),
        ):
            getattr(self, name).from_numpy(np.ascontiguousarray(value, dtype=dtype))
        self.bound_max = float(bound.max())  # compile-time constant of the cell size
        self.drag_work.fill(0)
        self.acc.fill(0)
        self.count[None] = 0

    def constants(self) -> dict[str, np.ndarray]:
        """Per-iceberg constants, arrays of shape (N,)."""
        return {k: getattr(self, k).to_numpy() for k in ("width", "thickness", "mass", "inertia")}

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        """Load ``x, z, theta, vx, vz, omega`` (arrays of shape (N,))."""
        dtype = np.float32 if self.real == ti.f32 else np.float64
        for k in STATE:
            getattr(self, k).from_numpy(np.ascontiguousarray(state[k], dtype=dtype))

    def state(self) -> dict[str, np.ndarray]:
        """Current state, arrays of shape (N,)."""
        return {k: getattr(self, k).to_numpy() for k in STATE}

    def sample(self) -> dict[str, np.ndarray]:
        """State plus per-body kinetic and potential energy and drag work, one transfer."""
        self._pack()
        buf = self.out.to_numpy()
        return {k: buf[r] for r, k in enumerate(ROWS)}

    def totals(self) -> Totals:
        acc = self.acc.to_numpy()
        return Totals(
            collision_dissipated=float(acc[ACC_COLLISION]),
            correction_work=float(acc[ACC_CORRECTION]),
            wall_impulse=float(acc[ACC_WALL_IMPULSE]),
            impulse_sum=float(acc[ACC_IMPULSE]),
            contacts=int(self.count[None]),
        )

    def accumulators(self) -> dict[str, np.ndarray]:
        """Everything besides the state that the next step's bookkeeping depends on."""
        return {"drag_work": self.drag_work.to_numpy(), "acc": self.acc.to_numpy(), "count": np.array(self.count[None])}

    def set_accumulators(self, acc: dict[str, np.ndarray]) -> None:
        self.drag_work.from_numpy(acc["drag_work"].astype(self.drag_work.to_numpy().dtype))
        self.acc.from_numpy(acc["acc"])
        self.count[None] = int(acc["count"])

    def advance(self, steps: int) -> None:
        """Advance ``steps`` time steps (no I/O, no host transfers besides one overflow flag)."""
        if steps <= 0:
            return
        if self.mode == "serial":
            self._steps_serial(steps)
        else:
            for _ in range(steps):
                self._step_parallel()
        if self.fx.contacts and self.overflow[None]:
            raise ContactOverflow(
                f"contacts.max_partners = {self.slots}: an iceberg had more contact partners than slots; "
                "raise contacts.max_partners"
            )

    def contact_pairs(self) -> tuple[list[tuple[int, int]], list[int]]:
        """Contacts the next step would consider, without changing the state.

        Returns ``(pairs, wall)``: body pairs ``(i, j)`` with ``i < j`` in the order the
        impulse pass visits them, and the bodies with a wall contact. Velocities count
        (speculative contacts), so call it on the state whose velocities you mean.
        """
        if not self.fx.contacts:
            return [], []
        self._reach_all()
        self._bin_count()
        self._bin_scan()
        self._bin_fill()
        self._detect_all()
        cnt = self.ncontact.to_numpy()
        partner = self.partner.to_numpy()
        pairs = [(i, int(partner[i, s])) for i in range(self.n) for s in range(cnt[i])]
        wall = [int(i) for i in np.flatnonzero(self.wall_on.to_numpy())] if self.fx.wall else []
        return pairs, wall

    def _step_parallel(self) -> None:
        self._kick_all()
        if self.fx.contacts:
            self._reach_all()
            self._bin_count()
            self._bin_scan()
            self._bin_fill()
            self._detect_all()
            self._impulses()
        self._drift_all()
        if self.fx.contacts:
            self._correct()

    # ------------------------------------------------------------------ phases (per body)
    @ti.func
    def kick(self, i):
        m = self.mass[i]
        fz = 0.0
        tau = 0.0
        if ti.static(self.fx.gravity):
            fz -= m
        if ti.static(self.fx.buoyancy):
            mo = submerged_moments(self.z[i], self.theta[i], 0.5 * self.width[i], 0.5 * self.thickness[i], self.wl)
            fz += mo[0]
            tau += mo[1]
        if ti.static(self.fx.gravity or self.fx.buoyancy):
            self.vz[i] += self.dt * fz / m
        if ti.static(self.fx.buoyancy):
            self.omega[i] += self.dt * tau / self.inertia[i]
        if ti.static(self.fx.drag):
            vx, vz, om = self.vx[i], self.vz[i], self.omega[i]
            lin = 1.0 / (1.0 + self.c_lin * self.dt)
            ang = 1.0 / (1.0 + self.c_ang * self.dt)
            self.vx[i] = vx * lin
            self.vz[i] = vz * lin
            self.omega[i] = om * ang
            self.drag_work[i] += 0.5 * m * (vx * vx + vz * vz) * (1.0 - lin * lin) + 0.5 * self.inertia[i] * om * om * (
                1.0 - ang * ang
            )

    @ti.func
    def drift(self, i):
        self.x[i] += self.dt * self.vx[i]
        self.z[i] += self.dt * self.vz[i]
        self.theta[i] += self.dt * self.omega[i]

    @ti.func
    def body_reach(self, i):
        """Upper bound on the distance any point of body i moves in this step."""
        speed = ti.sqrt(self.vx[i] ** 2 + self.vz[i] ** 2) + ti.abs(self.omega[i]) * self.bound[i]
        return self.dt * speed

    @ti.func
    def cell_index(self, x, size):
        c = ti.cast(ti.floor(x / size), ti.i64)
        return ti.cast(c & (self.ncells - 1), ti.i32)

    @ti.func
    def cell_size(self):
        # Bodies closer than the sum of their inflated bounding radii lie in adjacent cells.
        return 2.0 * (self.bound_max + self.reach_max[None]) + 1e-9

    @ti.func
    def detect(self, i, size):
        """Contacts of body i with partners j > i, into slots sorted by j, plus the wall."""
        self.ncontact[i] = 0
        if ti.static(self.fx.collisions):
            xi = self.x[i]
            zi = self.z[i]
            home = ti.cast(ti.floor(xi / size), ti.i64)
            for dc in ti.static(range(-1, 2)):
                cell = ti.cast((home + dc) & (self.ncells - 1), ti.i32)
                for slot in range(self.cell_start[cell], self.cell_start[cell + 1]):
                    j = self.sorted_ids[slot]
                    if j > i:
                        reach = self.reach[i] + self.reach[j]
                        dx = xi - self.x[j]
                        dz = zi - self.z[j]
                        lim = self.bound[i] + self.bound[j] + reach
                        if dx * dx + dz * dz < lim * lim:
                            self.narrow(i, j, reach)
        if ti.static(self.fx.wall):
            self.detect_wall(i)

    @ti.func
    def near_body(self, p, r, j, reach):
        """Whether a disc at p of radius r can touch body j within this step."""
        c = ti.cos(self.theta[j])
        s = ti.sin(self.theta[j])
        dx = p[0] - self.x[j]
        dz = p[1] - self.z[j]
        lu = dx * c + dz * s
        lv = -dx * s + dz * c
        return ti.abs(lu) < 0.5 * self.width[j] + r + reach and ti.abs(lv) < 0.5 * self.thickness[j] + r + reach

    @ti.func
    def narrow(self, i, j, reach):
        """Merge every close disc pair of (i, j) into one contact (weights = reach - gap)."""
        ci, si = ti.cos(self.theta[i]), ti.sin(self.theta[i])
        cj, sj = ti.cos(self.theta[j]), ti.sin(self.theta[j])
        hwi, hhi, ri = 0.5 * self.width[i], 0.5 * self.thickness[i], self.radius[i]
        hwj, hhj, rj = 0.5 * self.width[j], 0.5 * self.thickness[j], self.radius[j]
        wsum = 0.0
        px = 0.0
        pz = 0.0
        nx = 0.0
        nz = 0.0
        gap = 1e30
        for a in range(self.discs):
            pa = to_world(disc_local(a, self.k, hwi, hhi, ri), self.x[i], self.z[i], ci, si)
            if self.near_body(pa, ri, j, reach):
                for b in range(self.discs):
                    pb = to_world(disc_local(b, self.k, hwj, hhj, rj), self.x[j], self.z[j], cj, sj)
                    d = pa - pb
                    dist = d.norm()
                    g = dist - ri - rj
                    if g < reach and dist > 0:
                        w = reach - g
                        wsum += w
                        mid = pb + d * (rj + 0.5 * g) / dist
                        px += w * mid[0]
                        pz += w * mid[1]
                        nx += w * d[0] / dist
                        nz += w * d[1] / dist
                        gap = ti.min(gap, g)
        if wsum > 0:
            nn = ti.sqrt(nx * nx + nz * nz)
            if nn > 0:
                self.insert_contact(i, j, px / wsum, pz / wsum, nx / nn, nz / nn, gap)

    @ti.func
    def insert_contact(self, i, j, px, pz, nx, nz, gap):
        cnt = self.ncontact[i]
        if cnt >= self.slots:
            self.overflow[None] = 1
        else:
            pos = cnt
            while pos > 0 and self.partner[i, pos - 1] > j:
                self.partner[i, pos] = self.partner[i, pos - 1]
                self.c_px[i, pos] = self.c_px[i, pos - 1]
                self.c_pz[i, pos] = self.c_pz[i, pos - 1]
                self.c_nx[i, pos] = self.c_nx[i, pos - 1]
                self.c_nz[i, pos] = self.c_nz[i, pos - 1]
                self.c_gap[i, pos] = self.c_gap[i, pos - 1]
                pos -= 1
            self.partner[i, pos] = j
            self.c_px[i, pos] = px
            self.c_pz[i, pos] = pz
            self.c_nx[i, pos] = nx
            self.c_nz[i, pos] = nz
            self.c_gap[i, pos] = gap
            self.ncontact[i] = cnt + 1

    @ti.func
    def detect_wall(self, i):
        c, s = ti.cos(self.theta[i]), ti.sin(self.theta[i])
        hw, hh, r = 0.5 * self.width[i], 0.5 * self.thickness[i], self.radius[i]
        reach = self.reach[i]
        self.wall_on[i] = 0
        if self.x[i] - self.bound[i] - reach < self.wall_x:
            wsum = 0.0
            pz = 0.0
            gap = 1e30
            for a in range(self.discs):
                pa = to_world(disc_local(a, self.k, hw, hh, r), self.x[i], self.z[i], c, s)
                g = pa[0] - r - self.wall_x
                if g < reach:
                    w = reach - g
                    wsum += w
                    pz += w * pa[1]
                    gap = ti.min(gap, g)
            if wsum > 0:
                self.wall_on[i] = 1
                self.wall_pz[i] = pz / wsum
                self.wall_gap[i] = gap

    @ti.func
    def normal_speed(self, i, j, rx1, rz1, rx2, rz2, nx, nz):
        """Normal relative velocity at the contact; j < 0 is the wall (at rest)."""
        v1x = self.vx[i] - self.omega[i] * rz1
        v1z = self.vz[i] + self.omega[i] * rx1
        v2x = 0.0
        v2z = 0.0
        if j >= 0:
            v2x = self.vx[j] - self.omega[j] * rz2
            v2z = self.vz[j] + self.omega[j] * rx2
        return (v1x - v2x) * nx + (v1z - v2z) * nz

    @ti.func
    def resolve(self, i, j, px, pz, nx, nz, gap):
        """Apply the SPEC impulse to the pair (i, j) (j < 0: the wall) if it approaches."""
        rx1 = px - self.x[i]
        rz1 = pz - self.z[i]
        rx2 = 0.0
        rz2 = 0.0
        if j >= 0:
            rx2 = px - self.x[j]
            rz2 = pz - self.z[j]
        vn = self.normal_speed(i, j, rx1, rz1, rx2, rz2, nx, nz)
        if vn < 0 and gap + self.dt * vn < 0:
            n = ti.Vector([nx, nz])
            a1 = cross2(ti.Vector([rx1, rz1]), n)
            kk = 1.0 / self.mass[i] + a1 * a1 / self.inertia[i]
            a2 = 0.0
            if j >= 0:
                a2 = cross2(ti.Vector([rx2, rz2]), n)
                kk += 1.0 / self.mass[j] + a2 * a2 / self.inertia[j]
            jn = -(1.0 + self.e) * vn / kk
            self.vx[i] += jn * nx / self.mass[i]
            self.vz[i] += jn * nz / self.mass[i]
            self.omega[i] += a1 * jn / self.inertia[i]
            if j >= 0:
                self.vx[j] -= jn * nx / self.mass[j]
                self.vz[j] -= jn * nz / self.mass[j]
                self.omega[j] -= a2 * jn / self.inertia[j]
            else:
                self.acc[ACC_WALL_IMPULSE] += jn
            self.acc[ACC_COLLISION] += 0.5 * (1.0 - self.e * self.e) * vn * vn / kk
            self.acc[ACC_IMPULSE] += jn
            self.count[None] += 1

    @ti.func
    def body_energy(self, i):
        return potential_energy(
            self.z[i],
            self.theta[i],
            0.5 * self.width[i],
            0.5 * self.thickness[i],
            self.mass[i],
            self.wl,
            ti.static(self.fx.gravity),
            ti.static(self.fx.buoyancy),
        )

    @ti.func
    def push(self, i, j, px, pz, nx, nz, gap):
        """Remove the overlap left after the drift, splitting the push by inverse mass."""
        dt = self.dt
        # Arms at the start of the step, when the contact was found.
        rx1 = px - (self.x[i] - dt * self.vx[i])
        rz1 = pz - (self.z[i] - dt * self.vz[i])
        rx2 = 0.0
        rz2 = 0.0
        inv1 = 1.0 / self.mass[i]
        inv2 = 0.0
        moved = self.shift_x[i] * nx + self.shift_z[i] * nz
        if j >= 0:
            rx2 = px - (self.x[j] - dt * self.vx[j])
            rz2 = pz - (self.z[j] - dt * self.vz[j])
            inv2 = 1.0 / self.mass[j]
            moved -= self.shift_x[j] * nx + self.shift_z[j] * nz
        g = gap + dt * self.normal_speed(i, j, rx1, rz1, rx2, rz2, nx, nz) + moved
        if g < 0:
            depth = -g
            u0 = self.body_energy(i)
            s1 = depth * inv1 / (inv1 + inv2)
            self.x[i] += s1 * nx
            self.z[i] += s1 * nz
            self.shift_x[i] += s1 * nx
            self.shift_z[i] += s1 * nz
            du = self.body_energy(i) - u0
            if j >= 0:
                u0 = self.body_energy(j)
                s2 = depth * inv2 / (inv1 + inv2)
                self.x[j] -= s2 * nx
                self.z[j] -= s2 * nz
                self.shift_x[j] -= s2 * nx
                self.shift_z[j] -= s2 * nz
                du += self.body_energy(j) - u0
            self.acc[ACC_CORRECTION] -= du

    @ti.func
    def impulse_pass(self):
        for _ in range(self.passes):
            for i in range(self.n):
                if ti.static(self.fx.wall):
                    if self.wall_on[i]:
                        self.resolve(i, -1, self.wall_x, self.wall_pz[i], 1.0, 0.0, self.wall_gap[i])
                if ti.static(self.fx.collisions):
                    for s in range(self.ncontact[i]):
                        self.resolve(
                            i, self.partner[i, s], self.c_px[i, s], self.c_pz[i, s], self.c_nx[i, s], self.c_nz[i, s], self.c_gap[i, s]
                        )

    @ti.func
    def correction_pass(self):
        for i in range(self.n):
            self.shift_x[i] = 0.0
            self.shift_z[i] = 0.0
        for i in range(self.n):
            if ti.static(self.fx.wall):
                if self.wall_on[i]:
                    self.push(i, -1, self.wall_x, self.wall_pz[i], 1.0, 0.0, self.wall_gap[i])
            if ti.static(self.fx.collisions):
                for s in range(self.ncontact[i]):
                    self.push(i, self.partner[i, s], self.c_px[i, s], self.c_pz[i, s], self.c_nx[i, s], self.c_nz[i, s], self.c_gap[i, s])

    @ti.func
    def scan_cells(self):
        total = 0
        for c in range(self.ncells):
            self.cell_start[c] = total
            self.cell_fill[c] = total
            total += self.cell_count[c]
            self.cell_count[c] = 0
        self.cell_start[self.ncells] = total

    # ------------------------------------------------------------------ kernels
    @ti.kernel
    def _steps_serial(self, steps: ti.i32):
        ti.loop_config(serialize=True)
        for _ in range(steps):
            for i in range(self.n):
                self.kick(i)
            if ti.static(self.fx.contacts):
                rmax = 0.0
                for i in range(self.n):
                    self.reach[i] = self.body_reach(i)
                    rmax = ti.max(rmax, self.reach[i])
                self.reach_max[None] = rmax
                size = self.cell_size()
                if ti.static(self.fx.collisions):
                    for i in range(self.n):
                        c = self.cell_index(self.x[i], size)
                        self.cell_of[i] = c
                        self.cell_count[c] += 1
                    self.scan_cells()
                    for i in range(self.n):
                        c = self.cell_of[i]
                        self.sorted_ids[self.cell_fill[c]] = i
                        self.cell_fill[c] += 1
                for i in range(self.n):
                    self.detect(i, size)
                self.impulse_pass()
            for i in range(self.n):
                self.drift(i)
            if ti.static(self.fx.contacts):
                self.correction_pass()

    @ti.kernel
    def _kick_all(self):
        for i in range(self.n):
            self.kick(i)

    @ti.kernel
    def _reach_all(self):
        self.reach_max[None] = 0.0
        for i in range(self.n):
            r = self.body_reach(i)
            self.reach[i] = r
            ti.atomic_max(self.reach_max[None], r)

    @ti.kernel
    def _bin_count(self):
        size = self.cell_size()
        for i in range(self.n):
            if ti.static(self.fx.collisions):
                c = self.cell_index(self.x[i], size)
                self.cell_of[i] = c
                ti.atomic_add(self.cell_count[c], 1)

    @ti.kernel
    def _bin_scan(self):
        ti.loop_config(serialize=True)
        for _ in range(1):
            if ti.static(self.fx.collisions):
                self.scan_cells()

    @ti.kernel
    def _bin_fill(self):
        for i in range(self.n):
            if ti.static(self.fx.collisions):
                c = self.cell_of[i]
                slot = ti.atomic_add(self.cell_fill[c], 1)
                self.sorted_ids[slot] = i

    @ti.kernel
    def _detect_all(self):
        size = self.cell_size()
        for i in range(self.n):
            self.detect(i, size)

    @ti.kernel
    def _impulses(self):
        ti.loop_config(serialize=True)
        for _ in range(1):
            self.impulse_pass()

    @ti.kernel
    def _drift_all(self):
        for i in range(self.n):
            self.drift(i)

    @ti.kernel
    def _correct(self):
        ti.loop_config(serialize=True)
        for _ in range(1):
            self.correction_pass()

    @ti.kernel
    def _pack(self):
        for i in range(self.n):
            m = self.mass[i]
            self.out[0, i] = self.x[i]
            self.out[1, i] = self.z[i]
            self.out[2, i] = self.theta[i]
            self.out[3, i] = self.vx[i]
            self.out[4, i] = self.vz[i]
            self.out[5, i] = self.omega[i]
            self.out[6, i] = 0.5 * m * (self.vx[i] ** 2 + self.vz[i] ** 2) + 0.5 * self.inertia[i] * self.omega[i] ** 2
            self.out[7, i] = self.body_energy(i)
            self.out[8, i] = self.drag_work[i]
