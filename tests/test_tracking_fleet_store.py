"""The fleet tracker's cheap paths against their readable forms, bit for bit, on a run with births
and drops nearly every scan: every vessel's estimates made in one pass after a step (against each
vessel's rows made on their own), and the tracks of a fleet (row store, ticks where every vessel
scanned read as slices) against each vessel tracked alone."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjasc.perception.detection import Detections
from mjasc.perception.tracking import TrackingConfig
from mjasc.perception.tracking.fleet import FleetTracker

DT = 0.2
N_VESSELS = 3


def _detections(rng, t, origin, n_targets=4, clutter=1.5):
    ang = np.arange(n_targets) * 2 * math.pi / n_targets + 0.03 * t
    r = 20.0 + 6.0 * np.arange(n_targets)
    c = np.stack([r * np.cos(ang), r * np.sin(ang)], axis=-1)
    c[-1] = (-10.0, 15.0)  # a buoy (static, with an outline)
    c = c + rng.normal(scale=0.15, size=(n_targets, 2))
    k = rng.poisson(clutter)
    c = np.concatenate([c, rng.uniform(-40, 40, size=(k, 2))])
    m = c.shape[0]
    rad = np.concatenate([np.full(n_targets, 1.2), rng.uniform(0.1, 0.5, size=k)])
    pts = np.repeat(c, 3, axis=0) + rng.normal(scale=0.2, size=(3 * m, 2))
    return Detections(t, origin, 0.0, c, c - origin, rad, rng.uniform(0.02, 0.2, size=m), np.full(m, 3),
                      np.hypot(*(c - origin).T), np.zeros(m, dtype=bool), np.repeat(np.arange(m), 3),
                      rng.random(m) < 0.2), pts


def _run(fleets, steps=150):
    """Feed each vessel's scans to ``fleets[i]`` (one FleetTracker, or one per vessel); yield after each tick."""
    rng = [np.random.default_rng([5, i]) for i in range(N_VESSELS)]
    origins = [np.array([3.0 * i, -2.0 * i]) for i in range(N_VESSELS)]
    for k in range(steps):
        t = k * DT
        scanning = [i for i in range(N_VESSELS) if not (i == 2 and k % 3 == 1)]  # vessel 2 skips some ticks
        if k % 20 == 5:
            for i in range(N_VESSELS):
                ft, o = fleets[i]
                tb = t - 0.3  # target 0 is a team mate
                ft.set_team_positions(o, {"v0": (tb, 20.0 * np.array([math.cos(0.03 * tb), math.sin(0.03 * tb)])),
                                          "v9": (tb, np.array([-30.0, -30.0]))})
        scans = {i: _detections(rng[i], t, origins[i]) for i in scanning}
        groups = {}
        for i in scanning:
            groups.setdefault(id(fleets[i][0]), []).append(i)
        for members in groups.values():
            ft = fleets[members[0]][0]
            ft.step([fleets[i][1] for i in members], [t] * len(members), [scans[i][0] for i in members],
                    [origins[i] for i in members], None, [scans[i][1] for i in members])
        yield k


def _fields(ests):
    return [(e.track_id, e.time_s, e.position_m.tobytes(), e.heading_rad, e.speed_m_s, e.turn_rate_rad_s,
             e.radius_m, e.position_covariance.tobytes(), e.is_static, e.team_member,
             None if e.outline_m is None else e.outline_m.tobytes(), e.source) for e in ests]


def test_estimates_made_at_once_equal_each_vessels_own():
    cfg = TrackingConfig()
    ft = FleetTracker(cfg)
    owners = [ft.add_owner(60.0) for _ in range(N_VESSELS)]
    for _ in _run([(ft, o) for o in owners]):
        for o in owners:
            rows = ft.rows_of(o)
            readable = ft._estimates_of(rows[ft.mgmt._confirmed[rows]])
            assert _fields(ft.estimates(o)) == _fields(readable)
            assert ft.estimates(o) is not ft.estimates(o)  # a new list each call
        c = ft._counts
        births = int(c[:, 0].sum())
    ests = [e for o in owners for e in ft.estimates(o)]
    assert births > 50 and len(ests) >= 6
    assert any(e.team_member == "v0" for e in ests) and any(e.outline_m is not None for e in ests)


