"""The benchmark harness of ``wbc bench``: cycle time of the controller, where it goes,
and what it could be. It measures only; nothing here changes how the controller solves.

It lives beside the package, not in it (a wheel does not ship it): ``wbc bench`` (the
thin entry point :mod:`wbc.cli.bench`) finds it in the source tree and calls
:func:`.cli.bench`.

- **Cases** (:mod:`.timing`): Talos, full stack (5 levels: limits + two foot contacts /
  CoM / both hands / posture / contact-force regularisation, each sole's wrench towards
  half the weight) and TIAGo (limits / hand position / posture, differential drive), each
  with the ``projection``, ``hqp`` and ``weighted`` solvers, the QP solvers with every
  back-end; the stacks are :mod:`.stacks`, shared with the tests. ``cycles`` cycles after a
  warm-up, along the moving trajectory of :mod:`.trajectory` (CoM sinusoid, hand targets
  on small circles; the state integrated from the returned q̈, dt = 1 ms). Per case:
  median, p99 and max cycle time, and the split by phase (model update, task rows, solve,
  torques and diagnostics), measured by wrapping the controller's own methods with timers.
- **Floor** (:mod:`.floor`): what one Talos cycle cannot go below in this process: the
  pinocchio calls plus one daqp solve of a same-size QP (the whole stack as a single
  weighted QP, level 0 as constraints: 50 variables, 18 equality and 100 inequality rows).
- **Closed loop** (:mod:`.closed_loop`): controller and physics of ``talos_balance``,
  the real-time factor and the median simulator step.
- **Peer** (:mod:`.peers`): PlaCo's ``DynamicsSolver`` on Talos with comparable tasks,
  and PlaCo's ``KinematicsSolver`` on the IK problem of :mod:`.placo_peer`.
- **Scaling** (:mod:`.scaling`): cycle time against nv (serial chains built with
  pinocchio, nv 12 to 156) and against the number of levels (Talos, the same tasks split
  over 1 to 10 levels), with the log-log exponents, plotted to ``<out-dir>/scaling.png``.
- **Machine** (:mod:`.machine`) and **report** (:mod:`.report`): what ran where, the
  progress lines and ``results.md``.
"""
