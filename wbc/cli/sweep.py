"""``wbc sweep SPEC.yaml``: the command (registered by :func:`add_parser`, like ``wbc bench``).

Exit status: 0 the sweep ran (whatever the robot did), 1 some case raised or crashed
its worker (status error or failed; the others still ran), 2 a spec that does not
validate (file, line, key path).
"""

from __future__ import annotations

import argparse
import shlex
import sys

DESCRIPTION = """Run a parameter sweep or Monte Carlo study of a scenario: the cases of SPEC.yaml (a base scenario,
axes over any scenario key by key path, model perturbations) on a local process pool or on Ray,
one CSV row per case written as it ends (an interrupted sweep keeps what it finished; running it
again runs only the missing cases), then a summary (survived fraction per group; for a bisection
the limit per group) and plots beside results.csv. --validate checks the spec and builds sample
cases, as `wbc validate` does for a scenario."""

EPILOG = """examples:
  wbc sweep benchmarks/push_recovery.yaml                 largest survived push per direction and solver
  wbc sweep benchmarks/robustness.yaml --workers 2        200 random cases, survived fraction per solver
  wbc sweep my_sweep.yaml --validate                      exit 0, or 2 with file, line and key path
  wbc sweep my_sweep.yaml --executor ray --address auto   the same cases on a Ray cluster

spec format: see wbc/sweep/spec.py (python -c "import wbc.sweep.spec as s; print(s.__doc__)")."""


def _command(args) -> str:
    parts = ["wbc", "sweep", args.spec]
    for opt in ("executor", "workers", "address", "timeout", "out"):
        v = getattr(args, opt)
        if v is not None:
            parts += [f"--{opt}", str(v)]
    if args.retry:
        parts.append("--retry")
    return " ".join(shlex.quote(p) for p in parts)


def _cmd_sweep(args) -> int:
    from wbc.sweep.engine import run_sweep
    from wbc.sweep.spec import load_spec
    from wbc.sweep.validate import check

    spec = load_spec(args.spec)
    built = check(spec)
    if args.validate:
        from wbc.sweep.spec import count_cases

        n = count_cases(spec)
        print(f"{args.spec}: ok (base {spec.base.stem}, mode {spec.mode}, {len(spec.axes)} axes, "
              f"{'at most ' if spec.mode == 'bisect' else ''}{n} cases; {built} sample cases built)")
        return 0
    res = run_sweep(spec, executor=args.executor, workers=args.workers, address=args.address,
                    timeout=args.timeout, out_dir=args.out, retry=args.retry, stop_after=args.stop_after,
                    progress=not args.quiet)
    from wbc.sweep.summary import markdown

    text = markdown(res, command=_command(args))
    (res.out_dir / "summary.md").write_text(text)
    print(text, end="")
    if not args.no_plots:
        from wbc.sweep.plots import plot_all

        for p in plot_all(res):
            print(f"plot written to {p}")
    print(f"results in {res.out_dir / 'results.csv'}, summary in {res.out_dir / 'summary.md'}")
    return 1 if res.count("error") or res.count("failed") else 0


def add_parser(sub) -> None:
    """Register the ``sweep`` sub-command on an argparse subparsers object."""
    p = sub.add_parser("sweep", help="parameter sweeps and Monte Carlo studies (grid, random, bisect), "
                       "local pool or Ray", description=DESCRIPTION, epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("spec", metavar="SPEC.yaml", help="sweep spec (base scenario, axes, mode, survival criterion)")
    p.add_argument("--validate", action="store_true",
                   help="check the spec and build sample cases (every axis value); run nothing")
    p.add_argument("--executor", choices=["local", "ray"], default=None,
                   help="local process pool (default) or Ray tasks (pip install 'wbc[sweep]')")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="worker processes (local; default: the cores) or Ray CPUs used (default: the cluster's)")
    p.add_argument("--address", default=None, metavar="ADDR",
                   help="Ray cluster address (auto, ray://host:10001; default: start Ray on this machine)")
    p.add_argument("--timeout", type=float, default=None, metavar="S",
                   help="per-case wall-time limit in s (default: the spec's timeout, else 300)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="folder of results.csv, summary.md and the plots (default: the spec's output, "
                        "else SPEC's folder / SPEC's stem)")
    p.add_argument("--retry", action="store_true", help="run again the cases stored as error, failed or timeout")
    p.add_argument("--no-plots", action="store_true", help="write no PNG plots")
    p.add_argument("--quiet", action="store_true", help="no progress line on stderr")
    p.add_argument("--stop-after", type=int, default=None, metavar="N", help=argparse.SUPPRESS)
    p.set_defaults(fn=_cmd_sweep)


def main(argv: list[str] | None = None) -> int:
    """``python -m wbc.cli.sweep SPEC ...`` (the same as ``wbc sweep``)."""
    from wbc.cli.exits import dispatch

    parser = argparse.ArgumentParser(prog="python -m wbc.cli.sweep")
    parser.add_argument("--debug", action="store_true", help="show the full traceback of an error")
    add_parser(parser.add_subparsers(dest="cmd"))
    return dispatch(parser.parse_args(["sweep", *(sys.argv[1:] if argv is None else argv)]))


if __name__ == "__main__":
    sys.exit(main())

