"""One shape: every iceberg is an outline (issue 48, item 1).

A rectangle given by its width and thickness and the same rectangle written out as its four
corners (:func:`melange_ti.geometry.rectangle`, from the lower right, counter-clockwise) are
one body, bit for bit, under every effect; every outline takes the one narrow phase with its
candidate lists; and one disc layout rule gives a rectangle the paper's discs and any other
outline ``discs // K`` per edge.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from melange_ti import scene
from melange_ti.geometry import disc_radius, polygon_disc_local, polygon_discs, rectangle
from melange_ti.model import Model
from melange_ti.physics.step.narrow import ENTRIES

from .scenes import make_scene

R = 0.8946
EVERY = ["gravity", "buoyancy", "drag", "form_drag", "added_mass", "collisions", "wall", "friction", "waves"]


def _parallelogram(w: float, t: float, lean: float) -> np.ndarray:
    """A w x t block whose upright faces lean by ``lean`` radians (same area), counter-clockwise
    from the lower right."""
    d = 0.5 * t * math.tan(lean)
    return np.array([[0.5 * w - d, -0.5 * t], [0.5 * w + d, 0.5 * t], [-0.5 * w + d, 0.5 * t], [-0.5 * w - d, -0.5 * t]])


def _row(by_corners: bool, w: float, n: int = 12, seed: int = 1, extra=None):
    """A row of n w x 1.4 w blocks 0.3 w apart, tilted and spinning at random (they capsize into
    each other and the wall), each given by width and thickness or by its four corners."""
    rng = np.random.default_rng(seed)
    bergs = []
    for k in range(n):
        b = {"x": 0.7 * w + 1.3 * w * k, "theta": float(rng.uniform(-0.1, 0.1)), "omega": float(rng.uniform(-0.3, 0.3))}
        b.update({"vertices": rectangle(w, 1.4 * w).tolist()} if by_corners else {"width": w, "thickness": 1.4 * w})
        bergs.append(b)
    return bergs + list(extra or [])


def _same_states(one: Model, two: Model, steps) -> None:
    for n in steps:
        one.advance(n)
        two.advance(n)
        a, b = one.state(), two.state()
        for key in a:
            assert np.array_equal(a[key], b[key]), (n, key)


@pytest.mark.parametrize("w", [1.0, 1.3])
def test_a_rectangle_by_its_corners_is_the_same_body_under_every_effect(w):
    """Twelve blocks capsizing into each other and the wall with every effect but the bonds
    (waves, form drag, added mass, friction): given by their corners (a scene whose kernels
    read outlines, in the parallel form) they follow the blocks given by width and thickness
    (in the serial form) bit for bit, mid-run and after capsizing."""
    physics = {"density_ratio": R, "friction": 0.3, "form_drag": 1.0, "added_mass": 0.5, "wall_x": 0.0}
    plain = Model(make_scene(EVERY, _row(False, w), physics), mode="serial")
    corners = Model(make_scene(EVERY, _row(True, w), physics), mode="parallel")
    assert plain.fx.vertices == 0 and corners.fx.vertices == 4  # two stores, one body
    _same_states(plain, corners, (1, 10, 200, 2000, 3000))
    assert np.abs(plain.state()["theta"]).max() > 1.0 and plain.totals().impulses > 100  # capsized, collided


def test_a_bonded_row_by_its_corners_is_the_same_body_in_waves():
    """Six 1.3 x 1.82 blocks bonded side by side in waves, the last one lifted: by corners and
    by width and thickness, bit for bit, bonds and all."""
    w = 1.3

    def bergs(by_corners):
        out = []
        for k in range(6):
            b = {"x": 0.5 * w + w * k, "vz": 0.05 if k == 5 else 0.0}
            b.update({"vertices": rectangle(w, 1.4 * w).tolist()} if by_corners else {"width": w, "thickness": 1.4 * w})
            out.append(b)
        return out

    def model(by_corners):
        doc = {
            "scene": {"name": "bonded", "effects": ["gravity", "buoyancy", "drag", "collisions", "bonds", "waves"]},
            "physics": {"density_ratio": R},
            "iceberg": bergs(by_corners),
            "bond": [{"a": k, "b": k + 1} for k in range(5)],
            "time": {"duration": 1.0},
        }
        return Model(scene.from_dict(doc), mode="serial")

    models = [model(False), model(True)]
    _same_states(*models, (1, 10, 100, 1500))
    assert np.abs(models[0].state()["omega"]).max() > 1e-3  # the shelf moved


def _outline_model():
    """A rectangle by its corners, a parallelogram leaning 20 degrees, a triangle and a
    pentagon, in pairs that touch (``_pairs``), with collisions and the wall."""
    tri = np.array([[0.5, -0.4], [0.0, 0.5], [-0.5, -0.4]])
    pent = np.array([[0.5, -0.3], [0.6, 0.3], [0.0, 0.7], [-0.6, 0.3], [-0.5, -0.3]])
    shapes = [rectangle(1.0, 1.4), _parallelogram(1.0, 1.4, math.radians(20)), tri, pent] * 3
    bergs = [{"x": 10.0 * k, "z": 0.0, "vertices": s.tolist()} for k, s in enumerate(shapes)]
    sc = make_scene(["collisions", "wall"], bergs, {"wall_x": -3.0}, contacts={"discs": 28, "max_partners": 64})
    return Model(sc)


@pytest.fixture(scope="module")
def outline_model():
    return _outline_model()


def _contacts_now(m):
    from melange_ti.physics.data.schema import BodyInt

    pairs, wall = m.contact_pairs()
    nc = m.arrays.bi.to_numpy()[:, BodyInt.NCONTACT]
    cd, cp = m.arrays.cd.to_numpy(), m.arrays.cp.to_numpy()
    return pairs, wall, [(cp[: nc[i], i].tobytes(), cd[: nc[i], i].tobytes()) for i in range(m.n)]


def test_a_rectangle_by_corners_and_a_parallelogram_take_the_one_narrow_phase(outline_model):
    """Each closing on its neighbour: both pairs are found by the narrow phase that keeps
    candidate lists (a kept entry naming the partner, with runs), and those lists give a fresh
    search's contacts bit for bit."""
    m = outline_model
    assert m.lists
    s = {k: v.copy() for k, v in m.state().items()}
    s["z"][:3] = 0.0
    s["theta"][:3] = 0.0
    s["x"][0] = 0.0
    k = m.constants()
    discs = []
    for q in range(3):
        corners = np.stack([k["corner_u"][q], k["corner_v"][q]], -1)[: k["corners"][q]]
        discs.append(polygon_disc_local(corners, 28))
    for q in (1, 2):  # each 0.005 of touching the one before (numpy discs, bisection), closing at 1
        s["vx"][q] = -1.0
        lo, hi = s["x"][q - 1], s["x"][q - 1] + 3.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            d = np.linalg.norm(discs[q][0] + (mid, 0.0) - (discs[q - 1][0] + (s["x"][q - 1], 0.0))[:, None], axis=2)
            lo, hi = (lo, mid) if d.min() - discs[q][1] - discs[q - 1][1] > 0.005 else (mid, hi)
        s["x"][q] = hi
    m.set_state(s)
    warm = _contacts_now(m)
    assert {(0, 1), (1, 2)} <= set(map(tuple, warm[0]))
    nl = m.arrays.nl.to_numpy()
    for i, j in ((0, 1), (1, 2)):
        entries = [e for e in range(ENTRIES) if nl[i, e] == j]
        assert entries and nl[i, ENTRIES + entries[0]] > 0, (i, j)  # a kept list with runs
    m.set_state(s)
    again = _contacts_now(m)  # from the kept lists
    m.clear_candidate_lists()
    assert again == _contacts_now(m) == warm


