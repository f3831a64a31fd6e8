"""``wbc sweep --validate``: the spec's structure (:func:`wbc.sweep.spec.load_spec`) and then
what only the base scenario can tell:

- every axis and ``set:`` key path fits the base scenario's document: list items exist
  (``pushes[1]`` of a scenario with one push is refused), a ``@magnitude`` /
  ``@direction_deg`` axis addresses a list of 3 numbers, a mapping key that the base does
  not have (``sensing.noise_q`` of a scenario without ``sensing:``) is accepted only if the
  scenario with it builds (the scenario's own checks refuse unknown keys, with a
  did-you-mean); ``model.mass_scale.<link>`` names a link or joint of the robot;
- a sample case builds (the first value of every axis), and so does the case with each
  listed value, choice or range end of each axis in turn (the others at their first),
  through :func:`wbc.scenario.loader.load_config`, exactly as a worker builds it.

Errors are :class:`ConfigError` naming the spec file, the line and the key path of the
axis (``axes.solver.type``) with the scenario's own message quoted.
"""

from __future__ import annotations

import copy
from typing import Any

from ..errors import ConfigError, WbcError
from . import keypath
from .cases import make_case
from .perturb import body_joint
from .spec import SweepSpec


def _plain(key: str) -> str:
    return key.partition("@")[0]


def _related(a: str, b: str | None) -> bool:
    """Whether key paths ``a`` and ``b`` are one inside the other."""
    if not b:
        return False
    a, b = _plain(a), _plain(b)
    return a == b or a.startswith(b + ".") or a.startswith(b + "[") or b.startswith(a + ".") or b.startswith(a + "[")


def _check_path(spec: SweepSpec, doc: dict, key: str, where: str) -> None:
    """The key path fits ``doc``: set it there (list items must exist, a missing mapping key
    is created, a vector component needs 3 numbers)."""
    if key.startswith("model."):
        return
    try:
        keypath.assign(doc, key, 0.0)
    except ConfigError as exc:
        raise spec.error(f"{exc.message} (base scenario {spec.base.name})", where) from None


def _build(spec: SweepSpec, values: dict[str, Any]) -> ConfigError | None:
    """Build the case of ``values``: None, or the error."""
    from .worker import build

    try:
        case = make_case(spec, values, spec.seed, "check")
        sc, _ = build(case.payload())
        for link in case.perturbation.link_scale:
            try:
                body_joint(sc.robot.model, link)
            except ConfigError as exc:
                raise ConfigError(exc.message, key=f"model.mass_scale.{link}") from None
    except WbcError as exc:
        return exc if isinstance(exc, ConfigError) else ConfigError(str(exc), key=exc.key)
    return None


def _quote(exc: WbcError) -> str:
    text = exc.message or str(exc)
    return f"{exc.key}: {text}" if exc.key else text


def check(spec: SweepSpec) -> int:
    """Check ``spec`` against its base scenario (module docstring); returns the number of
    cases built. Raises :class:`ConfigError` at the spec's key path."""
    doc = copy.deepcopy(spec.base_doc)
    for k, v in spec.fixed.items():                 # set: applies in order, before the axes
        _check_path(spec, copy.deepcopy(doc), k, f"set.{k}")
        if not k.startswith("model."):
            keypath.assign(doc, k, v)
    for a in spec.axes:
        _check_path(spec, copy.deepcopy(doc), a.key, f"axes.{a.key}")
    first = {a.key: a.probes()[0] for a in spec.axes}
    err = _build(spec, first)
    built = 1
    if err is not None:
        _blame_first(spec, first, err)
    for a in spec.axes:
        for v in a.probes()[1:]:
            err = _build(spec, {**first, a.key: v})
            built += 1
            if err is not None:
                raise spec.error(f"value {v!r} gives a case that does not build: {_quote(err)}", f"axes.{a.key}")
    return built


def _blame_first(spec: SweepSpec, first: dict, err: ConfigError) -> None:
    """The first case does not build: the base, a ``set:`` key or an axis is to blame."""
    saved, spec.fixed = spec.fixed, {}
    try:
        base_err = _build(spec, {})
    finally:
        spec.fixed = saved
    if base_err is not None:
        raise spec.error(f"the base scenario {spec.base} does not build: {_quote(base_err)}", "base")
    if _build(spec, {}) is not None:
        key = next((k for k in spec.fixed if _related(k, err.key)), None)
        raise spec.error(f"gives a case that does not build: {_quote(err)}", f"set.{key}" if key else "set")
    key = next((a.key for a in spec.axes if _related(a.key, err.key)), spec.axes[0].key)
    raise spec.error(f"value {first[key]!r} gives a case that does not build: {_quote(err)}", f"axes.{key}")
