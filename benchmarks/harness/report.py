"""What a bench prints and writes: the progress lines and ``results.md``.

:func:`case_line` (under :data:`HEADER`) is one case's progress line; the ``fmt_*``
functions give the lines of the floor, the closed loop, the peer and the scaling; and
:func:`results_markdown` the whole of ``benchmarks/results.md`` from :func:`.cli.run`'s
dict. Times in ms.
"""

from __future__ import annotations

from .timing import PHASES
from .trajectory import COM_AMPLITUDE, COM_FREQUENCY, HAND_FREQUENCY, HAND_RADIUS


def case_line(c: dict) -> str:
    be = c.get("backend") or "-"
    if "error" in c:
        return f"{c['robot']:6s} {c['solver']:10s} {be:9s} FAILED: {c['error']}"
    ph = c.get("phases", {})
    st = ",".join(f"{k}:{n}" for k, n in c["statuses"].items())
    return (f"{c['robot']:6s} {c['solver']:10s} {be:9s} {c['levels']:2d} {c['nv']:3d} "
            f"{c['median_ms']:7.3f} {c['p99_ms']:7.3f} {c['max_ms']:7.2f} | "
            + " ".join(f"{ph.get(p, float('nan')):6.3f}" for p in (*PHASES, "other"))
            + f" | {c.get('phase_coverage', float('nan')):5.3f} {c['qp_per_cycle']:4.1f}"
            + f" {c.get('diagnostics_ms', float('nan')):6.3f} {st}"
            + (f" TRUNCATED ({c['cycles']} cycles)" if "truncated" in c else "")
            + f" warm-up max {c['warmup_max_ms']:.0f} ms")


HEADER = ("robot  solver     backend   lv  nv  median     p99     max | update   rows  solve finish  other"
          " | cover qp/c  diag status")


def cases_markdown(cases: list[dict]) -> str:
    rows = ["| robot | solver | backend | levels | nv | median ms | p99 ms | max ms | update | rows | solve | "
            "finish | other | coverage | QPs/cycle | diagnostics ms | statuses |",
            "|" + " --- |" * 17]
    for c in cases:
        be = c.get("backend") or "-"
        if "error" in c:
            rows.append(f"| {c['robot']} | {c['solver']} | {be} | failed: {c['error']} |" + " |" * 13)
            continue
        ph = c["phases"]
        st = ", ".join(f"{k} {n}" for k, n in c["statuses"].items())
        if "truncated" in c:
            st += f" (truncated: {c['cycles']} cycles)"
        rows.append(f"| {c['robot']} | {c['solver']} | {be} | {c['levels']} | {c['nv']} | {c['median_ms']:.3f} | "
                    f"{c['p99_ms']:.3f} | {c['max_ms']:.2f} | " + " | ".join(f"{ph[p]:.3f}" for p in (*PHASES, "other"))
                    + f" | {c['phase_coverage']:.3f} | {c['qp_per_cycle']:.2f} | {c.get('diagnostics_ms', float('nan')):.3f}"
                    f" | {st} |")
    return "\n".join(rows)


def fmt_floor(fl: dict) -> str:
    if "missing" in fl:
        return f"missing: {fl['missing']}"
    s = fl["qp_size"]
    return (f"whole-body terms (kinematics, joint Jacobians, CRBA, NLE, CoM) {fl['whole_body']:.3f} + "
            f"frame Jacobians/drifts {fl['jacobians_drifts']:.3f} = pinocchio {fl['pinocchio']:.3f} ms; "
            f"daqp QP ({s['variables']} vars, {s['equalities']} eq, {s['inequalities']} ineq) "
            f"{fl['qp_daqp']:.3f} ms; sum {fl['sum']:.3f} ms (medians)")


def fmt_sim_loop(sl: dict) -> list[str]:
    if "missing" in sl:
        return [f"missing: {sl['missing']}"]
    out = []
    for solver in ("hqp", "projection"):
        r = sl.get(solver)
        if r:
            out.append(f"{sl['scenario']} ({sl['duration_s']:g} s simulated), {solver}: real-time factor "
                       f"{r['real_time_factor']:.2f}; median per cycle: controller {r['controller_median_ms']:.3f} ms, "
                       f"simulator {r['simulator_median_ms']:.3f} ms" + ("; FELL" if r["fell"] else ""))
    return out


def fmt_placo(pd: dict, pk: dict) -> list[str]:
    lines = []
    if "missing" in pd:
        lines.append(f"PlaCo DynamicsSolver (Talos): missing: {pd['missing']}")
    else:
        lines.append(f"PlaCo DynamicsSolver (Talos): solve median {pd['solve']['median_ms']:.3f} ms "
                     f"(p99 {pd['solve']['p99_ms']:.3f}, max {pd['solve']['max_ms']:.2f}); update_kinematics + solve "
                     f"median {pd['cycle']['median_ms']:.3f} ms; {pd['success']}/{pd['cycles']} successful; "
                     f"mean CoM error {pd['com_error_mean_mm']:.2f} mm")
    if "missing" in pk:
        lines.append(f"PlaCo KinematicsSolver (benchmarks/harness/placo_peer.py IK): missing: {pk['missing']}")
    else:
        lines.append(f"PlaCo KinematicsSolver (benchmarks/harness/placo_peer.py IK): solve median {pk['solve_median_ms']:.3f} ms "
                     f"over {pk['iterations']} iterations, hand error {pk['hand_error_mm']:.3f} mm")
    return lines