def test_fleet_equals_each_vessel_alone_through_births_and_drops():
    cfg = TrackingConfig()
    shared = FleetTracker(cfg)
    fleet = [(shared, shared.add_owner(60.0)) for _ in range(N_VESSELS)]
    alone = []
    for _ in range(N_VESSELS):
        ft = FleetTracker(cfg)
        alone.append((ft, ft.add_owner(60.0)))
    for _ in zip(_run(fleet), _run(alone)):
        for (fa, oa), (fb, ob) in zip(fleet, alone):
            assert _fields(fa.estimates(oa, include_tentative=True)) == _fields(fb.estimates(ob, include_tentative=True))
            assert fa.last_assignment(oa) == fb.last_assignment(ob)
            assert fa.counts(oa) == fb.counts(ob)
            assert [(e.time_s, e.kind, e.track_id, e.text) for e in fa.events[oa]] == \
                   [(e.time_s, e.kind, e.track_id, e.text) for e in fb.events[ob]]
    assert sum(fb.counts(ob)["born"] for fb, ob in alone) > 50


def _after_update_numpy(mg, rows, t_s, used, assigned_det, rad, occ, speeds):
    """The numpy form of TrackManagement.after_update (the reference of its compiled pass)."""
    cfg = mg.config
    hist = ((mg._hist[rows] << 1) | used) & mg._window_mask
    mg._hist[rows] = hist
    mg._scans[rows] += 1
    mg._n_upd[rows] += used
    mg._last[rows] = np.where(used, t_s, mg._last[rows])
    if used.any():  # an occluded detection only grows the radius
        g = np.arange(mg._radius.size)[rows][used]
        r_new = rad[assigned_det[used]]
        r_old = mg._radius[g]
        occ_u = occ[assigned_det[used]] if occ.size else np.zeros(r_new.size, dtype=bool)
        change = (r_new > r_old) | ~occ_u
        gain = np.where(r_new > r_old, cfg.radius_grow_gain, cfg.radius_shrink_gain)
        mg._radius[g] = np.where(change, r_old + gain * (r_new - r_old), r_old)
    conf = mg._confirmed[rows]
    new_conf = ~conf & (mg._popcount[hist] >= cfg.confirm_hits)
    conf |= new_conf
    mg._confirmed[rows] = conf
    old = (t_s - mg._born[rows]) >= cfg.static_min_age_s
    mg._static[rows] = conf & old & np.where(mg._static[rows], speeds < 2 * cfg.static_speed_m_s,
                                             speeds < cfg.static_speed_m_s)
    return new_conf


def test_after_update_equals_its_numpy_form():
    import copy

    from mjasc.perception.tracking.management import TrackManagement

    rng = np.random.default_rng(2)
    mg = TrackManagement(TrackingConfig())
    ref = copy.deepcopy(mg)
    seen_static = seen_conf = False
    for step in range(200):
        n = mg._hist.size
        if n:
            rows = slice(None) if step % 2 else np.sort(rng.choice(n, size=int(rng.integers(1, n + 1)), replace=False))
            k = n if isinstance(rows, slice) else rows.size
            m = int(rng.integers(0, 6))
            used = rng.random(k) < 0.7 if m else np.zeros(k, dtype=bool)
            assigned = np.where(used, rng.integers(0, max(m, 1), size=k), -1)
            rad = rng.uniform(0.2, 3.0, size=m)
            occ = rng.random(m) < 0.3 if step % 3 else np.zeros(0, dtype=bool)
            speeds = rng.uniform(0.0, 0.8, size=k)
            t = step * 0.2 if step % 5 == 0 else np.full(k, step * 0.2)
            got = mg.after_update(rows, t, used, assigned, rad, occ, speeds)
            want = _after_update_numpy(ref, rows, t, used, assigned, rad, occ, speeds)
            assert np.array_equal(got, want)
            for name in TrackManagement._ROWS:
                assert getattr(mg, name).tobytes() == getattr(ref, name).tobytes(), name
            seen_static |= bool(mg._static.any())
            seen_conf |= bool(mg._confirmed.any())
        b = int(rng.integers(0, 3))
        if b:
            r0 = rng.uniform(0.2, 2.0, size=b)
            mg.append(step * 0.2, r0)
            ref.append(step * 0.2, r0)
        if mg._hist.size > 4 and rng.random() < 0.5:
            keep = rng.random(mg._hist.size) < 0.8
            mg.keep(keep)
            ref.keep(keep)
    assert seen_conf and seen_static


