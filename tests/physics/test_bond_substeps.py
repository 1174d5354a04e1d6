"""The drift's sub-steps for the bonds (issue 50, item 8): ``physics.bond_substeps = n`` kicks
the bonds' forces and dashpots with ``h = dt / n`` and drifts in ``n`` sub-steps of ``h``, the
bonds' forces again at each, while every other force, the contacts and the break check act
once a step (docs/bonds.md, The time step). ``n = 1`` is the step without sub-steps to the bit:
the regression hashes (``tests/regression``, the bonded shelf among them) pin it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from melange_ti.model import Model
from melange_ti.physics.effects.bonds import Bond
from melange_ti.scene import DENSITY_RATIO, SceneError, loads

from .scenes import KERNEL_FORMS
from .test_bonds import E_N, E, H, budget, in_every_form, run_text, same_bits_breaking_some, struck_row


def free_pair(
    dt: float,
    n: int,
    duration: float,
    damping: float = 0.05,
    vx: float = 1e-3,
    strength: float = 1e6,
    tumbling: bool = True,
    snapshot: float = 0.08,
) -> str:
    """The tumbling, shearing pair of ``test_bonds`` with nothing but its bond (no water): its
    motion is the bond's alone, sampled every ``snapshot``."""
    return (
        '[scene]\nname = "pair"\neffects = ["bonds"]\n'
        f"[physics]\nbond_modulus = {E}\nbond_damping = {damping}\ntensile_strength = {strength}\nshear_strength = {strength}\n"
        f"bond_substeps = {n}\n[time]\ndt = {dt}\nduration = {duration}\n"
        f"[output]\nsnapshot_interval = {snapshot}\ndiagnostic_interval = {snapshot}\n"
        f"[[iceberg]]\nx = 0.0\nvx = {-vx}\nomega = {1e-3 if tumbling else 0.0}\n"
        f"[[iceberg]]\nx = 1.0\nvx = {vx}\nvz = {5e-4 if tumbling else 0.0}\n"
        "[[bond]]\na = 0\nb = 1\n"
    )


def test_the_substeps_of_a_pair_with_nothing_but_its_bond_are_the_fine_steps(tmp_path):
    """With no other force, ``n`` sub-steps of a step ``dt`` are ``n`` steps of ``dt / n``: the
    same kicks, dashpots and drifts in the same order (only ``dt (F / n)`` against ``(dt / n) F``
    rounds differently). A damped, tumbling pair at dt = 0.008 in 4 sub-steps against dt = 0.002:
    every snapshot within 1e-9 of the motion's scale, mid-run as at the end, the energies and
    ledgers alike, and both budgets closed to 1e-6 of the energy (the bond's energy as the
    sub-step keeps it, ``U - h/2 dU/dt``, with ``h`` = 0.002 in both)."""
    fine = run_text(tmp_path, free_pair(0.002, 1, 1.6), "fine.h5")
    split = run_text(tmp_path, free_pair(0.008, 4, 1.6), "split.h5")
    s, f = split["snapshots"], fine["snapshots"]
    assert s["time"].size == f["time"].size == 21
    np.testing.assert_allclose(s["time"], f["time"], rtol=0, atol=1e-12)
    for k in ("x", "z", "theta", "vx", "vz", "omega"):
        scale = np.abs(f[k]).max()
        assert scale > 0, k
        np.testing.assert_allclose(s[k], f[k], rtol=0, atol=1e-9 * scale, err_msg=k)
    g, h = split["diagnostics"], fine["diagnostics"]
    for k in ("bond_energy", "bond_damping_dissipated", "bond_offset_work"):
        np.testing.assert_allclose(g[k], h[k], rtol=0, atol=1e-9 * np.abs(h["bond_energy"]).max(), err_msg=k)
    assert g["bond_damping_dissipated"][-1] > 0.05 * budget(split)[0]  # the dashpots took a share
    for d in (split, fine):
        e = budget(d)
        assert np.ptp(e) < 1e-6 * e[0], np.ptp(e) / e[0]


