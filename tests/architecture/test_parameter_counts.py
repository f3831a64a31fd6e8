"""Named state: outside the compiled kernels, no function of ``wbc/`` takes more than
:data:`LIMIT` parameters (docs/architecture.md, "Option records").

Counted with :mod:`ast` from the source: every parameter a caller can give (positional-only,
positional, keyword-only), ``self``/``cls`` left out, and ``*args`` and ``**kwargs`` one each
(a record's fields given one by one as keywords, :class:`wbc.options.Options`, are one
``**settings``). A kernel is a function decorated with numba (``@nb.njit``, ``@numba.njit``,
``@jit``...) or defined in a module of a ``kernels`` package (``wbc/solvers/kernels/``): its
arguments are arrays and scalars numba compiles, grouped where they belong together.
"""

from __future__ import annotations

import ast
from pathlib import Path

WBC = Path(__file__).resolve().parents[2] / "wbc"
LIMIT = 8


def parameter_count(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """The parameters a caller gives ``fn`` (module docstring's rule)."""
    a = fn.args
    names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
    if names and names[0] in ("self", "cls"):
        names = names[1:]
    return len(names) + (a.vararg is not None) + (a.kwarg is not None)


def is_kernel(fn: ast.FunctionDef | ast.AsyncFunctionDef, path: Path) -> bool:
    """Compiled by numba (a decorator naming ``jit``), or in a ``kernels`` package."""
    if "kernels" in path.relative_to(WBC).parts[:-1]:
        return True
    for d in fn.decorator_list:
        target = d.func if isinstance(d, ast.Call) else d
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name in ("njit", "jit", "vectorize", "guvectorize", "cfunc"):
            return True
    return False


def long_signatures(root: Path = WBC) -> list[tuple[str, int]]:
    """``path:line name (n)`` of every non-kernel function over :data:`LIMIT` parameters."""
    out = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not is_kernel(node, path):
                n = parameter_count(node)
                if n > LIMIT:
                    out.append((f"{path.relative_to(root.parent)}:{node.lineno} {node.name}", n))
    return out


def test_no_function_outside_the_kernels_takes_more_than_8_parameters():
    long = long_signatures()
    assert not long, f"functions over {LIMIT} parameters (group them in an option record): {long}"


def test_the_count_sees_every_kind_of_parameter(tmp_path):
    src = tmp_path / "wbc" / "m.py"
    src.parent.mkdir()
    src.write_text("def f(a, /, b, *c, d, **e): pass\n"
                   "class K:\n    def g(self, a, b, c, d, e, f, g, h, i): pass\n"
                   "@nb.njit(cache=True)\ndef k(a, b, c, d, e, f, g, h, i): pass\n")
    fns = {n.name: n for n in ast.walk(ast.parse(src.read_text())) if isinstance(n, ast.FunctionDef)}
    assert parameter_count(fns["f"]) == 5
    assert parameter_count(fns["g"]) == 9
    assert is_kernel(fns["k"], WBC / "m.py") and not is_kernel(fns["g"], WBC / "m.py")
    assert is_kernel(fns["g"], WBC / "solvers" / "kernels" / "m.py")
