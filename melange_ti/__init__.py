"""melange_ti: a 2-D discrete-element model of capsizing icebergs and ice-melange expansion.

Guttenberg et al. (2011), Annals of Glaciology: rectangular floating icebergs with exact
hydrostatic buoyancy, linear drag and impulse-based collisions found through disc
representations, on Taichi (CPU by default). See SPEC.md for units and the file format.
"""

import os

# Before Taichi is imported anywhere: no banner on stdout, and no Python print buffer, which
# Taichi enables whenever sys.stdout is not the real stdout (pytest, Jupyter) and which
# slows every kernel call many times over.
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "False")
os.environ.setdefault("TI_ENABLE_PYBUF", "0")

__version__ = "0.1.0"
