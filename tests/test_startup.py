"""Start-up: Taichi's front end reuses the source-position text of each AST node
(``melange_ti.runtime.memoize_source_positions``, docs/performance.md). Kernels and their
compile errors must be what they were. (No ``from __future__ import annotations`` here:
Taichi reads the kernel's annotations as objects.)"""

import numpy as np
import pytest
import taichi as ti

from melange_ti import runtime


def test_compile_errors_still_quote_the_source_every_time():
    assert runtime.memoize_source_positions()  # applied at import; idempotent

    @ti.kernel
    def broken(a: ti.types.ndarray()) -> ti.f64:
        return a[0] + undefined_name  # noqa: F821

    messages = []
    for _ in range(2):
        with pytest.raises(ti.TaichiCompilationError) as err:
            broken(np.zeros(3))
        messages.append(str(err.value))
    assert "return a[0] + undefined_name" in messages[0] and "^" in messages[0]
    assert messages[0] == messages[1]


def test_memoized_text_equals_taichi_own():
    """The cached text is the text Taichi itself makes, for every node of a kernel."""
    import ast
    import inspect
    import textwrap

    from taichi.lang.ast.ast_transformer_utils import ASTTransformerContext

    patched = ASTTransformerContext.get_pos_info
    original = next(c.cell_contents for c in patched.__closure__ if callable(c.cell_contents))

    def sample(a, b):
        s = 0.0
        for i in range(3):
            if a > b:
                s += a * i
        return s

    lines, start = inspect.getsourcelines(sample)
    src = textwrap.dedent("".join(lines)).splitlines()
    tree = ast.parse("\n".join(src))

    class Ctx:
        file = __file__
        lineno_offset = start - 1
        indent = len(lines[0]) - len(lines[0].lstrip())
        func = type("F", (), {"func": sample})

    ctx = Ctx()
    ctx.src = [" " * ctx.indent + line for line in src]
    nodes = [n for n in ast.walk(tree) if isinstance(n, (ast.stmt, ast.expr))]
    assert len(nodes) > 10
    for n in nodes:
        assert patched(ctx, n) == original(ctx, n)
        assert patched(ctx, n) == original(ctx, n)  # from the cache
