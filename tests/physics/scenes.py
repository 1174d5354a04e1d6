"""Scenes of a few explicit icebergs for the physics tests, built as a user would write them."""

from __future__ import annotations

from melange_ti.testing import initial, make_scene  # one copy, shared with validation/

__all__ = ["KERNEL_FORMS", "initial", "make_scene", "every_form"]

# The kernel forms that must give the same bits: (mode, islands, groups) for Model
KERNEL_FORMS = (("serial", None, None), ("parallel", False, 1), ("parallel", False, 3), ("parallel", True, None))


def every_form(scene, steps: int):
    """Each kernel form's state and owners' table after ``steps`` steps of ``scene`` (a
    ``Scene``), asserted equal to the serial form's to the bit; the serial form's table."""
    import numpy as np

    from melange_ti.model import Model

    forms = {}
    for mode, islands, groups in KERNEL_FORMS:
        kw = {} if mode == "serial" else {"islands": islands, **({"groups": groups} if groups else {})}
        m = Model(scene, mode=mode, **kw)
        m.advance(steps)
        forms[(mode, islands, groups)] = (m.state(), m.own_rows())
    state0, table0 = forms[KERNEL_FORMS[0]]
    for form, (state, table) in forms.items():
        for k in state0:
            np.testing.assert_array_equal(state[k], state0[k], err_msg=f"{form} {k}")
        np.testing.assert_array_equal(table, table0, err_msg=str(form))
    return table0
