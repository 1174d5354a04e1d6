"""The schema (melange_ti.physics.data.schema): every array indexed through its own namespace.

Taichi compiles ``a.cd[s, i, Body.VX]`` without complaint (both are integers), so this test
reads every kernel module and checks that each subscript whose column comes from a schema
namespace indexes the array that namespace describes, and that no schema array is indexed
by a bare integer column. A checker test on a deliberately wrong snippet shows that the
lint catches what it is for. A second lint finds a kernel's division by a constant that is
not a power of two, which a device rounds otherwise (docs/devices.md).
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import pytest

from melange_ti.physics.data import schema
from melange_ti.physics.data.columns import ROLES, Column

PHYSICS = Path(schema.__file__).resolve().parent.parent  # melange_ti/physics
ARRAYS = {t.array: t for t in schema.TABLES}  # "b" -> BODIES, ...
NAMESPACES = {t.namespace.__name__: t for t in schema.TABLES}  # "Body" -> BODIES, ...


def _array_name(node: ast.AST, aliases: dict[str, str]) -> str | None:
    """``a.b`` -> "b"; a local alias ``b = ti.static(a.b)`` -> "b"; else None."""
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "a":
        return node.attr
    if isinstance(node, ast.Name):
        return aliases.get(node.id)
    return None


def _aliases(func: ast.FunctionDef) -> dict[str, str]:
    out = {}
    for node in ast.walk(func):
        if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
            v = node.value
            if isinstance(v, ast.Call) and getattr(v.func, "attr", None) == "static" and v.args:
                name = _array_name(v.args[0], {})
                if name is not None:
                    out[node.targets[0].id] = name
    # kernel parameters are the arrays themselves (b: arr, par: arr, ...)
    for arg in func.args.args:
        if arg.arg in ARRAYS and arg.arg not in out:
            out[arg.arg] = arg.arg
    return out


def check_source(text: str, where: str = "<source>") -> list[str]:
    """Problems in ``text``: a namespace column used on another array, or a schema array
    indexed by a bare integer column."""
    problems = []
    tree = ast.parse(text)
    for func in ast.walk(tree):
        if not isinstance(func, ast.FunctionDef):
            continue
        aliases = _aliases(func)
        for node in ast.walk(func):
            if not isinstance(node, ast.Subscript):
                continue
            array = _array_name(node.value, aliases)
            if array is None or array not in ARRAYS:
                continue
            index = node.slice.elts if isinstance(node.slice, ast.Tuple) else [node.slice]
            last = index[-1]
            line = f"{where}:{node.lineno}"
            if isinstance(last, ast.Attribute) and isinstance(last.value, ast.Name) and last.value.id in NAMESPACES:
                table = NAMESPACES[last.value.id]
                if table.array != array:
                    problems.append(
                        f"{line}: {array}[..., {last.value.id}.{last.attr}] indexes {array} with {table.name}'s columns"
                    )
                elif not hasattr(table.namespace, last.attr):
                    problems.append(f"{line}: {last.value.id}.{last.attr} is not a column")
            elif isinstance(last, ast.Constant) and isinstance(last.value, int) and ARRAYS[array].columns:
                if array in ("cp", "nl"):
                    continue
                problems.append(f"{line}: {array}[..., {last.value}] uses a bare integer column")
            for other in index[:-1]:  # a namespace column in a leading (row) position
                if isinstance(other, ast.Attribute) and isinstance(other.value, ast.Name) and other.value.id in NAMESPACES:
                    problems.append(f"{line}: {other.value.id}.{other.attr} used as a row index of {array}")
    return problems


def _modules():
    return sorted(p for p in PHYSICS.rglob("*.py") if p.name not in ("columns.py", "schema.py"))


def test_lint_catches_a_wrong_array_index():
    wrong = "def f(a, i, s):\n    return a.cd[s, i, Body.VX] + a.b[i, 3] + a.par[Config.N]\n"
    problems = check_source(wrong)
    assert len(problems) == 3, problems
    right = "def f(a, i, s):\n    b = ti.static(a.b)\n    return a.cd[s, i, Contact.NX] + b[i, Body.VX] + a.par[Param.DT]\n"
    assert check_source(right) == []


def test_kernel_modules_index_arrays_through_their_namespaces():
    modules = _modules()
    assert len(modules) >= 10, "the lint must see the step's modules"
    problems = [p for m in modules for p in check_source(m.read_text(), str(m.relative_to(PHYSICS)))]
    assert not problems, "\n".join(problems)


def test_lint_sees_the_kernels():
    """Guard against a vacuous lint: it recognises hundreds of namespaced subscripts."""
    seen = 0
    for m in _modules():
        tree = ast.parse(m.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Subscript):
                s = node.slice.elts[-1] if isinstance(node.slice, ast.Tuple) else node.slice
                if isinstance(s, ast.Attribute) and isinstance(s.value, ast.Name) and s.value.id in NAMESPACES:
                    seen += 1
    assert seen > 200, seen


@pytest.mark.parametrize("table", schema.TABLES, ids=lambda t: t.name)
def test_every_column_is_described(table):
    for c in table.columns:
        assert c.role in ROLES and c.units and c.doc, c
    assert table.size >= len(table.columns)


def test_body_row_fits_cache_lines():
    """The hot columns (what the impulse pass and the correction touch) share line 0; the
    row is a whole number of 64-byte lines in f64."""
    b = schema.BODIES
    assert b.size % 8 == 0
    hot = ("X", "Z", "VX", "VZ", "OM", "INV_MASS", "SHIFT_X", "SHIFT_Z")
    assert {b.columns[b.index(n)].line for n in hot} == {0}
    assert all(c.line == k // 8 for k, c in enumerate(b.columns))


def test_derived_lists():
    """State, constants and ledgers come from the roles (SPEC section 5's names)."""
    assert set(schema.BODIES.outputs("state")) == set(schema.STATE_NAMES) == {"x", "z", "theta", "vx", "vz", "omega"}
    assert schema.CONSTANTS == ("width", "thickness", "mass", "inertia")
    assert "drag_dissipated" in schema.BODY_LEDGERS
    assert set(schema.ENERGY_LEDGERS) == {
        "drag_dissipated",
        "added_mass_work",
        "collision_dissipated",
        "impulse_offset_work",
        "correction_work",
        "friction_dissipated",
        "wave_absorbed",
        "bond_damping_dissipated",
        "fracture_released",
        "bond_offset_work",
        "bond_correction_work",
    }
    from melange_ti import diagnostics

    assert set(schema.ENERGY_LEDGERS) <= set(diagnostics.NAMES)


def test_parameters_come_from_scene_keys():
    """Every parameter slot but the derived ones names the scene key it is filled from, and
    that key exists (derived: the largest bounding radius, machine epsilon, and the wave
    grid's spacing, a power-of-2 division of the domain, and rounding quantum, and the drift's
    sub-steps, the most any named effect asks for)."""
    from melange_ti import scene

    sc = scene.load(None)
    for c in schema.PARAMS.columns:
        if c.name in ("BOUND_MAX", "EPS", "SIX", "TWELVE", "SUBSTEPS", "WAVE_DX", "WAVE_Q"):
            assert c.source is None
            continue
        section, key = c.source.split(".")
        assert hasattr(getattr(sc, section), key), c


def test_energy_ledgers_are_marked_not_matched_by_units():
    """The budget's terms are the columns marked ``budget`` (the test above pins them); a
    budget column whose units are mistyped is refused when declared, not dropped."""
    assert schema.ENERGY_LEDGERS == tuple(c.output for t in schema.TABLES for c in t.columns if c.budget)
    with pytest.raises(ValueError, match="budget"):
        Column("TYPO", "ledger", "rho_w g w3", "energy with mistyped units", "typo_work", budget=True)
    with pytest.raises(ValueError, match="budget"):
        Column("TYPO", "scratch", schema.E, "not a ledger", "typo_work", budget=True)


def _constant(node: ast.AST):
    """The number a literal expression (``6.0``, ``-6``, ``2 * 3.0``) stands for, else None."""
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return node.value
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        v = _constant(node.operand)
        return None if v is None else (-v if isinstance(node.op, ast.USub) else v)
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Add, ast.Sub)):
        x, y = _constant(node.left), _constant(node.right)
        if x is not None and y is not None:
            return {ast.Mult: x * y, ast.Add: x + y, ast.Sub: x - y}[type(node.op)]
    return None


