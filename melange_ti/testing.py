"""What the tests and the validation scripts share: scenes of a few explicit icebergs written as
a user would, a model's first impulse read off its velocities and contact columns, a period
from zero crossings, and the contact law of docs/model.md written again in numpy,
independently of the kernels, to check them against.

Nothing here is used by a run; it is importable so that ``tests/`` and ``validation/`` use one
copy (validation scripts do not import from ``tests/``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from . import scene as scene_mod
from .geometry import area_centroid, below, rectangle  # noqa: F401  (rectangle: the tests' and validation's)
from .physics.data.schema import STATE_NAMES
from .scene import dumps_toml


# ---------------------------------------------------------------- scenes
def make_scene(
    effects: Iterable[str],
    bergs: Iterable[Mapping[str, float]],
    physics: Mapping | None = None,
    *,
    contacts: Mapping | None = None,
    dt: float = 0.01,
    name: str = "physics",
) -> scene_mod.Scene:
    """A validated scene of the ``[[iceberg]]`` tables ``bergs`` (one step long; every output
    interval one step), with ``[physics]`` and ``[contacts]`` values as given."""
    doc = {
        "scene": {"name": name, "effects": list(effects)},
        "physics": dict(physics or {}),
        "contacts": dict(contacts or {}),
        "time": {"dt": dt, "duration": dt},
        "output": {"snapshot_interval": dt, "diagnostic_interval": dt, "checkpoint_interval": dt},
        "iceberg": [{k: (v if k == "vertices" else float(v)) for k, v in b.items()} for b in bergs],
    }
    return scene_mod.loads(dumps_toml(doc))


def initial(sc: scene_mod.Scene) -> dict[str, np.ndarray]:
    """The scene's initial state, ``{x, z, theta, vx, vz, omega}`` as float arrays (N,)."""
    b = sc.icebergs()
    return {k: np.array(getattr(b, k), dtype=float) for k in STATE_NAMES}


def kinetic(s: Mapping[str, np.ndarray], idx: Iterable[int], mass, inertia) -> float:
    """Kinetic energy of the bodies ``idx`` of state ``s``."""
    return sum(0.5 * mass[q] * (s["vx"][q] ** 2 + s["vz"][q] ** 2) + 0.5 * inertia[q] * s["omega"][q] ** 2 for q in idx)


def point_velocity(s: Mapping[str, np.ndarray], q: int, r) -> np.ndarray:
    """Velocity of the point at arm ``r`` (from the centre, world frame) of body ``q`` of state ``s``."""
    return np.array([s["vx"][q] - s["omega"][q] * r[1], s["vz"][q] + s["omega"][q] * r[0]])


def zero_crossing_period(t: np.ndarray, y: np.ndarray, least: int = 3) -> float:
    """Period of an oscillation ``y(t)`` from the mean spacing of its zero crossings (linear
    interpolation between samples); NaN with fewer than ``least`` crossings."""
    idx = np.flatnonzero(np.signbit(y[1:]) != np.signbit(y[:-1]))
    if idx.size < max(2, least):
        return float("nan")
    tc = t[idx] + (t[idx + 1] - t[idx]) * y[idx] / (y[idx] - y[idx + 1])
    return float(2.0 * (tc[-1] - tc[0]) / (tc.size - 1))


def first_impulse(m, steps: int = 40):
    """Step one at a time until an impulse is applied: (state before, after, totals before, after)."""
    for _ in range(steps):
        b, tb = m.state(), m.totals()
        m.advance(1)
        a, ta = m.state(), m.totals()
        if ta.impulses > tb.impulses:
            return b, a, tb, ta
    raise AssertionError(f"no impulse within {steps} steps")


def corner_x(width: float, thickness: float, theta: float) -> float:
    """How far a rectangle's leftmost corner lies left of its centre at tilt ``theta``."""
    return 0.5 * width * abs(np.cos(theta)) + 0.5 * thickness * abs(np.sin(theta))


# ---------------------------------------------------------------- contacts read off a model
@dataclass(frozen=True)
class ContactSeen:
    """A contact of body ``i`` (partner ``j``, -1 for the wall) as the step's impulse pass met
    it: point ``p`` and unit normal ``n`` (from j to i), read from the model's contact columns."""

    i: int
    j: int
    p: np.ndarray
    n: np.ndarray


