"""Exceptions the command line turns into one-line messages (no heavy imports here)."""


class RunError(RuntimeError):
    """A run that cannot start or continue (exit status 2)."""


class ArchError(RuntimeError):
    """The requested Taichi backend is not available (exit status 2)."""


class NumericalError(RuntimeError):
    """The state became non-finite or the energy ran away; output up to here is kept (exit 3)."""


class ContactOverflow(RuntimeError):
    """A body had more contact partners than slots; raised instead of dropping contacts (exit 3)."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) stopped a run at an output event, with a checkpoint written there; the
    message says how far it got and how to continue (exit status 130)."""
