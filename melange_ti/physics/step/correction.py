"""Overlap correction: the overlap left after the drift is removed along the contact normal,
split by inverse mass so that the pair's centre of mass does not move (the paper: "move a
colliding pair back until they are just touching").

Sequential, in the impulse pass's order. The overlap of a pair is estimated from its gap when
found, the final velocities and the pushes so far (:func:`predicted_gap`); the wall's is
measured from the discs. Sweeps repeat (at most ``MAX_CORRECT``) until none pushes, so a
push that drives a body back into the wall or a third body is undone too. The potential
energy the pushes add is booked per moved body (``Acc.CORRECTION``, ``correction_work``).
A pair whose overlap a named effect holds (its ``kept`` term: a bond beside a crevasse's
walls, which touch through impulses) is not pushed. With crushing (effect ``crushing``) an
overlap is ice crushed at the contact: kept up to one disc radius (the smaller of the
pair's), only the rest pushed out (docs/model.md, "Crushing").
"""

import taichi as ti

from ..data.schema import Acc, Body, BodyInt, Contact, Param
from ..effects import KEPT, SUBSTEPPED
from ..numerics import TINY
from . import wall
from .forces import any_on, contact_mass, potential_energy
from .impulses import contact, contact_range, in_pass
from .pairs import normal_speed, relative_normal
from .terms import module as term_module
from .terms import term as term_of

MAX_CORRECT = 4  # correction sweeps while some overlap is still being pushed apart


def drift_sum(fx) -> tuple:
    """With sub-steps (``fx.substepped``): the body columns in which the sub-stepped effect named
    sums the velocities each sub-step drifted with (its kernel module's ``DRIFT_SUM``)."""
    return next(term_module(e).DRIFT_SUM for e in SUBSTEPPED if e.on(fx))


@ti.func
def predicted_gap(fx: ti.template(), a: ti.template(), i, j, px, pz, nx, nz, gap):
    """Gap of the contact (i, j) at the end of the step: its gap when found, advanced
    linearly with the final velocities (arms from the bodies' positions at the start of
    the step); with sub-steps, with the velocities the sub-steps drifted with, ``h`` times
    their sum each (:func:`drift_sum`). Call after the drift and before any correction."""
    b = ti.static(a.b)
    out = 0.0
    if ti.static(fx.substepped):
        h = a.par[Param.DT] / a.par[Param.SUBSTEPS]
        cx, cz, com = ti.static(drift_sum(fx))
        rx1 = px - (b[i, Body.X] - h * b[i, cx])
        rz1 = pz - (b[i, Body.Z] - h * b[i, cz])
        rx2 = px - (b[j, Body.X] - h * b[j, cx])
        rz2 = pz - (b[j, Body.Z] - h * b[j, cz])
        out = gap + h * relative_normal(a, i, j, cx, cz, com, rx1, rz1, rx2, rz2, nx, nz)
    else:
        dt = a.par[Param.DT]
        rx1 = px - (b[i, Body.X] - dt * b[i, Body.VX])
        rz1 = pz - (b[i, Body.Z] - dt * b[i, Body.VZ])
        rx2 = px - (b[j, Body.X] - dt * b[j, Body.VX])
        rz2 = pz - (b[j, Body.Z] - dt * b[j, Body.VZ])
        out = gap + dt * normal_speed(a, i, j, rx1, rz1, rx2, rz2, nx, nz)
    return out


@ti.func
def kept(fx: ti.template(), a: ti.template(), i, j) -> ti.i32:
    """1 if a named effect holds the overlap of the touching pair (i, j) (its ``kept`` term:
    a bond beside a crevasse's walls), which the correction then leaves."""
    out = 0
    for e in ti.static(KEPT):
        if ti.static(e.on(fx)):
            out = out | ti.static(term_of(e, "kept"))(a, i, j)
    return out


@ti.func
def push(fx: ti.template(), a: ti.template(), sweep, i, j, nx, nz, g_end, eager: ti.template()):
    """Remove the overlap left after the drift, split by inverse mass (pair centre fixed).

    Between two icebergs the overlap is ``g_end`` (:func:`predicted_gap`) plus the pushes
    so far along the normal; at the wall (j < 0, normal fixed) it is measured exactly from
    the discs. A body moved for the first time in this pass records its potential energy
    (``Body.POT_START``; with ``eager``, :func:`prepare_body` recorded it) and is marked
    with the sweep (``BodyInt.PUSHED``); the pass books the energy change per body. A pair
    a named effect holds (:func:`kept`) is left as it is; with crushing, only the overlap
    beyond one disc radius is pushed out (module docstring)."""
    b = ti.static(a.b)
    _m1, inv1, _i1 = contact_mass(fx, a, i)
    inv2 = 0.0
    g = 0.0
    if j >= 0:
        _m2, inv2, _i2 = contact_mass(fx, a, j)
        g = g_end + (b[i, Body.SHIFT_X] - b[j, Body.SHIFT_X]) * nx + (b[i, Body.SHIFT_Z] - b[j, Body.SHIFT_Z]) * nz
    else:
        g = wall.gap(a, i)
    pushed = 0
    held = 0
    if ti.static(any_on(KEPT, fx)):  # asked only of a pair that overlaps
        if g < -TINY and j >= 0:
            held = kept(fx, a, i, j)
    depth = -g
    if ti.static(fx.crushing):
        if g < -TINY and held == 0:
            # the overlap is ice crushed: kept up to one disc radius (deeper, the discs of
            # flat faces would pass through each other), the rest pushed out as without
            r = b[i, Body.RADIUS]
            if j >= 0:
                r = ti.min(r, b[j, Body.RADIUS])
            depth = -g - r
            if depth <= TINY:
                held = 1
    if g < -TINY and held == 0:
        pushed = 1
        if ti.static(not eager):
            if a.bi[i, BodyInt.PUSHED] < 0:
                b[i, Body.POT_START] = potential_energy(fx, a, i)
        a.bi[i, BodyInt.PUSHED] = sweep
        s1 = depth * inv1 / (inv1 + inv2)
        b[i, Body.X] += s1 * nx
        b[i, Body.Z] += s1 * nz
        b[i, Body.SHIFT_X] += s1 * nx
        b[i, Body.SHIFT_Z] += s1 * nz
        if j >= 0:
            if ti.static(not eager):
                if a.bi[j, BodyInt.PUSHED] < 0:
                    b[j, Body.POT_START] = potential_energy(fx, a, j)
            a.bi[j, BodyInt.PUSHED] = sweep
            s2 = depth * inv2 / (inv1 + inv2)
            b[j, Body.X] -= s2 * nx
            b[j, Body.Z] -= s2 * nz
            b[j, Body.SHIFT_X] -= s2 * nx
            b[j, Body.SHIFT_Z] -= s2 * nz
    return pushed


