"""The paper scene written with pymunk (Chipmunk2D): an engine that shares none of the model's
contact code, for the physics (``validation/capsize_peer.py``: does the mélange jam there too?)
and for the speed (``melange-ti bench peers`` times it beside melange_ti).

:class:`PymunkMelange` is what a user would write without melange_ti: Chipmunk2D handles the
rigid bodies and their contacts, and every step a vectorised numpy function computes the exact
hydrostatic force and torque of each rectangle clipped at the water line (the same
Green's-theorem formula as the kernels, :func:`melange_ti.geometry.submerged_moments`) plus
linear drag, and hands them to Chipmunk as body forces. Gravity is Chipmunk's.

Differences from melange_ti that a reader should know (they do not change the cost much):
Chipmunk resolves contacts with its own iterative solver (``iterations``, default 10) on the
exact polygons rather than discs, with Baumgarte-style position correction; restitution is
the product of the two shapes' elasticities, so each shape gets ``sqrt(restitution)``;
friction is zero (the paper applies normal impulses only); drag is applied as an explicit
force (``v -= c v dt``) where melange_ti uses ``v /= 1 + c dt``.

pymunk is an optional dependency: ``pip install "melange_ti[peers]"`` (or ``pymunk>=6.6``).
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry import mass_inertia, potential_energy, submerged_moments
from ..scene.keys import DENSITY_RATIO


def have_pymunk() -> bool:
    try:
        import pymunk  # noqa: F401
    except ImportError:
        return False
    return True


class PymunkMelange:
    """The paper scene in pymunk: boxes, a wall, numpy buoyancy and drag every step.

    ``state`` is a dict of arrays ``x, z, theta, vx, vz, omega, width, thickness`` (N,), e.g.
    from :meth:`melange_ti.scene.Scene.icebergs` or a melange_ti model's state.
    """

    @classmethod
    def for_scene(cls, state: dict, scene) -> PymunkMelange:
        """The peer of a melange_ti ``scene`` (its physics and dt), from ``state``."""
        p = scene.physics
        return cls(
            state,
            density_ratio=p.density_ratio,
            restitution=p.restitution,
            drag=p.drag,
            angular_drag=p.angular_drag,
            water_level=p.water_level,
            wall_x=p.wall_x,
            dt=scene.time.dt,
        )

    def __init__(
        self,
        state: dict,
        density_ratio: float = DENSITY_RATIO,
        restitution: float = 0.5,
        drag: float = 0.01,
        angular_drag: float = 0.01,
        water_level: float = 0.0,
        wall_x: float | None = 0.0,
        dt: float = 0.01,
        iterations: int = 10,
    ):
        import pymunk

        self.pymunk = pymunk
        self.dt = dt
        self.r = density_ratio
        self.c_lin = drag
        self.c_ang = angular_drag
        self.wl = water_level
        self.width = np.asarray(state["width"], dtype=np.float64)
        self.thickness = np.asarray(state["thickness"], dtype=np.float64)
        self.n = len(self.width)
        self.mass, self.inertia = mass_inertia(self.width, self.thickness, density_ratio)
        space = pymunk.Space()
        space.gravity = (0.0, -1.0)
        space.iterations = iterations
        space.collision_slop = 1e-3  # the default 0.1 assumes pixels; ours are iceberg widths
        elast = math.sqrt(restitution)  # Chipmunk multiplies the two shapes' elasticities
        self.bodies = []
        for i in range(self.n):
            b = pymunk.Body(float(self.mass[i]), float(self.inertia[i]))
            b.position = (float(state["x"][i]), float(state["z"][i]))
            b.angle = float(state["theta"][i])
            b.velocity = (float(state["vx"][i]), float(state["vz"][i]))
            b.angular_velocity = float(state["omega"][i])
            shape = pymunk.Poly.create_box(b, (float(self.width[i]), float(self.thickness[i])))
            shape.elasticity = elast
            shape.friction = 0.0
            space.add(b, shape)
            self.bodies.append(b)
        if wall_x is not None:
            depth = 4.0 * float(self.thickness.max() + self.width.max())
            wall = pymunk.Poly(
                space.static_body,
                [(wall_x - depth, -depth), (wall_x, -depth), (wall_x, depth), (wall_x - depth, depth)],
            )
            wall.elasticity = elast
            wall.friction = 0.0
            space.add(wall)
        self.space = space
        self.steps = 0
        try:
            import pymunk.batch as batch

            self._batch = batch
            F = batch.BodyFields
            # The batch functions visit every body of the space, the wall's static body
            # included, in Chipmunk's order: find our bodies' rows once by id.
            ids = batch.Buffer()
            batch.get_space_bodies(space, F.BODY_ID, ids)
            order = list(memoryview(ids.int_buf()).cast("P"))
            where = {bid: k for k, bid in enumerate(order)}
            self._rows = np.array([where[b.id] for b in self.bodies], dtype=np.intp)
            self._identity = bool(np.array_equal(self._rows, np.arange(self.n)))
            self._nrows = len(order)
            self._get = batch.Buffer()
            self._set = batch.Buffer()
            self._forces = np.zeros((self._nrows, 3))
            self._set.set_float_buf(self._forces.reshape(-1))
            self._fields_get = F.POSITION | F.ANGLE | F.VELOCITY | F.ANGULAR_VELOCITY
            self._fields_set = F.FORCE | F.TORQUE
        except ImportError:  # pymunk < 6.6: one Python call per body
            self._batch = None

    def _read(self) -> np.ndarray:
        """(N, 6) array of x, z, theta, vx, vz, omega."""
        if self._batch is not None:
            self._get.clear()
            self._batch.get_space_bodies(self.space, self._fields_get, self._get)
            rows = np.frombuffer(self._get.float_buf(), dtype=np.float64).reshape(self._nrows, 6)
            return rows[: self.n] if self._identity else rows[self._rows]
        return np.array([(*b.position, b.angle, *b.velocity, b.angular_velocity) for b in self.bodies])

    def step(self) -> None:
        s = self._read()
        a, sx, _ = submerged_moments(s[:, 1], s[:, 2], 0.5 * self.width, 0.5 * self.thickness, self.wl)
        fx = -self.c_lin * self.mass * s[:, 3]
        fz = a - self.c_lin * self.mass * s[:, 4]
        tau = sx - self.c_ang * self.inertia * s[:, 5]
        if self._batch is not None:
            f = self._forces[: self.n] if self._identity else self._forces
            rows = slice(None) if self._identity else self._rows
            f[rows, 0] = fx
            f[rows, 1] = fz
            f[rows, 2] = tau
            self._batch.set_space_bodies(self.space, self._fields_set, self._set)
        else:
            for i, b in enumerate(self.bodies):
                b.force = (float(fx[i]), float(fz[i]))
                b.torque = float(tau[i])
        self.space.step(self.dt)
        self.steps += 1

    def advance(self, steps: int) -> None:
        for _ in range(steps):
            self.step()

    def state(self) -> dict[str, np.ndarray]:
        s = self._read().copy()
        return {k: s[:, j] for j, k in enumerate(("x", "z", "theta", "vx", "vz", "omega"))}

    def energy(self) -> float:
        """Kinetic plus potential energy (gravity and buoyancy), summed."""
        s = self.state()
        ke = 0.5 * self.mass * (s["vx"] ** 2 + s["vz"] ** 2) + 0.5 * self.inertia * s["omega"] ** 2
        pe = potential_energy(s["z"], s["theta"], self.width, self.thickness, self.r, self.wl)
        return float(ke.sum() + pe.sum())
