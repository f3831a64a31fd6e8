"""Benchmark harness: cycle time of the controller, where it goes, and what it could be.

    wbc bench [--quick] [--json FILE] [--out-dir DIR] [--cycles N] [--backends daqp,proxqp,...]

The command: it times the control cycle (Talos and TIAGo, every solver and QP back-end,
split by phase), its floor, the closed loop, PlaCo as a peer and the scaling with nv and
levels. The harness itself is ``benchmarks/harness/`` of wbc's source tree (see its
``__init__``), beside the package, not in it. This module parses the options (so ``wbc
bench --help`` works anywhere), finds the harness beside the installed package (a source
checkout or an editable install) or in the current directory, and runs it. A wheel does
not ship the harness: then the command says where to get it and exits with status 2.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from wbc.errors import HarnessNotFound, WbcError

#: where the harness sits in a source tree, from its top directory
HARNESS = Path("benchmarks") / "harness"


def harness_roots() -> list[Path]:
    """The directories that may hold :data:`HARNESS`, in the order they are tried: the one
    above the ``wbc`` package (a source checkout or an editable install), then the current
    directory."""
    roots = [Path(__file__).resolve().parents[2], Path.cwd().resolve()]
    return list(dict.fromkeys(roots))


def load_harness():
    """The harness's command module (``benchmarks.harness.cli``) from the first of
    :func:`harness_roots` that has it; :class:`~wbc.errors.HarnessNotFound` if none has."""
    roots = harness_roots()
    root = next((r for r in roots if (r / HARNESS / "__init__.py").is_file()), None)
    if root is None:
        raise HarnessNotFound(
            "wbc bench needs the benchmark harness, benchmarks/harness/ of wbc's source tree, which an installed "
            f"wheel does not ship (looked in {' and '.join(str(r) for r in roots)}); get wbc's source (the "
            "repository or the sdist it was installed from) and run `wbc bench` (or `make bench`) in its top directory")
    if str(root) not in sys.path:
        sys.path.insert(0, str(root))
    from benchmarks.harness import cli  # found on the path just set: a source tree's, not the package's
    found = Path(cli.__file__).resolve().parent
    if found != (root / HARNESS).resolve():
        raise HarnessNotFound(f"`benchmarks.harness` was imported from {found}, not from {root / HARNESS}: "
                              "another `benchmarks` package is on the path; run `wbc bench` in wbc's source tree")
    return cli


def _cmd_bench(args) -> int:
    return load_harness().bench(args)


def add_parser(sub) -> None:
    """Register the ``bench`` sub-command on an argparse subparsers object."""
    p = sub.add_parser("bench", help="cycle-time benchmark: cases, phases, floor, PlaCo peer, scaling",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="short run (< 1 min): 100 cycles, fewer scaling points; "
                   "writes no results.md, and no scaling.png unless --out-dir is given")
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--out-dir", metavar="DIR", default=None, help="results.md and scaling.png go here (default benchmarks/)")
    p.add_argument("--cycles", type=int, default=None, metavar="N",
                   help="timed cycles per case (default: the harness's, benchmarks/harness/options.py)")
    p.add_argument("--backends", nargs="+", default=None, metavar="NAME",
                   help="QP back-ends for hqp and weighted, comma or space separated (default: all of the "
                        "harness's: daqp, proxqp, quadprog, osqp)")
    p.add_argument("--budget", type=float, default=None, metavar="SECONDS",
                   help="wall-time budget per case in s; a case that uses it up stops and is marked truncated "
                        "(default: the harness's, shorter with --quick)")
    p.add_argument("--blas-threads", type=int, default=None, metavar="N",
                   help="set the OpenBLAS thread count first (default: leave it as the environment set it)")
    p.set_defaults(fn=_cmd_bench)


def main(argv: list[str] | None = None) -> int:
    """``python -m wbc.cli.bench [options]``: as ``wbc bench``; a missing harness prints one
    ``error:`` line and returns 2."""
    parser = argparse.ArgumentParser(prog="python -m wbc.cli.bench")
    sub = parser.add_subparsers(dest="cmd")
    add_parser(sub)
    args = parser.parse_args(["bench", *(sys.argv[1:] if argv is None else argv)])
    try:
        return args.fn(args)
    except WbcError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