def constant_divisions(text: str, where: str = "<source>") -> list[str]:
    """Divisions by a literal that is not a power of two inside ``@ti.func``/``@ti.kernel``
    functions: a device's compiler turns ``x / 6.0`` into ``x * (1/6)``, not correctly
    rounded (docs/devices.md), so the kernels divide by such numbers read at run time."""
    problems = []
    for func in ast.walk(ast.parse(text)):
        if not isinstance(func, ast.FunctionDef):
            continue
        if not any(getattr(d, "attr", None) in ("func", "kernel") for d in func.decorator_list):
            continue
        for node in ast.walk(func):
            if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
                v = _constant(node.right)
                if v is not None and (v == 0 or math.frexp(abs(v))[0] != 0.5):
                    problems.append(f"{where}:{node.lineno}: divides by the constant {v}")
    return problems


def test_lint_catches_a_division_by_a_constant():
    wrong = "@ti.func\ndef f(x, y):\n    return x / 6.0 + x / (2 * 3) + x / -12\n"
    assert len(constant_divisions(wrong)) == 3, constant_divisions(wrong)
    right = "@ti.func\ndef f(x, y, six):\n    return x / six + x / 2.0 + 0.25 / 4 + 1.0 / (1.0 + y)\n"
    right += "\ndef host(x):\n    return x / 6.0\n"  # not a kernel
    assert constant_divisions(right) == []


def test_kernels_divide_by_no_constant_but_a_power_of_two():
    problems = [p for m in _modules() for p in constant_divisions(m.read_text(), str(m.relative_to(PHYSICS)))]
    assert not problems, "\n".join(problems)
