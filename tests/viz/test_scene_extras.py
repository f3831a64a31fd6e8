"""Scene.add_arrow / add_point and show(arrows=..., points=...): in a recording each
arrow keys its length in a ``scale`` track and its presence in a ``visible`` track
(meshcat's animation keeps only position and rotation of a transform)."""

from __future__ import annotations

import numpy as np

import wbc
from wbc.viz import Scene


def test_recorded_extras_keep_length_and_visibility():
    robot = wbc.load_robot("panda")
    scene = Scene(robot, [], record=True)
    try:
        scene.add_arrow("push", 0x8E44AD)
        scene.add_point("goal", 0x2E86DE)
        start, vec = np.array([0.3, 0.0, 0.4]), np.array([0.0, 0.0, 2.0])
        for k in range(4):
            on = k in (1, 2)
            scene.show(robot.q_default, arrows={"push": (start, vec, 0.1) if on else None},
                       points={"goal": [0.1 * k, 0.0, 0.5]})
        clips = {str(p.lower()): c for p, c in scene.anim.clips.items()}
        push = clips["/meshcat/extras/push"].tracks
        assert push["visible"].values == [False, True, True, False]
        assert [s[1] for s in push["scale"].values[1:3]] == [0.1, 0.1]     # length along the cylinder axis
        assert max(push["scale"].values[0]) < 1e-5 and max(push["scale"].values[3]) < 1e-5
        np.testing.assert_allclose(push["position"].values[1], start + 0.05 * vec / 2.0)   # the arrow's middle
        goal = clips["/meshcat/extras/goal"].tracks
        np.testing.assert_allclose([p[0] for p in goal["position"].values], [0.0, 0.1, 0.2, 0.3])
    finally:
        scene.close()


# ------------------------------------------------------------ interaction: force tasks, glass frame
def _objects(scene) -> list[str]:
    """Record the paths of the objects the scene creates from now on (its set_object commands)."""
    made: list[str] = []
    window = scene.vis.window
    send = window.send

    def spy(command):
        data = command.lower()
        if data["type"] == "set_object":
            made.append(data["path"])
        return send(command)

    window.send = spy
    return made


def test_wipe_scene_draws_desired_and_measured_force_to_scale(monkeypatch):
    """tiago_wipe, recorded: at every frame the force task's two arrows start at the pad
    and have lengths |λ_D| and |λ_m| × 1 cm per N, along the contact normal."""
    import pinocchio as pin

    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config
    from wbc.viz import viewer_callback

    sc = load_config("tiago_wipe")
    task, contact = sc.stack["hand_pad_contact_force"], sc.stack["hand_pad_contact"]
    robot = sc.robot
    scene = Scene(robot, sc.environment, record=True)
    seen = []                     # per recorded frame: (pad position, |λ_D|, |λ_m| or None)
    data = robot.model.createData()
    show = scene.show

    def recording_show(q, stack=None, sim=None, t=0.0, **kw):
        fid = robot.frame_id(contact.surface(robot).frame)
        pin.framesForwardKinematics(robot.model, data, q)
        S = task.selection(3)[0]
        meas = None if task.measured is None else float(np.linalg.norm(S.T @ task.measured))
        seen.append((data.oMf[fid].translation.copy(), float(np.linalg.norm(task.reference())), meas))
        show(q, stack, sim, t, **kw)

    monkeypatch.setattr(scene, "show", recording_show)
    try:
        made = _objects(scene)
        run(sc, duration=0.5, callback=viewer_callback(scene, sc.stack, sc.dt, realtime=False, diagnostics_hz=0))
        assert {"/meshcat/task_forces/hand_pad_contact_force/desired",
                "/meshcat/task_forces/hand_pad_contact_force/measured"} <= set(made)
        clips = {str(p.lower()): c for p, c in scene.anim.clips.items()}
        for part, col in (("desired", 1), ("measured", 2)):
            tracks = clips[f"/meshcat/task_forces/hand_pad_contact_force/{part}"].tracks
            assert len(tracks["scale"].values) == len(seen)
            for k, row in enumerate(seen):
                lam = row[col]
                if lam is None or lam < 1e-3:
                    assert tracks["visible"].values[k] is False
                    continue
                length = lam * 0.01                                       # 1 cm per N
                assert tracks["visible"].values[k] is True
                np.testing.assert_allclose(tracks["scale"].values[k][1], length, rtol=1e-9)
                # the environment's force on the pad, up the table's normal, from the pad
                np.testing.assert_allclose(tracks["position"].values[k], row[0] + [0.0, 0.0, length / 2], atol=1e-9)
        assert seen[-1][1] == 10.0 and abs(seen[-1][2] - 10.0) < 0.5      # the ramp is over: 10 N both
        assert scene.task_force_scale == 0.1
    finally:
        scene.close()


def test_glass_scene_draws_the_hand_frame_and_a_scaled_push():
    """tiago_glass: the glass's (hand's) actual axes follow the hand's placement, its target's
    too; the 30 N elbow push is drawn 2 mm per N (6 cm) pointing at the elbow."""
    import pinocchio as pin

    from wbc.runner.loop import ScenarioRun
    from wbc.scenario.loader import load_config
    from wbc.viz import shown_frames, viewer_callback

    sc = load_config("tiago_glass")
    robot = sc.robot
    assert shown_frames(sc) == ("arm_tool_link",)          # the frame the hand task ("hand") names
    scene = Scene(robot, sc.environment, record=True)
    try:
        made = _objects(scene)
        r = ScenarioRun(sc, duration=0.05, callback=viewer_callback(scene, sc.stack, sc.dt, realtime=False,
                                                                    diagnostics_hz=0, frames=shown_frames(sc)))
        for k in range(r.n):
            assert r.cycle(k)
        assert "/meshcat/frames/arm_tool_link" in made and "/meshcat/targets/hand/axes" in made
        q = r.sim.q.copy()
        q[robot.model.joints[robot.model.getJointId("arm_7_joint")].idx_q] += 0.3   # tilt the glass
        scene.show(q, sc.stack, r.sim, t=2.0)                                      # the push acts at 2 s
        data = robot.model.createData()
        pin.framesForwardKinematics(robot.model, data, q)
        M = data.oMf[robot.frame_id("hand")]
        clips = {str(p.lower()): c for p, c in scene.anim.clips.items()}
        hand = clips["/meshcat/frames/arm_tool_link"].tracks
        np.testing.assert_allclose(hand["position"].values[-1], M.translation, atol=1e-9)
        quat = pin.Quaternion(M.rotation).coeffs()                                 # x, y, z, w
        assert min(np.abs(np.array(hand["quaternion"].values[-1]) - quat).max(),
                   np.abs(np.array(hand["quaternion"].values[-1]) + quat).max()) < 1e-9
        push = clips["/meshcat/pushes/0"].tracks
        assert push["visible"].values[-1] is True
        np.testing.assert_allclose(push["scale"].values[-1][1], 30.0 * 2e-3, rtol=1e-9)
        elbow = r.sim.data.oMf[r.sim.model.getFrameId("arm_4_link")].translation
        np.testing.assert_allclose(push["position"].values[-1], elbow + [0.0, 0.0, 0.03], atol=1e-9)
    finally:
        scene.close()
