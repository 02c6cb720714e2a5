"""A fleet tracker's drops and births in one compiled call (mjasc.perception.tracking.fleet_rows:
drops_births_into, with management's moved marks; births_into when a drop has events) against their separate
form — drops_every, then IMMBank.keep_rows and TrackColumns.keep; births_packed, then IMMBank.append_tracks
and TrackColumns.append_rows; then note_moved — bit for bit, on a run with births and drops nearly every scan
(per-row σ² and the config's)."""

from __future__ import annotations

import numpy as np
import pytest

from mjasc.perception.tracking import TrackingConfig
from mjasc.perception.tracking.fleet import FleetTracker
from mjasc.perception.tracking.fleet_views import _BORN, TrackEvent
from mjasc.perception.tracking.step_gathers import births_packed

from tests.test_tracking_fleet_store import N_VESSELS, _run


class _Separate(FleetTracker):
    _drops_in_one_call = False

    def _births(self, owners, pos_of, t_o, z, var, rad, idx, d_pos, claimed) -> None:  # (the form before births_into)
        bank = self.bank
        ints, floats, zb = births_packed(
            claimed, self.cols.owner, pos_of, d_pos, z, var, rad, bank.state_rows, self.cols.radius, owners, t_o,
            self._next_local, idx, self._counts, _BORN)
        k = zb.shape[0]
        if k == 0:
            return
        bp, own, local, dets = ints
        t_b, var_b, rad_b = floats
        bank.append_tracks(zb, t_b, var_b if self._use_var else None)
        self.cols.append_rows(t_b, rad_b, zb, own, local)
        self.version += 1
        for a in range(k):
            q = int(bp[a])
            o = int(owners[q])
            tid = int(local[a])
            self.events[o].append(TrackEvent(float(t_o[q]), "born", tid,
                                             f"track {tid} born at ({zb[a, 0]:.1f}, {zb[a, 1]:.1f}) m"))
            self._last_assign[o].append((local, dets, a, a + 1))


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("use_var", [True, False])
def test_births_in_one_call_equal_the_separate_calls(use_var, monkeypatch):
    cfg = TrackingConfig(use_detection_variance=use_var)
    from mjasc.perception.tracking import fleet_rows

    fused = [0]
    real = fleet_rows.drops_births_into

    def counted(*a):
        out = real(*a)
        fused[0] += out[3] >= 0 and (out[2] > 0 or out[6].shape[0] > 0)  # (compacted or born in the call)
        return out

    monkeypatch.setattr(fleet_rows, "drops_births_into", counted)
    got, want = FleetTracker(cfg), _Separate(cfg)
    og = [got.add_owner(60.0) for _ in range(N_VESSELS)]
    ow = [want.add_owner(60.0) for _ in range(N_VESSELS)]
    runs = (_run([(got, o) for o in og]), _run([(want, o) for o in ow]))
    n_born = n_gone = version = 0
    for _ in zip(*runs):
        a, b = got.bank, want.bank
        for name in ("_ids", "_t", "_Pc", "_n_gated", "_reasons", "_s", "_P", "_mu", "_x"):
            _same(getattr(a, name), getattr(b, name))
        for name in ("active", "x", "P", "n_meas"):
            _same(getattr(a._startup, name), getattr(b._startup, name))
        assert a._startup.n_active == b._startup.n_active and a._t_common == b._t_common
        assert a._next_id == b._next_id
        c, d = got.cols, want.cols
        assert c.n == d.n
        for name in ("born", "last", "radius", "nis", "anchor", "hull_anchor", "owner", "local_id", "hist", "scans",
                     "n_upd", "confirmed", "static", "anchored", "moved", "manoeuvring"):
            _same(getattr(c, name), getattr(d, name))
        assert c.team.tolist() == d.team.tolist()
        _same(got._counts, want._counts)
        _same(got._next_local, want._next_local)
        for o, p in zip(og, ow):
            assert got.events[o] == want.events[p]
            assert got.last_assignment(o) == want.last_assignment(p)
        n_born, n_gone = int(got._counts[:, 0].sum()), n_gone + got.version - version
        version = got.version
    assert n_born > 50 and n_gone > 100 and fused[0] > 50


def test_reserve_keeps_the_columns_views_current():
    """TrackColumns.reserve that grows the tables: the columns' views are those of the new tables (a step
    whose births room grew them but that had no birth writes its columns where the next call reads them)."""
    from mjasc.perception.tracking.track_columns import HIST, TrackColumns

    c = TrackColumns(capacity=4)
    c.append(0.0, np.ones(3))
    f, i, b = c.reserve(40)
    assert f.shape[1] >= 40 and c.n == 3
    c.hist[:] = 7
    assert (i[HIST, :3] == 7).all()


def test_drops_in_one_call_equal_the_separate_calls_on_a_run(monkeypatch):
    """The demo's first 40 s (clutter born and dropped nearly every step, tracks lost and merged): the same
    summary and tracks with the fleet's drops in one call and through drops_every, keep_rows and keep."""
    from dataclasses import replace

    import mjasc
    from mjasc.perception.tracking.fleet_rows import FleetRows
    from mjasc.runs.runner import Runner

    sc = mjasc.load_scenario("demo").with_overrides(duration_s=40.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))

    def run():
        runner = Runner(sc, out_dir=None, progress=False)
        s = runner.run().summary
        tracks = [[(e.track_id, *e.position_m, e.heading_rad, e.speed_m_s, e.team_member, e.radius_m)
                   for e in a.perception.tracks()] for a in runner.agents]
        return {k: v for k, v in s.items() if k not in ("wall_time_s", "real_time_factor", "timing_s")}, tracks

    def strip(s):
        if isinstance(s, dict):
            return {k: strip(v) for k, v in s.items() if not k.endswith("_us")}
        return s

    fused = run()
    monkeypatch.setattr(FleetRows, "_drops_in_one_call", False)
    separate = run()
    assert strip(fused[0]) == strip(separate[0]) and fused[1] == separate[1]
