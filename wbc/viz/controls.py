"""The page a person acts in (viser GUI and gizmos), in the drawing process (:mod:`wbc.viz.drawing`).

Built from the tasks' plain description (:func:`wbc.viz.live.view_spec`), never from the stack
itself (that lives in the control process). Everything the page does goes through
``mailbox.post(key, value)`` (sent to the control process, whose loop applies it at the start of
its next cycle, :mod:`wbc.runner.interactive`; keys as documented there):

- a transform gizmo on every CoM and frame task's target (translation along the world's axes;
  rotation too, in the target's axes, for a task holding an orientation): a drag posts the new
  target (a position, or a pose for a task holding an orientation) on every move;
- **Run**: pause / resume, single step (one control cycle), speed (× real time);
- **Tasks**: per task, kp and weight sliders (ranges of :mod:`wbc.tasks.tuning`, the loop clamps
  again), an enabled switch (not for contacts) and its level (0 = highest; one more than the
  lowest makes a new lowest level);
- **Push**: link, direction, magnitude (N) and duration (s), then the button;
- **Overlays**: a checkbox per overlay (contact forces, CoM and its projection, support polygon,
  shown frames, diagnostics table, and those of :mod:`wbc.viz.overlays` the run has);
- the priority diagnostics (residual, rank, σ_min per level; sacrificed levels in red; the
  disabled tasks) and two live plots (each level's residual, each contact's normal force).
"""

from __future__ import annotations

import html

import numpy as np
import pinocchio as pin

from .diagnostics import cells

PLOT_SECONDS = 5.0          # s of simulated time in the live plots
GIZMO_SCALE = 0.2           # m: a gizmo's arrows
DIRECTIONS = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1), "-z": (0, 0, -1)}
LEVEL_COLORS = ((231, 76, 60), (46, 134, 222), (39, 174, 96), (243, 156, 18), (142, 68, 173), (52, 73, 94))


def _pose(wxyz, position) -> np.ndarray:
    w, x, y, z = (float(a) for a in wxyz)
    T = np.eye(4)
    T[:3, :3] = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
    T[:3, 3] = np.asarray(position, float)
    return T


