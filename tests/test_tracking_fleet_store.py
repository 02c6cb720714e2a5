"""The fleet tracker's cheap paths against their readable forms, bit for bit, on a run with births
and drops nearly every scan: every vessel's estimates made in one pass after a step (against each
vessel's rows made on their own), and the tracks of a fleet (row store, ticks where every vessel
scanned read as slices) against each vessel tracked alone."""

from __future__ import annotations

import math

import numpy as np

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
