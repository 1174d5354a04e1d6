"""Column and table types of the schema (:mod:`.schema` builds the model's tables from them
and the effects' declarations, and fills the namespaces kernels index arrays with).

Importable alone, with no Taichi: effect declarations use these types to declare their
columns and tables.
"""

from __future__ import annotations

from dataclasses import dataclass

ROLES = ("state", "constant", "cache", "scratch", "ledger", "counter", "config", "reading")
E = "rho_w g w^3"  # energy per unit length into the page (g = rho_w = w = 1)


@dataclass(frozen=True)
class Column:
    """One column of a packed array.

    ``name``: the constant in the namespace (``VX``); ``output``: the name in files and
    in :meth:`Model.sample` (``vx``), or ``None``; ``units``: non-dimensional units (lengths
    in widths ``w``, time in ``sqrt(w/g)``, densities in ``rho_w``; energies per unit length
    into the page are in ``rho_w g w^3``); ``line``: cache line (bodies only);
    ``source``: for parameters, the scene key the value comes from (``physics.drag``);
    ``budget``: an energy ledger booked in the energy budget (``E(0) - E(t)`` is the sum of
    these), marked here rather than recognised by its units, so that a typo cannot drop a
    term: a ``budget`` column must be a ``ledger`` in units of :data:`E`; ``since``: for a
    ledger summed into a diagnostic, the run-file format version that first holds it (the
    figures read older files without it)."""

    name: str
    role: str
    units: str
    doc: str
    output: str | None = None
    line: int | None = None
    source: str | None = None
    owner: str | None = None  # the effect that declares the column (None: the model's own)
    budget: bool = False
    since: int = 1

    def __post_init__(self):
        if self.role not in ROLES:
            raise ValueError(f"column {self.name}: role {self.role!r} not in {ROLES}")
        if self.budget and (self.role != "ledger" or self.units != E or not self.output):
            raise ValueError(f"column {self.name}: a budget column must be a ledger in {E} with an output name")


@dataclass(frozen=True)
class Table:
    """A packed array: ``array`` is its attribute in :class:`Arrays` (``b``), ``dtype``
    ``"real"`` (the scene's precision), ``"f64"``, ``"i32"`` or ``"i64"``; ``shape`` says
    what indexes it, the column last."""

    name: str
    array: str
    dtype: str
    shape: str
    doc: str
    columns: tuple[Column, ...]
    namespace: type
    width: int = 0  # columns allocated (>= len(columns)); 0: exactly the columns

    def __post_init__(self):
        names = [c.name for c in self.columns]
        if len(set(names)) != len(names):
            raise ValueError(f"table {self.name}: duplicate column names")
        for k, name in enumerate(names):
            setattr(self.namespace, name, k)
        self.namespace.SIZE = self.size

    @property
    def size(self) -> int:
        return max(self.width, len(self.columns))

    def index(self, name: str) -> int:
        return [c.name for c in self.columns].index(name)

    def with_role(self, *roles: str) -> tuple[Column, ...]:
        return tuple(c for c in self.columns if c.role in roles)

    def outputs(self, *roles: str) -> dict[str, int]:
        """``{output name: column}`` of the columns with an output name and one of ``roles``."""
        return {c.output: k for k, c in enumerate(self.columns) if c.output and (not roles or c.role in roles)}
