"""The Model: the icebergs' arrays (Taichi ndarrays) and the compiled step for one effect set.

A model owns the arrays the schema describes (:mod:`melange_ti.physics.data.schema`: one row per
iceberg, contact slots, candidate lists, the cell list, parameters, counters and
accumulators). The effect set is fixed when the model is built; without contacts no contact
array is allocated and no contact kernel runs. The step is the stage list of
:mod:`melange_ti.physics.stages`.

For small N on the CPU one kernel call runs many steps with every loop serial (no launch
cost); for large N each stage is launched as parallel kernels. Both give the same bits; in
between, with several threads, the first advance times both and keeps the faster. The
contact passes' order (``contacts.order``, or ``Model(order=...)``) is fixed too: its
``"auto"`` is sequential on the CPU and coloured on a device (``Model.order`` says which;
:mod:`melange_ti.physics.forms.colours`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, make_dataclass
from types import SimpleNamespace

import numpy as np
import taichi as ti

from . import runtime  # noqa: F401  (imported for its patch: Taichi reuses source-position text)
from .errors import ContactOverflow
from .geometry import disc_radius, mass_properties, polygon_discs
from .physics import stages
from .physics.data.schema import (
    ACC_LEDGERS,
    ACCUMULATORS,
    BODIES,
    BODY_CARRIED,
    BODY_INTS,
    BODY_LEDGERS,
    CELLS,
    CONFIG,
    CONSTANTS,
    COUNTERS,
    LIST_POSES,
    PARAMS,
    SCRATCH,
    Arrays,
    Body,
    BodyInt,
    Config,
    Counter,
    Param,
    body_width,
    contact_width,
    own_rows,
)
from .physics.effects import SUBSTEPPED, hosts
from .physics.forms import colours, device
from .physics.step import narrow
from .scene import Icebergs, Scene
from .scene.keys import ORDERS

# On the CPU up to this N one kernel call runs many serial steps, above it each stage is
# launched as parallel kernels (the same bits): where the forms cross, docs/performance.md.
SERIAL_MAX_N = 50000

# Between these N, with more than one CPU thread, ``mode="auto"`` times both forms at the
# first advance and keeps the faster (:meth:`Model.advance`), as the crossing depends on the
# machine; below, a parallel step's launches cost more than a serial step (docs/performance.md).
CALIBRATE_MIN_N = 2000

# From this many CPU threads (always on a GPU) the parallel form solves islands of touching
# icebergs side by side (physics/forms/islands.py); on fewer, finding them costs what they save
# (docs/performance.md).
ISLANDS_MIN_THREADS = 4
MAX_GROUPS = 64  # contiguous groups of the sequential passes at most (physics/forms/groups.py)
CALIBRATE_STEPS = 8  # timed steps per form, after one untimed step each (compilation)


@dataclass(frozen=True)
class Form:
    """Which form of the step a model runs. Every form gives the serial form's bits for its
    contact order (the tests compare them); they differ only in speed."""

    order: str  # the contact passes' order: "sequential", or "coloured" (physics/forms/colours.py)
    islands: bool  # the parallel form solves islands of touching icebergs side by side (forms/islands.py)
    device_parts: bool  # the parts a CPU runs on one thread run as parallel block sums (forms/device.py)
    groups: int  # contiguous groups of the sequential passes solved side by side (forms/groups.py)
    mode: str  # "serial": many whole steps in one kernel call; "parallel": each stage's parts launched
    calibrate: bool  # mode "auto": both modes timed at the first advance, the faster kept


# The choice of form, as data: for each setting in turn, the first row whose condition holds
# gives its value (a value may be a function of what is known); an argument of Model other
# than None (mode: other than "auto") sets it instead. What a row's condition reads: ``cpu``
# (Taichi's x64 or arm64 backend; else a device: CUDA, Vulkan, Metal), ``threads`` (the CPU's
# threads), ``n`` (icebergs), ``contacts`` (the scene names collisions or the wall), ``asked``
# (``contacts.order``), ``auto`` (mode "auto"), and the settings chosen above it. Where the
# thresholds come from: docs/performance.md; the table as it falls out: docs/forms.md.
def _grouped(c) -> bool:
    """Whether the sequential passes can split into contiguous groups (forms/groups.py)."""
    return c.cpu and c.order == "sequential" and not c.islands and not c.device_parts


FORM_TABLE: tuple[tuple[str, str, Callable, object], ...] = (
    ("order", "no contact to order", lambda c: not c.contacts, "sequential"),
    ("order", "contacts.order asked for", lambda c: c.asked != "auto", lambda c: c.asked),
    ("order", "a device", lambda c: not c.cpu, "coloured"),
    ("order", "the CPU", lambda c: True, "sequential"),
    ("islands", "a device", lambda c: not c.cpu, True),
    ("islands", f"the CPU, threads >= {ISLANDS_MIN_THREADS}", lambda c: c.threads >= ISLANDS_MIN_THREADS, True),
    ("islands", "the CPU, fewer threads", lambda c: True, False),
    ("device_parts", "a device", lambda c: not c.cpu, True),
    ("device_parts", "the CPU", lambda c: True, False),
    ("groups", "the CPU, sequential order, islands and device parts off", _grouped, lambda c: c.threads),
    ("groups", "otherwise", lambda c: True, 1),
    ("mode", f"the CPU, n <= {SERIAL_MAX_N}", lambda c: c.cpu and c.n <= SERIAL_MAX_N, "serial"),
    ("mode", "otherwise", lambda c: True, "parallel"),
    (
        "calibrate",
        f"mode auto, the CPU, threads > 1, {CALIBRATE_MIN_N} <= n <= {SERIAL_MAX_N}",
        lambda c: c.auto and c.cpu and c.threads > 1 and CALIBRATE_MIN_N <= c.n <= SERIAL_MAX_N,
        True,
    ),
    ("calibrate", "otherwise", lambda c: True, False),
)


def choose_form(
    cpu: bool,
    threads: int,
    n: int,
    contacts: bool,
    order: str = "auto",
    mode: str = "auto",
    islands: bool | None = None,
    device_parts: bool | None = None,
    groups: int | None = None,
) -> Form:
    """The form :data:`FORM_TABLE` gives (``order``, ``mode``: as asked; the rest ``None`` for
    the table's choice). Groups are at most ``n - 1`` and :data:`MAX_GROUPS`, and exist only
    where the table's condition for them holds."""
    given = {"islands": islands, "device_parts": device_parts, "mode": None if mode == "auto" else mode}
    c = SimpleNamespace(cpu=cpu, threads=threads, n=n, contacts=contacts, asked=order, auto=mode == "auto")
    for name in (f.name for f in dataclasses.fields(Form)):
        value = given.get(name)
        if value is None:
            rule = next(v for setting, _, when, v in FORM_TABLE if setting == name and when(c))
            value = rule(c) if callable(rule) else rule
        setattr(c, name, value)
    if groups is not None and _grouped(c):
        c.groups = groups
    c.groups = max(1, min(int(c.groups), n - 1, MAX_GROUPS)) if _grouped(c) else 1
    return Form(**{f.name: getattr(c, f.name) for f in dataclasses.fields(Form)})


_DTYPES = {"f64": ti.f64, "i32": ti.i32, "i64": ti.i64}


Totals = make_dataclass(
    "Totals",
    [*((name, float) for name in ACC_LEDGERS), ("impulses", int)],
    frozen=True,
    namespace={
        "__doc__": "Cumulative scalar counters since t = 0: every run-wide ledger of the schema (``acc``, the effects' "
        "included, 0 for an effect not named) and the impulse count."
    },
)
Totals.__module__ = __name__


def _scene_value(scene: Scene, key: str) -> float:
    section, name = key.split(".")
    return float(getattr(getattr(scene, section), name))


class Model:
    """Icebergs as Taichi ndarrays plus the step for one fixed effect set."""

    def __init__(
        self,
        scene: Scene,
        icebergs: Icebergs | None = None,
        mode: str = "auto",
        islands: bool | None = None,
        device_parts: bool | None = None,
        groups: int | None = None,
        order: str | None = None,
    ):
        bergs = icebergs if icebergs is not None else scene.icebergs()
        self.scene = scene
        self.n = n = bergs.count
        self._cells = None if bergs.parent is None else (bergs.parent, bergs.cell)
        self.real = ti.f32 if scene.precision == "f32" else ti.f64
        self.np_real = np.float32 if scene.precision == "f32" else np.float64
        self.calibration: dict[str, float] | None = None  # ms/step of each form, if measured
        self._part_times: dict[str, float] | None = None  # per kernel, while profile(parts=True) runs
        cfg = ti.lang.impl.current_cfg()
        on_cpu = cfg.arch in (ti.x64, ti.arm64)
        threads = int(cfg.cpu_max_num_threads) if on_cpu else 0
        asked = scene.contacts.order if order is None else order
        if asked not in ORDERS:
            raise ValueError(f"order must be one of {', '.join(ORDERS)}, not {asked!r}")
        if mode not in ("auto", "serial", "parallel"):
            raise ValueError(f"mode must be 'auto', 'serial' or 'parallel', not {mode!r}")
        # which form runs: FORM_TABLE, a row per rule (docs/forms.md lists what it gives)
        form = choose_form(
            cpu=on_cpu, threads=threads, n=n, contacts=scene.effects.contacts, order=asked, mode=mode,
            islands=islands, device_parts=device_parts, groups=groups,
        )  # fmt: skip
        self.form = form
        self.order = form.order
        coloured = form.order == "coloured"
        # a polygon among the icebergs: every outline is read from its corners (the scene's most)
        vertices = int(bergs.corners.max()) if bergs.outline is not None else 0
        # the drift's sub-steps: the most any named effect asks for (Effect.substeps; 1: none, and
        # then none is compiled)
        self.substeps = max((int(_scene_value(scene, e.substeps)) for e in SUBSTEPPED if e.on(scene.effects)), default=1)
        self.fx = dataclasses.replace(scene.effects, coloured=coloured, vertices=vertices, substepped=self.substeps > 1)
        self._colours: int | None = None  # colours of the last colouring, once read
        self.islands = form.islands
        self.device_parts = form.device_parts
        self.groups = form.groups
        self.mode = form.mode
        self._calibrate = form.calibrate  # measured at the first advance (serial meanwhile)
        self.contacts = self.fx.contacts
        # the host side of every named effect that owns a table; their rows stacked in one
        # table, a.own, in the registry's order, each from its first row (docs/architecture.md)
        self.owned = {e.name: hosts.state(e, scene, self.np_real) for e in self.fx.owners}
        self._own_size = {e.name: e.table.size for e in self.fx.owners}
        first = 0
        for state in self.owned.values():
            state.model = self
            state.first_row = first
            first += state.rows
        own_shape = (first, max(self._own_size.values())) if self.owned else (1, 1)
        slots = scene.contacts.max_partners if self.fx.collisions else 1
        ncells = 1 << max(2, math.ceil(math.log2(max(n, 4)))) if self.fx.collisions else 4
        # candidate lists for the narrow phase, in both forms: the same contacts bit for bit,
        # found faster at every N (docs/performance.md)
        self.lists = bool(self.fx.collisions)
        nc = n if self.contacts else 1
        nlists = n if self.lists else 1

        def alloc(table, *lead):
            dtype = self.real if table.dtype == "real" else _DTYPES[table.dtype]
            return ti.ndarray(dtype, shape=(*lead, table.size))

        self.arrays = Arrays(
            b=ti.ndarray(self.real, shape=(n, body_width(self.fx))),
            bi=alloc(BODY_INTS, n),
            # slot `slots`: the wall contact's deferred terms (islands)
            cd=ti.ndarray(self.real, shape=(slots + 1, nc, contact_width(self.fx))),
            cp=ti.ndarray(ti.i32, shape=(slots, nc)),
            nl=ti.ndarray(ti.i32, shape=(nlists, narrow.list_width(scene.contacts.discs // 4))),
            nr=alloc(LIST_POSES, nlists, narrow.ENTRIES),
            cells=alloc(CELLS, ncells + 1),
            par=alloc(PARAMS),
            scr=alloc(SCRATCH),
            cfg=alloc(CONFIG),
            cnt=alloc(COUNTERS),
            acc=alloc(ACCUMULATORS),
            red=ti.ndarray(ti.f64, shape=(device.red_rows(n, ncells) if self.device_parts else 1, device.RED_WIDTH)),
            own=ti.ndarray(self.real, shape=own_shape),
        )
        # where :meth:`sample` puts what it fetches (numpy: the kernel writes it in place)
        self._out, self._out_acc, self._out_cnt = self._sample_buffers(1, table=False)

        a = self.arrays
        p = scene.physics
        rows = np.zeros((n, body_width(self.fx)), dtype=np.float64)
        outlines = bergs.outlines(p.density_ratio) if bergs.outline is not None else None
        mass, inertia, bound = mass_properties(bergs, p.density_ratio, outlines)
        if bergs.outline is not None:  # polygons: their corners, axes and discs (geometry.outline)
            rows[:, Body.CORNERS] = bergs.corners
            rows[:, Body.AXIS] = [o["axis"] for o in outlines]
            for i, o in enumerate(outlines):
                rows[i, Body.U0 : Body.U0 + o["corners"].size] = o["corners"].ravel()
                r, inner, count = polygon_discs(o["corners"], scene.contacts.discs, scene.contacts.disc_spacing)
                rows[i, Body.IU0 : Body.IU0 + inner.size] = inner.ravel()
                rows[i, Body.NDISC0 : Body.NDISC0 + count.size] = count
                rows[i, Body.RADIUS] = r
        self.axis = rows[:, Body.AXIS].copy() if bergs.outline is not None else None
        rows[:, Body.WIDTH] = bergs.width
        rows[:, Body.THICK] = bergs.thickness
        rows[:, Body.MASS] = mass
        rows[:, Body.INERTIA] = inertia
        if bergs.outline is None:
            rows[:, Body.RADIUS] = disc_radius(bergs.width, bergs.thickness, scene.contacts.discs, scene.contacts.disc_spacing)
        rows[:, Body.BOUND] = bound
        for name, col in BODIES.outputs("state").items():
            rows[:, col] = getattr(bergs, name)
        for state in self.owned.values():  # the owning effects' per-iceberg columns
            state.bodies(rows)
        m_real = mass.astype(self.np_real)
        rows[:, Body.INV_MASS] = self.np_real(1.0) / m_real  # as the device would round it
        a.b.from_numpy(rows.astype(self.np_real))
        a.bi.from_numpy(np.zeros(a.bi.shape, dtype=np.int32))
        a.cells.from_numpy(np.zeros(a.cells.shape, dtype=np.int32))
        self.clear_candidate_lists()

        # parameters: each slot from the scene key the schema names, plus the derived ones
        # and the hydrostatics' run-time divisors (schema.BASE_PARAMS)
        par = np.zeros(PARAMS.size)
        for k, col in enumerate(PARAMS.columns):
            if col.source is not None:
                par[k] = _scene_value(scene, col.source)
        par[Param.BOUND_MAX] = float(bound.max())
        par[Param.EPS] = float(np.finfo(self.np_real).eps)
        par[Param.SIX] = 6.0
        par[Param.TWELVE] = 12.0
        par[Param.SUBSTEPS] = self.substeps
        for state in self.owned.values():
            for name, value in state.params().items():
                par[getattr(Param, name)] = value
        a.par.from_numpy(par.astype(self.np_real))
        a.scr.from_numpy(np.zeros(a.scr.shape, dtype=self.np_real))
        a.acc.from_numpy(np.zeros(ACCUMULATORS.size))
        a.red.from_numpy(np.zeros(a.red.shape))
        a.cnt.from_numpy(np.zeros(COUNTERS.size, dtype=np.int64))
        cfg = np.zeros(CONFIG.size, dtype=np.int64)
        cfg[Config.N] = n
        cfg[Config.K] = scene.contacts.discs // 4
        cfg[Config.SLOTS] = slots
        cfg[Config.PASSES] = scene.contacts.contact_passes
        cfg[Config.NCELLS] = ncells
        cfg[Config.DISCS] = scene.contacts.discs
        cfg[Config.LISTS] = int(self.lists)
        cfg[Config.GROUPS] = self.groups
        cfg[Config.ID_BITS] = colours.id_bits(n, slots)
        own = np.zeros(own_shape, dtype=self.np_real)
        for e in self.fx.owners:
            state = self.owned[e.name]
            for name, value in state.config().items():
                cfg[getattr(Config, name)] = value
            row0, count = own_rows(e)
            cfg[row0], cfg[count] = state.first_row, state.rows
            own[state.first_row : state.first_row + state.rows, : e.table.size] = state.initial()
        a.cfg.from_numpy(cfg)
        a.own.from_numpy(own)

    def effect(self, name: str):
        """The host side (:class:`~melange_ti.physics.effects.State`) of the named effect that
        owns state (its methods: the effect's ``host.py``; docs/architecture.md). ``KeyError``
        if the model has none by that name."""
        if name not in self.owned:
            raise KeyError(f"the model's scene names no effect {name!r} that owns state")
        return self.owned[name]

    def own_rows(self, name: str | None = None, table: np.ndarray | None = None) -> np.ndarray:
        """The owners' table (``a.own``) as numpy, or with ``name`` that effect's rows and
        columns of it (of ``table``, a copy of it, if given)."""
        whole = self.arrays.own.to_numpy() if table is None else table
        if name is None:
            return whole
        state = self.effect(name)
        return whole[state.first_row : state.first_row + state.rows, : self._own_size[name]]

    # ------------------------------------------------------------------ host side
    def _rows(self) -> np.ndarray:
        return self.arrays.b.to_numpy()

    def constants(self) -> dict[str, np.ndarray]:
        """Per-iceberg constants ``width, thickness, mass, inertia``, arrays of shape (N,); with
        polygons also their outlines (``corners``, ``corner_u``, ``corner_v`` (N, corners),
        ``axis``: :data:`melange_ti.io.hdf5.OUTLINE_ATTRS`); with cells each body's iceberg and
        place in its grid (``cell_iceberg``, ``cell_ix``, ``cell_iz``: :data:`melange_ti.io.hdf5.CELL_ATTRS`)."""
        rows = self._rows()
        cols = BODIES.outputs("constant")
        out = {k: rows[:, cols[k]].copy() for k in CONSTANTS}
        if self.fx.vertices:  # polygons: the outlines (io.hdf5.OUTLINE_ATTRS)
            corners = rows[:, Body.U0 : Body.U0 + 2 * self.fx.vertices].reshape(self.n, -1, 2)
            out.update(
                corners=rows[:, Body.CORNERS].astype(np.int64),
                corner_u=corners[..., 0].copy(),
                corner_v=corners[..., 1].copy(),
                axis=rows[:, Body.AXIS].copy(),
            )
        if self._cells is not None:
            parent, cell = self._cells
            out.update(cell_iceberg=np.asarray(parent, dtype=np.int64), cell_ix=cell[:, 0].copy(), cell_iz=cell[:, 1].copy())
        return out

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        """Load ``x, z, theta, vx, vz, omega`` (arrays of shape (N,))."""
        rows = self._rows()
        for name, col in BODIES.outputs("state").items():
            rows[:, col] = state[name]
        self.arrays.b.from_numpy(rows)

    def state(self) -> dict[str, np.ndarray]:
        """Current state, arrays of shape (N,)."""
        rows = self._rows()
        return {k: rows[:, c].copy() for k, c in BODIES.outputs("state").items()}

    def sample(self) -> dict[str, np.ndarray]:
        """State, the per-body ledgers (e.g. ``drag_dissipated``) and per-body ``kinetic``
        and ``potential`` energy (:data:`stages.SAMPLE_NAMES`)."""
        return self.sample_with_totals()[0]

    def sample_with_totals(self, owners: bool = True) -> tuple[dict[str, np.ndarray], Totals]:
        """:meth:`sample` and :meth:`totals` of the same instant, in one kernel launch (an
        output event's whole fetch); without ``owners``, the icebergs' columns alone (none of
        the owning effects' part, :meth:`State.sample`)."""
        a = self.arrays
        stages.sample_all(self.fx, a.b, a.par, a.acc, a.cnt, self._out, self._out_acc, self._out_cnt)
        return self._unpack(self._out, self._out_acc, self._out_cnt, None, 0, owners)

    def advance_sampled(self, segments: list[int], light: tuple[int, ...] = ()) -> list[tuple[dict[str, np.ndarray], Totals]]:
        """Advance ``segments[0]`` steps and take :meth:`sample_with_totals`, then
        ``segments[1]`` steps and sample again, ...; the serial form does it all in one
        kernel launch (a run's output events between two writes). The same bits as
        :meth:`advance` and :meth:`sample_with_totals` in turn. The samples numbered in
        ``light`` leave the owning effects' part out (``owners=False``)."""
        if self.mode != "serial" or self._calibrate or len(segments) < 2:
            out = []
            for k, steps in enumerate(segments):
                self.advance(steps)
                out.append(self.sample_with_totals(owners=k not in light))
            return out
        bufs = self._sample_buffers(len(segments))
        stages.steps_serial_sampled(self.fx, np.asarray(segments, dtype=np.int32), *self.arrays.ndarrays(), *bufs)
        self._check_overflow()
        return [self._unpack(*bufs, k, k not in light) for k in range(len(segments))]

    def peek(self, steps: int = 1) -> tuple[dict[str, np.ndarray], Totals]:
        """:meth:`sample_with_totals` ``steps`` steps on, leaving the model as it was: every
        array a step reads or writes is copied first and put back after, so the run that
        goes on (or a later :meth:`advance`) gives the same bits as without the look. The
        run's diagnostics read the energy at the step time from the state two consecutive
        steps leave; the last row of a run looks one step past its end this way."""
        arrays = self.arrays.ndarrays()
        saved = [x.to_numpy() for x in arrays]
        colours, calibrate = self._colours, self._calibrate
        self._calibrate = False
        try:
            if self.mode == "serial":  # the fused kernel a run's launches use (an empty second
                # segment makes it one): a run that never needed the plain one does not load it
                return self.advance_sampled([steps, 0])[0]
            self.advance(steps)
            return self.sample_with_totals()
        finally:
            for x, v in zip(arrays, saved, strict=True):
                x.from_numpy(v)
            self._colours, self._calibrate = colours, calibrate

    def _sample_buffers(self, count: int, table: bool = True) -> tuple[np.ndarray, ...]:
        """Where a launch puts its samples; with ``table``, also a copy of the owners' table per
        sample (one element without one), as the fused launch writes it."""
        bufs = (
            np.zeros((count, self.n, len(stages.SAMPLE_NAMES)), dtype=self.np_real),
            np.zeros((count, ACCUMULATORS.size), dtype=np.float64),
            np.zeros((count, COUNTERS.size), dtype=np.int64),
        )
        if not table:
            return bufs
        shape = self.arrays.own.shape
        return (*bufs, np.zeros((count, *shape), dtype=self.np_real))

    def _unpack(self, out, out_acc, out_cnt, out_own, k: int, owners: bool = True) -> tuple[dict[str, np.ndarray], Totals]:
        """Sample ``k`` of the buffers; each owning effect's part from its rows of the owners'
        table, copied in the launch (``out_own``) or, ``None``, fetched now: the same values."""
        sample = {name: out[k, :, q].copy() for q, name in enumerate(stages.SAMPLE_NAMES)}
        if self.axis is not None:  # polygons: the principal axes the capsize angle is measured by
            sample["axis"] = self.axis
        if self.owned and owners:
            whole = self.own_rows() if out_own is None else out_own[k]
            for name, state in self.owned.items():
                sample.update(state.sample(self.own_rows(name, whole), sample))
        return sample, self._totals(out_acc[k], out_cnt[k])

    def totals(self) -> Totals:
        return self._totals(self.arrays.acc.to_numpy(), self.arrays.cnt.to_numpy())

    @staticmethod
    def _totals(acc: np.ndarray, cnt: np.ndarray) -> Totals:
        return Totals(**{name: float(acc[k]) for name, k in ACC_LEDGERS.items()}, impulses=int(cnt[Counter.IMPULSES]))

    def accumulators(self) -> dict[str, np.ndarray]:
        """Everything cumulative besides the state (for checkpoints): the per-body ledgers
        by name, the run-wide accumulators (``acc``) and the counters (``counters``)."""
        rows = self._rows()
        out = {name: rows[:, col].copy() if col < rows.shape[1] else np.zeros(self.n) for name, col in BODY_LEDGERS.items()}
        for name, col in BODY_CARRIED.items():  # an effect's per-body state without an output name
            out[f"carried_{name}"] = rows[:, col].copy() if col < rows.shape[1] else np.zeros(self.n)
        out["acc"] = self.arrays.acc.to_numpy()
        out["counters"] = self.arrays.cnt.to_numpy()
        if self.owned:  # each owning effect's rows of the owners' table, under its name
            whole = self.own_rows()
            out.update({name: self.own_rows(name, whole).copy() for name in self.owned})
        return out

    def set_accumulators(self, acc: dict[str, np.ndarray]) -> None:
        rows = self._rows()
        for name, col in BODY_LEDGERS.items():
            if col < rows.shape[1]:
                rows[:, col] = acc[name]
        for name, col in BODY_CARRIED.items():
            if col < rows.shape[1] and f"carried_{name}" in acc:  # a checkpoint from before it was added: zeros
                rows[:, col] = acc[f"carried_{name}"]
        self.arrays.b.from_numpy(rows)
        self.arrays.acc.from_numpy(np.asarray(acc["acc"], dtype=np.float64))
        counters = np.zeros(COUNTERS.size, dtype=np.int64)
        stored = np.asarray(acc["counters"], dtype=np.int64)[: COUNTERS.size]
        counters[: stored.size] = stored  # a checkpoint from before a counter was added
        self.arrays.cnt.from_numpy(counters)
        if self.owned:
            whole = self.own_rows()
            for name in self.owned:
                self.own_rows(name, whole)[...] = np.asarray(acc[name], dtype=self.np_real)
            self.arrays.own.from_numpy(whole)

    def clear_candidate_lists(self) -> None:
        """Forget the narrow phase's candidate lists: the next detection searches every pair
        afresh. Contacts are bit-for-bit the same either way; only speed differs."""
        a = self.arrays
        a.nl.from_numpy(np.full(a.nl.shape, -1, dtype=np.int32))
        a.nr.from_numpy(np.zeros(a.nr.shape, dtype=self.np_real))
        ints = a.bi.to_numpy()
        ints[:, BodyInt.NEXT_ENTRY] = 0
        a.bi.from_numpy(ints)

    def prepare(self) -> None:
        """Refresh what a step caches from the state (cos and sin of every tilt)."""
        stages.orient_all(self.arrays.b)

    # ------------------------------------------------------------------ stepping
    def advance(self, steps: int) -> None:
        """Advance ``steps`` time steps (no I/O; one small read of the overflow flag)."""
        if steps <= 0:
            return
        if self._calibrate and steps >= 2 * (CALIBRATE_STEPS + 1):
            steps -= self._choose_mode()
        if self.mode == "serial":
            stages.steps_serial(self.fx, steps, *self.arrays.ndarrays())
        else:
            self.prepare()  # the state may have been set from the host since the last call
            for _ in range(steps):
                self._step_parallel(None)
        self._check_overflow()

    def _choose_mode(self) -> int:
        """Run one untimed and ``CALIBRATE_STEPS`` timed steps in each form and keep the
        faster; the steps are the run's own (both forms give the same bits). Returns the
        number of steps taken."""
        self._calibrate = False
        per_step = {}
        for mode in ("serial", "parallel"):
            self.mode = mode
            self.advance(1)
            ti.sync()
            t0 = time.perf_counter()
            self.advance(CALIBRATE_STEPS)
            ti.sync()
            per_step[mode] = (time.perf_counter() - t0) / CALIBRATE_STEPS * 1e3
        self.mode = min(per_step, key=per_step.get)
        self.calibration = per_step
        return 2 * (CALIBRATE_STEPS + 1)

    def profile(self, steps: int, parts: bool = False) -> dict[str, float]:
        """Advance ``steps`` steps in the parallel form, stage by stage with a sync after
        each, and return wall seconds per step for each stage (:data:`stages.STAGE_NAMES`)
        plus ``other`` (the rest of the step); with ``parts``, also for each kernel a stage
        launches (``"stage.function"``, a sync after each; included in the stage's time)."""
        times = dict.fromkeys(stages.STAGE_NAMES, 0.0)
        self._part_times = {} if parts else None
        total = 0.0
        self.prepare()
        ti.sync()
        for _ in range(steps):
            t0 = time.perf_counter()
            self._step_parallel(times)
            ti.sync()
            total += time.perf_counter() - t0
        self._check_overflow()
        times["other"] = max(0.0, total - sum(times.values()))
        times.update(self._part_times or {})
        self._part_times = None
        return {k: v / max(steps, 1) for k, v in times.items()}

    def _run(self, stage: stages.Stage, times: dict | None) -> None:
        t0 = time.perf_counter() if times is not None else 0.0
        grouped = self.groups > 1 and stage.groups is not None  # groups > 1 only with islands off
        coloured = self.fx.coloured and stage.coloured is not None
        if not self.islands and stage.islands_only and not grouped and not coloured:
            return
        parts, repeat = stage.parallel, self.scene.contacts.contact_passes if stage.per_pass else 1
        if coloured:
            parts = stage.coloured_device if self.device_parts and stage.coloured_device is not None else stage.coloured
        elif grouped:
            parts = stage.groups
        elif not self.islands and stage.without_islands is not None:
            parts, repeat = stage.without_islands, 1  # the sequential pass loops its passes itself
        elif self.device_parts and stage.device is not None:
            parts = stage.device
        for _ in range(repeat):
            for part in parts:
                if part.needs(self.fx):
                    self._launch(stage, part)
        if times is not None:
            ti.sync()
            times[stage.name] += time.perf_counter() - t0

    def _launch(self, stage: stages.Stage, part: stages.Part) -> None:
        """Run one part (again while it says it changed something, if it ``repeat``s),
        timed into the part profile while :meth:`profile` asks for it."""
        t1 = 0.0
        if self._part_times is not None:
            ti.sync()
            t1 = time.perf_counter()
        if part.recolour:
            self._colours = None
        launches = 1
        if part.per_colour:  # read once per colouring: the one device read it costs
            if self._colours is None:
                self._colours = int(self.arrays.cnt[Counter.COLOURS])
            launches = self._colours
        limit = (part.limit or self.n * (self.scene.contacts.max_partners + 1)) if part.repeat else 1
        for _ in range(limit if launches else 0):
            for _ in range(launches):
                stages.run_part(self.fx, part, *self.arrays.ndarrays())
            if part.repeat and int(self.arrays.cnt[Counter.CHANGED]) == 0:
                break
        if self._part_times is not None:
            ti.sync()
            key = f"{stage.name}.{part.func.__name__}"
            self._part_times[key] = self._part_times.get(key, 0.0) + time.perf_counter() - t1

    def _step_parallel(self, times: dict | None) -> None:
        """One step of :data:`stages.STEP`, each stage launched as its parallel parts."""
        for part in stages.STEP:
            if not part.needs(self.fx):
                continue
            if part.kind == "stage":
                self._run(part, times)
                continue
            if part.kind == "substeps":
                for _ in range(self.substeps - 1):
                    for st in part.loop:
                        if st.needs(self.fx):
                            self._run(st, times)
                for st in part.after:
                    self._run(st, times)
                continue
            redetect = True
            for _ in range(part.limit):
                if redetect:
                    for st in part.detect:
                        self._run(st, times)
                for st in part.solve:
                    self._run(st, times)
                again = int(self.arrays.cnt[Counter.AGAIN])  # the one device read per round
                redetect = again == 2
                if again == 0:
                    break

    def _check_overflow(self) -> None:
        if self.fx.collisions and self.arrays.cnt[Counter.OVERFLOW]:
            raise ContactOverflow(
                f"contacts.max_partners = {self.scene.contacts.max_partners}: an iceberg had more contact partners "
                "than slots; raise contacts.max_partners"
            )

    def contact_pairs(self) -> tuple[list[tuple[int, int]], list[int]]:
        """Contacts the next step would consider, without changing the state.

        Returns ``(pairs, wall)``: body pairs ``(i, j)``, ``i < j``, in the order the impulse
        pass visits them, and the bodies touching the wall. Velocities count (speculative
        contacts), so call it on the state whose velocities you mean.
        """
        if not self.contacts:
            return [], []
        self.prepare()
        for st in (stages.BROAD, stages.NARROW):
            self._run(st, None)
        bi = self.arrays.bi.to_numpy()
        cp = self.arrays.cp.to_numpy()
        pairs = []
        if self.fx.collisions:
            pairs = [(i, int(cp[s, i])) for i in range(self.n) for s in range(bi[i, BodyInt.NCONTACT])]
        wall = [int(i) for i in np.flatnonzero(bi[:, BodyInt.WALL_ON])] if self.fx.wall else []
        return pairs, wall


__all__ = ["Model", "Totals", "ContactOverflow", "SERIAL_MAX_N", "CALIBRATE_MIN_N"]
