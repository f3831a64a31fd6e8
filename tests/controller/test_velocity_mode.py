"""The velocity-level mode (wbc/controller/velocity.py): IK convergence against an independent
Gauss–Newton solve, strict priority on q̇, joint limits, bad stacks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from wbc import Controller, Stack
from wbc.controller.velocity import VelocityController
from wbc.errors import ConfigError, TaskDefinitionError
from wbc.tasks import CoM, Contact, ContactWrench, Frame, JointLimits, Posture

LOCAL = pin.ReferenceFrame.LOCAL
WORLD = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def _ik_stack(robot, hand_offset):
    feet = [Contact("left_foot"), Contact("right_foot")]
    com, hand, post = CoM(), Frame("right_hand", mask="position"), Posture()
    robot.update(robot.q_default.copy(), np.zeros(robot.nv))
    com.target = robot.com.copy() + np.array([0.01, 0.0, -0.02])
    hand.target = robot.frame_placement(robot.frame_id("right_hand")).translation + hand_offset
    return Stack([feet, [com], [hand], [post]]), hand.target.translation.copy(), com.target.copy()


def _reference_gauss_newton(robot, q, feet_ref, com_ref, hand_ref, iters=200):
    """Constrained Gauss–Newton on the same IK problem, written straight on pinocchio (no wbc
    task, row or solver): min ‖q_ref ⊖ q‖² over the joints s.t. feet at their placements,
    CoM and hand at their targets; each step the KKT system of the linearised problem."""
    m, d = robot.model, robot.data
    fids = [robot.frame_id(robot.contact(c).frame) for c in ("left_foot", "right_foot")]
    hid = robot.frame_id("right_hand")
    nv, j = robot.nv, robot.joint_idx
    for _ in range(iters):
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        Jc = [pin.getFrameJacobian(m, d, f, LOCAL) for f in fids]
        ec = [pin.log6(d.oMf[f].actInv(r)).vector for f, r in zip(fids, feet_ref)]
        Jcom = pin.jacobianCenterOfMass(m, d, q, False)
        Jh = pin.getFrameJacobian(m, d, hid, WORLD)[:3]
        A = np.vstack([*Jc, Jcom, Jh])
        c = np.concatenate([*ec, com_ref - d.com[0], hand_ref - d.oMf[hid].translation])
        P = np.zeros((len(j), nv))
        P[np.arange(len(j)), j] = 1.0
        e = pin.difference(m, q, robot.q_default)[j]
        K = np.block([[P.T @ P + 1e-12 * np.eye(nv), A.T], [A, np.zeros((len(c), len(c)))]])
        dq = np.linalg.solve(K, np.concatenate([P.T @ e, c]))[:nv]
        q = pin.integrate(m, q, dq)
        if np.linalg.norm(dq) < 1e-13:
            break
    return q


def test_velocity_hqp_converges_to_gauss_newton_pose(talos):
    robot = talos
    dt = 0.01
    stack, hand_ref, com_ref = _ik_stack(robot, np.array([0.1, -0.05, 0.1]))
    ctrl = Controller(robot, stack, mode="velocity", dt=dt, gain=1.0 / dt)
    assert isinstance(ctrl, VelocityController)
    q = robot.q_default.copy()
    for _ in range(80):
        sol = ctrl.solve(q)
        assert sol.status == "ok"
        q = sol.q_next
    assert np.linalg.norm(sol.qd) < 1e-9
    feet_ref = [stack["left_foot_contact"].reference, stack["right_foot_contact"].reference]
    q_gn = _reference_gauss_newton(robot, robot.q_default.copy(), feet_ref, com_ref, hand_ref)
    assert np.linalg.norm(pin.difference(robot.model, q, q_gn)) < 1e-6
    # and it is a solution: feet, CoM and hand on target
    robot.update_kinematics(q)
    assert np.linalg.norm(robot.com - com_ref) < 1e-9
    assert np.linalg.norm(robot.frame_placement(robot.frame_id("right_hand")).translation - hand_ref) < 1e-9


@pytest.mark.parametrize("solver", ["hqp", "projection", "weighted"])
def test_lower_levels_never_change_higher_rows(talos, solver):
    """A conflicting lower level (the same hand asked to move elsewhere) leaves every higher
    level's rows A_k q̇ as they were without it; the lower one is reported sacrificed. The
    weighted solver is strict at level 0 only (its lower levels are one weighted QP)."""
    robot = talos
    rng = np.random.default_rng(3)
    q0 = robot.q_default.copy()
    robot.update(q0, np.zeros(robot.nv))
    here = robot.frame_placement(robot.frame_id("right_hand")).translation
    for _ in range(3):
        hand = Frame("right_hand", mask="position", name="hand")
        hand.target = here + rng.uniform(-0.1, 0.1, 3)
        other = Frame("right_hand", mask="position", name="hand_elsewhere")
        other.target = here + rng.uniform(-0.1, 0.1, 3)
        base = [[Contact("left_foot"), Contact("right_foot"), JointLimits()], [CoM()], [hand]]
        a = Controller(robot, Stack(base), mode="velocity", solver=solver, dt=0.01)
        sol_a = a.solve(q0)
        rows_a = [lvl.A @ sol_a.qd - lvl.b for lvl in a.levels]
        b = Controller(robot, Stack([*base, [other], [Posture()]]), mode="velocity", solver=solver, dt=0.01)
        sol_b = b.solve(q0)
        rows_b = [lvl.A @ sol_b.qd - lvl.b for lvl in b.levels]
        strict = rows_a if solver != "weighted" else rows_a[:1]
        for ra, rb in zip(strict, rows_b):
            assert np.allclose(ra, rb, atol=1e-9)
        if solver != "weighted":
            assert "hand_elsewhere" in sol_b.diagnostics[3].sacrificed


def test_joint_limits_hold_and_are_reached(talos):
    """A posture target beyond the joint limits: every cycle's q stays inside [q_min, q_max],
    q̇ inside ±v_max, and the joints end on their limit (minus the margin)."""
    robot = talos
    dt = 0.01
    target = robot.q_default.copy()
    target[7:] = robot.q_max[7:] + 0.5
    limits = JointLimits(margin=0.01, horizon=0.05)
    ctrl = Controller(robot, Stack([[limits], [Posture(kp=400.0, target=target)]]), mode="velocity", dt=dt)
    q = robot.q_default.copy()
    idx = np.arange(7, robot.nq)
    for _ in range(300):
        sol = ctrl.solve(q)
        assert sol.ok
        assert np.all(np.abs(sol.qd[6:]) <= robot.v_max[6:] + 1e-9)
        q = sol.q_next
        assert np.all(q[idx] <= robot.q_max[idx] + 1e-9)
        assert np.all(q[idx] >= robot.q_min[idx] - 1e-9)
    assert np.allclose(q[idx], robot.q_max[idx] - 0.01, atol=1e-4)


def test_torque_only_task_is_refused(talos):
    stack = Stack([[Contact("left_foot"), Contact("right_foot")], [ContactWrench("left_foot_contact")]])
    with pytest.raises(TaskDefinitionError) as exc:
        Controller(talos, stack, mode="velocity")
    assert "stack[1][0].type" in str(exc.value) and "contact_wrench" in str(exc.value)
    with pytest.raises(ConfigError):
        Controller(talos, Stack([[Posture()]]), mode="velocity", weighting="inertia")


def test_cli_mode_velocity_refuses_torque_tasks_with_file_and_line(capsys, tmp_path):
    """`wbc run --mode velocity` on a scenario with a torque-only task, and a `mode: velocity`
    scenario with one: exit 2, the file, the line and the key path of the task's type."""
    from pathlib import Path

    from wbc.cli.main import main

    src = Path(__file__).resolve().parents[2] / "wbc" / "data" / "scenarios" / "talos_balance.yaml"
    assert main(["run", str(src), "--headless", "--mode", "velocity", "--duration", "0.01"]) == 2
    err = capsys.readouterr().err
    assert "talos_balance.yaml:11: stack[0][1].type" in err and "torque_limits" in err
    bad = tmp_path / "bad.yaml"
    bad.write_text(src.read_text() + "mode: velocity\n")
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "bad.yaml:11: stack[0][1].type" in err