def contacts_seen(m) -> list[ContactSeen]:
    """The contacts the last step found (its last detection round): the wall's and each body's
    partners j > i. The narrow phase alone writes these columns, so after a step they hold the
    contacts its impulse pass used (a step with one detection round)."""
    from .physics.data.schema import Body, BodyInt, Contact, Param

    a = m.arrays
    b, bi, cd, cp = a.b.to_numpy(), a.bi.to_numpy(), a.cd.to_numpy(), a.cp.to_numpy()
    wall_x = float(a.par.to_numpy()[Param.WALL_X])
    seen = []
    for i in range(b.shape[0]):
        if m.fx.wall and bi[i, BodyInt.WALL_ON]:
            seen.append(ContactSeen(i, -1, np.array([wall_x, b[i, Body.WALL_PZ]]), np.array([1.0, 0.0])))
        for s in range(bi[i, BodyInt.NCONTACT] if m.fx.collisions else 0):
            p = np.array([cd[s, i, Contact.PX], cd[s, i, Contact.PZ]])
            seen.append(ContactSeen(i, int(cp[s, i]), p, np.array([cd[s, i, Contact.NX], cd[s, i, Contact.NZ]])))
    return seen


# ---------------------------------------------------------------- the contact law, again
def cross(r: np.ndarray, d: np.ndarray) -> float:
    return float(r[0] * d[1] - r[1] * d[0])


def contact_matrix(n: np.ndarray, arms: Iterable[tuple[np.ndarray, float, float]]) -> np.ndarray:
    """``K``, the 2x2 effective-mass matrix of a contact point in the frame ``(n, t)``,
    ``t = (-n_z, n_x)``: ``K_ab = sum_k 1/m_k (a . b) + (r_k x a)(r_k x b) / I_k`` over the
    bodies ``(arm r_k, mass m_k, inertia I_k)`` of the contact (one for the wall)."""
    t = np.array([-n[1], n[0]])
    frame = (n, t)
    k = np.zeros((2, 2))
    for r, mass, inertia in arms:
        for x in range(2):
            for y in range(2):
                k[x, y] += float(frame[x] @ frame[y]) / mass + cross(r, frame[x]) * cross(r, frame[y]) / inertia
    return k


def newton_coulomb(k: np.ndarray, vn: float, vt: float, e: float, mu: float) -> tuple[float, float, str]:
    """``(J_n, J_t, regime)``: Newton's restitution with Coulomb friction at a contact point
    whose relative velocity ``(v_n, v_t)`` (approaching: ``v_n < 0``) changes by ``K J``.

    Stick: the impulse giving ``v_n' = -e v_n`` and ``v_t' = 0``, if ``|J_t| <= mu J_n``.
    Else slide on the cone's edge on the stick impulse's side, ``J_t = s mu J_n``, with
    ``J_n`` again from ``v_n' = -e v_n``. It can create energy (:func:`kept_restitution`)."""
    jn, jt = np.linalg.solve(k, [-(1.0 + e) * vn, -vt])
    if abs(jt) <= mu * jn:
        return float(jn), float(jt), "stick"
    side = float(np.sign(jt))
    jn = -(1.0 + e) * vn / (k[0, 0] + side * mu * k[0, 1])
    return float(jn), float(side * mu * jn), "slide"


def impact_gain(k: np.ndarray, vn: float, vt: float, jn: float, jt: float) -> float:
    """Kinetic energy the impulse ``(J_n, J_t)`` gives a pair: ``J . u + J . K J / 2``."""
    j = np.array([jn, jt])
    return float(j @ np.array([vn, vt]) + 0.5 * j @ k @ j)