def fmt_scaling(sc: dict) -> list[str]:
    e, up = sc["exponents"], sc.get("upper_range", {})
    lines = []
    for axis in ("nv", "levels"):
        if f"{axis}_hqp" not in e:
            continue
        line = (f"{axis} sweep ({sc[axis]['stack']}): exponent hqp {num(e[f'{axis}_hqp'])}, "
                f"projection {num(e[f'{axis}_projection'])}")
        if f"{axis}_hqp_upper" in e:
            line += (f"; over {up.get(axis, 'the upper half')}: hqp {num(e[f'{axis}_hqp_upper'])}, "
                     f"projection {num(e.get(f'{axis}_projection_upper'))}")
        lines.append(line)
    return lines


def num(x, fmt: str = ".2f") -> str:
    return "n/a" if x is None else format(x, fmt)


def scaling_markdown(sc: dict) -> str:
    out = ["| nv | hqp ms | projection ms |", "| --- | --- | --- |"]
    for n in sorted({p["nv"] for p in sc["nv"]["points"]}):
        row = {p["solver"]: p["median_ms"] for p in sc["nv"]["points"] if p["nv"] == n}
        out.append(f"| {n} | {row.get('hqp', float('nan')):.3f} | {row.get('projection', float('nan')):.3f} |")
    out += ["", "| levels | hqp ms | projection ms |", "| --- | --- | --- |"]
    for n in sorted({p["levels"] for p in sc["levels"]["points"]}):
        row = {p["solver"]: p["median_ms"] for p in sc["levels"]["points"] if p["levels"] == n}
        out.append(f"| {n} | {row.get('hqp', float('nan')):.3f} | {row.get('projection', float('nan')):.3f} |")
    return "\n".join(out)


def results_markdown(res: dict) -> str:
    m = res["machine"]
    fl = res.get("floor_ms", {}).get("talos_parts", {"missing": "not run"})
    pl = res.get("placo", {})
    text = [
        "# wbc bench results",
        "",
        f"Command: `{res['command']}` (total {res['wall_s']:.0f} s).",
        "",
        f"Machine: {m['cpu']}, {m['cores']} cores, {m['platform']}; Python {m['python']}, numpy {m['numpy']}, "
        f"pin {m['pin']}; BLAS threads {m['blas_threads']}; load average at start {m.get('load_average_start')}, "
        f"at end {m.get('load_average_end')}.",
        "",
        f"Cycles: {res['settings']['cycles']} timed after {res['settings']['warmup']} warm-up, dt = 1 ms, targets "
        f"moving every cycle (CoM ±{COM_AMPLITUDE * 100:.0f} cm at {COM_FREQUENCY} Hz, hands on "
        f"{HAND_RADIUS * 100:.0f} cm circles at {HAND_FREQUENCY} Hz), state integrated from q̈. Times in ms. "
        "Median, p99 and max come from a pass with nothing but the controller; the phases and the diagnostics "
        "from a second pass over the same trajectory with each phase wrapped in a timer and sol.diagnostics read "
        "after each cycle. Phases are medians (update = robot.update, rows = stack.layout + stack.assemble, "
        "solve = solver, finish = Controller._finish, other = the rest of Controller.solve); coverage = Σ mean "
        "phase / mean cycle of that second pass.",
        "",
        cases_markdown(res["cases"]),
        "",
        "## Floor (Talos, same trajectory)",
        "",
        fmt_floor(fl),
        "",
        "## Closed loop (controller + physics, no viewer)",
        "",
        *[f"- {ln}" for ln in fmt_sim_loop(res.get("sim_loop", {"missing": "not run"}))],
        "",
        "## Peer (PlaCo)",
        "",
        *[f"- {ln}" for ln in fmt_placo(pl.get("talos_dynamics", {"missing": "not run"}),
                                        pl.get("talos_kinematics", {"missing": "not run"}))],
        "",
        "## Scaling",
        "",
        *[f"- {ln}" for ln in fmt_scaling(res["scaling"])],
        "",
        f"Median cycle time ({res['scaling']['cycles']} cycles per point); plot: `scaling.png`.",
        "",
        scaling_markdown(res["scaling"]),
        "",
        "## Notes",
        "",
        *[f"- {ln}" for ln in notes(res)],
        "",
    ]
    return "\n".join(text)


def notes(res: dict) -> list[str]:
    """What a reader should not miss: truncated or failed cases, slow outliers, warnings."""
    out = []
    for c in res["cases"]:
        name = f"{c['robot']} {c['solver']}" + (f"/{c['backend']}" if c.get("backend") else "")
        if "error" in c:
            out.append(f"{name}: failed: {c['error']}")
            continue
        if "truncated" in c:
            out.append(f"{name}: {c['truncated']}")
        if c["max_ms"] > 100:
            out.append(f"{name}: slowest cycle {c['max_ms']:.0f} ms (p99 {c['p99_ms']:.0f} ms)")
        for msg, n in (c.get("warnings") or {}).items():
            if "SparseConversion" in msg or "PendingDeprecation" in msg:
                continue
            out.append(f"{name}: {n} × {msg}")
    svd = res["machine"].get("svd_ms")
    if svd:
        out.append("SVD probe (numpy full n × n SVD, median ms, default BLAS threads / 1 thread): "
                   + ", ".join(f"n={n}: {r['default']:.3f} / {r['1 thread']:.3f}" for n, r in svd.items()))
    return out
