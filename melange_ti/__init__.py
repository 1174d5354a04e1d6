"""melange_ti: a 2-D discrete-element model of capsizing icebergs and ice-melange expansion.

Guttenberg et al. (2011), Annals of Glaciology: rectangular floating icebergs with exact
hydrostatic buoyancy, linear drag and impulse-based collisions found through disc
representations, on Taichi (CPU by default). See SPEC.md for units and the file format.
"""

__version__ = "0.1.0"
