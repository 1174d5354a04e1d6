"""Which bond breaks first (docs/bonds.md, "Which bond breaks first"): the peak stresses a run's
break check sees, and the weakest-link threshold they give.

A bond's strength enters nothing but its break check, so until the first break a run with
weaker bonds is the same run, bit for bit, as one with unbreakable bonds. With bond ``i``'s
strengths ``S w_i`` (tensile and shear alike: ``w_i`` its Weibull factor) and ``p_i`` the
largest of its tensile and shear stress the check saw in the unbreakable run, a bond breaks
within that time if and only if ``S < max_i p_i / w_i =: S_c``, and a hair below ``S_c`` the
first to break is the bond of the maximum, at the stress it peaked at. Exact: the test
asserts it a hair either side of ``S_c``.
"""

from __future__ import annotations

import numpy as np
import pytest

import melange_ti as mt
from melange_ti.io.hdf5 import read_run
from melange_ti.model import Model
from melange_ti.physics.effects.bonds import Bond
from melange_ti.scene import loads

from .test_bonds import struck_row

STEPS = 400  # 2 time units: the striker's blow runs along the row
BIG = 1e6  # strengths no stress reaches


def bonds_after(strength: float, steps: int = STEPS) -> np.ndarray:
    # seed 11: the first to break is neither the most stressed bond nor the weakest
    text = struck_row().replace("seed = 4", "seed = 11").replace("tensile_strength = 0.3", f"tensile_strength = {strength!r}")
    text = text.replace("shear_strength = 0.3", f"shear_strength = {strength!r}")
    m = Model(loads(text))
    m.advance(steps)
    t = m.own_rows("bonds")
    return t[t[:, Bond.A] >= 0]


@pytest.fixture(scope="module")
def unbreakable():
    return bonds_after(BIG)


def test_the_peaks_are_the_largest_stress_the_check_saw(unbreakable):
    t = unbreakable
    assert np.all(t[:, Bond.INTACT] == 1.0)
    # a blow runs along the row: every bond feels it, each in tension or shear at some step
    assert np.all(t[:, Bond.PEAK_SIG] > 0.0) and np.all(t[:, Bond.PEAK_TAU] > 0.0)
    # the peak only grows: a longer run's peaks are at least the shorter run's
    later = bonds_after(BIG, STEPS + 100)
    assert np.all(later[:, Bond.PEAK_SIG] >= t[:, Bond.PEAK_SIG])
    assert np.all(later[:, Bond.PEAK_TAU] >= t[:, Bond.PEAK_TAU])


def test_the_first_break_is_the_weakest_link_of_the_peaks(unbreakable):
    t = unbreakable
    w = t[:, Bond.ST] / BIG  # the seed's Weibull factors (shear's the same)
    np.testing.assert_allclose(t[:, Bond.SS] / BIG, w, rtol=1e-15)
    assert w.std() > 0.05, "the case needs a spread of strengths"
    ratio = np.maximum(t[:, Bond.PEAK_SIG], t[:, Bond.PEAK_TAU]) / w
    first = int(np.argmax(ratio))
    s_c = float(ratio[first])
    # the case tells the rule apart: the bond that breaks first is neither the most stressed nor the weakest
    assert first != int(np.argmax(np.maximum(t[:, Bond.PEAK_SIG], t[:, Bond.PEAK_TAU]))) and first != int(np.argmin(w))

    above = bonds_after(s_c * (1.0 + 1e-9))
    assert np.all(above[:, Bond.INTACT] == 1.0), "a hair above S_c nothing breaks"

    below = bonds_after(s_c * (1.0 - 1e-9))
    broken = np.flatnonzero(below[:, Bond.INTACT] < 0.5)
    assert broken.size >= 1, "a hair below S_c a bond breaks"
    ages = below[broken, Bond.AGE]  # the step each broke at
    firsts = broken[ages == ages.min()]
    assert firsts.tolist() == [first]
    # at the very stress it peaked at in the unbreakable run
    assert below[first, Bond.BREAK_SIG] == t[first, Bond.PEAK_SIG] or below[first, Bond.BREAK_TAU] == t[first, Bond.PEAK_TAU]
    stress = max(below[first, Bond.BREAK_SIG] / w[first], below[first, Bond.BREAK_TAU] / w[first])
    assert stress == pytest.approx(s_c, rel=1e-12)


def test_the_run_file_holds_the_peaks(tmp_path, unbreakable):
    text = (
        struck_row(duration=2.0).replace("seed = 4", "seed = 11").replace("tensile_strength = 0.3", f"tensile_strength = {BIG!r}")
    )
    text = text.replace("shear_strength = 0.3", f"shear_strength = {BIG!r}")
    out = tmp_path / "run.h5"
    mt.run(loads(text), out, overwrite=True)
    b = read_run(out)["bonds"]
    np.testing.assert_array_equal(b["peak_stress"], unbreakable[:, Bond.PEAK_SIG])
    np.testing.assert_array_equal(b["peak_shear"], unbreakable[:, Bond.PEAK_TAU])
