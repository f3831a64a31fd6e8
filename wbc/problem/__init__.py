"""The boundary between the stack and the solvers: plain data only.

- :mod:`.rows`: what a task contributes (:class:`Rows`, written into a :class:`RowSlot`
  the problem owns), a level of rows and task names (:class:`Level`), every level's rows
  in five arrays (:class:`StackedRows`), where the forces live in x (:class:`Layout`);
- :mod:`.buffer`: every level's rows in five stack-wide arrays (:class:`RowBuffer`);
- :mod:`.problem`: one cycle's :class:`Problem` handed to ``solver.solve``;
- :mod:`.result`: what every solver returns, :class:`SolveResult` with a
  :class:`LevelInfo` per level.

The solvers import this package, their kernels and :mod:`wbc.errors`, nothing else of wbc.
"""

from .problem import ROW_MARGIN, Problem
from .result import CERTIFIED, LevelInfo, SolveResult
from .rows import Layout, Level, Rows, RowSlot, StackedRows

__all__ = ["CERTIFIED", "ROW_MARGIN", "Layout", "Level", "LevelInfo", "Problem", "Rows", "RowSlot", "SolveResult",
           "StackedRows"]
