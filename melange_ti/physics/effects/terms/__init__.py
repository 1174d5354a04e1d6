"""The ``@ti.func`` terms of the effects (one module per effect, named as the effect):
what :mod:`..` declares, compiled into the kernels only for a scene that names it."""
