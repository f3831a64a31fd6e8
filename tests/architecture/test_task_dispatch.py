"""No dispatch on a task's type name outside ``wbc/tasks/`` (issue #22: "dispatch on strings").

Code that treats a com task differently from a frame task asks the task's class
(``isinstance(task, CoM)``) or a property the task classes declare (``task.moves_orientation``),
not ``task.kind == "com"``: a renamed kind or a subclass then cannot silently fall through.
Found from the source with :mod:`ast`: a comparison (``==``, ``!=``, ``in``, ``not in``) of
something's ``.kind`` (or a variable named ``kind``) with a string literal, or a tuple, list or
set of them, that names a task type.

Allowed, each for its reason:

- ``wbc/tasks/``: the task library itself (``TASK_TYPES`` maps a YAML ``type:`` to its class there;
  the scenario's task builder looks the string up in that map, with no literal);
- :data:`PLAIN_DATA`: the solvers' side of the plain boundary, which reads a level's ``kinds``
  (plain strings the problem carries; solvers may not import :mod:`wbc.tasks`).
"""

from __future__ import annotations

import ast
from pathlib import Path

import wbc.tasks
from wbc.tasks.base import Task

WBC = Path(__file__).resolve().parents[2] / "wbc"

#: modules that read the problem's level ``kinds`` (plain data), not a task object
PLAIN_DATA = {"wbc/problem/rows.py", "wbc/solvers/projection.py"}


def task_kinds() -> set[str]:
    """The ``kind`` of every task class (all subclasses of :class:`Task`, the library's)."""
    assert wbc.tasks.TASK_TYPES      # the library is imported, so its subclasses are known
    found: set[str] = set()
    todo: list[type] = [Task]
    while todo:
        cls = todo.pop()
        todo.extend(cls.__subclasses__())
        if cls is not Task and cls.__module__.startswith("wbc.tasks"):
            found.add(cls.kind)
    return found


def _names_kind(node: ast.expr) -> bool:
    return (isinstance(node, ast.Attribute) and node.attr == "kind") or (isinstance(node, ast.Name) and node.id == "kind")


def _strings(node: ast.expr) -> set[str]:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return {node.value}
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return {e.value for e in node.elts if isinstance(e, ast.Constant) and isinstance(e.value, str)}
    return set()


def string_dispatch(source: str, kinds: set[str]) -> list[tuple[int, str]]:
    """(line, text) of each comparison of a ``kind`` with a literal naming one of ``kinds``."""
    hits = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Compare):
            continue
        operands = [node.left, *node.comparators]
        if not any(_names_kind(o) for o in operands):
            continue
        if any(_strings(o) & kinds for o in operands):
            hits.append((node.lineno, ast.unparse(node)))
    return sorted(hits)


def test_the_scan_finds_string_dispatch():
    kinds = task_kinds()
    assert {"com", "frame", "contact", "force", "collision_avoidance"} <= kinds
    src = ('if task.kind == "frame": pass\n'
           'x = [t for t in s if t.kind in ("com", "frame")]\n'
           'if kind != "contact_wrench": pass\n'
           'if c.kind == "surface": pass\n')          # a contact surface's kind: not a task type
    assert [line for line, _ in string_dispatch(src, kinds)] == [1, 2, 3]


def test_no_task_kind_dispatch_outside_tasks():
    kinds = task_kinds()
    found = []
    for path in sorted(WBC.rglob("*.py")):
        rel = path.relative_to(WBC.parent).as_posix()
        if rel.startswith("wbc/tasks/") or rel in PLAIN_DATA:
            continue
        found += [f"{rel}:{line}: {text}" for line, text in string_dispatch(path.read_text(), kinds)]
    assert not found, ("dispatch on a task's type name; use isinstance against wbc.tasks' classes or a "
                       "property the task classes declare:\n" + "\n".join(found))


def test_the_allowed_modules_still_need_it():
    """An allowance that no longer matches anything is removed, not kept."""
    kinds = task_kinds()
    for rel in PLAIN_DATA:
        assert string_dispatch((WBC.parent / rel).read_text(), kinds), rel