def kept_restitution(k: np.ndarray, vn: float, vt: float, e: float, mu: float) -> float:
    """The restitution an impact keeps (docs/model.md, "An impact never creates energy"): ``e``
    where Newton's law with the cone creates no kinetic energy, else the largest ``e' < e`` at
    which it creates none, in closed form per regime. Sticking, the gain is
    ``(e'^2 M_nn v_n^2 - u . M u) / 2`` with ``M = K^-1``, zero at
    ``e' = sqrt(u . M u / (M_nn v_n^2))``; sliding on side ``s`` (``d = (1, s mu)``) it is
    ``J_n (d . u) + J_n^2 (d . K d) / 2``, zero at ``J_n = -2 (d . u) / (d . K d)``, that is
    ``e' = -J_n (K_nn + s mu K_nt) / v_n - 1``. The gain changes sign once over ``[0, e]`` (it
    is <= 0 at ``e' = 0``), so the root whose regime is the law's own there is the one."""
    jn, jt, _ = newton_coulomb(k, vn, vt, e, mu)
    if impact_gain(k, vn, vt, jn, jt) <= 64.0 * np.finfo(float).eps * 0.5 * vn * vn / k[0, 0]:  # as the kernel: past rounding
        return e
    u = np.array([vn, vt])
    m = np.linalg.inv(k)
    roots = [(float(np.sqrt(u @ m @ u / (m[0, 0] * vn * vn))), "stick", 0.0)]
    for side in (1.0, -1.0):
        d = np.array([1.0, side * mu])
        star = -2.0 * (d @ u) / (d @ k @ d)
        roots.append((float(-star * (k[0, 0] + side * mu * k[0, 1]) / vn - 1.0), "slide", side))
    for kept, regime, side in roots:
        if -1e-12 <= kept <= e + 1e-12:
            kept = min(max(kept, 0.0), e)
            jn, jt, got = newton_coulomb(k, vn, vt, kept, mu)
            if got == regime and (regime == "stick" or np.sign(jt) == side):
                return kept
    raise AssertionError(f"no restitution keeps the energy (K = {k.tolist()}, u = {vn}, {vt}, e = {e}, mu = {mu})")


def coulomb_impulse(k: np.ndarray, vn: float, vt: float, e: float, mu: float) -> tuple[float, float, str]:
    """``(J_n, J_t, regime)`` of the model's impact law with friction: :func:`newton_coulomb` at
    the restitution the impact keeps (:func:`kept_restitution`), so that it never creates
    kinetic energy; ``v_n' = -e' v_n``."""
    return newton_coulomb(k, vn, vt, kept_restitution(k, vn, vt, e, mu), mu)


# ---------------------------------------------------------------- floating stability, in numpy
# A polygon floating freely: at each orientation it sits at the water line that leaves the
# share ``r`` of it submerged; its potential energy there is ``-rho g r A z_B``, ``z_B`` the
# submerged part's centroid above the centre of mass. Clipped by Sutherland-Hodgman
# (:func:`..geometry.below`), independently of the model's edge-by-edge hydrostatics.
def rotated(poly: np.ndarray, theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return poly @ np.array([[c, s], [-s, c]])


def floating(poly: np.ndarray, r: float, theta: float) -> tuple[float, float, float]:
    """``(U / (rho g), z_G, x_B)`` of ``poly`` (about its centre of mass) turned by ``theta``
    and floating at the draft that submerges the share ``r`` of it, the water line at z = 0;
    ``x_B``: the submerged part's centroid from the centre of mass (0 at an equilibrium)."""
    p = rotated(poly, theta)
    total = area_centroid(p)[0]
    lo, hi = float(p[:, 1].min()), float(p[:, 1].max())
    for _ in range(64):  # bisection of the water line (to 2^-64 of the height)
        mid = 0.5 * (lo + hi)
        if area_centroid(below(p, mid))[0] < r * total:
            lo = mid
        else:
            hi = mid
    level = 0.5 * (lo + hi)
    a, xb, zb = area_centroid(below(p, level))
    return -a * zb, -level, xb


def floating_minimum(poly: np.ndarray, r: float, period: float = 2 * np.pi, grid: int = 1440) -> tuple[float, float]:
    """The global minimum of the floating potential over every orientation (``period``: the
    shape's rotational symmetry): ``(theta, z_G)``, from a sweep of ``grid`` angles refined
    by golden section, then (U being flat there) by bisection of the torque's root, ``x_B =
    0``, where it changes sign next to the minimum."""
    angles = np.linspace(0.0, period, grid, endpoint=False)
    u = [floating(poly, r, t)[0] for t in angles]
    k = int(np.argmin(u))
    a, b = angles[k] - period / grid, angles[k] + period / grid
    g = (np.sqrt(5.0) - 1.0) / 2.0
    for _ in range(80):
        c, d = b - g * (b - a), a + g * (b - a)
        if floating(poly, r, c)[0] < floating(poly, r, d)[0]:
            b = d
        else:
            a = c
    theta = 0.5 * (a + b)
    lo, hi = theta - 1e-5, theta + 1e-5
    f_lo = floating(poly, r, lo)[2]
    if f_lo * floating(poly, r, hi)[2] < 0:
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            f_mid = floating(poly, r, mid)[2]
            if f_mid * f_lo > 0:
                lo, f_lo = mid, f_mid
            else:
                hi = mid
        theta = 0.5 * (lo + hi)
    return float(theta), floating(poly, r, theta)[1]
