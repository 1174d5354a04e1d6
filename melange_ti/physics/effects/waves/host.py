"""The waves' host side (numpy, no Taichi): the grid's size and constants, and what an output
event reads from it (the surface, the wave energy). Made by the model of a scene that names
the waves (:class:`~..base.State`)."""

from __future__ import annotations

import numpy as np

from ..base import State
from . import SPONGE_RATE, TABLE, Wave, cells_and_spacing, steps_per_wave


class WaveGrid(State):
    """The wave grid of one model: ``cells`` (M) of spacing ``dx`` from the wall; its table
    has a row per cell (the cosine transform's work too)."""

    def __init__(self, scene, np_real):
        p = self.physics = scene.physics
        self.np_real = np_real
        self.every = steps_per_wave(p, scene.time.dt)  # K: time steps per wave step
        self.cells, self.dx = cells_and_spacing(p.wall_x, p.wave_end, p.wave_dx)
        self.rows = self.cells

    def params(self) -> dict[str, float]:
        # shares of displaced water are multiples of WAVE_Q: their sums stay exact below 32
        # (f64; 16 in f32), so the order of the additions does not matter (coupling.py); a
        # cell's column holds minus the submerged areas over a wave step, about the drafts of
        # the icebergs over it
        return {"WAVE_DX": self.dx, "WAVE_Q": 2.0**-48 if self.np_real is np.float64 else 2.0**-20}

    def config(self) -> dict[str, int]:
        return {"WAVE_CELLS": self.cells, "WAVE_LOG": self.cells.bit_length() - 1, "WAVE_EVERY": self.every}

    def x(self) -> np.ndarray:
        """x of the cell centres."""
        return self.physics.wall_x + (np.arange(self.cells) + 0.5) * self.dx

    def initial(self) -> np.ndarray:
        """The grid at rest, with its constants: the absorbing layer's rates, the operator's
        symbol and the transform's twiddles (computed here, in numpy)."""
        rows = np.zeros((self.rows, TABLE.size), dtype=np.float64)
        m, p = self.cells, self.physics
        x = self.x()
        start = p.wave_end - p.wave_sponge
        if p.wave_sponge > 0:
            rows[:m, Wave.SPONGE] = np.where(x > start, SPONGE_RATE * ((x - start) / p.wave_sponge) ** 2, 0.0)
        k = np.pi * np.arange(m) / (m * self.dx)
        rows[:m, Wave.KT] = k * np.tanh(k * p.water_depth) / m
        # cosh(k (H - d)) / cosh(k H), written without overflow
        d, h = p.wave_pressure_depth, p.water_depth
        rows[:m, Wave.AT] = (np.exp(-k * d) + np.exp(-k * (2 * h - d))) / (1 + np.exp(-2 * k * h)) / m
        rows[:m, Wave.CR] = np.cos(np.pi * np.arange(m) / (2 * m))
        rows[:m, Wave.CI] = np.sin(np.pi * np.arange(m) / (2 * m))
        rows[: m // 2, Wave.TWR] = np.cos(2 * np.pi * np.arange(m // 2) / m)
        rows[: m // 2, Wave.TWI] = -np.sin(2 * np.pi * np.arange(m // 2) / m)
        bits = m.bit_length() - 1
        q = np.arange(m)
        rows[:m, Wave.REV] = sum(((q >> b) & 1) << (bits - 1 - b) for b in range(bits))
        return rows.astype(self.np_real)

    def dims(self) -> dict[str, int]:
        return {"wave_cell": self.cells}

    def constants(self) -> dict[str, np.ndarray]:
        return {"waves/x": self.x()}

    def surface(self, rows: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """``eta``, ``phi`` and ``g_phi`` (``G phi``) at the cell centres, from the table's rows
        (``None``: the model's now). ``g_phi`` is ``G`` of ``phi`` as the last wave step left
        it: after the next one opens (its kick taken, phase not 0) it is not ``G`` of this
        ``phi``; :meth:`apply_g` is."""
        rows = (self.model.own_rows() if rows is None else rows)[: self.cells]
        return {"eta": rows[:, Wave.ETA].copy(), "phi": rows[:, Wave.PHI].copy(), "g_phi": rows[:, Wave.GPHI].copy()}

    def energy(self, surface: dict[str, np.ndarray] | None = None) -> float:
        """``rho g / 2 sum eta^2 dx + rho / 2 sum phi G phi dx``, summed in f64, of ``surface``
        (:meth:`surface`; ``None``: the model's now), the stored pair as it is, taken with
        the stored ``g_phi``: between a wave step's opening and its close that is ``G`` of
        ``phi`` before the opening's kick, so take it at a close (the diagnostic
        ``wave_energy`` is :meth:`energy_now`, right at any step)."""
        w = {k: v.astype(np.float64) for k, v in (surface or self.surface()).items()}
        return float(0.5 * self.dx * (np.dot(w["eta"], w["eta"]) + np.dot(w["phi"], w["g_phi"])))

    def energy_now(self, rows: np.ndarray | None = None) -> float:
        """The diagnostic ``wave_energy``: ``E_w`` with ``phi`` at the time of the grid's
        last step (summed in f64). The grid's symplectic Euler staggers ``phi`` by half a
        wave step: after a wave step closed (phase 0) the stored ``phi`` is half its kick
        before that time, ``phi - Dt/2 g eta`` is at it; once the next has opened (its kick
        taken), ``phi + Dt/2 g eta`` is. Taken so, ``E_w`` is the energy the stepping
        conserves between reflecting ends to second order in ``Dt`` (the stored pair's is
        off by ``Dt/2 rho int eta G phi``, first order, which grows with the wave step)."""
        rows = (self.model.own_rows() if rows is None else rows)[: self.cells]
        eta = rows[:, Wave.ETA].astype(np.float64)
        half = 0.5 * self.every * self.model.scene.time.dt
        phi = rows[:, Wave.PHI].astype(np.float64) + (half if int(rows[0, Wave.PHASE]) else -half) * eta
        return float(0.5 * self.dx * (np.dot(eta, eta) + np.dot(phi, self.apply_g(phi))))

    def sample(self, rows: np.ndarray, bodies: dict) -> dict:
        return {"eta": rows[: self.cells, Wave.ETA].copy(), "wave_energy": np.array(self.energy_now(rows))}

    def refresh(self) -> None:
        from .kernels import refresh

        a = self.model.arrays
        refresh(a.cfg, a.own)

    # ------------------------------------------------------------ for scripts and tests
    def apply_g(self, v: np.ndarray) -> np.ndarray:
        """``G v`` at the cell centres (numpy, f64): ``k tanh(k H)`` on each of the grid's
        cosine modes, through scipy's orthonormal cosine transform (the kernels' ``G``,
        whose ``G phi`` the step keeps only as of the grid's last step)."""
        from scipy.fft import dct, idct

        k = np.pi * np.arange(self.cells) / (self.cells * self.dx)
        sym = k * np.tanh(k * self.physics.water_depth)
        return idct(sym * dct(np.asarray(v, dtype=np.float64), norm="ortho"), norm="ortho")

    def set_surface(self, eta: np.ndarray, phi: np.ndarray | None = None) -> None:
        """Set the sea surface (and the potential, default 0) at the cell centres."""
        rows = self.model.own_rows()
        rows[: self.cells, Wave.ETA] = eta
        rows[: self.cells, Wave.PHI] = 0.0 if phi is None else phi
        self.model.arrays.own.from_numpy(rows)
        self.refresh()