def test_velocity_scenario_runs_in_both_simulators():
    """tiago_table_reach_velocity, 0.3 s: position servos in each simulator follow the command
    (the simulated q within 5 cm·rad of q_next: the servo lag 2/ω_b ≈ 13 ms at the start's ~2 rad/s;
    an arm left to gravity is 0.3 rad off within 0.3 s), no fault, no relaxed level."""
    pytest.importorskip("mujoco")
    from wbc.runner.loop import ScenarioRun
    from wbc.scenario.loader import load_config

    for sim in ("pinocchio", "mujoco"):
        sc = load_config("tiago_table_reach_velocity")
        r = ScenarioRun(sc, simulator=sim, duration=0.3)
        for k in range(r.n):
            assert r.cycle(k)
            assert r.last_sol.status == "ok"
            gap = np.linalg.norm(pin.difference(sc.robot.model, r.sim.q, r.q_cmd))
            assert gap < 0.05, (sim, k, gap)


def _fresh_rows(robot, ctrl, q):
    """Every level's (A, b, box lo, box hi) from velocity_rows called afresh (new arrays, no
    plan), √weight scaled and stacked in level order, at q."""
    from wbc.tasks.velocity import velocity_rows

    robot.update_kinematics(q)
    out = []
    for tasks in ctrl.groups():
        rs = [(t, velocity_rows(t, robot, robot.nv, ctrl.dt, ctrl.gain)) for t in tasks]
        A = [np.sqrt(t.weight) * r.A for t, r in rs if r.A is not None]
        b = [np.sqrt(t.weight) * r.b for t, r in rs if r.A is not None]
        box = [r.box for _, r in rs if r.box is not None]
        out.append((np.vstack(A) if A else np.zeros((0, robot.nv)), np.concatenate(b) if b else np.zeros(0),
                    np.concatenate([x[1] for x in box]) if box else None,
                    np.concatenate([x[2] for x in box]) if box else None))
    return out


