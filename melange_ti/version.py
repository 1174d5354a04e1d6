"""The package's version, in a module of its own so that the modules that write it into files
import it without importing the package's front (:mod:`melange_ti`, which reaches the API)."""

__version__ = "0.2.0"
