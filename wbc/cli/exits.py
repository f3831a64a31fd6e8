"""`wbc`'s exit statuses and the one place that turns a command's outcome into one: shared
by :mod:`wbc.cli.main` and the sub-commands' own ``python -m`` entry points."""

from __future__ import annotations

import sys
import traceback

from wbc.errors import WbcError

#: exit statuses of `wbc`: ok; the robot fell or the controller failed; bad input; a bug in wbc
EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERNAL = 0, 1, 2, 3


def dispatch(args) -> int:
    """Run the parsed `wbc` command ``args.fn(args)``; returns its exit status (:data:`EXIT_OK` ... :data:`EXIT_INTERNAL`).

    Bad input (a :class:`WbcError`: a scenario or robot YAML that does not validate, an
    unknown file) prints one ``error:`` line and returns 2; anything else is a bug in wbc:
    a short message and 3, the traceback only with ``--debug``."""
    try:
        return args.fn(args)
    except WbcError as exc:
        if args.debug:
            traceback.print_exc()
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("wbc: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:        # a bug: never a bare traceback unless asked for
        if args.debug:
            traceback.print_exc()
        where = "".join(traceback.format_exception_only(type(exc), exc)).strip().splitlines()[-1]
        print(f"wbc: internal error in `wbc {args.cmd}`: {where}\n"
              f"  this is a bug in wbc, not in your input: please report it with --debug output "
              f"(wbc --debug {args.cmd} ...)", file=sys.stderr)
        return EXIT_INTERNAL