class Controls:
    """The page's controls for ``view`` (a :class:`~wbc.viz.drawing.Drawer`) over the tasks of
    ``spec`` (:func:`wbc.viz.live.view_spec`), posting to ``mailbox``."""

    def __init__(self, view, spec: dict, mailbox) -> None:
        self.view, self.mailbox = view, mailbox
        gui, scene = view.server.gui, view.server.scene
        self.gizmos: dict = {}
        self.rotates: dict[str, bool] = {}  # a gizmo that turns too (a task holding an orientation)
        self.dragged: set[str] = set()      # targets the page has moved: no longer drawn from the loop's
        self.sliders: dict = {}
        tasks = spec["tasks"]
        for task in tasks:
            if task["kind"] in ("com", "frame"):
                self._gizmo(scene, task)
        with gui.add_folder("Run"):
            self.status = gui.add_markdown("starting…")
            self.pause = gui.add_button("Pause")
            self.step = gui.add_button("Step one cycle")
            self.speed = gui.add_slider("speed (× real time)", 0.05, 4.0, 0.05, float(spec["speed"]))
        self.pause.on_click(lambda _: self._toggle_pause())
        self.step.on_click(lambda _: (mailbox.post("pause", True), mailbox.post("step", 1)))
        self.speed.on_update(lambda _: mailbox.post("speed", float(self.speed.value)))
        self.paused = False
        with gui.add_folder("Tasks"):
            for task in tasks:
                with gui.add_folder(task["name"], expand_by_default=False):
                    self._task_controls(gui, task, spec["levels"])
        with gui.add_folder("Push", expand_by_default=False):
            self.push_link = gui.add_dropdown("link", tuple(spec["push_frames"]) or ("base",))
            self.push_dir = gui.add_dropdown("direction", tuple(DIRECTIONS), initial_value="+y")
            self.push_mag = gui.add_slider("magnitude (N)", 0.0, 400.0, 5.0, 100.0)
            self.push_dur = gui.add_slider("duration (s)", 0.02, 1.0, 0.01, 0.1)
            self.push_button = gui.add_button("Push")
        self.push_button.on_click(lambda _: self._push())
        self.overlay_boxes: dict = {}
        with gui.add_folder("Overlays", expand_by_default=False):
            for name in view.overlays:
                box = gui.add_checkbox(name, view.overlays[name])
                box.on_update(lambda ev, name=name: view.overlays.__setitem__(name, bool(ev.target.value)))
                self.overlay_boxes[name] = box
        with gui.add_folder("Diagnostics"):
            self.table = gui.add_html("")
        with gui.add_folder("Plots"):
            self.levels = spec["levels"]
            x = np.zeros(2)
            self.residual_plot = None if not self.levels else gui.add_uplot(
                (x,) + tuple(np.full(2, 1e-12) for _ in range(self.levels)),
                ({"label": "t (s)"},) + tuple({"label": f"L{k}", "stroke": f"rgb{LEVEL_COLORS[k % 6]}"}
                                              for k in range(self.levels)),
                title="residual per level", scales={"y": {"distr": 3}}, aspect=1.6)
            self.contact_names = list(spec["contacts"])
            self.normal_plot = None if not self.contact_names else gui.add_uplot(
                (x,) + tuple(np.zeros(2) for _ in self.contact_names),
                ({"label": "t (s)"},) + tuple({"label": f"{n} (N)", "stroke": f"rgb{LEVEL_COLORS[k % 6]}"}
                                              for k, n in enumerate(self.contact_names)),
                title="contact normal force (N)", aspect=1.6)
        view.on_snapshot.append(self._on_snapshot)
        view.on_plot.append(self._on_plot)
        view.on_diagnostics.append(self._on_diagnostics)

    # ------------------------------------------------------------------ building
    def _gizmo(self, scene, task: dict) -> None:
        name, rotate = task["name"], task["rotate"]
        g = scene.add_transform_controls(f"/targets/{name}", scale=GIZMO_SCALE, disable_rotations=not rotate,
                                         depth_test=False, visible=False)     # placed by the first snapshot
        scene.add_icosphere(f"/targets/{name}/marker", radius=0.025 if task["kind"] == "com" else 0.018,
                            color=(46, 134, 222), opacity=0.7)

        def moved(event, name=name) -> None:
            self.dragged.add(name)
            h = event.target
            value = _pose(h.wxyz, h.position) if rotate else np.asarray(h.position, float)
            self.mailbox.post(("target", name), value)

        g.on_update(moved)
        self.gizmos[name] = g
        self.rotates[name] = rotate

    def _task_controls(self, gui, task: dict, nlev: int) -> None:
        name, post = task["name"], self.mailbox.post
        if task["kp_range"] is not None:
            lo, hi = task["kp_range"]
            s = gui.add_slider("kp", lo, hi, (hi - lo) / 400.0, float(task["kp"]))
            s.on_update(lambda ev: post(("kp", name), float(ev.target.value)))
            self.sliders[(name, "kp")] = s
        lo, hi = task["weight_range"]
        w = gui.add_slider("weight (log10)", float(np.log10(lo)), float(np.log10(hi)), 0.1,
                           float(np.clip(np.log10(task["weight"]), np.log10(lo), np.log10(hi))))
        w.on_update(lambda ev: post(("weight", name), float(10.0 ** ev.target.value)))
        self.sliders[(name, "weight")] = w
        if task["kind"] != "contact":
            on = gui.add_checkbox("enabled", True)
            on.on_update(lambda ev: post(("enabled", name), bool(ev.target.value)))
            self.sliders[(name, "enabled")] = on
        lv = gui.add_number("level (0 = highest)", task["level"], min=0, max=nlev, step=1)
        lv.on_update(lambda ev: post(("level", name), int(ev.target.value)))
        self.sliders[(name, "level")] = lv

    def _toggle_pause(self) -> None:
        self.paused = not self.paused
        self.mailbox.post("pause", self.paused)
        self.pause.label = "Resume" if self.paused else "Pause"

    def _push(self) -> None:
        force = float(self.push_mag.value) * np.asarray(DIRECTIONS[self.push_dir.value], float)
        self.mailbox.post(("push", self.push_link.value), (force, float(self.push_dur.value)))

    # ------------------------------------------------------------------ drawing process
    def _on_snapshot(self, snap) -> None:
        if bool(snap.paused) != self.paused:      # the loop's state (another tab, a test) decides the label
            self.paused = bool(snap.paused)
            self.pause.label = "Resume" if self.paused else "Pause"
        for name, g in self.gizmos.items():
            target = snap.targets.get(name)
            if target is None or name in self.dragged:
                continue
            if target.shape == (4, 4):
                g.position = target[:3, 3]
                if self.rotates[name]:      # else world axes: drag along x, y, z of the world
                    g.wxyz = pin.Quaternion(target[:3, :3]).coeffs()[[3, 0, 1, 2]]
            else:
                g.position = target
            g.visible = True

    def _on_plot(self, history) -> None:
        if len(history) < 2:
            return
        t = np.array([s.t for s in history])
        keep = t >= t[-1] - PLOT_SECONDS
        diag = [s for s, k in zip(history, keep) if k and s.rows is not None]
        if len(diag) >= 2 and self.residual_plot is not None:      # the snapshots that carry the rows
            res = np.full((self.levels, len(diag)), np.nan)
            for i, s in enumerate(diag):
                for row in s.rows:
                    if row["level"] < self.levels:
                        res[row["level"], i] = max(row["residual"], 1e-12)
            self.residual_plot.data = (np.array([s.t for s in diag]),) + tuple(res)
        if self.normal_plot is not None:
            normal = tuple(np.array([s.normal.get(n, 0.0) for s in history])[keep] for n in self.contact_names)
            self.normal_plot.data = (t[keep],) + normal

    def _on_diagnostics(self, snap) -> None:
        rows = snap.rows
        state = "paused" if snap.paused else ("finished" if snap.done else "running")
        self.status.content = (f"t = {snap.t:.3f} s · {state} · speed {snap.speed:g}× · "
                               f"real-time factor {snap.rtf:.2f}")
        if not self.view.overlays.get("diagnostics", True):
            self.table.content = ""
            return
        style = "font:11px/1.3 monospace;border-collapse:collapse"
        out = [f'<table id="wbc-diagnostics" style="{style}"><tr><th>L</th><th>tasks</th><th>residual</th>'
               "<th>rank</th><th>σmin</th><th>limited by</th></tr>"]
        for row in rows:
            color = "#c0392b" if row["sacrificed"] else "#b76e00" if row["active"] else "inherit"
            tds = "".join(f"<td>{html.escape(c)}</td>" for c in cells(row))
            out.append(f'<tr class="{"sacrificed" if row["sacrificed"] else "ok"}" style="color:{color}">{tds}</tr>')
        out.append("</table>")
        if snap.disabled:
            out.append(f"<div>disabled: {html.escape(', '.join(snap.disabled))}</div>")
        self.table.content = "".join(out)
