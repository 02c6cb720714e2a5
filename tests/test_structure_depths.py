"""structure_tracks' compiled loop over the polygons (mjasc.avoidance.structure._structure_depths)
against the numpy form it replaced (one distance and inside test per polygon), bit for bit."""

import numpy as np

from mjasc.avoidance.structure import structure_tracks
from mjasc.core.estimates import TrackEstimate
from mjasc.core.geometry import distance_to_polygon, point_in_polygon


def _reference(tracks, polygons, slow_m_s):
    polys = [np.asarray(p, dtype=float) for p in polygons or ()]
    strangers = [tr for tr in tracks if not tr.is_static and tr.team_member is None]
    if not polys or not strangers:
        return {}, set()
    centres = np.array([tr.position_m for tr in strangers], dtype=float).reshape(-1, 2)
    radii = np.array([tr.radius_m for tr in strangers], dtype=float)
    slow = np.array([tr.speed_m_s < slow_m_s for tr in strangers])
    depth = np.full(len(strangers), -1.0)
    beside = np.zeros(len(strangers), dtype=bool)
    for p in polys:
        d = distance_to_polygon(centres, p)
        depth = np.where(point_in_polygon(centres, p), np.maximum(depth, d), depth)
        beside |= slow & (d < radii)
    return ({tr.track_id: float(k) for tr, k in zip(strangers, depth) if k >= 0.0},
            {tr.track_id for tr, k, b in zip(strangers, depth, beside) if b and k < 0.0})


def test_structure_tracks_match_the_numpy_form():
    rng = np.random.default_rng(4)
    found_inside = found_beside = 0
    for trial in range(300):
        polys = []
        for _ in range(int(rng.integers(0, 5))):
            c = rng.uniform(-60.0, 60.0, 2)
            k = int(rng.integers(3, 9))
            ang = np.sort(rng.uniform(0.0, 2 * np.pi, k))
            polys.append(c + rng.uniform(3.0, 25.0) * np.column_stack([np.cos(ang), np.sin(ang)]))
        tracks = [TrackEstimate(track_id=i, time_s=1.0, position_m=rng.uniform(-70.0, 70.0, 2),
                                heading_rad=0.0, speed_m_s=float(rng.choice([0.1, 0.2, 2.0])),
                                turn_rate_rad_s=0.0, radius_m=float(rng.uniform(1.0, 9.0)),
                                is_static=bool(rng.random() < 0.1),
                                team_member="mate" if rng.random() < 0.1 else None)
                  for i in range(int(rng.integers(0, 8)))]
        got = structure_tracks(tracks, polys, 0.3)
        ref = _reference(tracks, polys, 0.3)
        assert got[1] == ref[1]
        assert got[0].keys() == ref[0].keys()
        for k, v in ref[0].items():
            assert np.float64(got[0][k]).tobytes() == np.float64(v).tobytes()
            assert type(got[0][k]) is float
        found_inside += len(got[0])
        found_beside += len(got[1])
    assert found_inside > 20 and found_beside > 5