def test_block_pairs_flat_equals_its_numpy_form():
    from mjasc.perception.tracking.association import block_pairs
    from mjasc.perception.tracking.pair_kernels import block_pairs_flat

    rng = np.random.default_rng(4)
    for _ in range(50):
        p = int(rng.integers(1, 6))
        n_a, n_b = rng.integers(0, 4, size=p), rng.integers(0, 4, size=p)
        q, i, j, start, ga, gb = block_pairs_flat(n_a, n_b)
        for x, y in zip((q, i, j, start), block_pairs(n_a, n_b)):
            assert np.array_equal(x, y)
        a0, b0 = np.cumsum(n_a) - n_a, np.cumsum(n_b) - n_b
        assert np.array_equal(ga, a0[q] + i) and np.array_equal(gb, b0[q] + j)


def _losses_numpy(mg, rows, t_s, positions, Pc, origins_m, max_range_m):
    """The numpy form of the losses in TrackManagement.drops (the reference of its compiled pass)."""
    cfg = mg.config
    k = positions.shape[0]
    reason = [""] * k
    hist, conf = mg._hist[rows], mg._confirmed[rows]
    misses = np.minimum(mg._scans[rows], cfg.confirm_window) - mg._popcount[hist]
    drop = ~conf & (misses > cfg.confirm_window - cfg.confirm_hits)
    tr = 0.5 * (Pc[:, 0, 0] + Pc[:, 1, 1])
    lam = tr + np.sqrt(np.maximum(tr**2 - (Pc[:, 0, 0] * Pc[:, 1, 1] - Pc[:, 0, 1] ** 2), 0.0))
    since = t_s - mg._last[rows]
    gone = conf & (since > cfg.max_coast_s)
    for j in np.flatnonzero(gone):
        drop[j], reason[j] = True, f"not seen for {since[j]:.1f} s"
    vague = conf & ~drop & (lam > cfg.max_position_std_m**2)
    for j in np.flatnonzero(vague):
        drop[j], reason[j] = True, f"position uncertainty {math.sqrt(lam[j]):.1f} m"
    rng = np.hypot(positions[:, 0] - origins_m[:, 0], positions[:, 1] - origins_m[:, 1])
    out = rng > max_range_m + cfg.range_margin_m
    out &= ~drop
    for j in np.flatnonzero(out):
        drop[j], reason[j] = True, f"out of range ({rng[j]:.0f} m)"
    return drop, reason


def test_losses_equal_their_numpy_form():
    from mjasc.perception.tracking.management import TrackManagement

    rng = np.random.default_rng(9)
    cfg = TrackingConfig()
    mg = TrackManagement(cfg)
    n = 400
    mg.append(rng.uniform(0, 5, size=n), rng.uniform(0.2, 2, size=n))
    mg._hist[:] = rng.integers(0, 1 << cfg.confirm_window, size=n)
    mg._scans[:] = rng.integers(1, 10, size=n)
    mg._confirmed[:] = rng.random(n) < 0.6
    mg._last[:] = rng.uniform(0, 10, size=n)
    A = rng.normal(size=(n, 2, 2)) * rng.uniform(0.1, 8.0, size=(n, 1, 1))
    P = A @ np.swapaxes(A, 1, 2)
    pos = rng.uniform(-120, 120, size=(n, 2))
    org = np.where(rng.random((n, 1)) < 0.2, np.nan, rng.uniform(-5, 5, size=(n, 2)))
    max_range = np.full(n, 100.0)
    for rows in (slice(None), np.sort(rng.choice(n, size=150, replace=False))):
        k = n if isinstance(rows, slice) else rows.size
        sub = (lambda a: a) if isinstance(rows, slice) else (lambda a: a[rows])
        t = rng.uniform(8, 14, size=k)
        drop, reason, _ = mg.drops(rows, np.zeros(k, dtype=np.int64), t, sub(pos) + 1000.0 * np.arange(k)[:, None],
                                   sub(P), sub(org), max_range[:k])
        want_drop, want_reason = _losses_numpy(mg, rows, t, sub(pos) + 1000.0 * np.arange(k)[:, None], sub(P), sub(org),
                                               max_range[:k])
        assert np.array_equal(drop, want_drop) and reason == want_reason
        assert {r.split()[0] for r in reason if r} == {"not", "position", "out"}


