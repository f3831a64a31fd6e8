"""The import rules of ``docs/architecture.md``, held: the import graph of ``wbc/`` is built
from the source with :mod:`ast` (imports inside functions included, ``if TYPE_CHECKING:``
blocks excluded: they never run). Circles between modules are held by ``test_imports.py``;
here: no circle between packages, and every import between packages is one the importing
package's rules allow.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

WBC = Path(__file__).resolve().parents[2] / "wbc"

#: package (or top-level module) -> the packages it may import, besides itself. The same
#: rules are stated in each package's ``__init__`` docstring and drawn in docs/architecture.md.
BASE = {"wbc.errors", "wbc.options"}
ALLOWED: dict[str, set[str]] = {
    "wbc.errors": set(),
    "wbc.options": set(),
    "wbc.blas": set(),
    "wbc.jsonable": set(),
    "wbc.kernel_cache": set(),
    "wbc.null_space": set(),
    "wbc.cholesky": set(),
    "wbc.validation": BASE,
    "wbc.robot": BASE | {"wbc.validation"},
    "wbc.problem": BASE,
    "wbc.collision": BASE | {"wbc.validation", "wbc.robot", "wbc.sim"},
    "wbc.tasks": BASE | {"wbc.validation", "wbc.robot", "wbc.problem", "wbc.null_space", "wbc.collision",
                         "wbc.cholesky"},
    "wbc.stack": BASE | {"wbc.tasks", "wbc.problem"},
    "wbc.solvers": BASE | {"wbc.problem", "wbc.cholesky"},
    "wbc.controller": BASE | {"wbc.validation", "wbc.robot", "wbc.tasks", "wbc.problem", "wbc.solvers", "wbc.stack"},
    "wbc.sim": BASE | {"wbc.robot"},
    "wbc.chapter": BASE | {"wbc.validation", "wbc.robot", "wbc.null_space", "wbc.sim"},
    "wbc.trajectories": BASE | {"wbc.validation"},
    "wbc.locomotion": BASE | {"wbc.tasks"},
    "wbc.interaction": BASE | {"wbc.validation", "wbc.robot", "wbc.tasks"},
    "wbc.scenario": BASE | {"wbc.validation", "wbc.robot", "wbc.tasks", "wbc.stack", "wbc.trajectories",
                            "wbc.interaction", "wbc.sim", "wbc.solvers", "wbc.controller", "wbc.locomotion"},
    "wbc.runner": BASE | {"wbc.validation", "wbc.robot", "wbc.tasks", "wbc.trajectories", "wbc.interaction",
                          "wbc.sim", "wbc.controller", "wbc.scenario", "wbc.collision",
                          "wbc.locomotion", "wbc.blas"},
    "wbc.viz": BASE | {"wbc.sim", "wbc.robot", "wbc.tasks", "wbc.jsonable"},
    "wbc.sweep": BASE | {"wbc.validation", "wbc.jsonable", "wbc.blas", "wbc.robot", "wbc.scenario", "wbc.runner"},
}
#: may import anything of wbc (nothing of wbc imports them)
TOP = {"wbc", "wbc.cli"}


def module_name(path: Path) -> str:
    parts = list(path.relative_to(WBC.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING")


def imports_of(path: Path, modules: set[str]) -> set[str]:
    """The wbc modules ``path`` imports, anywhere in it (``from pkg import mod`` counts as
    ``pkg.mod`` when that is a module, else as ``pkg``)."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.split(".")[0] == "wbc")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] == "wbc":
                for a in node.names:
                    sub = f"{target}.{a.name}"
                    found.add(sub if sub in modules else target)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(ast.parse(path.read_text(encoding="utf-8")))
    found.discard(name)
    return found


def graph() -> dict[str, set[str]]:
    files = sorted(WBC.rglob("*.py"))
    modules = {module_name(p) for p in files}
    return {module_name(p): imports_of(p, modules) for p in files}


def owner(module: str) -> str:
    """The package a module belongs to for the rules: ``wbc.x`` for ``wbc.x.y.z``."""
    parts = module.split(".")
    return ".".join(parts[:2])


def find_cycle(g: dict[str, set[str]]) -> list[str] | None:
    """One circle of ``g`` as a list of nodes (first == last), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def dfs(n: str) -> list[str] | None:
        state[n] = 1
        stack.append(n)
        for m in sorted(g.get(n, ())):
            if state.get(m) == 1:
                return stack[stack.index(m):] + [m]
            if m not in state:
                found = dfs(m)
                if found:
                    return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(g):
        if n not in state:
            found = dfs(n)
            if found:
                return found
    return None


def test_the_graph_sees_function_level_imports():
    g = graph()
    # wbc.chapter.joint_space imports nothing of wbc.runner; the CLI imports the runner inside a function
    assert any(m.startswith("wbc.runner") for m in g["wbc.cli.main"])


def test_no_import_circle_between_packages():
    g: dict[str, set[str]] = {}
    for m, deps in graph().items():
        if m == "wbc":
            continue
        g.setdefault(owner(m), set()).update(owner(d) for d in deps if owner(d) != owner(m) and d != "wbc")
    cycle = find_cycle(g)
    assert cycle is None, "import circle between packages: " + " -> ".join(cycle)


def test_every_package_has_rules():
    assert {owner(m) for m in graph()} - set(ALLOWED) - TOP == set()


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_imports_follow_the_rules(package):
    bad = sorted(f"{m} imports {d}" for m, deps in graph().items() if owner(m) == package
                 for d in deps if owner(d) != package and owner(d) not in ALLOWED[package])
    assert not bad, f"{package} may import only {sorted(ALLOWED[package])}: " + "; ".join(bad)


def test_at_most_12_modules_directly_under_wbc():
    top = sorted(p.name for p in WBC.glob("*.py"))
    assert len(top) <= 12, top


def test_the_bench_harness_does_not_import_the_command_that_loads_it():
    """``wbc.cli.bench`` imports ``benchmarks.harness.cli`` (from a source tree); the harness
    owns its defaults (``benchmarks/harness/options.py``) and imports no ``wbc.cli``."""
    harness = WBC.parent / "benchmarks" / "harness"
    modules = {module_name(p) for p in WBC.rglob("*.py")}
    bad = {p.name: sorted(m for m in imports_of(p, modules) if m.startswith("wbc.cli"))
           for p in harness.glob("*.py")}
    assert not {k: v for k, v in bad.items() if v}
