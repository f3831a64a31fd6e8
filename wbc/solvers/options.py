"""The options each priority solver takes, checked: one a solver has no use for is an error.

Every solver takes ``backend`` (a QP back-end name or instance) and ``damping`` (the
singularity damping, :class:`~wbc.solvers.cascade.Damping`); beyond those each class lists its
own in ``options`` (``projection``: ``weighting``; ``weighted``: ``level_weight``; ``hqp``:
none). :func:`check_options` is what every ``create`` calls, so ``weighting`` given to ``hqp``
is a :class:`~wbc.errors.ConfigError` naming the option and the solver, never silently dropped.
"""

from __future__ import annotations

from ..errors import ConfigError

#: what every solver's ``create`` takes
COMMON_OPTIONS = ("backend", "damping")


def check_options(solver_name: str, takes: tuple[str, ...], given: dict, every: dict[str, tuple[str, ...]]) -> None:
    """Raise ConfigError for a key of ``given`` that solver ``solver_name`` does not take
    (``takes``: its own options; ``every``: each solver's own, to say who takes it)."""
    for key in given:
        if key in takes or key in COMMON_OPTIONS:
            continue
        owners = [name for name, opts in every.items() if key in opts]
        where = f"an option of the {' and '.join(owners)} solver{'s' if len(owners) > 1 else ''}" if owners \
            else "not an option of any solver"
        accepted = ", ".join(COMMON_OPTIONS + takes)
        raise ConfigError(f"solver '{solver_name}' does not take the option '{key}' ({where}); "
                          f"'{solver_name}' takes {accepted}", key=f"solver.{key}")
