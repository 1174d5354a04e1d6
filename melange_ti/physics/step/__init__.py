"""The step, phase by phase: the stage list (:mod:`..stages`, made of :mod:`.parts`), the kick
and the drift (:mod:`.forces`), contact detection (:mod:`.broad`, :mod:`.narrow`, the
wall's contact :mod:`.wall`), the contact law and its impulse pass (:mod:`.impulses`) and
the overlap correction (:mod:`.correction`)."""
