"""A bonded slab against beam theory (effect ``bonds``): the three checks of issue #31 at a
test's size (``validation/bonds_beam.py`` runs them at full size, docs/validation.md "Bonds:
a floating beam"; its scene builder, formulas and rigid-block chain are used here).

The slab: blocks of width ``b = 0.4``, thickness 1, default modulus (plane strain), so
``1/beta = 4.78`` (sqrt(2) times the flexural length) holds 11.9 blocks (the issue's ">= 10"); half length ``5/beta``. Tolerances:

* against the formulas, the issue's (2% deflection and frequency, 5% breaking load);
* against the rigid-block chain (the same blocks and bonds as numpy linear algebra), 0.1% /
  0.2%: what is left is the geometric nonlinearity (slopes ~1e-3) and the settling's residue
  (drag 1 for 20 time units: e^-10);
* the breaking load is predicted at the bonds next to the load, x = b/2, where Hetenyi's
  moment is ``P / (4 beta) (1 - beta b)`` to first order: ``P_c = 4 beta sigma_t t^2 / 6 /
  (1 - beta b)`` (the second order, (beta b)^2 = 0.7%, is inside the 5%).
"""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

from ..conftest import ROOT

_spec = importlib.util.spec_from_file_location("bonds_beam", ROOT / "validation" / "bonds_beam.py")
bb = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bb)

B, T = 0.4, 1.0
BETA = bb.beta_of(bb.E0, T)
N = 2 * math.ceil(5 / BETA / B) + 1
P = bb.p_crit(bb.E0, T, bb.SIGMA_T) / (1 - BETA * B)
SETTLE = 20.0