def test_planned_rows_follow_targets_gains_weights_and_structure(talos):
    """The velocity cycle's rows, written in place by the plan made at the first cycle
    (wbc/controller/velocity_plan.py), equal the rows built afresh at every cycle while the
    targets, gains, contact reference, weights and a contact's sliding flag change between
    cycles; the plan's arrays are kept while the structure holds (no rebuild per cycle) and
    replaced when a contact turns sliding (its rows change count)."""
    robot = talos
    rng = np.random.default_rng(7)
    hand, other = Frame("right_hand", mask="position", name="hand"), Frame("left_hand", name="other")
    feet = [Contact("left_foot"), Contact("right_foot"), JointLimits()]
    stack = Stack([feet, [CoM()], [hand, other], [Posture()]])
    ctrl = Controller(robot, stack, mode="velocity", dt=0.01)
    q = robot.q_default.copy()
    ctrl.solve(q)
    A0 = ctrl.levels[0].A
    here = robot.frame_placement(robot.frame_id("right_hand")).translation.copy()
    for k in range(6):
        hand.target = here + rng.uniform(-0.05, 0.05, 3)
        stack["com"].target = robot.com + rng.uniform(-0.02, 0.02, 3)
        hand.set_gains(float(rng.uniform(5, 50)))
        if k == 2:
            other.weight = 3.0
        stack["posture"].target = pin.integrate(robot.model, robot.q_default, 0.05 * rng.standard_normal(robot.nv))
        if k == 3:
            stack["left_foot_contact"].reference = None        # re-made where the foot is
        if k == 4:
            stack["right_foot_contact"].sliding = True
        q = pin.integrate(robot.model, q, 0.02 * rng.standard_normal(robot.nv))
        ctrl.solve(q)
        for lvl, (A, b, lo, hi) in zip(ctrl.levels, _fresh_rows(robot, ctrl, q)):
            assert np.array_equal(lvl.A, A) and np.array_equal(lvl.b, b)
            if lo is not None:
                assert np.array_equal(lvl.box[1], lo) and np.array_equal(lvl.box[2], hi)
        rebuilt = ctrl.levels[0].A is not A0
        assert rebuilt == (k in (2, 4))                              # else the same plan, rows in place
        if k >= 4:
            assert ctrl.levels[0].A.shape[0] == 12 - 3               # the sliding foot: 3 rows
        A0 = ctrl.levels[0].A