def test_a_pair_stepped_past_the_bonds_limit_rings_at_the_substeps_frequency(tmp_path):
    """A step 2.4 times the bonds' stable limit is refused without sub-steps, naming
    ``physics.bond_substeps`` and how many; in 3 sub-steps the undamped pair, pulled apart,
    rings as the kick-drift step of ``h = dt / 3`` does: each sub-step turns its phase by
    ``theta = 2 asin(omega h / 2)`` (``omega^2 = 2 k_n / m``), so its stretch sampled once a step
    obeys ``d_(k+1) + d_(k-1) = 2 cos(3 theta) d_k`` (the step's map has trace ``2 cos(3 theta)``
    and determinant 1), which is asserted to 1e-9 from the run's every step, 200 of them (a
    period, 0.106, is under two steps of 0.081 here, so no zero crossing can be read); the
    budget stays closed to 1e-9."""
    with pytest.raises(SceneError, match="stable limit") as exc:
        loads(free_pair(0.05, 1, 0.1, damping=0.0, vx=0.01))
    limit = float(str(exc.value).split("stable limit ")[1].split(" ")[0])
    dt = round(2.4 * limit, 6)
    with pytest.raises(SceneError, match=r"^time\.dt = .*above the bonds' stable limit") as exc:
        loads(free_pair(dt, 1, 0.1, damping=0.0, vx=0.01))
    text = str(exc.value)
    assert "\n" not in text and "physics.bond_substeps >= 3" in text, text
    with pytest.raises(SceneError, match=r"over physics\.bond_substeps = 2, above the bonds' stable limit") as exc:
        loads(free_pair(dt, 2, 0.1, damping=0.0, vx=0.01))
    named = float(str(exc.value).split("use time.dt <= ")[1].split(",")[0])
    assert 1.9 * limit < named <= 2 * limit
    loads(free_pair(named, 2, 0.1, damping=0.0, vx=0.01))  # the step it names is accepted
    n = 3
    pair = free_pair(dt, n, 200 * dt, damping=0.0, vx=0.01, tumbling=False, snapshot=dt)
    d = run_text(tmp_path, pair, "past.h5")
    s = d["snapshots"]
    stretch = s["x"][:, 1] - s["x"][:, 0] - 1.0
    assert stretch.size == 201 and np.abs(stretch).max() > 0
    omega = math.sqrt(2 * E_N * H / (DENSITY_RATIO * H))
    theta = 2 * math.asin(omega * dt / n / 2)
    got = stretch[2:] + stretch[:-2]
    want = 2 * math.cos(n * theta) * stretch[1:-1]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * np.abs(stretch).max())
    assert abs(math.cos(n * theta) - math.cos(omega * dt)) > 0.01  # the sub-steps' own, told apart from the exact
    e = budget(d)
    assert np.ptp(e) < 1e-9 * e[0], np.ptp(e) / e[0]


def substepped_row(n: int = 2, dt: float = 0.01, duration: float = 2.0, snapshot: float = 0.5) -> str:
    return (
        struck_row(duration=duration, snapshot=snapshot)
        .replace("dt = 0.005", f"dt = {dt}")
        .replace("strength_modulus = 5.0\n", f"strength_modulus = 5.0\nbond_substeps = {n}\n")
    )


def test_every_form_gives_the_same_bits_with_substeps():
    """The struck row (floating, drag, contacts, bonds breaking under the blow) at twice its
    step in 2 sub-steps, 200 steps in every kernel form: the serial form's bits."""
    same_bits_breaking_some(in_every_form(substepped_row(), 200))


@pytest.mark.parametrize("form", ["serial", "device parts"])
def test_coloured_passes_with_substeps_give_the_parallel_forms_bits(form):
    """The coloured order (a device's default) with sub-steps: the struck row in 2 sub-steps,
    200 steps; the serial form and the device's parts on the CPU give the parallel form's state
    and bond table, bit for bit, with bonds broken and kept."""
    text = substepped_row().replace("[time]", '[contacts]\norder = "coloured"\n[time]')

    def run(**kw):
        m = Model(loads(text), **kw)
        m.advance(200)
        return m.state(), m.own_rows()

    state, table = run(mode="parallel")
    other, other_table = run(mode="serial") if form == "serial" else run(mode="parallel", device_parts=True)
    assert Model(loads(text)).fx.coloured and Model(loads(text)).substeps == 2
    for k in state:
        np.testing.assert_array_equal(other[k], state[k], err_msg=k)
    np.testing.assert_array_equal(other_table, table)
    intact = table[table[:, Bond.A] >= 0, Bond.INTACT]
    assert 0 < intact.sum() < intact.size, "the case must break some bonds and keep others"


