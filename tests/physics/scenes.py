"""Scenes of a few explicit icebergs for the physics tests, built as a user would write them."""

from __future__ import annotations

from melange_ti.testing import initial, make_scene  # one copy, shared with validation/

__all__ = ["KERNEL_FORMS", "initial", "make_scene"]

# The kernel forms that must give the same bits: (mode, islands, groups) for Model
KERNEL_FORMS = (("serial", None, None), ("parallel", False, 1), ("parallel", False, 3), ("parallel", True, None))