def test_estimates_asked_again_between_steps_are_the_first_ones_and_renewed_by_a_step():
    """A vessel's confirmed estimates are made once per step (its report is asked again after comms):
    asked again they are the same objects, equal to the readable form made afresh; after a step, new."""
    cfg = TrackingConfig()
    ft = FleetTracker(cfg)
    owners = [ft.add_owner(60.0) for _ in range(N_VESSELS)]
    before = {}
    for _ in _run([(ft, o) for o in owners]):
        for o in owners:
            first = ft.estimates(o)
            rows = ft.rows_of(o)
            readable = ft._estimates_of(rows[ft.mgmt._confirmed[rows]])
            again = ft.estimates(o)
            assert again is not first and all(a is b for a, b in zip(again, first)) and len(again) == len(first)
            assert _fields(again) == _fields(readable)
            assert not any(e is b for e in first for b in before.get(o, ()))  # made afresh after the step
            before[o] = first


def _drops_numpy(mg, rows, group, t_s, positions, Pc, origins_m, max_range_m):
    """TrackManagement.drops as it was before drop_rows: the losses' pass, then the duplicates found by
    merge_candidates on the live tracks sorted by vessel, resolved in Python in the order found."""
    from mjasc.perception.tracking.pair_kernels import merge_candidates

    cfg = mg.config
    drop, reason = _losses_numpy(mg, rows, t_s, positions, Pc, origins_m, max_range_m)
    conf, n_upd = mg._confirmed[rows], mg._n_upd[rows]
    merged = []
    live = (~drop).nonzero()[0]
    if live.size > 1:
        live = live[np.argsort(group[live], kind="stable")]
        a, b = merge_candidates(live, np.ascontiguousarray(group[live], dtype=np.int64),
                                np.ascontiguousarray(positions, dtype=float), mg._radius[rows],
                                float(cfg.merge_fraction))
        for a_, b_ in zip(a.tolist(), b.tolist()):
            if drop[a_] or drop[b_]:
                continue
            keep, go = (a_, b_) if (conf[a_], n_upd[a_]) >= (conf[b_], n_upd[b_]) else (b_, a_)
            drop[go] = True
            reason[go] = ""
            if conf[go]:
                merged.append((go, keep))
    return drop, reason, merged


@pytest.mark.parametrize("seed", range(10))
def test_drops_equal_their_numpy_form(seed):
    """drop_rows (losses, then merges of close tracks of one vessel) against the numpy form, with many
    duplicates: several vessels, tracks in clusters, ties in the number of updates."""
    from mjasc.perception.tracking.management import TrackManagement

    rng = np.random.default_rng(seed)
    cfg = TrackingConfig()
    mg = TrackManagement(cfg)
    n = int(rng.integers(2, 60))
    mg.append(rng.uniform(0, 5, size=n), rng.uniform(0.5, 3, size=n))
    mg._hist[:] = rng.integers(0, 1 << cfg.confirm_window, size=n)
    mg._scans[:] = rng.integers(1, 10, size=n)
    mg._n_upd[:] = rng.integers(1, 4, size=n)
    mg._confirmed[:] = rng.random(n) < 0.6
    mg._last[:] = rng.uniform(0, 10, size=n)
    A = rng.normal(size=(n, 2, 2)) * rng.uniform(0.1, 3.0, size=(n, 1, 1))
    P = A @ np.swapaxes(A, 1, 2)
    centres = rng.uniform(-60, 60, size=(5, 2))
    pos = centres[rng.integers(0, 5, n)] + rng.normal(size=(n, 2)) * 1.5
    org = np.where(rng.random((n, 1)) < 0.2, np.nan, rng.uniform(-5, 5, size=(n, 2)))
    group = rng.integers(0, 3, size=n)
    for rows in (slice(None), np.sort(rng.choice(n, size=max(1, n // 2), replace=False))):
        k = n if isinstance(rows, slice) else rows.size
        sub = (lambda a: a) if isinstance(rows, slice) else (lambda a: a[rows])
        t = rng.uniform(8, 12, size=k)
        mr = np.full(k, 100.0)
        got = mg.drops(rows, sub(group), t, sub(pos), sub(P), sub(org), mr)
        want = _drops_numpy(mg, rows, sub(group), t, sub(pos), sub(P), sub(org), mr)
        assert np.array_equal(got[0], want[0]) and got[1] == want[1] and got[2] == want[2]
        if isinstance(rows, slice):  # (a strided view of the positions, as the fleet tracker passes them)
            x = np.concatenate([pos, rng.normal(size=(n, 2))], axis=1)
            again = mg.drops(rows, group, t, x[:, :2], P, org, mr)
            assert np.array_equal(again[0], want[0]) and again[1] == want[1] and again[2] == want[2]