coord = st.floats(-1.0, 1.0)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.floats(0.6, 3.0),
    st.lists(coord, min_size=24, max_size=24),
    st.lists(st.floats(-7.0, 7.0), min_size=12, max_size=12),
    st.sampled_from([0.0, 1e-6, 1e-3, 0.02, 0.1]),
    st.lists(coord, min_size=36, max_size=36),
)
def test_candidate_lists_of_any_outline_give_the_searched_contacts(outline_model, spread, xz, theta, scale, move):
    """Twelve outlines of four shapes strewn about, their lists made, then moved (not at all,
    a little, past the skin): the contacts are bit for bit those of a fresh search."""
    m = outline_model
    xz, move = np.array(xz).reshape(2, 12), np.array(move).reshape(3, 12) * scale
    state = {k: v.copy() for k, v in m.state().items()}
    state.update(x=spread * 2.0 * xz[0], z=spread * 2.0 * xz[1], theta=np.array(theta))
    for k in ("vx", "vz", "omega"):
        state[k] = np.zeros(12)
    m.set_state(state)
    m.contact_pairs()  # lists made here
    moved = {**state, "x": state["x"] + move[0], "z": state["z"] + move[1], "theta": state["theta"] + move[2]}
    m.set_state(moved)
    warm = _contacts_now(m)
    m.clear_candidate_lists()
    assert warm == _contacts_now(m)


