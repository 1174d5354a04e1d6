"""The similarity-law analysis (melange_ti.analysis.similarity) on curves of known law."""

from __future__ import annotations

import math

import numpy as np
import pytest

from melange_ti.analysis import similarity as sim


def _diffusive(t, c):
    return 0.05 * np.sqrt(t / c)


def test_collapse_picks_the_scaling_the_curves_follow():
    t = np.linspace(1.0, 8000.0, 4000)
    curves = [sim.Curve(c, t, _diffusive(t, c)) for c in (0.0025, 0.01, 0.04)]
    good, (lo, hi) = sim.collapse_misfit(curves, "t / c")
    bad, _ = sim.collapse_misfit(curves, "t c")
    assert lo == pytest.approx(1.0 / 0.0025) and hi == pytest.approx(8000.0 / 0.04)
    assert good < 1e-3 * bad
    assert bad > 1.0  # in t c the same scaled time is 16x apart in t / c: sqrt(16) = 4x apart


def test_misfit_to_reference_only_where_late_and_overlapping():
    t = np.linspace(1.0, 8000.0, 4000)
    ref = sim.Curve(0.01, np.linspace(1.0, 60000.0, 20000), _diffusive(np.linspace(1.0, 60000.0, 20000), 0.01))
    others = [sim.Curve(c, t, _diffusive(t, c) + (t * c < 20) * 5.0) for c in (0.005, 0.04)]  # early: off
    good = sim.misfit_to_reference([ref, *others], ref, "t / c", late=20.0)
    assert set(good) == {0.005, 0.04} and max(good.values()) < 1e-3
    bad = sim.misfit_to_reference(others, ref, "t c", late=20.0)
    assert min(bad.values()) > 0.5
    early = sim.misfit_to_reference(others, ref, "t / c", late=0.0)
    assert min(early.values()) > 0.1  # the early offset counts when not cut


def test_no_overlap_is_nan():
    t = np.linspace(1.0, 10.0, 50)
    curves = [sim.Curve(0.001, t, t), sim.Curve(1.0, t, t)]
    assert math.isnan(sim.collapse_misfit(curves, "t / c")[0])


def test_fits_recover_known_laws():
    x = np.geomspace(1e4, 1e7, 50)
    a, beta = sim.fit_power_law(x, 0.049 * x**0.5)
    assert a == pytest.approx(0.049, rel=1e-10) and beta == pytest.approx(0.5, rel=1e-12)
    a, b = sim.fit_line(x, 0.195 + 0.0069 * x)
    assert a == pytest.approx(0.195, rel=1e-9) and b == pytest.approx(0.0069, rel=1e-12)
    with pytest.raises(ValueError):
        sim.fit_power_law(np.array([1.0, -1.0]), np.array([1.0, 1.0]))


def test_pooled_keeps_late_points_of_every_drag():
    runs = {
        0.01: [{"time": np.array([100.0, 1000.0, 2000.0]), "L": np.array([1.0, 2.0, 3.0])}],
        0.02: [{"time": np.array([100.0, 1000.0, 2000.0]), "L": np.array([4.0, 5.0, 6.0])}],
    }
    x, y = sim.pooled(runs, "L", "t / c", late=10.0)  # t c >= 10: t >= 1000 at 0.01, >= 500 at 0.02
    np.testing.assert_array_equal(x, [1e5, 2e5, 5e4, 1e5])
    np.testing.assert_array_equal(y, [2.0, 3.0, 5.0, 6.0])


def test_bootstrap_spread_is_zero_for_identical_runs_and_positive_for_scatter():
    x = np.geomspace(1e4, 1e6, 30)
    same = {0.01: [{"time": x * 0.01, "L": 0.05 * np.sqrt(x)}] * 4}

    def beta(runs):
        return [sim.fit_power_law(*sim.pooled(runs, "L", "t / c"))[1]]

    value, sd = sim.bootstrap(same, beta, samples=50)
    assert value[0] == pytest.approx(0.5, rel=1e-12) and sd[0] == pytest.approx(0.0, abs=1e-12)
    rng = np.random.default_rng(1)
    noisy = {0.01: [{"time": x * 0.01, "L": 0.05 * x ** rng.normal(0.5, 0.02)} for _ in range(6)]}
    value, sd = sim.bootstrap(noisy, beta, samples=100)
    assert 0.001 < sd[0] < 0.05
    again = sim.bootstrap(noisy, beta, samples=100)
    np.testing.assert_array_equal(again[1], sd)  # seeded: reproducible
