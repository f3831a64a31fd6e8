"""Option records (:class:`wbc.options.Options`): each a frozen dataclass whose every field has
its own docstring; a setting given by keyword is the record's field, an unknown one a TypeError."""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
from pathlib import Path

import pytest

from wbc.options import Options, flat_parameters

WBC = Path(__file__).resolve().parents[2] / "wbc"


def records() -> list[type[Options]]:
    """Every Options subclass defined in wbc/ (its modules imported)."""
    for path in sorted(WBC.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if "(Options)" in text or "Gains)" in text:
            parts = path.relative_to(WBC.parent).with_suffix("").parts
            try:
                importlib.import_module(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
            except ImportError:         # an optional package (mujoco, ray, viser) absent
                pass
    found, todo = [], list(Options.__subclasses__())
    while todo:
        c = todo.pop()
        found.append(c)
        todo += c.__subclasses__()
    return sorted(found, key=lambda c: c.__qualname__)


RECORDS = records()


def test_the_records_are_found():
    names = {c.__name__ for c in RECORDS}
    assert {"SimOptions", "ControllerOptions", "ContactOptions", "ForceFeedback", "CollisionOptions",
            "SweepRunOptions", "ImpedanceGains"} <= names


@pytest.mark.parametrize("cls", RECORDS, ids=[c.__name__ for c in RECORDS])
def test_a_record_is_frozen_and_documents_each_field(cls):
    assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen
    tree = ast.parse(inspect.getsource(cls))
    body = tree.body[0].body
    documented = {s.target.id for s, nxt in zip(body, body[1:]) if isinstance(s, ast.AnnAssign)
                  and isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant) and isinstance(nxt.value.value, str)}
    own = {s.target.id for s in body if isinstance(s, ast.AnnAssign)}
    assert own <= documented, f"{cls.__name__}: fields without a docstring: {sorted(own - documented)}"


@pytest.mark.parametrize("cls", RECORDS, ids=[c.__name__ for c in RECORDS])
def test_keywords_fill_the_record_and_an_unknown_one_is_refused(cls):
    f = dataclasses.fields(cls)[0]
    base = cls()
    value = getattr(base, f.name)
    got = cls.of(None, {f.name: value}, "owner")
    assert got == base and cls.of(base, {}) is base
    with pytest.raises(TypeError, match="owner: unknown setting.*no_such_setting"):
        cls.of(None, {"no_such_setting": 1}, "owner")


def test_a_task_mapping_takes_the_record_fields():
    from wbc.tasks.contact import Contact, ContactOptions

    params = flat_parameters(Contact.__init__, Contact.options_record)
    assert {f.name for f in dataclasses.fields(ContactOptions)} <= set(params)
    assert "options" not in params and "settings" not in params
    c = Contact("left_foot", fmin=5.0, sliding=True)
    assert (c.fmin, c.sliding) == (5.0, True)