def test_velocity_commands_keep_the_table_at_full_speed(tmp_path):
    """TIAGo's hand driven into a table top from the start (unreachable), velocity mode, closed
    loop on the own simulator's position servos, no rate limit (joints up to their velocity
    limits, ~20 mrad a cycle): the exact distance (coal) from every link to the table at every
    *commanded* configuration stays above d_s − 10 mm. A row only linearises d; the hulls'
    witness features switch as the arm turns, and without re-linearising at the command
    (wbc.tasks.velocity.collision_correction) the commands reach 5.6 mm (d_s = 30 mm). The
    margin left: the servo lag lets the measured state sit below d_s, and the damper recovers at
    ξ (d_s − d)/(d_i − d_s) only (measured: 27.6 mm)."""
    import yaml

    from wbc.collision.model import CollisionModel
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config

    doc = yaml.safe_load((Path(__file__).resolve().parents[2] / "wbc" / "data" / "scenarios"
                          / "tiago_table_reach_velocity.yaml").read_text())
    doc.pop("events")
    doc["stack"][0][0] = {"type": "joint_limits", "horizon": 0.1, "margin": 0.01}
    doc["stack"][1][0]["target"] = [1.0, -0.2, 0.68]
    doc["duration"] = 2.0
    (tmp_path / "into.yaml").write_text(yaml.safe_dump(doc))
    sc = load_config(str(tmp_path / "into.yaml"))
    task = sc.stack["collision_avoidance"]
    table = CollisionModel(sc.robot, obstacles=task.obstacles, self_collision=False)
    data = sc.robot.model.createData()
    worst = [np.inf]

    def watch(t, s, sol):
        worst[0] = min(worst[0], float(table.all_distances(sol.q_next, data).min()))

    m = run(sc, simulator="pinocchio", callback=watch)
    assert not m["fell"] and m["relaxed_cycles"] == 0
    assert worst[0] >= task.safety - 0.010, worst[0]


def test_rate_limit_bounds_the_change_of_the_command():
    """JointLimits(rate_limit=True) in velocity mode: |q̇ − v| ≤ ā dt on every limited joint,
    whatever the tasks ask (a far hand target would otherwise step q̇ to the velocity limit)."""
    from wbc.scenario.loader import load_config

    sc = load_config("tiago_table_reach_velocity")
    robot = sc.robot
    jl = JointLimits(horizon=0.1, rate_limit=True, max_acceleration=4.0)
    hand = Frame("hand", kp=400.0, mask="position", target=np.array([0.9, -0.4, 1.0]))
    ctrl = Controller(robot, Stack([[jl], [hand], [Posture()]]), dt=sc.dt, mode="velocity")
    v = np.zeros(robot.nv)
    q = robot.q_default.copy()
    for _ in range(20):
        sol = ctrl.solve(q, v)
        (_, vi, extra, idx), _ = jl.coordinates(robot)
        assert np.all(np.abs(sol.qd[idx] - v[idx]) <= 4.0 * sc.dt + 1e-9)
        q, v = sol.q_next, sol.qd
    assert np.abs(v).max() > 0.3        # it does accelerate, at the bounded rate
