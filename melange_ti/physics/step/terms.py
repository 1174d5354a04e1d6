"""Every effect's Taichi side, found by the effect's name: the module of its ``@ti.func`` terms
and its own stages (``STAGES``).

An effect's declaration (:mod:`..effects`) is data and imports none of its kernels: the
declarations are the ground the schema is built from, and the kernels stand on the schema, so
a declaration that reached its kernels would close a circle. The link runs the other way,
here, from the step down to each kernel module by a plain import. The contact law's own
impulse (friction's) is linked one floor up, in :mod:`.impulses`, because it stands on the
contact point's effective mass (:mod:`.pairs`), which stands on the forces' added inertia.

To add an effect with terms: declare them (``Effect.terms``), write its module, and name it
in :data:`MODULES` (or in :data:`.impulses.LAWS` for an ``impulse`` term); the check below
refuses an effect whose terms have no module at import.
"""

from types import ModuleType

from ..effects import REGISTRY
from ..effects.base import TERMS, Effect
from ..effects.bonds import kernels as bonds
from ..effects.terms import added_mass, buoyancy, drag, form_drag, gravity
from ..effects.waves import kernels as waves

MODULES: dict[str, ModuleType] = {
    "gravity": gravity,
    "buoyancy": buoyancy,
    "drag": drag,
    "form_drag": form_drag,
    "added_mass": added_mass,
    "waves": waves,
    "bonds": bonds,
}

# the terms a module here must hold: every declared one but the contact law's ``impulse`` (.impulses.LAWS)
LINKED_HERE = tuple(t for t in TERMS if t != "impulse")


def module(effect: Effect) -> ModuleType | None:
    """The module of ``effect``'s terms and stages, or ``None`` if it has none here."""
    return MODULES.get(effect.name)


def term(effect: Effect, which: str):
    """The ``@ti.func`` ``which`` of ``effect`` (``force``, ``damp``, ...), or ``None`` when
    the effect declares no such term."""
    if which not in effect.terms:
        return None
    return getattr(MODULES[effect.name], which)


def stages(effect: Effect) -> tuple:
    """``((anchor, Stage), ...)``: the stages ``effect`` adds to the step."""
    return getattr(module(effect), "STAGES", ())


def _unlinked() -> list[str]:
    """Every declared term that has no ``@ti.func`` here, as ``effect.term``."""
    missing = []
    for e in REGISTRY:
        for which in e.terms:
            if which in LINKED_HERE and not callable(getattr(MODULES.get(e.name), which, None)):
                missing.append(f"{e.name}.{which}")
    return missing


if _unlinked():  # an effect declared a term that no module gives: refuse at import, not at a compile
    raise ImportError(f"effects' terms with no kernel module in {__name__}.MODULES: {', '.join(_unlinked())}")
