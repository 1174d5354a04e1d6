"""Linear water-wave theory for a heaving rectangle: the reference the ``waves`` effect's
radiation is checked against (docs/validation.md, "A heaving iceberg against linear theory").

A rectangle of ``beam`` and ``draft`` floats in water of ``depth`` and heaves with a small
amplitude at frequency ``omega``. Linear potential flow (the fluid inviscid, the motion
irrotational, the free surface linearised, two dimensions) gives the force on it as
``omega^2 a(omega) s + i omega b(omega) s`` for a heave ``s exp(-i omega t)``: ``a`` is the
added mass and ``b`` the radiation damping. :func:`heave_coefficients` computes them by
eigenfunction matching, the classical solution for rectangles in finite depth (Porter 2008,
"Calculation of the hydrodynamic coefficients for cylinders of rectangular cross-section
oscillating in the free surface", University of Bristol): outside the body the potential is
a sum of the propagating wave and the evanescent modes of the free-surface region; under it,
a particular solution that moves with the body's bottom plus the cosine modes of the gap to
the sea floor; the potential and the horizontal velocity are matched at the body's sides by
projection onto each region's modes. Units are the model's: ``rho_water = g = 1``, so ``a``
is in ``rho_w w^2`` and ``b`` in ``rho_w w^2 sqrt(g / w)`` per unit length.

Two checks of the solution are independent of the matching: ``b`` from the pressure on the
body equals ``b`` from the energy flux of the radiated waves (:func:`heave_coefficients`
returns both), and the added mass at every frequency gives the same infinite-frequency added
mass through the retardation function (Ogilvie's relation; :func:`free_decay`).

:func:`free_decay` gives linear theory's free heave decay of a block released from a lift,
in the time domain (Cummins' equation, the retardation function from ``b(omega)``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def wavenumbers(K: float, depth: float, n: int) -> tuple[float, np.ndarray]:
    """The propagating root ``k0`` of ``K = k tanh(k h)`` and the first ``n`` evanescent
    roots ``kappa`` of ``K = -kappa tan(kappa h)`` (one in each ``((j - 1/2) pi, j pi) / h``),
    by bisection (``K = omega^2 / g``)."""
    lo, hi = 0.0, K + np.sqrt(K / depth) + 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mid * np.tanh(mid * depth) < K else (lo, mid)
    j = np.arange(1, n + 1)
    a, b = (j - 0.5) * np.pi / depth, j * np.pi / depth
    for _ in range(100):
        mid = 0.5 * (a + b)
        low = K + mid * np.tan(mid * depth) < 0  # increasing from -inf to K on the interval
        a, b = np.where(low, mid, a), np.where(low, b, mid)
    return 0.5 * (lo + hi), 0.5 * (a + b)


@dataclass(frozen=True)
class HeaveSolution:
    """The matched potential of a unit heave (:func:`heave_solution`): outside, amplitudes
    ``A`` of the modes ``psi_n(z) exp(i k_n (|x| - a))``; under the body, ``B`` of
    ``cosh(lam_m x) / cosh(lam_m a) cos(lam_m (z + h))`` on the particular solution."""

    omega: float
    depth: float
    draft: float
    half_beam: float
    k: np.ndarray  # k_0 (real), then i kappa_n
    lam: np.ndarray  # m pi / (h - d)
    A: np.ndarray
    B: np.ndarray
    velocity: complex  # the heave velocity, -i omega

    def outside(self, x: float, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The potential and its x-derivative at ``x >= a`` (depths ``z`` in (-h, 0))."""
        h, k = self.depth, self.k
        zz = np.asarray(z, float)[:, None]
        psi = np.empty((zz.shape[0], k.size), complex)
        k0 = k[0].real  # cosh(k0 (z + h)) / cosh(k0 h), finite at large k0 h
        psi[:, 0] = (np.exp(k0 * zz) * (1 + np.exp(-2 * k0 * (zz + h))) / (1 + np.exp(-2 * k0 * h)))[:, 0]
        kap = k[1:].imag
        psi[:, 1:] = np.cos(kap[None, :] * (zz + h)) / np.cos(kap[None, :] * h)
        phase = np.exp(1j * k * (x - self.half_beam))
        return psi @ (self.A * phase), psi @ (1j * k * self.A * phase)

    def under(self, x: float, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The potential and its x-derivative at ``|x| <= a`` under the body (``z`` in
        (-h, -d))."""
        h, a, lam = self.depth, self.half_beam, self.lam
        e = h - self.draft
        zz = np.asarray(z, float)[:, None]
        ax = abs(x)
        # cosh(lam x) / cosh(lam a) and its x-derivative over lam, finite at large lam a
        ratio = np.exp(lam * (ax - a)) * (1 + np.exp(-2 * lam * ax)) / (1 + np.exp(-2 * lam * a))
        slope = np.sign(x) * np.exp(lam * (ax - a)) * (1 - np.exp(-2 * lam * ax)) / (1 + np.exp(-2 * lam * a))
        modes = np.cos(lam[None, :] * (zz + h))
        V = self.velocity
        phi = V * ((zz[:, 0] + h) ** 2 - x * x) / (2 * e) + modes @ (self.B * ratio)
        phi_x = -V * x / e + modes @ (self.B * lam * slope)
        return phi, phi_x


def heave_solution(omega: float, depth: float, draft: float, beam: float = 1.0, modes: int = 100) -> HeaveSolution:
    """The radiation potential of a rectangle heaving with unit amplitude at ``omega``, by
    eigenfunction matching with ``modes`` evanescent modes outside and ``modes`` cosine
    modes under the body (:class:`HeaveSolution`)."""
    h, d, a, N = float(depth), float(draft), 0.5 * float(beam), int(modes)
    if not 0 < d < h:
        raise ValueError(f"draft {d} must lie between 0 and the depth {h}")
    K = omega * omega
    k0, kap = wavenumbers(K, h, N)
    e = h - d  # the gap under the body
    lam = np.arange(N + 1) * np.pi / e
    sign = (-1.0) ** np.arange(N + 1)
    V = -1j * omega  # heave velocity of a unit heave
    k = np.concatenate([[k0 + 0j], 1j * kap])
    # outside: psi_n = cosh(k_n (z + h)) / cosh(k_n h); Q_n its norm over the depth,
    # ratio_n = sinh(k_n e) / cosh(k_n h), both written to stay finite at large k0 h
    Q = np.empty(N + 1, complex)
    Q[0] = h / (2 * np.cosh(min(k0 * h, 350.0)) ** 2) + np.tanh(k0 * h) / (2 * k0)
    Q[1:] = (h / 2 + np.sin(2 * kap * h) / (4 * kap)) / np.cos(kap * h) ** 2
    ratio = np.empty(N + 1, complex)
    ratio[0] = np.exp(-k0 * d) * (1 - np.exp(-2 * k0 * e)) / (1 + np.exp(-2 * k0 * h))
    ratio[1:] = 1j * np.sin(kap * e) / np.cos(kap * h)
    # D[n, m] = int_{-h}^{-d} psi_n(z) cos(lam_m (z + h)) dz
    D = k[:, None] * ratio[:, None] * sign[None, :] / (k[:, None] ** 2 + lam[None, :] ** 2)
    # under the body: V ((z + h)^2 - x^2) / (2 e) + sum_m B_m cosh(lam_m x) / cosh(lam_m a) cos(lam_m (z + h))
    P = np.empty(N + 1, complex)
    P[0] = V / (2 * e) * (e**3 / 3 - a * a * e)
    P[1:] = V * sign[1:] / lam[1:] ** 2
    norm = np.full(N + 1, e / 2)
    norm[0] = e
    slope = np.zeros(N + 1)
    slope[1:] = lam[1:] * np.tanh(lam[1:] * a)
    # unknowns: the outside amplitudes A_n, then the gap's B_m
    M = np.zeros((2 * N + 2, 2 * N + 2), complex)
    rhs = np.zeros(2 * N + 2, complex)
    M[: N + 1, : N + 1] = D.T  # the potential matched on the gap's modes
    M[: N + 1, N + 1 :] = -np.diag(norm)
    rhs[: N + 1] = P
    M[N + 1 :, : N + 1] = np.diag(1j * k * Q)  # the horizontal velocity on the outside modes
    M[N + 1 :, N + 1 :] = -D * slope[None, :]
    rhs[N + 1 :] = -V * a / e * D[:, 0]
    sol = np.linalg.solve(M, rhs)
    return HeaveSolution(omega, h, d, a, k, lam, sol[: N + 1], sol[N + 1 :], V)


def bottom_integral(sol: HeaveSolution) -> complex:
    """``int_{-a}^{a} phi(x, -d) dx``, the potential under the body's bottom, in closed form."""
    a, lam, B, V = sol.half_beam, sol.lam, sol.B, sol.velocity
    e = sol.depth - sol.draft
    sign = (-1.0) ** np.arange(lam.size)
    out = V / (2 * e) * (2 * a * e * e - 2 * a**3 / 3) + 2 * a * B[0]
    return out + np.sum(B[1:] * sign[1:] * 2 * np.tanh(lam[1:] * a) / lam[1:])


def heave_coefficients(omega: float, depth: float, draft: float, beam: float = 1.0, modes: int = 100):
    """Added mass, radiation damping (from the pressure) and radiation damping (from the
    radiated waves' energy flux) of a rectangle heaving at ``omega``, per unit length."""
    sol = heave_solution(omega, depth, draft, beam, modes)
    force = 1j * omega * bottom_integral(sol)  # the pressure i omega rho phi over the bottom
    k0, h = sol.k[0].real, sol.depth
    cg = omega / (2 * k0) * (1 + (2 * k0 * h / np.sinh(2 * k0 * h) if k0 * h < 350 else 0.0))
    # each side carries 0.5 rho g |eta|^2 cg, eta = i omega phi / g at the surface
    damping_far = 2 * cg * abs(sol.A[0]) ** 2
    return float(force.real / omega**2), float(force.imag / omega), float(damping_far)


def free_decay(
    mass: float,
    stiffness: float,
    lift: float,
    depth: float,
    draft: float,
    beam: float = 1.0,
    dt: float = 0.01,
    duration: float = 60.0,
    omega_max: float = 8.0,
    n_omega: int = 800,
    modes: int = 60,
) -> dict:
    """Linear theory's free heave of a block released from rest at ``lift`` above its
    equilibrium: ``(m + a_inf) z'' + int_0^t K(t - s) z'(s) ds + c z = 0`` (Cummins), with the
    retardation function ``K(t) = (2 / pi) int_0^inf b(omega) cos(omega t) d omega`` and
    ``a_inf`` from Ogilvie's relation ``a_inf = a(omega) + (1 / omega) int_0^inf K(t)
    sin(omega t) dt``, evaluated at four frequencies (their spread is returned as a check).
    Integrated by symplectic Euler at ``dt`` with the memory by the trapezoidal rule."""
    omegas = np.linspace(omega_max / n_omega, omega_max, n_omega)
    coef = np.array([heave_coefficients(w, depth, draft, beam, modes)[:2] for w in omegas])
    added, damping = coef[:, 0], coef[:, 1]
    t = np.arange(round(duration / dt) + 1) * dt
    # b is flat below the first frequency: that piece integrated as a rectangle
    kernel = (2 / np.pi) * (np.trapezoid(damping[None, :] * np.cos(np.outer(t, omegas)), omegas, axis=1) + damping[0] * omegas[0])
    ogilvie = []
    for w in (0.5, 1.0, 1.5, 2.0):
        i = int(np.argmin(np.abs(omegas - w)))
        ogilvie.append(added[i] + np.trapezoid(kernel * np.sin(omegas[i] * t), t) / omegas[i])
    a_inf = float(np.mean(ogilvie))
    z, v = np.zeros(t.size), np.zeros(t.size)
    z[0] = lift
    for i in range(t.size - 1):
        # int_0^t_i K(t_i - s) v(s) ds by the trapezoidal rule over s_j = j dt
        memory = dt * (np.dot(kernel[i::-1], v[: i + 1]) - 0.5 * kernel[0] * v[i] - 0.5 * kernel[i] * v[0]) if i else 0.0
        v[i + 1] = v[i] + dt * (-stiffness * z[i] - memory) / (mass + a_inf)
        z[i + 1] = z[i] + dt * v[i + 1]
    return {
        "t": t,
        "z": z,
        "a_inf": a_inf,
        "a_inf_spread": float(np.ptp(ogilvie)),
        "omega": omegas,
        "added_mass": added,
        "damping": damping,
    }


def decay(t: np.ndarray, z: np.ndarray, skip: int = 1) -> tuple[float, float]:
    """The period and the amplitude ratio per period of a decaying oscillation: from its
    positive maxima after the first ``skip`` (the spacing's mean, the geometric mean of
    successive ratios)."""
    i = np.flatnonzero((z[1:-1] > z[:-2]) & (z[1:-1] >= z[2:]) & (z[1:-1] > 0)) + 1
    i = i[skip:]
    if i.size < 3:
        raise ValueError("fewer than three maxima to measure a decay from")
    period = float(np.mean(np.diff(t[i])))
    ratio = float(np.exp(np.mean(np.diff(np.log(z[i])))))
    return period, ratio
