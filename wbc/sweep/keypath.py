"""Key paths into a YAML document, as the error messages write them: ``pushes[0].force``,
``stack[1][0].kp``, ``solver.type``, ``environment[0].mu``, ``robot``.

One reader (:func:`get`) and one writer (:func:`assign`) for every sweep axis: an axis
sets a value of the scenario's YAML document (a plain dict from ``yaml.safe_load``)
before the :class:`~wbc.scenario.loader.Scenario` is built, so any key the scenario format has
(``simulator``, once it exists, included) is an axis without code here.

A key path may end in a *vector component* suffix, for 3-vectors such as a push force
(N) or a CoM offset (m): ``pushes[0].force@magnitude`` (the horizontal norm, units of
the vector) and ``pushes[0].force@direction_deg`` (the horizontal direction, degrees
from +x towards +y). The vector's z is kept; a magnitude without a direction keeps the
base vector's direction and vice versa (:func:`apply_polar`).
"""

from __future__ import annotations

import copy
import math
import re
from typing import Any

from ..errors import ConfigError

#: suffixes of a key path that address a 3-vector in horizontal polar form
POLAR = ("magnitude", "direction_deg")
_NAME = r"[A-Za-z_][A-Za-z0-9_\-]*"
_SEG = re.compile(rf"({_NAME})((?:\[\d+\])*)")
_INDEX = re.compile(r"\[(\d+)\]")


def parse(path: str) -> tuple[list[str | int], str | None]:
    """``"stack[1][0].kp"`` -> (``["stack", 1, 0, "kp"]``, None); a ``@magnitude`` or
    ``@direction_deg`` suffix is returned second. Raises :class:`ConfigError` (message
    only: the caller names the key) for a malformed path."""
    if not isinstance(path, str) or not path:
        raise ConfigError(f"a key path must be text such as 'pushes[0].force', got {path!r}")
    body, _, suffix = path.partition("@")
    if suffix and suffix not in POLAR:
        raise ConfigError(f"unknown suffix '@{suffix}' of a key path; expected one of "
                          f"{['@' + s for s in POLAR]}")
    parts: list[str | int] = []
    for seg in body.split("."):
        m = _SEG.fullmatch(seg)
        if m is None:
            raise ConfigError(f"malformed key path '{path}': each part is a name with optional [index]es, "
                              "e.g. 'stack[1][0].kp'")
        parts.append(m.group(1))
        parts += [int(i) for i in _INDEX.findall(m.group(2))]
    return parts, suffix or None


def join(parts: list[str | int]) -> str:
    """Inverse of :func:`parse` (without suffix): ``["stack", 1, 0, "kp"]`` -> ``"stack[1][0].kp"``."""
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out


def _walk(doc: Any, parts: list[str | int], create: bool) -> tuple[Any, str | int]:
    """The container of the last part and that part; missing mappings are created when
    ``create``. Raises :class:`ConfigError` naming the deepest prefix that exists."""
    node = doc
    for i, p in enumerate(parts[:-1]):
        node = _child(node, p, parts[: i + 1], create, parts[i + 1])
    last = parts[-1]
    _check_slot(node, last, parts)
    return node, last


def _check_slot(node: Any, p: str | int, parts: list[str | int]) -> None:
    where = join(parts[:-1]) or "the document"
    if isinstance(p, int):
        if not isinstance(node, list):
            raise ConfigError(f"{where} is not a list (it is {type(node).__name__}): [{p}] does not apply")
        if p >= len(node):
            raise ConfigError(f"{where} has {len(node)} item(s): [{p}] does not exist")
    elif not isinstance(node, dict):
        raise ConfigError(f"{where} is not a mapping (it is {type(node).__name__}): .{p} does not apply")


def _child(node: Any, p: str | int, prefix: list[str | int], create: bool, nxt: str | int) -> Any:
    _check_slot(node, p, prefix)
    if isinstance(p, str) and p not in node:
        if not create:
            raise ConfigError(f"{join(prefix)} is not in the document")
        if isinstance(nxt, int):
            raise ConfigError(f"{join(prefix)} is not in the document (a list cannot be created by a key path)")
        node[p] = {}
    elif isinstance(p, str) and node[p] is None and create:   # `sensing:` written empty
        node[p] = {}
    return node[p]


def exists(doc: Any, path: str) -> bool:
    """Whether the key path (without suffix) has a value in ``doc``."""
    try:
        get(doc, path)
    except ConfigError:
        return False
    return True


def get(doc: Any, path: str) -> Any:
    """The value at ``path`` in ``doc``; :class:`ConfigError` if any part is missing."""
    parts, _ = parse(path)
    node, last = _walk(doc, parts, create=False)
    if isinstance(last, str) and last not in node:
        raise ConfigError(f"{join(parts)} is not in the document")
    return node[last]


def assign(doc: Any, path: str, value: Any) -> None:
    """Set ``path`` in ``doc`` (in place) to a deep copy of ``value``. Mapping keys that
    are missing are created (the scenario's own validation refuses unknown ones when the
    case is built); list items must exist. A suffixed path is set with :func:`apply_polar`."""
    parts, suffix = parse(path)
    if suffix is not None:
        apply_polar(doc, join(parts), {suffix: value})
        return
    node, last = _walk(doc, parts, create=True)
    node[last] = copy.deepcopy(value)


def apply_polar(doc: Any, path: str, polar: dict[str, float]) -> None:
    """Replace the horizontal part of the 3-vector at ``path`` by ``magnitude`` (units of
    the vector) along ``direction_deg`` (degrees from +x towards +y); either may be
    missing from ``polar`` and is then taken from the vector itself. z is kept."""
    vec = get(doc, path)
    if not (isinstance(vec, list) and len(vec) == 3 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                              for x in vec)):
        raise ConfigError(f"{path}@...: needs a list of 3 numbers at {path}, found {vec!r}")
    x, y, z = (float(c) for c in vec)
    mag = float(polar["magnitude"]) if "magnitude" in polar else math.hypot(x, y)
    ang = math.radians(float(polar["direction_deg"])) if "direction_deg" in polar else math.atan2(y, x)
    # exact zeros along the axes (cos 90° is 6e-17): keeps the documents, and their hashes, clean
    c, s = _cos_sin(ang)
    node, last = _walk(doc, parse(path)[0], create=False)
    node[last] = [mag * c, mag * s, z]


def _cos_sin(a: float) -> tuple[float, float]:
    k = a / (math.pi / 2)
    if abs(k - round(k)) < 1e-12:
        return [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][int(round(k)) % 4]
    return math.cos(a), math.sin(a)


def apply_all(doc: dict, overrides: dict[str, Any]) -> dict:
    """A deep copy of ``doc`` with every ``key path: value`` of ``overrides`` set, plain
    paths in their order first, then the ``@`` vector components per vector."""
    out = copy.deepcopy(doc)
    polar: dict[str, dict[str, float]] = {}
    for path, value in overrides.items():
        parts, suffix = parse(path)
        if suffix is None:
            assign(out, path, value)
        else:
            polar.setdefault(join(parts), {})[suffix] = value
    for path, comp in polar.items():
        apply_polar(out, path, comp)
    return out