@pytest.fixture(scope="module")
def settled(tmp_path_factory):
    """The slab settled under P with unbreakable bonds: (its file, its scene text, the
    deflection, down +, at each block's centre)."""
    path = tmp_path_factory.mktemp("bonds") / "settled.h5"
    delta = P / (bb.R * B)
    text = bb.slab(N, B, T, delta, duration=SETTLE, drag=1.0, zeta=0.05)
    out = bb.run_text(text, path)
    th = np.full(N, T)
    th[N // 2] += delta
    return path, text, -(out["snapshots"]["z"][-1] - (-bb.R * T + th / 2))


def test_point_load_settles_to_hetenyi(settled):
    _, _, w = settled
    x = (np.arange(N) - N // 2) * B
    wh = bb.hetenyi(x, P, BETA)
    w0h = wh[N // 2]
    assert w[N // 2] == pytest.approx(w0h, rel=0.02)
    near = np.abs(x) <= 3 / BETA  # the dip, and the uplift beyond 3 pi / (4 beta)
    assert np.abs(w - wh)[near].max() < 0.02 * w0h
    assert w[np.argmin(np.abs(x - math.pi / BETA))] < 0  # lifted where Hetenyi lifts it
    wd, _, _ = bb.discrete_static(N, B, T, P / (bb.R * B))
    np.testing.assert_allclose(w[near], wd[near], rtol=0, atol=1e-3 * w0h)


def test_first_bond_breaks_under_the_load_at_the_critical_load(settled, tmp_path):
    """Restarted from the settled state (so no dynamic overshoot), with the tensile strength
    5% above and 5% below the stress P makes by the formula: holds, then breaks, first at
    the two bonds of the loaded block."""
    path, text, _ = settled
    head = text.split("[[iceberg]]")[0]
    got = {}
    for factor in (1.05, 0.95):
        restart = head.replace(f"tensile_strength = {bb.UNBREAKABLE!r}", f"tensile_strength = {factor * bb.SIGMA_T!r}")
        restart = restart.replace(f"duration = {SETTLE!r}", "duration = 1.0") + f'\n[start]\nfile = "{path}"\ntime = {SETTLE!r}\n'
        out = bb.run_text(restart, tmp_path / f"restart_{factor}.h5")
        got[factor] = out["bonds"]
    assert np.all(np.isnan(got[1.05]["break_time"]))
    bt = got[0.95]["break_time"]
    assert not np.all(np.isnan(bt))
    first = np.nonzero(bt == np.nanmin(bt))[0]
    pairs = {(int(got[0.95]["a"][k]), int(got[0.95]["b"][k])) for k in first}
    assert pairs == {(N // 2 - 1, N // 2), (N // 2, N // 2 + 1)}  # where the moment peaks
    assert np.nanmin(bt) < 0.05  # at once: the settled stress, no overshoot


def test_flexural_gravity_mode(tmp_path):
    """The first symmetric free-free mode (k L = 4.730) of a free slab 20 w long, excited by
    an initial velocity in its shape (the bonds at rest in the flat slab), no drag, no
    dashpot: its frequency from zero crossings in each half of 4 periods."""
    row, _ = bb.mode_run(0.5, T, 20.0, bb.FREE_FREE[0], periods=4.0, snapshot=0.1, work=tmp_path)
    for half in ("first_half", "second_half"):
        assert row[f"omega_{half}"] == pytest.approx(row["omega_theory"], rel=0.02)
        assert row[f"omega_{half}"] == pytest.approx(row["omega_discrete"], rel=2e-3)
    assert row["omega_first_half"] == pytest.approx(row["omega_second_half"], rel=1e-3)  # undamped, linear
    assert row["bending_share"] > 0.2  # the bending term matters: without it omega is 1.057


@pytest.mark.parametrize("b, t, layers", [(0.5, 1.0, 1), (0.25, 0.5, 1), (0.25, 1.0, 2)])
def test_a_load_at_the_free_edge_breaks_the_slab_a_quarter_wave_in(b, t, layers, tmp_path):
    """A floating slab loaded at its free edge (issue 50, item 7): the semi-infinite beam's
    moment ``-(P / beta) e^(-beta x) sin(beta x)`` peaks at ``pi / (4 beta)``; settled, then
    restarted with the strength just below its largest stress, the slab breaks first within
    one block of it (every bond that breaks in that step), where the rigid-block chain puts
    its largest stress (the same bond), and the model's stresses are the chain's (0.5%); a
    slab of two layers of cells too, its joints' layer bonds carrying the bending as stretch
    (a layer's ``F_n / t_c + 6 |M_c| / t_c^2`` is the slab's surface stress ``6 M / t^2``)."""
    row = bb.edge_run(b, t, work=tmp_path, layers=layers)
    peak = math.pi / (4 * bb.beta_of(bb.E0, t))
    assert row["first_breaks"] >= 1
    assert abs(row["first_break_x_min"] - peak) <= b and abs(row["first_break_x_max"] - peak) <= b
    assert row["peak_model"] == row["peak_discrete"]
    assert row["stress_model_over_discrete"] == pytest.approx(1.0, abs=5e-3)


_ispec = importlib.util.spec_from_file_location("impact_stress", ROOT / "validation" / "impact_stress.py")
im = importlib.util.module_from_spec(_ispec)
_ispec.loader.exec_module(im)


def test_a_head_on_impacts_peak_bond_stress_converges_in_the_step(tmp_path):
    """Issue 50, item 5 (docs/validation.md, "Impacts into elastic ice"): a block striking a
    bonded slab end-on; a rigid impulse is a velocity jump, which a bond answers as a spring
    over its period, so the peak bond stress is the same at half the step (1%) and with twice
    the discs (flat faces meet flat: 0.1%), and it is tension somewhere in the slab."""
    coarse = im.one("head-on", 0.005, 28, tmp_path)
    fine = im.one("head-on", 0.0025, 28, tmp_path)
    discs = im.one("head-on", 0.0025, 56, tmp_path)
    assert coarse["peak_tension"] > 0.05
    assert fine["peak_tension"] == pytest.approx(coarse["peak_tension"], rel=0.01)
    assert discs["peak_tension"] == pytest.approx(fine["peak_tension"], rel=1e-3)