@ti.func
def prepare_body(fx: ti.template(), a: ti.template(), i, eager: ti.template()):
    """Before the sweeps: body i not pushed yet, and each of its contacts' end-of-step gap
    (stored in ``Contact.GAP``), once, before anything is pushed. With ``eager`` (the
    parallel form) also its potential energy (``Body.POT_START``), which the sweeps would
    otherwise record at its first push, sequentially: nothing moves it before then, so the
    bits are the same."""
    b = ti.static(a.b)
    cd = ti.static(a.cd)
    b[i, Body.SHIFT_X] = 0.0
    b[i, Body.SHIFT_Z] = 0.0
    a.bi[i, BodyInt.PUSHED] = -1  # the last sweep that moved body i
    if ti.static(eager):
        b[i, Body.POT_START] = potential_energy(fx, a, i)
    if ti.static(fx.collisions):
        for s in range(a.bi[i, BodyInt.NCONTACT]):
            cd[s, i, Contact.GAP] = predicted_gap(
                fx,
                a,
                i,
                a.cp[s, i],
                cd[s, i, Contact.PX],
                cd[s, i, Contact.PZ],
                cd[s, i, Contact.NX],
                cd[s, i, Contact.NZ],
                cd[s, i, Contact.GAP],
            )


@ti.func
def sweep_body(fx: ti.template(), a: ti.template(), sweep, i, eager: ti.template()):
    """One sweep's pushes of body i's contacts (wall, then partners j > i ascending:
    :func:`.impulses.contact_range`; coloured: those of the colour under way,
    :func:`.impulses.in_pass`); after the first sweep only contacts of a body moved in the
    previous one. Returns how many pushed."""
    since = sweep - 1
    pushed = 0
    first, last = contact_range(fx, a, i)
    for s in range(first, last):
        j, slot, _px, _pz, nx, nz, g_end = contact(fx, a, i, s)
        if in_pass(fx, a, i, slot):
            moved = a.bi[i, BodyInt.PUSHED]
            if j >= 0:
                moved = ti.max(moved, a.bi[j, BodyInt.PUSHED])
            if moved >= since:
                pushed += push(fx, a, sweep, i, j, nx, nz, g_end, eager)
    return pushed


@ti.func
def prepare_all(fx: ti.template(), a: ti.template()):
    """:func:`prepare_body` of every body, eager (the parallel form)."""
    for i in range(a.b.shape[0]):
        prepare_body(fx, a, i, True)


@ti.func
def sweeps(fx: ti.template(), a: ti.template(), eager: ti.template()):
    """The sweeps over every body, in body order, until one pushes nothing (sequential)."""
    n = a.b.shape[0]
    for sweep in range(MAX_CORRECT):
        pushed = 0
        for i in range(n):
            pushed += sweep_body(fx, a, sweep, i, eager)
        if pushed == 0:
            break


@ti.func
def sweeps_eager(fx: ti.template(), a: ti.template()):
    """:func:`sweeps` after :func:`prepare_all` (the parallel form without islands)."""
    sweeps(fx, a, True)


@ti.func
def energy_change(fx: ti.template(), a: ti.template(), i):
    """Body i's change of potential energy in this pass, 0 if it was not moved."""
    du = 0.0
    if a.bi[i, BodyInt.PUSHED] >= 0:
        du = potential_energy(fx, a, i) - a.b[i, Body.POT_START]
    return du


@ti.func
def energy_all(fx: ti.template(), a: ti.template()):
    """Each moved body's change of potential energy, kept in ``Body.POT_START``."""
    for i in range(a.b.shape[0]):
        if a.bi[i, BodyInt.PUSHED] >= 0:
            a.b[i, Body.POT_START] = energy_change(fx, a, i)


@ti.func
def book(fx: ti.template(), a: ti.template()):
    """The changes :func:`energy_all` kept, summed in body order (sequential): the bits of
    :func:`correction_pass`'s own sum."""
    for i in range(a.b.shape[0]):
        if a.bi[i, BodyInt.PUSHED] >= 0:
            a.acc[Acc.CORRECTION] -= a.b[i, Body.POT_START]


@ti.func
def correction_pass(fx: ti.template(), a: ti.template()):
    """The whole pass, serial loops (the serial form)."""
    for i in range(a.b.shape[0]):
        prepare_body(fx, a, i, False)
    sweeps(fx, a, False)
    # the corrections' change of potential energy, per moved body, in body order
    for i in range(a.b.shape[0]):
        if a.bi[i, BodyInt.PUSHED] >= 0:
            a.acc[Acc.CORRECTION] -= energy_change(fx, a, i)
