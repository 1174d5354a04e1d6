"""Diagnostics as pure functions of state arrays (numpy; SPEC sections 1 and 5)."""

from __future__ import annotations

import numpy as np


def capsize_angle(theta: np.ndarray) -> np.ndarray:
    """``phi = |theta|`` folded into [0, pi/2]: the long axis' distance from vertical."""
    m = np.mod(np.abs(theta), np.pi)
    return np.minimum(m, np.pi - m)


def capsized(theta: np.ndarray) -> np.ndarray:
    """Boolean mask of icebergs with ``phi >= pi/4``."""
    return capsize_angle(theta) >= np.pi / 4


def capsized_fraction(theta: np.ndarray) -> float:
    return float(np.mean(capsized(theta))) if theta.size else 0.0


def leading_edge(x: np.ndarray, x0_max: float) -> float:
    """``max_i x_i(t) - max_i x_i(0)``."""
    return float(np.max(x) - x0_max)


def capsize_energy(density_ratio: float, width: float, thickness: float) -> float:
    """Potential energy released by one capsize, upright to flat: ``0.5 r (1-r) w h (h-w)``."""
    r = density_ratio
    return 0.5 * r * (1 - r) * width * thickness * (thickness - width)


def critical_aspect(density_ratio: float) -> float:
    """Thickness/width above which upright is unstable: ``1/sqrt(6 r (1-r))``."""
    return 1.0 / np.sqrt(6 * density_ratio * (1 - density_ratio))


def roll_period(density_ratio: float, width: float, thickness: float) -> float:
    """Small-amplitude roll period of a stable upright rectangle (no added mass)."""
    d = density_ratio * thickness
    gm = d / 2 + width**2 / (12 * d) - thickness / 2
    return 2 * np.pi / np.sqrt(12 * gm / (width**2 + thickness**2))


def heave_period(density_ratio: float, thickness: float) -> float:
    """Small-amplitude heave period ``2 pi sqrt(draft / g)``."""
    return 2 * np.pi * np.sqrt(density_ratio * thickness)
