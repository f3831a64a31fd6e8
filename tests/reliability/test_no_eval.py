"""Nothing in the package evaluates text or unpickles data: a scenario or robot YAML is data,
never code. Every module of ``wbc`` is parsed (ast) and every name is resolved through its
imports (``import pickle as p; p.loads`` is ``pickle.loads``); refused: the builtins that run
code (eval, exec, compile, __import__), YAML's loaders other than the safe one, pickle and its
kin, numpy's ``allow_pickle=True``, imports by computed name, shells, and in a module that imports
``multiprocessing`` a ``.send(...)`` / ``.recv(...)`` on an object (a ``Connection``'s, which pickle:
``send_bytes`` / ``recv_bytes`` carry bytes; a module's function of that name, such as
``jsonable.send``, or a class's own method, ``self.send``, is not flagged). The scanner is
checked first on a snippet with every one of them."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import wbc
from wbc.errors import ConfigError

BUILTINS = {"eval", "exec", "compile", "__import__", "breakpoint"}
MODULES = {"pickle", "_pickle", "cPickle", "dill", "cloudpickle", "marshal", "shelve", "jsonpickle", "joblib",
           "runpy", "code", "codeop"}
NAMES = {f"yaml.{n}" for n in ("load", "load_all", "unsafe_load", "unsafe_load_all", "full_load", "full_load_all",
                               "Loader", "UnsafeLoader", "FullLoader", "CLoader", "CUnsafeLoader", "CFullLoader",
                               "add_constructor", "add_multi_constructor", "constructor.UnsafeConstructor",
                               "constructor.FullConstructor", "constructor.Constructor")} | {
    "importlib.import_module", "importlib.util.spec_from_file_location", "os.system", "os.popen",
    "numpy.load", "pandas.read_pickle", "torch.load"} | {f"builtins.{b}" for b in BUILTINS}
PICKLING_METHODS = {"send", "recv"}       # multiprocessing.connection.Connection's (pickle.dumps / loads)
# modules still exchanging pickles through a Connection, each with the reason it is not yet fixed
KNOWN_CONNECTION_PICKLES: dict[str, str] = {}


def offences(source: str, filename: str = "<snippet>") -> list[str]:
    tree = ast.parse(source, filename)
    alias: dict[str, str] = {}
    bound: set[str] = set()             # every imported name, relative imports too (modules, functions)
    uses_mp = False
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            bound |= {a.asname or a.name.split(".")[0] for a in node.names}
            mods = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
            uses_mp |= any(m.split(".")[0] == "multiprocessing" for m in mods)
        if isinstance(node, ast.Import):
            for a in node.names:
                alias[a.asname or a.name.split(".")[0]] = a.name if a.asname else a.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            for a in node.names:
                alias[a.asname or a.name] = f"{node.module}.{a.name}"

    def dotted(node) -> str | None:
        if isinstance(node, ast.Name):
            return alias.get(node.id, node.id)
        if isinstance(node, ast.Attribute):
            base = dotted(node.value)
            return f"{base}.{node.attr}" if base else None
        return None

    found = []
    for node in ast.walk(tree):
        where = f"{filename}:{getattr(node, 'lineno', 0)}"
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            mods = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
            found += [f"{where}: imports {m}" for m in mods if m.split(".")[0] in MODULES]
            if isinstance(node, ast.ImportFrom):
                found += [f"{where}: imports {node.module}.{a.name}" for a in node.names
                          if f"{node.module}.{a.name}" in NAMES]
        name = dotted(node) if isinstance(node, (ast.Name, ast.Attribute)) else None
        if name:
            name = name.replace("np.", "numpy.", 1) if name.startswith("np.") else name
            imported = name.split(".")[0] in {v.split(".")[0] for v in alias.values()}
            if name in NAMES or (imported and name.split(".")[0] in MODULES) or \
                    (isinstance(node, ast.Name) and node.id in BUILTINS and node.id not in alias) or \
                    (isinstance(node, ast.Name) and node.id == "__builtins__"):
                found.append(f"{where}: {name}")
        if isinstance(node, ast.Call):
            f = node.func
            if uses_mp and isinstance(f, ast.Attribute) and f.attr in PICKLING_METHODS and \
                    not (isinstance(f.value, ast.Name) and (f.value.id in bound or f.value.id == "self")):
                found.append(f"{where}: {ast.unparse(f)}() (a multiprocessing Connection's {f.attr} pickles)")
            for kw in node.keywords:
                if kw.arg in ("allow_pickle", "shell") and not (isinstance(kw.value, ast.Constant) and not kw.value.value):
                    found.append(f"{where}: {kw.arg}={ast.unparse(kw.value)}")
            if dotted(node.func) == "getattr" and len(node.args) > 1 and dotted(node.args[0]) in ("yaml", "pickle", "builtins"):
                attr = node.args[1]
                if not (isinstance(attr, ast.Constant) and "Safe" in str(attr.value)):
                    found.append(f"{where}: getattr({dotted(node.args[0])}, {ast.unparse(attr)})")
    # methods such as re.compile or spec.compile are attributes, not the builtin: not flagged
    return sorted(set(found))


BAD = """
import pickle as p
import yaml, numpy as np, subprocess
from yaml import load as L, FullLoader
from importlib import import_module
p.loads(b"")
yaml.load(text, Loader=yaml.Loader)
L(text)
eval("1"); exec("x = 1"); compile("1", "f", "eval"); __import__("os")
np.load("f.npy", allow_pickle=True)
subprocess.run(cmd, shell=True)
import_module(name)
getattr(yaml, "unsafe_load")(text)
import builtins
builtins.exec("x = 1"); getattr(builtins, "eval")("1"); __builtins__["eval"]("1")
from multiprocessing.connection import Connection
conn.send(("post", key)); msg = self._conn.recv()
"""
GOOD = """
import re, yaml
yaml.safe_load(text); re.compile("x"); model.compile(); subprocess.run(["ls"], shell=False)
getattr(yaml, "CSafeLoader", yaml.SafeLoader)
from multiprocessing.connection import Connection
from . import jsonable
self.send("stop"); jsonable.send(conn, ("post", key)); msg = jsonable.receive(conn)
conn.send_bytes(b"{}"); conn.recv_bytes()
"""


def test_the_scanner_finds_each_way_of_running_text():
    got = offences(BAD)
    for needle in ("imports pickle", "pickle.loads", "yaml.load", "yaml.Loader", "yaml.FullLoader", "eval", "exec",
                   "compile", "__import__", "allow_pickle=True", "shell=True", "importlib.import_module",
                   "getattr(yaml, 'unsafe_load')", "builtins.exec", "getattr(builtins, 'eval')", "__builtins__",
                   "conn.send()", "self._conn.recv()"):
        assert any(needle in g for g in got), f"{needle} not found in {got}"
    assert offences(GOOD) == []


def test_no_module_of_the_package_evaluates_or_unpickles():
    root = Path(wbc.__file__).parent
    files = sorted(root.rglob("*.py"))
    assert len(files) > 50
    found = [o for f in files for o in offences(f.read_text(), str(f.relative_to(root.parent)))]
    found = [o for o in found if not (o.split(":")[0] in KNOWN_CONNECTION_PICKLES and "Connection's" in o)]
    assert found == [], "\n".join(found)
    for known in KNOWN_CONNECTION_PICKLES:      # an exception that no longer applies goes from the list
        assert any("Connection's" in o for o in offences((root.parent / known).read_text(), known)), known


@pytest.mark.parametrize("tag", ["!!python/object/apply:os.system ['true']", "!!python/name:builtins.eval"])
def test_a_scenario_with_a_python_tag_is_refused(tmp_path, tag):
    path = tmp_path / "evil.yaml"
    path.write_text(f"name: {tag}\nrobot: panda\nstack: []\n")
    with pytest.raises(ConfigError, match="evil.yaml"):
        wbc.load_config(path)
