"""Every parameter of the public API has its own entry in its docstring's ``Args:`` section.

The public API is ``wbc.__all__`` (its classes, their public methods and properties, its
functions) and ``wbc.tasks.__all__`` (each task's constructor and the cone helpers). A class's
constructor parameters are documented in the class docstring, under ``Args:`` (or
``Attributes:`` for a record). An entry is ``name:`` or ``name (type):`` at the section's
indentation; ``*args``/``**kwargs`` are documented as ``*args:``/``**kwargs:``.
"""

from __future__ import annotations

import inspect
import re

import pytest

import wbc
import wbc.tasks

#: dunder methods a user calls (``stack["name"]``, ``"name" in stack``, ``stack / level``)
_PUBLIC_DUNDERS = {"__getitem__", "__contains__", "__truediv__", "__add__", "__call__"}
_SECTIONS = ("Args:", "Attributes:")
_HEADER = re.compile(r"^[A-Z][A-Za-z ]*:$")


def _callables(module, methods: bool):
    """(qualified name, object) of each public callable of ``module.__all__``; with ``methods``
    also each class's own public methods and properties."""
    for name in module.__all__:
        obj = getattr(module, name)
        if inspect.ismodule(obj) or not callable(obj) or (inspect.isclass(obj) and issubclass(obj, BaseException)):
            continue
        yield f"{module.__name__}.{name}", obj
        if methods and inspect.isclass(obj):
            for key, member in vars(obj).items():
                if key.startswith("_") and key not in _PUBLIC_DUNDERS:
                    continue
                if isinstance(member, (staticmethod, classmethod)):
                    member = member.__func__
                if isinstance(member, property) or inspect.isfunction(member):
                    yield f"{module.__name__}.{name}.{key}", member


def public_api() -> list[tuple[str, object]]:
    return list(_callables(wbc, methods=True)) + list(_callables(wbc.tasks, methods=False))


def documented_args(doc: str) -> set[str]:
    """The names with an entry in ``doc``'s Args/Attributes sections."""
    names: set[str] = set()
    lines = inspect.cleandoc(doc).splitlines()
    for i, line in enumerate(lines):
        if line.strip() not in _SECTIONS:
            continue
        indent = None
        for entry in lines[i + 1:]:
            if not entry.strip():
                continue
            depth = len(entry) - len(entry.lstrip())
            if depth <= len(line) - len(line.lstrip()):
                break                            # the section ended (a dedent: next section or text)
            indent = depth if indent is None else indent
            if depth == indent:
                m = re.match(r"(\*{0,2}\w+)\s*(\([^)]*\))?:", entry.strip())
                if m:
                    names.add(m.group(1).lstrip("*"))
    return names


def parameters(obj) -> list[str]:
    """The parameters a caller passes (not self/cls)."""
    target = obj.fget if isinstance(obj, property) else obj
    sig = inspect.signature(target)
    return [p for p in sig.parameters if p not in ("self", "cls")]


API = public_api()


def test_the_walk_covers_the_api():
    names = {n for n, _ in API}
    for expected in ("wbc.Controller", "wbc.Controller.solve", "wbc.Stack.add", "wbc.Stack.__getitem__",
                     "wbc.RobotModel.update", "wbc.run", "wbc.load_robot", "wbc.tasks.Frame", "wbc.tasks.wrench_cone"):
        assert expected in names
    assert len(API) > 60


@pytest.mark.parametrize("name,obj", API, ids=[n for n, _ in API])
def test_public_callable_has_a_docstring(name, obj):
    doc = obj.__doc__ if isinstance(obj, property) else inspect.getdoc(obj)
    assert doc and doc.strip(), f"{name} has no docstring"


@pytest.mark.parametrize("name,obj", [(n, o) for n, o in API if not isinstance(o, property)],
                         ids=[n for n, o in API if not isinstance(o, property)])
def test_every_parameter_has_its_own_args_entry(name, obj):
    params = parameters(obj)
    if not params:
        return
    doc = inspect.getdoc(obj) or ""
    missing = [p for p in params if p not in documented_args(doc)]
    assert not missing, f"{name}: parameter(s) {missing} have no entry in its docstring's Args section"


def test_args_parser_reads_google_style():
    doc = """Summary.

    Args:
        a: first.
            continued: not an entry.
        b (float): second.
        **rest: the others.

    Returns:
        c: not an argument.
    """
    assert documented_args(doc) == {"a", "b", "rest"}
