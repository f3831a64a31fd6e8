"""Reading YAML files: ``yaml.safe_load`` semantics only, a mapping at the top, errors that
name the file and, where the parser knows it, the line.

:func:`read_document` also records the line (1-based) of every key path of the document
(``stack[1][0].kp`` -> 17), so that a check made later on the plain data can say where the
bad value was written. Refused with a :class:`~wbc.errors.ConfigError` (or the error class
asked for) naming the file: YAML syntax errors, tags other than YAML's own
(``!!python/object:...``), duplicate keys in a mapping, nesting deeper than
:data:`MAX_DEPTH`, integers longer than Python converts, text that is not UTF-8.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from wbc.errors import ConfigError, WbcError, join_key
from wbc.validation.schema import is_file

#: deepest nesting of lists and mappings accepted (a robot or scenario needs 5)
MAX_DEPTH = 50
#: largest file read (bytes): a scenario or robot YAML is a few kB
MAX_BYTES = 1 << 20


#: libyaml's parser when PyYAML was built with it (10x faster), else PyYAML's own; both
#: with PyYAML's SafeConstructor: the semantics of ``yaml.safe_load``
_SafeBase = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class _Loader(_SafeBase):
    """``yaml.safe_load``'s loader, refusing duplicate keys (PyYAML keeps the last silently).
    Keys merged in with ``<<:`` may be overridden, as YAML specifies."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            first: dict = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    earlier = first.get(key)
                except TypeError:        # an unhashable key: SafeLoader's own error follows
                    continue
                if earlier is not None:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"duplicate key {key!r} (first given on line {earlier})", key_node.start_mark)
                first[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep)

    def construct_object(self, node, deep=False):
        try:
            return super().construct_object(node, deep)
        except (ValueError, OverflowError) as exc:     # an integer of 5000 digits, a date 2025-13-01
            raise yaml.constructor.ConstructorError(None, None, f"a value YAML cannot convert: {exc}",
                                                    node.start_mark) from None


@dataclass
class Document:
    """A YAML file's data and the line of each key path in it (``lines``, 1-based)."""

    path: Path
    data: Any
    lines: dict[str, int] = field(default_factory=dict)

    def line(self, key: str | None) -> int | None:
        """Line of ``key``, else of its nearest enclosing key path that has one."""
        while key:
            if key in self.lines:
                return self.lines[key]
            cut = max(key.rfind("."), key.rfind("["))
            key = key[:cut] if cut > 0 else ""
        return None


def _record_lines(root, loader: _Loader) -> dict[str, int]:
    """Key path -> line of its value, walking the node graph once per node (aliases are
    not re-entered, so a document of nested aliases costs its size, not its expansion)."""
    lines: dict[str, int] = {}
    seen: set[int] = set()
    stack = [("", root)]
    while stack:
        path, node = stack.pop()
        if path:
            lines.setdefault(path, node.start_mark.line + 1)
        if id(node) in seen:
            continue
        seen.add(id(node))
        if isinstance(node, yaml.MappingNode):
            for key_node, value_node in node.value:
                if isinstance(key_node, yaml.ScalarNode):
                    try:
                        key = loader.construct_object(key_node)
                    except yaml.YAMLError:
                        continue
                    key_path = join_key(path, str(key))
                    lines.setdefault(key_path, key_node.start_mark.line + 1)
                    stack.append((key_path, value_node))
        elif isinstance(node, yaml.SequenceNode):
            for i, item in enumerate(node.value):
                stack.append((f"{path}[{i}]", item))
    return lines


def _depth(node, limit: int) -> int:
    """Nesting depth of a node graph, up to ``limit`` + 1 (iterative: no recursion)."""
    deepest, stack, seen = 0, [(node, 1)], set()
    while stack:
        n, d = stack.pop()
        deepest = max(deepest, d)
        if deepest > limit:
            return deepest
        if id(n) in seen:
            continue
        seen.add(id(n))
        if isinstance(n, yaml.MappingNode):
            stack.extend((v, d + 1) for pair in n.value for v in pair)
        elif isinstance(n, yaml.SequenceNode):
            stack.extend((v, d + 1) for v in n.value)
    return deepest


