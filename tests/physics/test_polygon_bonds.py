"""Bonds between polygons (issue 33; docs/bonds.md): an intact shelf cut by tilted faces.

A bond sits on the face two icebergs share at t = 0, whatever their outlines. Its normal,
length and span are checked against the parallelograms' own geometry; its stiffness
against the small oscillations of a pair bonded across a tilted face, derived here: the
bond's springs ``k_n = E L / s``, ``k_s = G L / s``, ``k_b = E L^3 / (12 s)`` on the relative
motion of its two points (normal, along the face, turning) give ``K = J^T diag(k) J``, with
``J`` written out below from the arms and the normal, and the pair's masses and moments of
inertia ``M`` from the parallelogram's formulas (not the model's outline): every mode
``K phi = omega^2 M phi`` rings at the kick-drift step's ``(2 / dt) asin(omega dt / 2)``,
alone. A tilted face couples the springs (its normal is not along the line of centres), so
no mode is the rectangles' plain stretch.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import eigh

from melange_ti.geometry import world_outlines
from melange_ti.model import Model
from melange_ti.physics.effects.bonds import POISSON, Bond
from melange_ti.scene import DENSITY_RATIO, loads
from melange_ti.testing import zero_crossing_period

from .test_bonds import budget, in_every_form, momenta, run_text, same_bits_breaking_some

R = DENSITY_RATIO
E = 1420.7  # the default bond_modulus
W, H, ALPHA = 1.0, 1.4, 0.3
DT = 0.0005


def parallelogram(w=W, h=H, alpha=ALPHA) -> np.ndarray:
    """Corners about the centroid, counter-clockwise from the lower right: horizontal top and
    bottom, both side faces leaning by ``alpha`` (top to +x), ``w`` apart horizontally."""
    s = 0.5 * h * math.tan(alpha)
    return np.array([[0.5 * w - s, -0.5 * h], [0.5 * w + s, 0.5 * h], [-0.5 * w + s, 0.5 * h], [-0.5 * w - s, -0.5 * h]])


def pair_scene(velocities, duration=0.6) -> str:
    """Two parallelograms side by side, A's right face B's left, bonded across it; only the
    bonds act (no gravity, no water); velocities ``(vx, vz, omega)`` of A then B."""
    corners = parallelogram().tolist()
    va, vb = [float(v) for v in velocities[:3]], [float(v) for v in velocities[3:]]
    return (
        '[scene]\nname = "tilted_pair"\neffects = ["bonds"]\n'
        "[physics]\nbond_damping = 0.0\ntensile_strength = 1e6\nshear_strength = 1e6\n"
        f"[time]\ndt = {DT}\nduration = {duration}\n"
        f"[output]\nsnapshot_interval = {2 * DT}\ndiagnostic_interval = {2 * DT}\n"
        f"[[iceberg]]\nx = 0.0\nz = 0.0\nvx = {va[0]!r}\nvz = {va[1]!r}\nomega = {va[2]!r}\nvertices = {corners}\n"
        f"[[iceberg]]\nx = {W}\nz = 0.0\nvx = {vb[0]!r}\nvz = {vb[1]!r}\nomega = {vb[2]!r}\nvertices = {corners}\n"
        "[[bond]]\na = 0\nb = 1\n"
    )


def modes():
    """``(omega (6,), phi (6, 6) M-orthonormal columns, M (6, 6))`` of the tilted pair,
    linearised about rest; coordinates ``(x_A, z_A, theta_A, x_B, z_B, theta_B)``."""
    m = R * W * H
    inertia = m * (W**2 + H**2 * (1 + math.tan(ALPHA) ** 2)) / 12.0  # sheared: u = u' + v tan(alpha)
    length, span = H / math.cos(ALPHA), W * math.cos(ALPHA)  # the face; the centres along its normal
    g, e_n = E / (2 * (1 + POISSON)), E / (1 - POISSON**2)  # shear modulus; plane strain
    k = np.diag([e_n * length / span, g * length / span, e_n * length**3 / (12 * span)])
    n = np.array([math.cos(ALPHA), -math.sin(ALPHA)])  # A's right face, outwards
    s = np.array([-n[1], n[0]])
    ra, rb = np.array([0.5 * W, 0.0]), np.array([-0.5 * W, 0.0])  # the face's middle from each centre

    def row(e):  # d(e . (p_B - p_A)) / d(coordinates); p = x + R(theta) r
        return np.array([-e[0], -e[1], -(e[1] * ra[0] - e[0] * ra[1]), e[0], e[1], e[1] * rb[0] - e[0] * rb[1]])

    jac = np.stack([row(n), row(s), [0, 0, -1, 0, 0, 1]])
    stiff = jac.T @ k @ jac
    mass = np.diag([m, m, inertia, m, m, inertia])
    w2, phi = eigh(stiff, mass)
    return np.sqrt(np.clip(w2, 0.0, None)), phi, mass


def test_a_bonded_cut_shelf_shares_every_cut():
    """An intact shelf cut at 0.3 rad: every neighbour bonded on its cut, no gap, the normal
    ``(cos a, -sin a)``, the face's length ``H / cos a``, the centres ``W cos a`` apart along
    it, the bond at the middle of the line of centres; the landward end bonded to the wall
    over its vertical face; with a spread about the tilt as well, every cut closed (the
    neighbour's corners on the iceberg's face to 1e-12)."""
    text = (
        '[scene]\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]\n'
        f"[shelf]\ncount = 10\nbonded = true\nbonded_wall = true\nfront = 0\ncut_tilt = {ALPHA}\n"
    )
    sc = loads(text)
    table = Model(sc).own_rows()
    on = table[table[:, Bond.A] >= 0]
    assert on.shape[0] == 10  # 9 cuts and the wall
    wall, cuts = on[on[:, Bond.B] < 0], on[on[:, Bond.B] >= 0]
    np.testing.assert_array_equal(cuts[:, Bond.B] - cuts[:, Bond.A], 1)
    np.testing.assert_allclose(cuts[:, [Bond.NU, Bond.NV]], [[math.cos(ALPHA), -math.sin(ALPHA)]] * 9, atol=1e-12)
    np.testing.assert_allclose(cuts[:, Bond.LEN], H / math.cos(ALPHA), rtol=1e-12)
    inner = cuts[1:-1]  # between two parallelograms (the shelf's ends are vertical)
    np.testing.assert_allclose(inner[:, Bond.SPAN], W * math.cos(ALPHA), rtol=1e-12)
    np.testing.assert_allclose(inner[:, [Bond.UA, Bond.VA]], [[0.5 * W, 0.0]] * 7, atol=1e-12)
    np.testing.assert_allclose(wall[0, [Bond.NU, Bond.NV, Bond.LEN]], [-1.0, 0.0, H], atol=1e-12)
    for spread in (0.0, 0.1):
        b = loads(text + f"cut_tilt_std = {spread}\nthickness_std = 0.0\n").icebergs()
        corners = world_outlines(b.x, b.z, b.theta, b.outline)
        for k in range(9):
            p, q = corners[k, 0], corners[k, 1]  # iceberg k's right face, bottom to top
            t = (q - p) / np.linalg.norm(q - p)
            for c in (corners[k + 1, 2], corners[k + 1, 3]):  # the neighbour's left face
                assert abs(t[0] * (c - p)[1] - t[1] * (c - p)[0]) < 1e-12, (spread, k)


@pytest.mark.parametrize("mode", [3, 4, 5])
def test_a_pair_bonded_across_a_tilted_face_rings_in_each_mode_alone(tmp_path, mode):
    """Started with the velocities of one elastic mode, the pair's coordinate in that mode
    oscillates at the kick-drift frequency of ``omega_k`` (within 0.1% over the run); the
    other modes, rigid and elastic, stay below 1e-3 of it; momentum and angular momentum
    constant to round-off; the budget to 1e-6 of the energy, as for the rectangles' turning
    pair (test_bonds.py: the bond's frame turns with A, so its energy is quadratic only to
    first order in the turn and the step's shadow energy keeps it to a share of the order
    of the turn; measured 3e-9 here, growing tenfold with a tenfold amplitude)."""
    omega, phi, mass = modes()
    assert omega[:3].max() < 1e-6 * omega[3]  # two translations and a turn of the pair
    v0 = 1e-3 * phi[:, mode] / np.abs(phi[:, mode]).max()
    d = run_text(tmp_path, pair_scene(v0))
    s = d["snapshots"]
    x = np.stack([s["x"][:, 0], s["z"][:, 0], s["theta"][:, 0], s["x"][:, 1], s["z"][:, 1], s["theta"][:, 1]], 1)
    q = (x - x[0]) @ mass @ phi  # each mode's coordinate (M-orthonormal phi)
    want = 2 * math.pi / ((2 / DT) * math.asin(omega[mode] * DT / 2))
    got = zero_crossing_period(s["time"], q[:, mode], least=6)
    assert abs(got / want - 1) < 1e-3, (mode, got, want)
    others = np.delete(q, mode, axis=1)
    assert np.abs(others).max() < 1e-3 * np.abs(q[:, mode]).max(), np.abs(others).max(0) / np.abs(q[:, mode]).max()
    for series in momenta(d):
        assert np.ptp(series) <= 1e-12 * max(1e-3, np.abs(series).max()), np.ptp(series)
    e = budget(d)
    assert np.ptp(e) < 1e-6 * e[0], np.ptp(e) / e[0]


CUT_SHELF = (
    '[scene]\nname = "cut_shelf"\neffects = ["gravity", "buoyancy", "drag", "collisions", "wall", "bonds"]\n'
    "[physics]\ntensile_strength = 0.2\nshear_strength = 0.2\nstrength_modulus = 5.0\n"
    "[time]\ndt = 0.01\nduration = 3.0\nseed = 4\n[output]\nsnapshot_interval = 0.5\ndiagnostic_interval = 0.1\n"
    "[shelf]\ncount = 12\nbonded = true\nbonded_wall = true\nfront = 3\ntilt = 0.2\ngap = 0.3\ncut_tilt = 0.25\n"
    "cut_tilt_std = 0.05\n"
)


@pytest.fixture(scope="module")
def cut_shelf_forms():
    """The cut shelf advanced 300 steps in every kernel form."""
    return in_every_form(CUT_SHELF, 300)


def test_a_cut_shelf_breaks_and_every_form_gives_the_same_bits(cut_shelf_forms):
    """Bonds between pieces cut at about 0.25 rad (each out of balance alone, its buoyancy
    off its centre of mass), at a strength of 0.2 (140 kPa at w = 70 m), the three free
    leaning icebergs in front tipping against the shelf: some bonds break, some hold, and
    the serial, parallel, grouped and island forms agree bit for bit."""
    same_bits_breaking_some(cut_shelf_forms)


def test_a_breaking_cut_shelf_closes_its_budget_at_every_instant(tmp_path):
    """With water, contacts, the wall and fracture (the free front icebergs rolling against
    the shelf break a bond): ``E + ledgers``, with ``E`` read at the step time (docs/model.md,
    "What the budget promises"), stays within 1e-3 of the largest energy released at every
    diagnostic time, and its largest departure shrinks with the step at least as fast as
    first order (what is left is the velocity changes the ledgers book whose half-kick
    offset they do not: the drag's and the dashpots' against the water's forces), the same
    bond breaking at the same time in both runs."""
    residual, breaks, released = {}, {}, {}
    for dt in (0.01, 0.005):
        d = run_text(tmp_path, CUT_SHELF.replace("dt = 0.01\n", f"dt = {dt}\n"), f"{dt}.h5")
        e = budget(d)
        residual[dt], breaks[dt] = e - e[0], d["bonds"]["break_time"]
        pe = d["diagnostics"]["potential_energy"]
        released[dt] = np.max(np.abs(pe[0] - pe))
    assert np.isfinite(breaks[0.01]).sum() >= 1
    np.testing.assert_array_equal(np.isfinite(breaks[0.01]), np.isfinite(breaks[0.005]))
    np.testing.assert_allclose(breaks[0.005], breaks[0.01], atol=0.011)
    for dt in residual:
        assert np.abs(residual[dt]).max() <= 1e-3 * released[dt], dt
    assert np.abs(residual[0.01]).max() >= 1.8 * np.abs(residual[0.005]).max()
