"""Bad input gets an error that names what was wrong and what was expected."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.scenario.build_tasks import build_stack, build_task
from wbc.tasks import CoM, Contact, Frame, Posture


def test_unknown_robot_lists_the_known_ones():
    with pytest.raises(wbc.RobotNotFound, match=r"unknown robot 'atlas'.*talos.*tiago"):
        wbc.load_robot("atlas")


def test_robot_yaml_with_missing_urdf_names_file_and_key(tmp_path):
    f = tmp_path / "bot.yaml"
    f.write_text("name: bot\nurdf: nowhere/bot.urdf\nroot: fixed\n")
    with pytest.raises(wbc.RobotDefinitionError, match=r"bot.yaml:2: urdf: file .*nowhere/bot.urdf.* does not exist"):
        wbc.load_robot(f)


def test_robot_yaml_with_bad_root_names_the_choices(tmp_path):
    f = tmp_path / "bot.yaml"
    f.write_text("name: bot\nurdf: x.urdf\nroot: floating\n")
    expected = r"bot.yaml:3: root: must be one of \['free_flyer', 'planar', 'fixed'\], got 'floating'"
    with pytest.raises(wbc.RobotDefinitionError, match=expected):
        wbc.load_robot(f)


def test_unknown_frame_names_the_frame_and_lists_aliases(talos):
    stack = wbc.Stack([[Frame("right_paw")]])
    with pytest.raises(wbc.FrameNotFound, match=r"no frame 'right_paw'.*left_foot.*right_hand"):
        wbc.Controller(talos, stack)


def test_unknown_contact_surface(talos):
    with pytest.raises(wbc.FrameNotFound, match=r"no contact surface 'right_hand'.*left_foot"):
        wbc.Controller(talos, wbc.Stack([[Contact("right_hand")]]))


def test_unknown_task_type_in_a_stack_spec():
    with pytest.raises(wbc.ConfigError, match=r"stack\[1\]\[0\]\.type: unknown task type 'centroid'.*'com'"):
        build_stack([[{"type": "posture"}], [{"type": "centroid", "kp": 3}]])


def test_unknown_task_parameter_names_it():
    with pytest.raises(wbc.ConfigError, match=r"stack\[0\]\.gain: unknown parameter of a 'com' task"):
        build_task({"type": "com", "gain": 3}, "stack[0]")


@pytest.mark.parametrize("make", [lambda: CoM(kp=-1.0), lambda: Frame("right_hand", kd=-2.0),
                                  lambda: Posture(kp=float("nan"))])
def test_negative_or_nan_gain_is_refused(make):
    with pytest.raises(wbc.TaskDefinitionError, match=r"task '.*': k[pd] must be a number >= 0 \(1/s.?\), got (-|NaN)"):
        make()


def test_negative_gain_in_a_stack_spec_names_the_key_path():
    with pytest.raises(wbc.ConfigError, match=r"stack\[0\]\[1\]\.kp: must be a number >= 0 \(1/s²\), got -5"):
        build_stack([[{"type": "posture"}, {"type": "com", "kp": -5}]])


def test_wrong_target_shapes_name_the_task(talos):
    com = CoM()
    with pytest.raises(wbc.TargetError, match=r"task 'com': target must have shape \(3,\)"):
        com.target = [0.1, 0.2]
    hand = Frame("right_hand")
    with pytest.raises(wbc.TargetError, match=r"task 'right_hand': target must be a pinocchio.SE3, a 4x4"):
        hand.target = np.zeros((2, 2))
    posture = Posture(target=np.zeros(5))
    with pytest.raises(wbc.TargetError, match=r"task 'posture': target must have shape \(39,\)"):
        wbc.Controller(talos, wbc.Stack([[posture]]))


def test_wrong_state_shape_is_refused_and_a_nan_state_is_a_held_fault(talos):
    ctrl = wbc.Controller(talos, wbc.Stack([[Posture()]]))
    with pytest.raises(wbc.TargetError, match=r"expected q of shape \(39,\) and v of shape \(38,\)"):
        ctrl.solve(np.zeros(38), np.zeros(38))
    q = talos.q_default.copy()
    q[10] = np.nan
    # a NaN in the measurement is a run-time fault (wbc.controller.faults), not bad input: held, counted
    sol = ctrl.solve(q, np.zeros(38))
    assert sol.status == "failed" and sol.fault == "state_faults" and "q[10]" in sol.message
    assert np.all(np.isfinite(sol.tau)) and ctrl.fault_counts()["state_faults"] == 1


def test_duplicate_task_names_and_unknown_solver(talos):
    with pytest.raises(wbc.StackError, match=r"two tasks are named 'com'"):
        wbc.Stack([[CoM()], [CoM()]])
    with pytest.raises(wbc.SolverError, match=r"unknown solver 'lqr'"):
        wbc.Controller(talos, wbc.Stack([[CoM()]]), solver="lqr")


def test_a_failed_first_cycle_commands_gravity_compensation_not_nan(talos, monkeypatch):
    """Nothing silently wrong: a solve that returns NaN is reported as failed, and the
    torque is the last good one, or on the first cycle gravity compensation g(q)."""
    from wbc.solvers.hqp import HierarchicalQP

    ctrl = wbc.Controller(talos, [[Contact("left_foot"), Contact("right_foot")], [CoM()]])
    # the torque cycle enters the hqp through profiled_result (after its compiled run,
    # wbc/controller/torque_step.py; solve_planned where that is off): its answer is poisoned
    entries = ("solve_planned", "profiled_result")
    real = {name: getattr(HierarchicalQP, name) for name in entries}

    def poisoning(name):
        def poisoned(self, problem, *args):
            res = real[name](self, problem, *args)
            res.x = np.full(problem.layout.nx, np.nan)
            return res
        return poisoned

    def poison(on: bool) -> None:
        for name in entries:
            monkeypatch.setattr(HierarchicalQP, name, poisoning(name) if on else real[name])

    poison(True)
    q = talos.q_default.copy()
    sol = ctrl.solve(q, np.zeros(talos.nv))
    assert sol.status == "failed" and np.all(np.isfinite(sol.tau))
    g = pin.computeGeneralizedGravity(talos.model, talos.model.createData(), q)
    np.testing.assert_allclose(sol.tau, g[talos.actuated_idx], atol=1e-9)
    assert np.abs(sol.tau).max() > 1.0           # a real gravity torque (N·m), not zeros
    poison(False)
    good = ctrl.solve(q, np.zeros(talos.nv))
    poison(True)
    again = ctrl.solve(q, np.zeros(talos.nv))
    assert good.status == "ok" and again.status == "failed"
    np.testing.assert_array_equal(again.tau, good.tau)      # the last good torque


def _exception_names() -> set[str]:
    """Exception and warning classes: the builtins' and wbc.errors'."""
    import builtins
    import inspect

    import wbc.errors

    out = {n for n, c in vars(builtins).items() if inspect.isclass(c) and issubclass(c, BaseException)}
    return out | {n for n, c in vars(wbc.errors).items() if inspect.isclass(c) and issubclass(c, BaseException)}


def test_every_error_class_lives_in_errors_py_under_one_name():
    """Read from the source (ast over wbc/): no exception or warning class is defined
    outside wbc/errors.py, and none gets a second name (``E = RobotDefinitionError``)."""
    import ast
    from pathlib import Path

    names = _exception_names()
    root = Path(wbc.__file__).parent
    defined, aliases = [], []
    for f in sorted(root.rglob("*.py")):
        tree = ast.parse(f.read_text(), str(f))
        where = f.relative_to(root.parent)
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef) and f.name != "errors.py":
                if any(ast.unparse(b).rpartition(".")[2] in names for b in node.bases):
                    defined.append(f"{where}:{node.lineno} class {node.name}")
            elif isinstance(node, ast.Assign) and isinstance(node.value, (ast.Name, ast.Attribute)):
                if ast.unparse(node.value).rpartition(".")[2] in names - {"NotImplemented"}:
                    aliases.append(f"{where}:{node.lineno} {ast.unparse(node)}")
    assert not defined, f"error classes outside wbc/errors.py: {defined}"
    assert not aliases, f"second names for error classes: {aliases}"
