"""The runner's state metrics with their held arguments packed in three arrays
(``state_kernel.pack_state``, ``state_metrics_packed``, #26) give what :func:`state_metrics` gives
with them as tuples, bit for bit: on random cycles, and in a run whose contact set changes
(``talos_step``: a foot released, the pair no longer watched), against the tuples the runner
built before, on accumulators of their own."""

from __future__ import annotations

import math

import numpy as np

from wbc.runner import metrics as metrics_module
from wbc.runner.loop import ScenarioRun
from wbc.runner.metrics import _joined, _offsets
from wbc.runner.state_kernel import pack_state, state_metrics, state_metrics_packed
from wbc.runner.stats import Running
from wbc.scenario.loader import load_config


def _tuples(parts: dict) -> tuple:
    """The former argument groups (limits, contacts, soles, pair, acc) of copies of ``parts``."""
    p = {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in parts.items()}
    limits = (p["qi"], p["vi"], p["q_lo"], p["q_hi"], p["v_hi"], p["actuated"], p["tau_hi"], p["mu_max"])
    contacts = (p["contact_ptr"], p["contact_idx"], p["contact_watched"])
    soles = (p["sole_ptr"], p["sole_idx"], p["sole_vptr"], p["sole_verts"], p["sole_watched"])
    acc = (p["viol"], p["slip2"], p["lifted"], p["fn_min"], p["edge_min"], p["inside"], p["loaded"], p["min_force"])
    return p["p0"], limits, contacts, soles, [p["pair_a"], p["pair_b"], p["both"]], acc


def test_random_cycles_give_the_tuples_figures():
    """Two 4-corner feet and a hand point, 1500 random cycles (limits crossed, feet lifted and
    loaded, flags toggled through the packed views): every return and running figure equal."""
    rng = np.random.default_rng(7)
    p0 = np.array([[sx * 0.1, 0.1 * side + sy * 0.05, 0.0] for side in (1, -1) for sx in (-1, 1) for sy in (-1, 1)]
                  + [[0.3, 0.0, 1.0]])
    i64 = np.int64
    parts = {"qi": np.arange(2, 12), "vi": np.arange(1, 11), "actuated": np.arange(2, 11),
             "contact_ptr": np.array([0, 4, 8, 9]), "contact_idx": np.arange(9), "sole_ptr": np.array([0, 4, 8]),
             "sole_idx": np.arange(8), "sole_vptr": np.array([0, 4, 8]), "sole_verts": np.array([0, 2, 3, 1, 4, 6, 7, 5]),
             "pair_a": np.arange(4), "pair_b": np.arange(4, 8), "viol": np.zeros(5, i64), "inside": np.zeros(2, i64),
             "loaded": np.zeros(2, i64), "q_lo": -np.ones(10), "q_hi": np.ones(10), "v_hi": np.full(10, 2.0),
             "tau_hi": np.full(9, 50.0), "mu_max": 0.7, "min_force": 20.0, "p0": p0, "slip2": np.zeros(3),
             "fn_min": np.full(2, np.inf), "edge_min": np.full(2, np.inf), "contact_watched": np.ones(3, np.bool_),
             "sole_watched": np.ones(2, np.bool_), "lifted": np.zeros(3, np.bool_), "both": True}
    parts = {k: v.astype(i64) if isinstance(v, np.ndarray) and v.dtype.kind == "i" else v for k, v in parts.items()}
    (ints, floats, flags), held = pack_state(parts)
    p0_t, limits, contacts, soles, pair, acc = _tuples(parts)
    support, verts = np.arange(8, dtype=i64), np.array([0, 2, 6, 7, 5, 1], dtype=i64)
    seen = np.zeros(4, dtype=bool)
    for k in range(1500):
        on = rng.random(3) > 0.15
        held["contact_watched"][:] = contacts[2][:] = on
        held["sole_watched"][:] = soles[4][:] = on[:2]
        held["both"][0] = pair[2] = bool(on[0] and on[1])
        q, v, tau = rng.normal(size=12) * 0.5, rng.normal(size=11) * 0.8, rng.normal(size=11) * 20.0
        c, sn = np.cos(k * 0.37), np.sin(k * 0.37)
        pts = p0 @ np.array([[c, sn, 0.0], [-sn, c, 0.0], [0.0, 0.0, 1.0]]) + rng.normal(size=p0.shape) * 1e-3
        pf = np.column_stack([rng.normal(size=(9, 2)) * 30.0, rng.normal(size=9) * 100.0 + 120.0])
        if k % 7 == 0:
            pf[rng.integers(0, 9), 2] = -1e-3
        if k % 13 == 0:
            pts[rng.integers(0, 8), 2] += 0.01
        cx, cy = rng.normal(size=2) * 0.08
        got = state_metrics_packed(q, v, tau, pf, pts, ints, floats, flags, support, verts, cx, cy)
        want = state_metrics(q, v, tau, pf, pts, p0_t, limits, contacts, soles, tuple(pair), (support, verts, cx, cy), acc)
        assert (math.isnan(got[0]) and math.isnan(want[0])) or got[0] == want[0], k
        assert got[1:] == want[1:], k
        seen |= [not math.isnan(got[0]), math.isnan(got[0]), bool(acc[2].any()), bool(acc[6].min() > 0)]
    for name, a in zip(("viol", "slip2", "lifted", "fn_min", "edge_min", "inside", "loaded"), acc, strict=False):
        assert np.array_equal(held[name], a), name
    assert seen.all() and (acc[0] > 0).all() and (acc[0] < 1500).all()


