"""step_inputs (mjasc.perception.tracking.step_gathers) against the two calls it fuses —
select_detections then step_rows — bit for bit, on every step of real runs (the 3-vessel crossing
scene and the demo's first seconds): the fourteen arrays sliced out of its four, the per-vessel
counters it adds to."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.perception.tracking import fleet as fleet_mod
from mjasc.perception.tracking.step_gathers import step_inputs, step_inputs_into, step_rows
from mjasc.perception.tracking.step_kernels import select_detections
from mjasc.runs.runner import Runner

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("name, duration", [("thesis_6_4_crossing", 30.0), ("demo", 20.0)])
def test_step_inputs_equal_select_detections_then_step_rows(monkeypatch, name, duration):
    n_checked = [0]

    def checked(m_all, sel, cen, var, rad, occ, use_var, owner, pos_of, every, owners, t_o, n_owners, counts, scans,
                dets, R):
        c_ref = counts.copy()
        sd = select_detections(m_all, sel, cen, var, rad, occ, use_var, R)
        M = sd[2].shape[0]
        sr = step_rows(owner, pos_of, every, owners, t_o, n_owners, c_ref, scans, dets, sd[6], M, R)
        got = step_inputs(m_all, sel, cen, var, rad, occ, use_var, owner, pos_of, every, owners, t_o, n_owners, counts,
                          scans, dets, R)
        ints, z, floats, flags, all_due, k = got
        p, n = sd[6].size, owner.size
        assert all_due == sr[2] and k == sr[3].size
        c = 2 * M + p
        _same(counts, c_ref)
        for a, b in ((ints[:M], sd[0]), (ints[M:2 * M], sd[1]), (z, sd[2]), (floats[:M], sd[3]),
                     (floats[M:2 * M], sd[4]), (flags[:M], sd[5]), (ints[2 * M:c], sd[6]),
                     (floats[2 * M:2 * M + n_owners], sr[0]), (ints[c:c + n], sr[1]), (ints[c + n:c + n + k], sr[3]),
                     (ints[c + n + k:c + n + 2 * k], sr[4]), (flags[M:], sr[5]), (ints[c + n + 2 * k:], sr[6]),
                     (floats[2 * M + n_owners:], sr[7])):
            _same(a, b)
        n_checked[0] += 1
        return got

    def checked_into(m_all, sel, cen, var, rad, occ, use_var, owner, pos_of, every, owners, t_o, n_owners, counts,
                     scans, dets, R, ints_b, z_b, floats_b, flags_b):
        """(what the step calls: step_inputs written into the step's buffers) against step_inputs."""
        c_ref = counts.copy()
        ints, z, floats, flags, all_due, k = checked(m_all, sel, cen, var, rad, occ, use_var, owner, pos_of, every,
                                                     owners, t_o, n_owners, c_ref, scans, dets, R)
        got = step_inputs_into(m_all, sel, cen, var, rad, occ, use_var, owner, pos_of, every, owners, t_o, n_owners,
                               counts, scans, dets, R, ints_b, z_b, floats_b, flags_b)
        assert got == (z.shape[0], all_due, k)
        _same(counts, c_ref)
        for a, b in ((ints_b[:ints.size], ints), (z_b[:z.shape[0]], z), (floats_b[:floats.size], floats),
                     (flags_b[:flags.size], flags)):
            _same(a, b)
        return got

    monkeypatch.setattr(fleet_mod, "step_inputs_into", checked_into)
    sc = mjasc.load_scenario(_ROOT / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert n_checked[0] > 50


def test_births_packed_equal_births_of(monkeypatch):
    """births_packed's three arrays hold births_of's eight, and the births of the fleet's one call
    (fleet_rows.births_into: its vessel positions, ids, detections and z) are births_of's, on every step of a
    real run with births (the births on their own call: with the drops' call, drops_births_into, they are
    births_into's inside it)."""
    from mjasc.perception.tracking import fleet_rows
    from mjasc.perception.tracking.step_gathers import births_of, births_packed

    n_checked = [0]
    births_into = fleet_rows.births_into

    def checked(claimed, owner, pos_of, d_pos, z, var, rad, x, radius, owners, t_o, next_local, idx, counts, col,
                *rest):
        c_ref, nl_ref = counts.copy(), next_local.copy()
        want = births_of(claimed, owner, pos_of, d_pos, z, var, rad, x, radius, owners, t_o, nl_ref, idx, c_ref, col)
        c_p, nl_p = counts.copy(), next_local.copy()
        ints, floats, zb = births_packed(claimed, owner, pos_of, d_pos, z, var, rad, x, radius, owners, t_o, nl_p, idx,
                                         c_p, col)
        _same(c_p, c_ref)
        _same(nl_p, nl_ref)
        for a, b in zip((ints[0], ints[1], ints[2], floats[0], zb, floats[1], floats[2], ints[3]), want):
            _same(a, b)
        got = births_into(claimed, owner, pos_of, d_pos, z, var, rad, x, radius, owners, t_o, next_local, idx, counts,
                          col, *rest)
        _same(counts, c_ref)
        _same(next_local, nl_ref)
        for a, b in zip((got[0][0], got[0][1], got[0][2], got[1]), (want[0], want[2], want[7], want[4])):
            _same(a, b)
        n_checked[0] += bool(zb.shape[0])
        return got

    monkeypatch.setattr(fleet_rows, "births_into", checked)
    monkeypatch.setattr(fleet_rows.FleetRows, "_drops_in_one_call", False)  # (births_into's own call every step;
    # the births inside drops_births_into: tests/test_fleet_rows.py)
    sc = mjasc.load_scenario(_ROOT / "tasks" / "demo.toml").with_overrides(duration_s=20.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert n_checked[0] > 20


@pytest.mark.parametrize("name, duration", [("thesis_6_4_crossing", 20.0)])
def test_step_views_are_the_slices_of_the_buffers(monkeypatch, name, duration):
    """The step's arrays (FleetTracker._step_views: views made once per sizes) are the slices of its buffers as
    step_inputs_into lays them out, at every step of a real run (the same memory, shape and strides), also
    after the buffers grew (a tracker started with none)."""
    made = fleet_mod.FleetTracker._step_views
    n_checked = [0]

    def checked(self, M, n, k, p, no):
        got = made(self, M, n, k, p, no)
        ints, z, floats, flags = self._bufs
        c, f = 2 * M + p, 2 * M + no
        ref = (z[:M], ints[:M], ints[M:2 * M], ints[2 * M:c], ints[c:c + n], ints[c + n:c + n + k],
               ints[c + n + k:c + n + 2 * k], ints[c + n + 2 * k:c + 2 * n + 2 * k], floats[:M], floats[M:2 * M],
               floats[2 * M:f], floats[f:f + n], flags[:M], flags[M:2 * M])
        assert len(got) == len(ref)
        for a, b in zip(got, ref):
            assert a.base is b.base and a.shape == b.shape and a.strides == b.strides
            assert a.__array_interface__["data"][0] == b.__array_interface__["data"][0]
        n_checked[0] += 1
        return got

    monkeypatch.setattr(fleet_mod.FleetTracker, "_step_views", checked)
    sc = mjasc.load_scenario(_ROOT / "tasks" / f"{name}.toml").with_overrides(duration_s=duration)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    Runner(sc, out_dir=None).run()
    assert n_checked[0] > 50
