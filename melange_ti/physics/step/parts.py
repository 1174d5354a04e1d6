"""What a step is made of: its stages (:class:`Stage`), each a serial form and parallel parts
(:class:`Part`), repeated rounds (:class:`Rounds`) and the drift's sub-steps (:class:`Substeps`). The step itself is
:data:`melange_ti.physics.stages.STEP`; an effect adds stages of its own
(``STAGES`` of its kernel module, :mod:`.terms`). No Taichi here: the parts' functions are the kernels'."""

from collections.abc import Callable
from dataclasses import dataclass


def always(fx) -> bool:
    return True


def contacts(fx) -> bool:
    return bool(fx.collisions or fx.wall)


def collisions(fx) -> bool:
    return bool(fx.collisions)


@dataclass(frozen=True)
class Part:
    """One kernel of the parallel form: ``func(fx, a)``; ``sequential`` parts run on one
    thread (their order is the physics); ``needs(fx)``: launched only when true; ``repeat``:
    launched again while it sets ``Counter.CHANGED`` (at most ``limit`` times; 0: once per
    possible contact); ``per_colour``: launched once per colour of the last colouring
    (``Counter.COLOURS``, :mod:`..forms.colours`), a repeat being all of them; ``recolour``:
    it starts a colouring (the model reads the colours' count again after it)."""

    func: Callable
    sequential: bool = False
    needs: Callable = always
    repeat: bool = False
    limit: int = 0
    per_colour: bool = False
    recolour: bool = False


@dataclass(frozen=True)
class Stage:
    """A named stage: ``serial(fx, a)`` is the whole stage with serial loops (inside the
    fused kernel); ``parallel`` its parts as kernels, in turn, ``contact_passes`` times if
    ``per_pass``; ``needs(fx)``: run only when true. Without islands
    (``Model(islands=False)``) the parallel form runs ``without_islands`` instead (once), and
    skips an ``islands_only`` stage; with groups (``Model(groups=G)``, G > 1: the sequential
    passes split into G contiguous groups, :mod:`..forms.groups`) it runs ``groups`` where given
    (``per_pass`` as ``parallel``), the islands stage included. On a device (``Model(device_parts=True)``) it runs
    ``device`` instead of ``parallel``, where given: no part on one thread but a walk over
    block sums (:mod:`..forms.device`). With coloured passes (``contacts.order``, the effect
    set's ``coloured``) it runs ``coloured`` (on a device ``coloured_device``, where given)
    in the parallel form and ``coloured_serial`` in the serial one, where given, whatever the
    islands and groups (:mod:`..forms.colours`). ``owner``: the effect that added it to the step."""

    name: str
    serial: Callable
    parallel: tuple[Part, ...]
    needs: Callable = always
    kind: str = "stage"
    per_pass: bool = False
    without_islands: tuple[Part, ...] | None = None
    islands_only: bool = False
    device: tuple[Part, ...] | None = None
    groups: tuple[Part, ...] | None = None
    coloured: tuple[Part, ...] | None = None
    coloured_device: tuple[Part, ...] | None = None
    coloured_serial: Callable | None = None
    owner: str | None = None  # the effect whose stage it is (None: the model's own)


@dataclass(frozen=True)
class Rounds:
    """Stages repeated until the last of ``solve`` (the check) says done (``Counter.AGAIN``
    0), at most ``limit`` times: ``detect`` runs in the first round and again after a round
    whose check found a body faster than the reach it was searched with (``AGAIN`` 2)."""

    detect: tuple[Stage, ...]
    solve: tuple[Stage, ...]
    limit: int
    needs: Callable = always
    kind: str = "rounds"


@dataclass(frozen=True)
class Substeps:
    """The drift's sub-steps, for effects whose forces are stiffer than the step (``Effect.substeps``):
    ``loop`` runs ``n - 1`` times after the drift's first sub-step, ``n`` the sub-steps the named
    effects ask for (``Param.SUBSTEPS``, read by the host from the scene), then ``after`` once.
    ``name``: what an effect's stage may be anchored after."""

    loop: tuple[Stage, ...]
    after: tuple[Stage, ...]
    needs: Callable = always
    kind: str = "substeps"
    name: str = "substeps"