def test_a_run_with_a_released_foot_gives_the_tuples_figures(monkeypatch):
    """``talos_step`` to 2.2 s (the right foot released at 1.5 s: the contact and the pair no
    longer watched, the support one foot): each cycle's compiled call returns what the former
    tuples return on their own accumulators, and the run's figures are theirs (the internal
    force's and the support margin's running figures as ``Running`` gives them from those values)."""
    sc = load_config("talos_step")
    r = ScenarioRun(sc, solver="hqp", simulator="pinocchio", duration=2.2)
    m, cm = r.measured, r.measured.contact_metrics
    groups = [np.asarray(m.pts_of[c.name], dtype=np.int64) for c in m.contacts]
    former = {"qi": m.qi.astype(np.int64), "vi": m.vi.astype(np.int64), "actuated": np.asarray(r.robot.actuated_idx,
              dtype=np.int64), "contact_ptr": _offsets(groups), "contact_idx": _joined(groups),
              "sole_ptr": cm.soles[0], "sole_idx": cm.soles[1], "sole_vptr": cm.soles[2], "sole_verts": cm.soles[3],
              "pair_a": cm.pair_points[0], "pair_b": cm.pair_points[1], "viol": np.zeros(5, np.int64),
              "inside": np.zeros(len(cm.index), np.int64), "loaded": np.zeros(len(cm.index), np.int64),
              "q_lo": m.q_lo, "q_hi": m.q_hi, "v_hi": m.v_hi, "tau_hi": m.tau_hi, "mu_max": float(m.mu_max),
              "min_force": float(cm.min_force), "p0": m.p0, "slip2": np.zeros(len(m.contacts)),
              "fn_min": np.full(len(cm.index), np.inf), "edge_min": np.full(len(cm.index), np.inf),
              "contact_watched": np.zeros(len(m.contacts), np.bool_), "sole_watched": np.zeros(len(cm.index), np.bool_),
              "lifted": np.zeros(len(m.contacts), np.bool_), "both": False}
    p0, limits, contacts, soles, pair, acc = _tuples(former)
    real, calls = metrics_module.state_cycle, []
    internal, margins = Running(), Running()        # the former running figures, from the tuples' values

    def both(q, v, tau, pf, pts, ints, floats, flags, support, run_stats):
        idx, verts, com = support
        cx, cy = (float(com[0]), float(com[1])) if len(idx) else (0.0, 0.0)
        got = (math.nan, *real(q, v, tau, pf, pts, ints, floats, flags, support, run_stats))
        watched = {name for name, _ in m.watched}          # the former code's flags, from the run's watch()
        contacts[2][:] = [c.name in watched for c in m.contacts]
        soles[4][:] = [name in watched for name in cm.index]
        pair[2] = cm.pair is not None and all(n in watched for n in cm.pair)
        want = state_metrics(q, v, tau, pf, pts, p0, limits, contacts, soles, tuple(pair), (idx, verts, cx, cy), acc)
        assert got[1:] == want[1:], len(calls)
        if math.isfinite(want[0]):
            internal.add(want[0])
        if len(idx):
            margins.add(want[2])
        calls.append((pair[2], len(idx)))
        return got[1:]

    monkeypatch.setattr(metrics_module, "state_cycle", both)
    for k in range(r.n):
        assert r.cycle(k)
    assert len(calls) == r.n and calls[0] == (True, 8) and calls[-1] == (False, 4)     # the release seen
    assert m.viol_counts.tolist() == acc[0].tolist() and m.slip2.tolist() == acc[1].tolist()
    assert m.lifted.tolist() == acc[2].tolist()
    for got, want in ((cm.fn_min, acc[3]), (cm.edge_min, acc[4]), (cm.inside, acc[5]), (cm.loaded, acc[6])):
        assert got.tolist() == want.tolist()
    for got_run, want_run in ((cm.internal, internal), (m.margins, margins)):     # state_cycle's running figures
        assert want_run.n > 0
        assert [getattr(got_run, a) for a in Running.__slots__] == [getattr(want_run, a) for a in Running.__slots__]