def test_the_struck_rows_budget_closes_with_substeps(tmp_path):
    """The struck row in sub-steps: every other force and the contacts act once a step of 0.01,
    the bonds' forces every 0.005; the budget closes to 1e-4 of the striker's kinetic energy,
    as without sub-steps at 0.005 (``test_bonds``), with bonds broken."""
    d = run_text(tmp_path, substepped_row(snapshot=0.1))
    e = budget(d)
    assert np.isfinite(d["bonds"]["break_time"]).sum() >= 3
    assert abs(e[-1] - e[0]) < 1e-4 * e[0], (e[-1] - e[0]) / e[0]


@pytest.mark.parametrize("bad", ["0", "-1", "1.5", "true", '"2"'])
def test_bad_substeps_are_refused_in_one_line(bad):
    with pytest.raises(SceneError, match=r"physics\.bond_substeps") as exc:
        loads(free_pair(0.001, 1, 0.1).replace("bond_substeps = 1", f"bond_substeps = {bad}"))
    assert "\n" not in str(exc.value)


def test_a_scene_without_bonds_has_one_substep():
    """The key belongs to the bonds: a scene that does not name them steps as before."""
    text = free_pair(0.001, 4, 0.1).replace('effects = ["bonds"]', 'effects = ["gravity", "buoyancy"]')
    text = text[: text.index("[[bond]]")]
    assert Model(loads(text)).substeps == 1
    assert Model(loads(free_pair(0.004, 4, 0.1))).substeps == 4


assert KERNEL_FORMS  # the forms compared above (tests/physics/scenes.py)


def test_the_correction_predicts_a_contacts_gap_from_the_substeps_drift():
    """A bonded pair rings 3/8 of a period within one step of 4 sub-steps beside a third block
    ``g0`` away: B starts moving away from C and ends the step moving towards it, having
    drifted away and only part of the way back. The overlap correction predicts each contact's
    gap at the step's end from the velocities the bodies drifted with (``h`` times the
    sub-steps' sum), not ``dt`` times the final one, which would put the pair in overlap and
    push C: C must not move (the gap stays open)."""
    v0, g0, n = 0.1, 0.002, 4
    omega = math.sqrt(2 * E_N * H / (DENSITY_RATIO * H))  # the pair's k_n = E' t / L, t = H, L = 1; m = r H
    dt = 0.75 * math.pi / omega  # three eighths of a period: B turns round within the step
    text = (
        '[scene]\nname = "three"\neffects = ["bonds", "collisions"]\n'
        f"[physics]\nbond_modulus = {E}\nbond_damping = 0.0\nbond_substeps = {n}\n"
        f"[time]\ndt = {dt!r}\nduration = {10 * dt!r}\n[output]\nsnapshot_interval = {dt!r}\ndiagnostic_interval = {dt!r}\n"
        f"[[iceberg]]\nx = 0.0\nvx = {v0}\n[[iceberg]]\nx = 1.0\nvx = {-v0}\n[[iceberg]]\nx = {2.0 + g0!r}\n"
        "[[bond]]\na = 0\nb = 1\n"
    )
    m = Model(loads(text))
    before = m.state()
    m.advance(1)
    after = m.state()
    gap = after["x"][2] - after["x"][1] - 1.0
    assert gap > g0, "B drifted away from C over the step"
    assert after["vx"][1] > 0.5 * v0, "and ends it moving towards C"
    assert g0 - dt * after["vx"][1] < 0, "dt times the final velocity would have closed the gap"
    for k in ("x", "z", "theta", "vx", "vz", "omega"):
        assert after[k][2] == before[k][2], k
