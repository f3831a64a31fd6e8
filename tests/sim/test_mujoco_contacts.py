"""The MuJoCo simulator's compiled contact read-out (wbc.sim.mujoco_contacts.read_contacts) against the
per-contact Python loop it replaced, kept here as the reference: the point forces and each contact's
body, point and force equal bit for bit, on Talos's own contacts and on random contact lists."""

from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco", reason="the MuJoCo back-end needs mujoco (pip install mujoco==4.0.0)")

from wbc.sim.environment import ground  # noqa: E402
from wbc.sim.mujoco_contacts import GeomPoints, read_contacts  # noqa: E402
from wbc.sim.mujoco_sim import MujocoSimulator  # noqa: E402


def reference(geom, frame, pos, forces6, xmat, xpos, geom_bodyid, geom_points, npts):
    """The loop MujocoSimulator._read_contacts ran per contact (``forces6[k]``: mj_contactForce's)."""
    point_forces = np.zeros((npts, 3))
    contacts = []
    for k in range(len(geom)):
        g, sign = (int(geom[k, 1]), 1.0) if int(geom[k, 1]) in geom_points else (int(geom[k, 0]), -1.0)
        if g not in geom_points:
            continue
        f = sign * (frame[k].reshape(3, 3).T @ forces6[k][:3])
        b = geom_bodyid[g]
        R = xmat[b].reshape(3, 3)
        r = R.T @ (pos[k] - xpos[b])
        contacts.append((b, r, R.T @ f))
        idx, offs = geom_points[g]
        point_forces[idx[np.argmin(((offs - r) ** 2).sum(axis=1))]] += f
    return point_forces, contacts


def compiled(geom, frame, pos, efc_address, dim, efc_force, xmat, xpos, geom_bodyid, geom_points, npts, ngeom):
    table = GeomPoints(ngeom, geom_points, geom_bodyid).args
    pf = np.full((npts, 3), np.nan)
    nc = len(geom)
    bodies, r, f = np.zeros(nc, dtype=np.int64), np.zeros((nc, 3)), np.zeros((nc, 3))
    n = read_contacts(geom, frame, pos, efc_address, dim, efc_force, xmat, xpos, table, pf, bodies, r, f)
    return pf, list(zip(bodies[:n], r[:n], f[:n], strict=True))


def assert_same(got, want):
    (pf, contacts), (pf_ref, contacts_ref) = got, want
    assert np.array_equal(pf, pf_ref, equal_nan=True)
    assert len(contacts) == len(contacts_ref)
    for (b, r, f), (b_ref, r_ref, f_ref) in zip(contacts, contacts_ref, strict=True):
        assert b == b_ref and np.array_equal(r, r_ref, equal_nan=True) and np.array_equal(f, f_ref, equal_nan=True)


def test_talos_contacts_read_as_the_python_loop_did(talos):
    sim = MujocoSimulator.for_robot(talos, [ground(mu=0.8)], dt=1e-3)
    mm, d = sim.mj_model, sim.mj_data
    tau = np.zeros(talos.model.nv)
    rng = np.random.default_rng(3)
    checked = contacts = 0
    for step in range(60):
        sim.step(tau + rng.normal(0.0, 5.0, talos.model.nv) * talos.actuated_mask)
        if step % 6:
            continue
        con = d.contact
        contacts += d.ncon
        forces6 = []
        for k in range(d.ncon):
            f6 = np.zeros(6)
            mujoco.mj_contactForce(mm, d, k, f6)
            forces6.append(f6)
            assert np.array_equal(f6[:3], d.efc_force[con.efc_address[k]: con.efc_address[k] + 3])
        want = reference(con.geom, con.frame, con.pos, forces6, d.xmat, d.xpos, mm.geom_bodyid, sim._geom_points,
                         len(sim.points))
        got = compiled(con.geom, con.frame, con.pos, con.efc_address, con.dim, d.efc_force, d.xmat, d.xpos,
                       mm.geom_bodyid, sim._geom_points, len(sim.points), mm.ngeom)
        assert_same(got, want)
        assert np.array_equal(sim.point_forces, want[0])        # what the simulator itself read
        checked += 1
    assert checked == 10 and contacts >= 30


def test_random_contact_lists_read_as_the_python_loop_did():
    rng = np.random.default_rng(7)
    ngeom, nbody = 9, 5
    geom_bodyid = rng.integers(0, nbody, ngeom)
    for case in range(300):
        # robot geoms 2, 5, 7 with 1-5 points each; any geom pair, either order; excluded contacts
        geom_points, npts = {}, 0
        for g in (2, 5, 7):
            m = int(rng.integers(1, 6))
            geom_points[g] = (np.arange(npts, npts + m), rng.normal(0.0, 0.05, (m, 3)))
            npts += m
        if case % 10 == 0:      # two points at the same place: the first is the nearest
            idx, offs = geom_points[2]
            offs[-1] = offs[0]
        nc = int(rng.integers(0, 12))
        geom = rng.integers(0, ngeom, (nc, 2)).astype(np.int32)
        frame = rng.normal(size=(nc, 9))
        pos = rng.normal(0.0, 0.1, (nc, 3))
        dim = rng.choice(np.array([1, 3, 4, 6], dtype=np.int32), nc)
        efc_address = np.concatenate([[0], np.cumsum(dim)[:-1]]).astype(np.int32) if nc else np.zeros(0, np.int32)
        excluded = rng.random(nc) < 0.15
        efc_address[excluded] = -1
        efc_force = rng.normal(0.0, 100.0, int(dim.sum()) if nc else 0)
        forces6 = []
        for k in range(nc):
            f6 = np.zeros(6)
            if efc_address[k] >= 0:
                f6[:dim[k]] = efc_force[efc_address[k]: efc_address[k] + dim[k]]
            forces6.append(f6)
        xmat = rng.normal(size=(nbody, 9))
        xpos = rng.normal(size=(nbody, 3))
        if case % 7 == 0 and nc:
            pos[0] = np.nan     # a diverged state: argmin's first NaN
        want = reference(geom, frame, pos, forces6, xmat, xpos, geom_bodyid, geom_points, npts)
        got = compiled(geom, frame, pos, efc_address, dim, efc_force, xmat, xpos, geom_bodyid, geom_points, npts,
                       ngeom)
        np.testing.assert_array_equal(got[0], want[0])
        assert_same(got, want)
