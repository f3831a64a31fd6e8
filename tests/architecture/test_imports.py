"""The package's shape: no import cycle, the core free of wbc.chapter, no module over 500 lines.

The imports are read from the source (ast over wbc/**/*.py, nothing is imported):
``import a.b`` and ``from a import b`` give an edge to the module ``a.b`` if there is one,
else to ``a``; relative imports are resolved against the importing module's package;
imports under ``if TYPE_CHECKING:`` are left out (they never run). "Module-level" imports
run when the module is imported (at the top, or in a top-level ``if``/``try``);
"deferred" ones inside a function or method run when it is called.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "wbc"
MAX_LINES = 500


def _modules() -> dict[str, tuple[Path, bool]]:
    """Dotted name -> (file, is a package's __init__)."""
    out = {}
    for f in sorted(PACKAGE.rglob("*.py")):
        parts = list(f.relative_to(PACKAGE.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_pkg else parts)] = (f, is_pkg)
    return out


MODULES = _modules()


def _is_type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


def _import_nodes(tree: ast.Module, deferred: bool) -> list[ast.Import | ast.ImportFrom]:
    """The module-level imports (``deferred`` False) or every import (True), without the
    TYPE_CHECKING blocks (a class body runs at import: its imports are module-level)."""
    found, todo = [], list(tree.body)
    while todo:
        node = todo.pop()
        if _is_type_checking(node):
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            found.append(node)
        elif isinstance(node, (ast.If, ast.Try, ast.With, ast.ClassDef)) or (deferred and not isinstance(node, ast.expr)):
            todo += [c for c in ast.iter_child_nodes(node) if isinstance(c, ast.stmt) or isinstance(c, ast.excepthandler)]
    return found


def _resolve(name: str | None) -> str | None:
    """The longest prefix of ``name`` that is a module of the package."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def imports_of(module: str, deferred: bool) -> set[str]:
    """The package's modules ``module`` imports."""
    path, is_pkg = MODULES[module]
    out = set()
    for node in _import_nodes(ast.parse(path.read_text(), str(path)), deferred):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        else:
            if node.level:
                base = module.split(".") if is_pkg else module.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                src = ".".join(base + ([node.module] if node.module else []))
            else:
                src = node.module or ""
            targets = [f"{src}.{a.name}" if f"{src}.{a.name}" in MODULES else src for a in node.names]
        out |= {t for t in map(_resolve, targets) if t and t != module}
    return out


def cycles(deferred: bool) -> set[frozenset[str]]:
    """The strongly connected components of more than one module (Tarjan), each a set."""
    graph = {m: imports_of(m, deferred) for m in MODULES}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = set()

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.add(frozenset(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_the_walker_sees_relative_deferred_and_type_checking_imports():
    """The walker itself, on modules whose imports are known: stack.py imports the task
    base and the sugar (relative, module level); the sweep's executor imports the ray pool
    only when asked (deferred); runner.py imports the scenario type for its hints only."""
    assert {"wbc.tasks.base", "wbc.tasks.group", "wbc.errors", "wbc.problem.rows"} <= imports_of("wbc.stack", deferred=False)
    assert "wbc.sweep.ray_pool" not in imports_of("wbc.sweep.executor", deferred=False)
    assert "wbc.sweep.ray_pool" in imports_of("wbc.sweep.executor", deferred=True)
    assert "wbc.tasks" in imports_of("wbc", deferred=False)          # `from . import tasks`: the subpackage


def test_no_import_cycle_at_module_level():
    found = cycles(deferred=False)
    assert not found, "import cycles: " + "; ".join(" <-> ".join(sorted(c)) for c in found)


def test_no_import_cycle_through_deferred_imports():
    """An import inside a function is still a dependency: no cycle through one (the four
    that existed before the layout change, cli <-> sweep cli, trajectories <-> their SO(3)
    part, the sweep executor <-> its pools and the bench harness <-> wbc bench, are gone)."""
    found = cycles(deferred=True)
    assert not found, "import cycles: " + "; ".join(" <-> ".join(sorted(c)) for c in found)


def test_tasks_do_not_import_the_sugar_user():
    """The tasks build the (a + b) / c sugar without importing the stack."""
    for m in MODULES:
        if m.startswith("wbc.tasks"):
            assert "wbc.stack" not in imports_of(m, deferred=True), m


def test_tasks_do_not_import_wbc_chapter():
    """The stack's tasks are the core; the chapter's controllers (wbc.chapter) are built
    on it, not the other way round."""
    bad = {m: sorted(t for t in imports_of(m, deferred=True) if t == "wbc.chapter" or t.startswith("wbc.chapter."))
           for m in MODULES if m == "wbc.tasks" or m.startswith("wbc.tasks.")}
    assert not {m: t for m, t in bad.items() if t}


def _lines(path: Path) -> int:
    return len(path.read_text().splitlines())


def test_no_module_over_500_lines():
    root = PACKAGE.parent
    over = {str(f.relative_to(root)): _lines(f) for f in PACKAGE.rglob("*.py")}
    over = {f: n for f, n in over.items() if n > MAX_LINES}
    assert not over, f"modules over {MAX_LINES} lines: {over}"