def _check_depth(text: str, path: Path, error: type[WbcError]) -> None:
    """Refuse nesting deeper than :data:`MAX_DEPTH`, from the parser's events (iterative),
    naming the line where it goes too deep."""
    # one entry per open container: [is_mapping, key or index, a mapping's next node is a key]
    open_: list[list] = []

    def key_path() -> str:      # the first 8 steps name the place; the rest is "..."
        out = ""
        for is_map, k, _ in open_[:8]:
            out = join_key(out, str(k)) if is_map else f"{out}[{k}]"
        return (out or "(top level)") + ("..." if len(open_) > 8 else "")

    def value_done() -> None:          # a value ended: its mapping awaits a key, its list the next item
        if open_:
            if open_[-1][0]:
                open_[-1][2] = True
            else:
                open_[-1][1] += 1

    for event in yaml.parse(text, Loader=_SafeBase):
        if isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            if open_ and open_[-1][0] and open_[-1][2]:
                open_[-1][2] = False       # a complex key: treated as the value's place
            if len(open_) >= MAX_DEPTH:
                raise error(f"lists and mappings nested more than {MAX_DEPTH} deep: not a wbc document",
                            key=key_path(), file=path, line=event.start_mark.line + 1)
            open_.append([isinstance(event, yaml.MappingStartEvent), "" if isinstance(event, yaml.MappingStartEvent)
                          else 0, True])
        elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
            open_.pop()
            value_done()
        elif isinstance(event, (yaml.ScalarEvent, yaml.AliasEvent)):
            if open_ and open_[-1][0] and open_[-1][2]:
                open_[-1][1], open_[-1][2] = getattr(event, "value", "*"), False
            else:
                value_done()


def parse(text: str, path: Path, error: type[WbcError] = ConfigError) -> Document:
    """:class:`Document` of YAML ``text`` read from ``path`` (for the messages)."""
    loader = None
    try:
        _check_depth(text, path, error)     # before composing (recursive: deep nesting overflows the stack)
        loader = _Loader(text)
        node = loader.get_single_node()
        if node is not None and _depth(node, MAX_DEPTH) > MAX_DEPTH:     # deep through aliases
            raise error(f"lists and mappings nested more than {MAX_DEPTH} deep: not a wbc document",
                        file=path, line=node.start_mark.line + 1)
        data = loader.construct_document(node) if node is not None else None
        lines = _record_lines(node, loader) if node is not None else {}
    except yaml.constructor.ConstructorError as exc:
        problem = exc.problem or str(exc)
        if "could not determine a constructor for the tag" in problem:
            tag = problem.split("tag", 1)[1].strip().strip("'")
            problem = (f"the YAML tag {tag!r} is not allowed: wbc reads plain YAML only (yaml.safe_load: "
                       "mappings, lists, numbers, text, true/false, null)")
        raise error(problem, file=path, line=_line(exc, text)) from None
    except yaml.reader.ReaderError as exc:
        raise error(f"not valid YAML: character {exc.character!r} is not allowed ({exc.reason})", file=path,
                    line=_line(exc, text)) from None
    except yaml.YAMLError as exc:
        problem = getattr(exc, "problem", None) or str(exc)
        context = getattr(exc, "context", None)
        raise error(f"not valid YAML: {problem}{f' ({context})' if context else ''}", file=path,
                    line=_line(exc, text)) from None
    except (RecursionError, MemoryError):
        raise error("the YAML is nested too deeply to read", file=path) from None
    except (ValueError, OverflowError) as exc:    # e.g. an integer of 5000 digits, a date 2025-13-01
        raise error(f"a value YAML cannot convert: {exc}", file=path) from None
    finally:
        if loader is not None:
            loader.dispose()
    return Document(path, data, lines)


def _line(exc: yaml.YAMLError, text: str) -> int | None:
    """The 1-based line a PyYAML error points at (its problem mark, or a reader's position)."""
    mark = getattr(exc, "problem_mark", None)
    if mark is not None:
        return mark.line + 1
    position = getattr(exc, "position", None)
    return text.count("\n", 0, position) + 1 if isinstance(position, int) else None


def read_document(path: str | Path, error: type[WbcError] = ConfigError) -> Document:
    """The YAML file ``path`` as a :class:`Document` whose data is a mapping."""
    path = Path(path)
    if not is_file(path):
        raise error("file not found", file=path)
    raw = path.read_bytes()
    if len(raw) > MAX_BYTES:
        raise error(f"{len(raw)} bytes: larger than {MAX_BYTES} bytes, not a wbc document", file=path)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise error(f"not UTF-8 text (byte {exc.start})", file=path, line=line) from None
    doc = parse(text, path, error)
    if not isinstance(doc.data, dict):
        found = "an empty file" if doc.data is None else f"a {type(doc.data).__name__}"
        raise error(f"expected a mapping (key: value lines) at the top level, got {found}", file=path, line=1)
    return doc


def read_mapping(path: str | Path, error: type[WbcError] = ConfigError) -> dict:
    """The data of :func:`read_document`."""
    return read_document(path, error).data
