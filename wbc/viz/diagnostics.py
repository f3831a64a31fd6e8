"""Priority diagnostics as text: one row per level of ``Solution.diagnostics``.

Columns: level, its tasks, residual ‖A x − b‖ (units of the level's rows), rank of
the projected Jacobian J̄_k over the free directions the level had, σ_min(J̄_k),
then the sacrificed tasks (residual above the controller's tolerance), the active
inequality rows per task and the saturated joints.

Two renderings: :func:`render_png` (a table image, the live view's head-up display:
meshcat 0.3.2's server forwards only scene commands, so text reaches the page as a
texture) and :func:`overlay_html` (an HTML panel for recorded replays, following
the animation's clock; ``replay.html#no-diagnostics`` hides it).
"""

from __future__ import annotations

import io
import json
from functools import lru_cache

HEADER = ("L", "tasks", "residual", "rank", "σmin", "limited by")
WIDTHS = (1, 22, 8, 6, 6, 36)          # characters per column
COLORS = {"ok": (20, 20, 20), "sacrificed": (192, 57, 43), "active": (183, 110, 0), "dim": (110, 110, 110),
          "desired": (22, 160, 133), "measured": (216, 27, 96)}   # the force tasks' arrows (wbc.viz.scene)


def _short(names: list[str], width: int) -> str:
    s = ", ".join(names)
    return s if len(s) <= width else s[: width - 1] + "…"


def diagnostics_rows(sol) -> list[dict]:
    """Plain rows (one per level) from a :class:`wbc.Solution`."""
    rows = []
    for d in sol.diagnostics:
        limits = []
        if d.sacrificed:
            limits.append("sacrificed " + ", ".join(d.sacrificed))
        if d.active:
            limits.append("active " + ", ".join(f"{k}×{v}" for k, v in d.active.items()))
        if d.saturated_joints:
            limits.append(f"saturated: {len(d.saturated_joints)} joints")
        if d.relaxed:
            limits.append("relaxed")
        rows.append({"level": d.index, "tasks": list(d.tasks), "residual": float(d.residual), "rank": int(d.rank),
                     "dof": int(d.dof_before), "sigma_min": float(d.sigma_min), "qp": bool(d.used_qp),
                     "sacrificed": bool(d.sacrificed), "active": bool(d.active or d.saturated_joints),
                     "limits": "; ".join(limits) or "—"})
    return rows


def status_line(sol, t: float) -> str:
    return f"t {t:6.2f} s  {sol.status}  QPs {sol.qp_count}   rank/free dof, σmin of J̄k"


def cells(row: dict) -> tuple[str, ...]:
    """The row's text per column of :data:`HEADER`."""
    tasks = [n.replace("_contact", "").replace("joint_limits", "q lim").replace("torque_limits", "τ lim")
             .replace("dynamics", "dyn") for n in row["tasks"]]
    return (str(row["level"]), _short(tasks, WIDTHS[1]), f"{row['residual']:.1e}",
            f"{row['rank']}/{row['dof']}", f"{row['sigma_min']:.2g}", _short([row["limits"]], WIDTHS[5]))


def table_lines(sol, t: float, extra=()) -> list[tuple[str, str]]:
    """(line, style) pairs: the status line, the header, one line per level, then ``extra``
    (the scene's force-task legend); style is ``"dim"``, ``"ok"``, ``"active"`` (limited by
    an active constraint), ``"sacrificed"``, or an arrow's ``"desired"`` / ``"measured"``."""
    lines = [(status_line(sol, t), "dim"), (" ".join(h.ljust(w) for h, w in zip(HEADER, WIDTHS)).rstrip(), "dim")]
    for row in diagnostics_rows(sol):
        style = "sacrificed" if row["sacrificed"] else "active" if row["active"] else "ok"
        lines.append((" ".join(c.ljust(w) for c, w in zip(cells(row), WIDTHS)).rstrip(), style))
    return lines + list(extra)


def text_table(sol, t: float) -> str:
    """The diagnostics as monospaced text (also used by the replay overlay)."""
    return "\n".join(line for line, _ in table_lines(sol, t))


