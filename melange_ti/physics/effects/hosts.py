"""The host side of every effect that owns state, found by the effect's name: the class the
model makes its state from (:class:`.base.State`) and the scene's checks that need the initial
state. Linked here, above the declarations (which import no host code, as they import no
kernels: :mod:`..step.terms`), so that the scene and the model reach an effect's host code
through its name alone."""

from collections.abc import Callable

from . import OWNERS
from .base import Effect, State
from .bonds import host as bonds
from .waves import host as waves

STATES: dict[str, type[State]] = {"bonds": bonds.BondState, "waves": waves.WaveGrid}
CHECK_START: dict[str, Callable] = {"bonds": bonds.check_start}

if {e.name for e in OWNERS} != STATES.keys():  # an effect that owns a table and no State: refuse at import
    raise ImportError(
        f"effects that own a table and their State classes differ: {sorted({e.name for e in OWNERS} ^ STATES.keys())}"
    )


def state(effect: Effect, scene, np_real) -> State:
    """``effect``'s host side for ``scene`` (the model makes it only when the scene names it)."""
    return STATES[effect.name](scene, np_real)


def check_start(effect: Effect, scene, icebergs) -> tuple[str, object, str] | None:
    """``effect``'s checks that need the initial state: ``(key, value, accepts)`` or ``None``."""
    check = CHECK_START.get(effect.name)
    return check(scene, icebergs) if check is not None else None