@pytest.mark.parametrize(("w", "t", "discs", "spacing"), [(1.0, 1.4, 28, 2.0), (1.3, 0.4, 12, 2.0), (0.7, 2.1, 60, 1.5)])
def test_one_disc_rule_gives_a_rectangle_the_papers_discs(w, t, discs, spacing):
    """The outline's rule on a rectangle's corners is the paper's, to the bit: ``discs / 4`` per
    face, radius ``L / (k spacing + 2)`` and the disc line inset by it."""
    r, inner, n = polygon_discs(rectangle(w, t), discs, spacing)
    assert r == disc_radius(w, t, discs, spacing)
    iu, iv = 0.5 * w - r, 0.5 * t - r
    assert np.array_equal(inner, np.array([[iu, -iv], [iu, iv], [-iu, iv], [-iu, -iv]]))
    assert n.tolist() == [discs // 4] * 4


@pytest.mark.parametrize("discs", [12, 28, 61])
def test_one_disc_rule_on_any_outline(discs):
    """A parallelogram, a triangle and a pentagon: ``discs // K`` discs on each of K edges, no
    neighbours farther apart than ``spacing r`` and, on the widest-spaced edge, exactly that
    (the smallest radius that keeps the rule)."""
    tri = np.array([[0.5, -0.4], [0.0, 0.5], [-0.5, -0.4]])
    pent = np.array([[0.5, -0.3], [0.6, 0.3], [0.0, 0.7], [-0.6, 0.3], [-0.5, -0.3]])
    for poly in (_parallelogram(1.0, 1.4, math.radians(25)), tri, pent):
        r, inner, n = polygon_discs(poly, discs, 2.0)
        assert r > 0 and n.tolist() == [discs // len(poly)] * len(poly)
        gaps = np.hypot(*(np.roll(inner, -1, 0) - inner).T) / n
        assert gaps.max() == pytest.approx(2.0 * r, rel=1e-12)
        assert np.all(gaps <= 2.0 * r * (1 + 1e-12))


def test_a_polygon_run_made_with_the_earlier_disc_rule_is_not_resumed(tmp_path):
    """A run file with polygons records the disc rule it was made with; one without the record
    (made before this rule: its discs laid out otherwise) is refused an extension in one line,
    and it and its checkpoint are left as they were; with the record, the same file extends."""
    import h5py

    import melange_ti as mt
    from melange_ti.errors import RunError
    from melange_ti.io.checkpoint import checkpoint_path
    from melange_ti.io.hdf5 import OUTLINE_DISCS, OUTLINE_DISCS_ATTR

    text = (
        '[scene]\neffects = ["gravity", "buoyancy", "drag", "collisions"]\n[time]\nduration = 0.5\n'
        "[output]\nsnapshot_interval = 0.25\ndiagnostic_interval = 0.25\ncheckpoint_interval = 0.25\n"
        f"[[iceberg]]\nx = 1.0\nvertices = {_parallelogram(1.0, 1.4, 0.3).tolist()}\n"
        "[[iceberg]]\nx = 2.4\nwidth = 1.0\nthickness = 1.4\n"
    )
    (tmp_path / "a.toml").write_text(text)
    path = tmp_path / "a.h5"
    mt.run(mt.load_scene(tmp_path / "a.toml"), path)
    with h5py.File(path, "r") as f:
        assert f.attrs[OUTLINE_DISCS_ATTR] == OUTLINE_DISCS
    old = tmp_path / "old.h5"
    old.write_bytes(path.read_bytes())
    checkpoint_path(old).write_bytes(checkpoint_path(path).read_bytes())
    with h5py.File(old, "r+") as f:
        del f.attrs[OUTLINE_DISCS_ATTR]
    before = (old.read_bytes(), checkpoint_path(old).read_bytes())
    with pytest.raises(RunError) as err:
        mt.extend(old, 1.0)
    message = str(err.value)
    assert "\n" not in message and "another rule" in message and "start it again" in message, message
    assert (old.read_bytes(), checkpoint_path(old).read_bytes()) == before
    mt.extend(path, 1.0)
    assert mt.open_run(path)["snapshots"]["time"].values[-1] == pytest.approx(1.0)
