"""melange_ti: a 2-D discrete-element model of capsizing icebergs and ice-mélange expansion.

The model of Guttenberg et al. (2011, Annals of Glaciology): rectangular floating icebergs
with exact hydrostatic buoyancy, drag and impulse-based collisions found through disc
representations, on Taichi (CPU by default). Units are non-dimensional: lengths in iceberg
widths ``w``, time in ``sqrt(w/g)``, densities in ``rho_water``. Docs: ``docs/`` in the
repository (``docs/api.md`` for this API).

>>> import melange_ti as mt
>>> scene = mt.load_scene(overrides={"shelf.count": 50, "time.duration": 100.0})
>>> summary = mt.run(scene, "out.h5")            # doctest: +SKIP
>>> tree = mt.open_run("out.h5")                 # doctest: +SKIP
"""

import os

# Before Taichi is imported anywhere: no banner on stdout, and no Python print buffer, which
# Taichi enables whenever sys.stdout is not the real stdout (pytest, Jupyter) and which
# slows every kernel call many times over.
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "False")
os.environ.setdefault("TI_ENABLE_PYBUF", "0")

from .version import __version__

_API = (
    "load_scene",
    "run",
    "extend",
    "open_run",
    "validated",
    "total_energy",
    "runaway",
    "fragment_table",
    "capsized_area_fraction",
    "Scene",
)
_ERRORS = ("SceneError", "RunError", "ArchError", "OutputError", "NumericalError", "ContactOverflow", "Interrupted")
__all__ = [*_API, *_ERRORS, "__version__"]


def __getattr__(name: str):
    # the API is imported on first use, so `import melange_ti` stays light (no Taichi)
    if name in _API or name in _ERRORS:
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'melange_ti' has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), *__all__])