@lru_cache(maxsize=4)
def _font(size: int):
    from PIL import ImageFont

    for path in ("DejaVuSansMono-Bold.ttf", "/usr/share/fonts/truetype/dejavu/DejaVuSansMono-Bold.ttf",
                 "DejaVuSansMono.ttf", "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf",
                 "LiberationMono-Bold.ttf", "LiberationMono-Regular.ttf"):
        try:
            return ImageFont.truetype(path, size)
        except OSError:
            continue
    try:   # matplotlib, when installed, ships DejaVu Sans Mono
        import matplotlib

        return ImageFont.truetype(str(matplotlib.get_data_path()) + "/fonts/ttf/DejaVuSansMono-Bold.ttf", size)
    except (ImportError, OSError):
        return ImageFont.load_default(size=size)


def render_png(sol, t: float, font_size: int = 16, extra=()) -> tuple[bytes, int, int]:
    """The diagnostics table as an opaque PNG (rows of ``font_size`` px, wide enough
    for every column): returns (png bytes, width, height). Sacrificed levels in red,
    levels limited by active constraints in amber; ``extra``: more (line, style) pairs
    (:func:`table_lines`). About 4 ms."""
    from PIL import Image, ImageDraw

    font = _font(font_size)
    lines = table_lines(sol, t, extra)
    cw = font.getlength("M") if hasattr(font, "getlength") else font_size * 0.6
    line = int(font_size * 1.35)
    width = int(16 + cw * max(sum(WIDTHS) + len(WIDTHS), *(len(text) for text, _ in lines)))
    height = line * len(lines) + 10
    img = Image.new("RGB", (width, height), (250, 250, 250))
    draw = ImageDraw.Draw(img)
    for i, (text, style) in enumerate(lines):
        draw.text((8, 5 + line * i), text, fill=COLORS[style], font=font)
    buf = io.BytesIO()
    img.save(buf, format="PNG", compress_level=1)
    return buf.getvalue(), width, height


OVERLAY = """
<style>
 #wbc-diagnostics .dim {color:#6e6e6e} #wbc-diagnostics .ok {color:#141414}
 #wbc-diagnostics .active {color:#b76e00} #wbc-diagnostics .sacrificed {color:#c0392b}
 #wbc-diagnostics .desired {color:#16a085} #wbc-diagnostics .measured {color:#d81b60}
</style>
<pre id="wbc-diagnostics" style="position:absolute;left:8px;top:8px;margin:0;padding:6px 10px;
 background:rgba(255,255,255,0.85);color:#141414;font:12px/1.35 'DejaVu Sans Mono',monospace;
 pointer-events:none;z-index:10;white-space:pre"></pre>
<script>
(function () {
  // priority diagnostics of the recorded run: text[i] (lines of [text, style]) holds from animation frame frames[i]
  var D = %s;
  var el = document.getElementById("wbc-diagnostics");
  var shown = -1;
  if (window.location.hash.indexOf("no-diagnostics") >= 0) { el.style.display = "none"; }   // page.html#no-diagnostics
  function now() {   // the animator's clock: follows playback and the time scrubber, stays at the end
    var a = (typeof viewer !== "undefined") ? viewer.animator : null;
    return (a && typeof a.time === "number") ? a.time : 0;
  }
  function tick() {
    var f = now() * D.fps + 1e-6, lo = 0, hi = D.frames.length - 1;
    while (lo < hi) { var mid = (lo + hi + 1) >> 1; if (D.frames[mid] <= f) { lo = mid; } else { hi = mid - 1; } }
    if (lo !== shown && D.text.length) {
      el.textContent = "";
      D.text[lo].forEach(function (line, i) {
        var span = document.createElement("span");
        span.className = line[1];
        span.textContent = line[0] + (i + 1 < D.text[lo].length ? "\\n" : "");
        el.appendChild(span);
      });
      shown = lo;
    }
    window.requestAnimationFrame(tick);
  }
  tick();
})();
</script>
"""


def overlay_html(frames: list[int], texts: list[list[tuple[str, str]]], fps: float) -> str:
    """An HTML panel (and its script) showing ``texts[i]`` (the (line, style) pairs of
    :func:`table_lines`) from animation frame ``frames[i]`` on; ``fps``: the animation's
    frame rate."""
    data = json.dumps({"fps": fps, "frames": frames, "text": texts}, ensure_ascii=False)
    return OVERLAY % data.replace("</", "<\\/")
