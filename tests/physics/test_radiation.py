"""Linear theory's heaving rectangle (``melange_ti.analysis.radiation``), the reference the
waves' radiation is compared with: checked against relations the eigenfunction matching does
not build in.

- Energy: the damping from the pressure on the body, ``Im F / omega``, equals the damping
  from the energy flux the radiated waves carry off both sides, ``2 c_g |eta|^2 / omega^2``
  per unit heave (rho = g = 1).
- Long waves: a body of beam B heaving slowly in depth h pushes ``B z'/2`` of water to each
  side, a long wave of height ``B z' / (2 c)`` with ``c = sqrt(g h)``: ``b -> B^2 / (2 c)``.
- Causality: ``a(omega) + (1/omega) int K(t) sin(omega t) dt`` is the same at every
  frequency (Ogilvie), and it is the added mass at infinite frequency.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from melange_ti.analysis import radiation


@pytest.mark.parametrize(
    "omega, depth, draft, beam",
    [(0.3, 6.0, 0.8946, 1.0), (0.86, 6.0, 0.8946, 1.0), (1.5, 6.0, 0.8946, 1.0), (0.5, 2.0, 1.2, 1.0), (1.0, 10.0, 0.3, 3.0)],
)
def test_damping_from_pressure_is_the_radiated_energy_flux(omega, depth, draft, beam):
    added, damping, damping_far = radiation.heave_coefficients(omega, depth, draft, beam)
    assert added > 0 and damping > 0
    assert damping == pytest.approx(damping_far, rel=1e-8)


def test_long_wave_damping():
    depth, beam = 1.0, 1.0
    _, damping, _ = radiation.heave_coefficients(0.01, depth, 0.01, beam, modes=200)
    assert damping == pytest.approx(beam**2 / (2 * math.sqrt(depth)), rel=1e-3)


def test_coefficients_converge_with_modes():
    coarse = radiation.heave_coefficients(0.86, 6.0, 0.8946, modes=100)
    fine = radiation.heave_coefficients(0.86, 6.0, 0.8946, modes=400)
    assert coarse[0] == pytest.approx(fine[0], rel=2e-3)
    assert coarse[1] == pytest.approx(fine[1], rel=2e-3)


def test_retardation_function_is_causal_and_the_decay_measured():
    """Ogilvie's relation gives one infinite-frequency added mass from four frequencies, the
    matching's own at omega = 20; the free decay from it rings down at about the frequency
    where ``(m + a(omega)) omega^2 = c`` with the per-period ratio ``exp(-pi b / ((m + a)
    omega))`` of the oscillator with the coefficients frozen there (within 5%: they vary
    across the decaying signal's band)."""
    r = radiation.free_decay(mass=0.8946, stiffness=1.0, lift=0.05, depth=6.0, draft=0.8946, duration=40.0, n_omega=400, modes=40)
    assert r["a_inf_spread"] < 2e-3 * r["a_inf"]
    assert r["a_inf"] == pytest.approx(radiation.heave_coefficients(20.0, 6.0, 0.8946, modes=200)[0], rel=3e-3)
    period, ratio = radiation.decay(r["t"], r["z"])
    omega = 2 * math.pi / period
    added, damping, _ = radiation.heave_coefficients(omega, 6.0, 0.8946)
    assert (0.8946 + added) * omega**2 == pytest.approx(1.0, rel=0.05)
    assert ratio == pytest.approx(math.exp(-math.pi * damping / ((0.8946 + added) * omega)), rel=0.05)


def test_decay_of_a_damped_cosine():
    t = np.arange(0, 60, 0.001)
    z = np.exp(-0.05 * t) * np.cos(1.1 * t)
    period, ratio = radiation.decay(t, z)
    assert period == pytest.approx(2 * math.pi / 1.1, rel=1e-3)
    assert ratio == pytest.approx(math.exp(-0.05 * 2 * math.pi / 1.1), rel=1e-3)


@pytest.mark.parametrize("omega", [0.5, 0.86, 1.5])
def test_matched_potential_is_continuous_at_the_body_side(omega):
    """Rebuilt from the solution's modes at x = a: the potential and the horizontal velocity
    outside equal those under the body over the gap (-h, -d), and the velocity outside
    vanishes on the body's wall (-d, 0), up to the truncation the corner's singularity
    leaves at 100 modes (medians over the depth, relative to the largest value under the
    body)."""
    h, d, a = 6.0, 0.8946, 0.5
    sol = radiation.heave_solution(omega, h, d)
    gap = np.linspace(-h, -d, 402)[1:-1]
    phi_out, u_out = sol.outside(a, gap)
    phi_in, u_in = sol.under(a, gap)
    assert np.median(np.abs(phi_out - phi_in)) < 2e-3 * np.max(np.abs(phi_in))
    assert np.median(np.abs(u_out - u_in)) < 2e-2 * np.max(np.abs(u_in))
    _, u_wall = sol.outside(a, np.linspace(-d, 0.0, 202)[1:-1])
    assert np.median(np.abs(u_wall)) < 4e-2 * np.max(np.abs(u_in))


def test_bottom_force_closed_form_against_quadrature():
    """The closed form of the potential integrated over the body's bottom, which gives the
    force, against the trapezoidal rule over the rebuilt potential."""
    sol = radiation.heave_solution(0.86, 6.0, 0.8946)
    x = np.linspace(-0.5, 0.5, 4001)
    phi = np.array([sol.under(xx, np.array([-0.8946]))[0][0] for xx in x])
    closed = radiation.bottom_integral(sol)
    assert abs(np.trapezoid(phi, x) - closed) < 1e-6 * abs(closed)
