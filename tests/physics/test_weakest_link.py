"""A strength that knows its size (``physics.strength_size``; issue 50, item 4 in part).

Weakest-link theory (Weibull): a piece of ice of size ``l`` survives a stress ``s`` with
probability ``exp(-(l / l_ref) (s / s_0)^m)``, so its strength is Weibull of modulus ``m``
scaled by ``(l / l_ref)^(-1/m)``; and the weakest of ``n`` independent pieces of size
``l / n`` is distributed as one piece of size ``l`` (the minimum of ``n`` Weibull draws of
scale ``n^(1/m)`` is a Weibull draw of scale 1). So a joint cut into ``nz`` layers of cells is,
at its weakest layer, as strong as the joint whole: refining the cells does not weaken the
shelf, where strengths that ignore their size make it ``nz^(-1/m)`` weaker (0.76 for 4 layers
at m = 5).
"""

from __future__ import annotations

import numpy as np
import pytest

from melange_ti.physics.effects.bonds import Bond
from melange_ti.physics.effects.bonds.host import build, pairs
from melange_ti.scene import SceneError, loads

M = 5.0


def shelf(count: int, cells: str, size: float, seed: int = 3) -> str:
    return (
        '[scene]\neffects = ["gravity", "buoyancy", "bonds"]\n'
        f"[physics]\nbond_modulus = 10.0\nstrength_modulus = {M}\nstrength_size = {size}\n"
        f"[time]\ndt = 0.001\nseed = {seed}\n[shelf]\ncount = {count}\nbonded = true\nfront = 0\ncells = {cells}\n"
    )


def joint_strengths(text: str) -> np.ndarray:
    """Each joint's weakest bond's tensile strength (the joints between pieces, in order)."""
    sc = loads(text)
    b = sc.icebergs()
    got, bad = pairs(sc, b)
    assert bad is None
    t = build(sc, b, got)
    t = t[t[:, Bond.A] >= 0]
    a, bb = t[:, Bond.A].astype(int), t[:, Bond.B].astype(int)
    piece = b.parent if b.parent is not None else np.arange(b.count)
    joint = (bb >= 0) & (piece[a] != piece[np.maximum(bb, 0)])
    left = piece[a][joint]
    st = t[joint, Bond.ST]
    return np.array([st[left == k].min() for k in np.unique(left)])


def test_each_bond_is_scaled_by_its_size():
    """The same draws (the same seed and bond order), scaled by ``(l / l_ref)^(-1/m)``."""
    plain = loads(shelf(6, "[2, 2]", 0.0))
    sized = loads(shelf(6, "[2, 2]", 1.4))
    b = plain.icebergs()
    got, _ = pairs(plain, b)
    t0, t1 = build(plain, b, got), build(sized, b, got)
    length = t0[:, Bond.LEN]
    np.testing.assert_allclose(t1[:, Bond.ST], t0[:, Bond.ST] * (length / 1.4) ** (-1 / M), rtol=1e-12)
    np.testing.assert_allclose(t1[:, Bond.SS], t0[:, Bond.SS] * (length / 1.4) ** (-1 / M), rtol=1e-12)
    assert {round(v, 12) for v in length} == {0.5, 0.7}  # two sizes of face


def test_a_joint_of_layers_is_as_strong_as_the_joint_whole():
    """1500 joints whole (one bond of face 1.4 each) and cut into 4 layers (faces of 0.35):
    with ``strength_size = 1.4`` the weakest layer of each joint has the whole joint's
    strength distribution (mean and spread within 4 standard errors of their estimates;
    two independent samples); without it the layered joints are ``4^(-1/5) = 0.76`` as strong."""
    whole = joint_strengths(shelf(1501, "[1, 1]", 1.4, seed=3))
    layers = joint_strengths(shelf(1501, "[1, 4]", 1.4, seed=4))
    blind = joint_strengths(shelf(1501, "[1, 4]", 0.0, seed=4))
    n = whole.size
    assert n == layers.size == 1500
    se_mean = np.hypot(whole.std(), layers.std()) / np.sqrt(n)
    assert abs(layers.mean() - whole.mean()) < 4 * se_mean, (layers.mean(), whole.mean(), se_mean)
    se_std = np.hypot(whole.std(), layers.std()) / np.sqrt(2 * (n - 1))  # normal-theory; Weibull m = 5 is near it
    assert abs(layers.std() - whole.std()) < 4 * se_std, (layers.std(), whole.std())
    assert blind.mean() / whole.mean() == pytest.approx(4 ** (-1 / M), rel=0.03)


def test_a_negative_size_is_refused():
    with pytest.raises(SceneError, match=r"physics.strength_size = -1.*>= 0"):
        loads(shelf(3, "[1, 1]", -1.0))
