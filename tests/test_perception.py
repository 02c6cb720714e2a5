"""The full perception chain (mjasc.perception.pipeline): MuJoCo range scans → detections → IMM tracks, with
the observing vessel held still and the targets (mocap bodies) moved along known trajectories, so
that only perception runs (no physics stepping); and the thesis §6.1 scenario through the runner."""

import math

import mujoco
import numpy as np
import pytest

from mjasc.core.geometry import covariance_ellipse
from mjasc.perception.pipeline import Perception
from mjasc.perception.range_sensor import SensorConfig
from mjasc.perception.tracking import TrackingConfig
from mjasc.physics.obstacles import CircleObstacle, MovingObstacle, PolygonObstacle
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import build_world
from mjasc.runs.recording import Recorder
from tests.test_tracking import truth

DT = 0.2


class Bench:
    """An Otter at (0, 0) heading 0 with perception; targets as mocap discs moved by hand."""

    def __init__(self, n_targets=0, statics=(), sensor=SensorConfig(), tracking=TrackingConfig(), seed=0,
                 vessels=(("own", (0.0, 0.0, 0.0)),), radius=2.5):
        vt = load_vessel_type("otter")
        moving = [MovingObstacle(f"t{k}", radius, (500.0 + 20 * k, 500.0)) for k in range(n_targets)]
        self.world = w = build_world([(n, vt) for n, _ in vessels], list(statics), moving)
        for i, (_, pose) in enumerate(vessels):
            w.data.qpos[w.qpos_adr[i]] = pose
        self.p = Perception(w, 0, sensor, tracking, np.random.default_rng(seed))

    def step(self, t, positions):
        w = self.world
        d = w.data
        if len(positions):
            d.mocap_pos[w.mocap_id, :2] = positions
        d.time = t
        mujoco.mj_kinematics(w.model, d)
        self.p.sense(t, None)
        self.p.update_tracks(t, None)

    def run(self, X, hidden=None):
        """X (T, n, 4) truth per scan; returns per scan the confirmed tracks (list of TrackEstimate)."""
        out = []
        for k in range(X.shape[0]):
            self.step(k * DT, X[k, :, :2])
            out.append(self.p.tracks())
        return out


KINDS = {  # start, heading, speed, turn rate(t): four targets around the observer, 60–90 m away
    "cv": ((60.0, -60.0), math.pi / 2, 1.5, lambda t: 0.0),
    "ct": ((-70.0, 0.0), -math.pi / 2, 1.5, lambda t: 0.03),
    "manoeuvring": ((0.0, 90.0), math.pi, 1.5, lambda t: 0.03 if t < 50 else -0.03),
    "static": ((40.0, 60.0), 0.0, 0.0, lambda t: 0.0),
}


def kind_truth(n_steps):
    return np.concatenate([truth(n_steps, DT, [p0], [th0], [v], w) for p0, th0, v, w in KINDS.values()], axis=1)


def score(X, out, t_from):
    """Per target: squared position errors, position NEES, V and ω errors of the nearest confirmed
    track (within 3 m) after t_from; and the ids seen per target over the whole run."""
    names = list(KINDS)
    res = {n: {"e2": [], "nees": [], "ev": [], "ew": [], "ids": set()} for n in names}
    for k, tracks in enumerate(out):
        t = k * DT
        for e in tracks:
            d = np.hypot(*(X[k, :, :2] - e.position_m).T)
            j = int(d.argmin())
            if d[j] > 3.0:
                continue
            r = res[names[j]]
            r["ids"].add(e.track_id)
            if t >= t_from:
                err = e.position_m - X[k, j, :2]
                r["e2"].append(err @ err)
                r["nees"].append(err @ np.linalg.solve(e.position_covariance, err))
                r["ev"].append(e.speed_m_s - X[k, j, 3])
                r["ew"].append(e.turn_rate_rad_s - KINDS[names[j]][3](t - DT))
    return res


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_full_chain_cv_ct_manoeuvring_and_static_targets(seed):
    """Four 2.5 m targets seen by a 720-beam sensor (5 cm noise, 2 % dropout, 0.5 clutter/scan) from
    60–110 m, 100 s at 5 Hz: one confirmed track each, kept throughout; after 40 s (manoeuvring:
    30 s after its switch at 50 s) position RMSE < 0.35 m, speed RMSE < 0.1 m/s, ω RMSE < 0.008
    rad/s (models 0.02 apart; thesis §6.1 reached 0.0312 for 0.03); the static one is flagged
    static; NEES of the position (2 dof) on average in [0.3, 4] (the detections' radial bias of
    ≲ 0.1 m is not in their variance; the static target's is lower, ≈ 0.08: the speed random walk
    of the models keeps its covariance wide). The static target hides the CV target at 90–100 s
    (partly, then fully): the occlusion flag keeps that track consistent."""
    n_steps = int(100 / DT) + 1
    X = kind_truth(n_steps)
    bench = Bench(4, seed=seed)
    out = bench.run(X)
    res = score(X, out, 40.0)
    last = {e.track_id: e for e in out[-1]}
    assert len(last) == 4
    for name, r in res.items():
        assert len(r["ids"]) == 1, (name, r["ids"])
        e2, nees, ev, ew = (np.asarray(r[k]) for k in ("e2", "nees", "ev", "ew"))
        if name == "manoeuvring":
            keep = np.arange(e2.size) >= (80.0 - 40.0) / DT - 1
            e2, nees, ev, ew = e2[keep], nees[keep], ev[keep], ew[keep]
        assert e2.size > 0.95 * (100 - 40) / DT * (0.3 if name == "manoeuvring" else 1.0)
        assert math.sqrt(e2.mean()) < 0.35, name
        assert math.sqrt(np.mean(ev**2)) < 0.1, name
        assert math.sqrt(np.mean(ew**2)) < 0.008, name
        assert (0.04 if name == "static" else 0.3) < nees.mean() < 4.0, (name, nees.mean())
        assert last[next(iter(r["ids"]))].is_static == (name == "static")
    s = bench.p.summary()
    assert s["tracks_confirmed"] == 4 and s["tracks_lost"] == 0 and s["confirmed_tracks_now"] == 4
    assert s["scans"] == n_steps


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_crossing_targets_keep_identities_through_merged_returns(seed):
    """Two targets cross 50 m ahead at right angles, 5 s apart (closest approach 5.3 m: their
    returns merge into one cluster for a while): each keeps its track id."""
    n_steps = int(70 / DT) + 1
    s = 7.5 / math.sqrt(2)
    a = truth(n_steps, DT, [[50.0 - 40.0, -40.0]], [math.pi / 4], [1.5], lambda t: 0.0)
    b = truth(n_steps, DT, [[50.0 + 40.0 + s, -40.0 - s]], [3 * math.pi / 4], [1.5], lambda t: 0.0)
    X = np.concatenate([a, b], axis=1)
    bench = Bench(2, seed=seed)
    out = bench.run(X)
    seen = [set(), set()]
    for k, tracks in enumerate(out):
        for e in tracks:
            d = np.hypot(*(X[k, :, :2] - e.position_m).T)
            if d.min() < 2.0:
                seen[int(d.argmin())].add(e.track_id)
    assert [len(x) for x in seen] == [1, 1] and seen[0] != seen[1]
    assert len(out[-1]) == 2


def test_occluded_target_is_coasted_and_recovered():
    """A target passes behind a 4 m buoy 30 m ahead (hidden ~5 s, coasted), then is taken back by
    the same track; heavy dropout (20 %) and clutter (5 per scan) degrade but do not break it."""
    n_steps = int(90 / DT) + 1
    X = truth(n_steps, DT, [[60.0, -55.0]], [math.pi / 2], [1.5], lambda t: 0.0)
    sensor = SensorConfig(dropout_probability=0.2, clutter_per_scan=5.0)
    bench = Bench(1, statics=[CircleObstacle("buoy", (30.0, 0.0), 4.0)], sensor=sensor, seed=4)
    hidden_steps = 0
    ids = set()
    for k in range(n_steps):
        bench.step(k * DT, X[k, :, :2])
        det = bench.p.detections
        seen = len(det) and np.hypot(*(det.centres_m - X[k, 0, :2]).T).min() < 1.5
        hidden_steps += not seen
        for e in bench.p.tracks():
            if np.hypot(*(e.position_m - X[k, 0, :2])) < 3.0:
                ids.add(e.track_id)
    assert hidden_steps * DT > 3.0  # it really was hidden
    assert len(ids) == 1
    final = [e for e in bench.p.tracks() if np.hypot(*(e.position_m - X[-1, 0, :2])) < 1.0]
    assert len(final) == 1 and abs(final[0].speed_m_s - 1.5) < 0.15
    assert bench.p.summary()["tracks_lost"] == 0


def test_static_structures_become_convex_polygons_not_tracks():
    """An L-shaped quay 25–60 m away is mapped as convex pieces hugging its walls (the basin inside
    the L stays free); it never becomes a confirmed track; a buoy beside it is tracked (static)."""
    quay = PolygonObstacle("quay", np.array([[25.0, -30.0], [60.0, -30.0], [60.0, 30.0], [55.0, 30.0],
                                             [55.0, -25.0], [25.0, -25.0]]))
    bench = Bench(0, statics=[quay, CircleObstacle("buoy", (-30.0, 20.0), 1.5)], seed=2)
    for k in range(int(20 / DT)):
        bench.step(k * DT, np.zeros((0, 2)))
    polys = bench.p.static_polygons()
    assert len(polys) >= 2
    from mjasc.core.geometry import distance_to_polygon, point_in_polygon

    for poly in polys:
        assert np.all(distance_to_polygon(poly, quay.vertices) < 2.0)
    basin = np.array([[40.0, 0.0], [50.0, 10.0]])
    assert not any(point_in_polygon(basin, p).any() for p in polys)
    tracks = bench.p.tracks()
    assert len(tracks) == 1 and tracks[0].is_static
    np.testing.assert_allclose(tracks[0].position_m, [-30.0, 20.0], atol=0.3)


def test_team_mates_are_tracked_and_named_from_broadcasts():
    bench = Bench(0, vessels=(("own", (0.0, 0.0, 0.0)), ("mate", (40.0, 10.0, 1.0))))
    for k in range(30):
        if k == 20:
            bench.p.set_team_positions({"mate": (k * DT - 1.0, np.array([40.2, 9.9]))})
        bench.step(k * DT, np.zeros((0, 2)))
    (track,) = bench.p.tracks()
    assert track.team_member == "mate"
    assert np.hypot(*(track.position_m - [40.0, 10.0])) < 0.6  # an Otter hull is 2 × 1.08 m


def test_sensor_rate_and_events_and_summary():
    """Slots at 10 Hz, sensor at 2 Hz: a scan every 0.5 s; a buoy's track is confirmed at its 4th
    scan (M = 4 of N = 6) and reported once through drain_events (births stay in the recording)."""
    bench = Bench(0, sensor=SensorConfig(rate_hz=2.0, clutter_per_scan=0.0), statics=[CircleObstacle("b", (20.0, 0.0), 1.0)])
    for k in range(15):
        bench.step(k * 0.1, np.zeros((0, 2)))
    assert bench.p.summary()["scans"] == 3 and bench.p.drain_events() == []
    for k in range(15, 40):
        bench.step(k * 0.1, np.zeros((0, 2)))
    s = bench.p.summary()
    assert s["scans"] == 8 and s["tracks_born"] == 1 and s["confirmed_tracks_now"] == 1
    ev = bench.p.drain_events()
    assert len(ev) == 1 and "confirmed" in ev[0][1] and ev[0][0] == pytest.approx(1.5)
    assert bench.p.drain_events() == []
    assert set(s) >= {"mean_detections_per_scan", "tracks_lost", "static_polygons", "mean_tracking_us"}


def test_a_sensor_rate_that_does_not_divide_the_slots_keeps_its_mean():
    """Slots at 5 Hz, sensor at 2 Hz: scans are due every 0.5 s and taken at the first slot at or after
    each due time (0, 0.6, 1.0, 1.6, 2.0, …): 2 scans a second on average. (Each scan used to be due 1/rate
    after the slot that took it: 0, 0.6, 1.2, 1.8 — 1.67 Hz.)"""
    bench = Bench(0, sensor=SensorConfig(rate_hz=2.0, clutter_per_scan=0.0))
    taken = []
    for k in range(101):
        before = bench.p.summary()["scans"]
        bench.step(k * 0.2, np.zeros((0, 2)))
        if bench.p.summary()["scans"] > before:
            taken.append(round(k * 0.2, 6))
    assert taken[:6] == [0.0, 0.6, 1.0, 1.6, 2.0, 2.6] and len(taken) == 41


def test_covariance_ellipse_is_rotated_correctly():
    rot = np.array([[math.cos(0.5), -math.sin(0.5)], [math.sin(0.5), math.cos(0.5)]])
    P = rot @ np.diag([4.0, 0.25]) @ rot.T
    c = np.array([3.0, -1.0])
    e = covariance_ellipse(c, P, n_sigma=2.0)
    d = e - c
    np.testing.assert_allclose(np.einsum("ij,jk,ik->i", d, np.linalg.inv(P), d), 4.0, rtol=1e-9)
    far = d[np.argmax(np.hypot(*d.T))]
    assert abs(math.atan2(far[1], far[0]) % math.pi - 0.5) < 0.1  # major axis at 0.5 rad
    np.testing.assert_allclose(e[0], e[-1])


def test_recording_has_hits_tracks_ellipses_and_events(tmp_path):
    import rerun as rr

    bench = Bench(1, seed=0)
    X = truth(60, DT, [[40.0, 0.0]], [math.pi / 2], [1.5], lambda t: 0.0)
    with Recorder(tmp_path / "r.rrd", "perception", 0) as rec:
        for k in range(60):
            bench.step(k * DT, X[k, :, :2])
            if k % 2 == 0 or k == 59:
                bench.p.log(rec, k * DT, "own")
    paths = set(rr.chunk.RrdReader(str(tmp_path / "r.rrd")).store().schema().entity_paths())
    for p in ["/world/vessels/own/sensor/hits", "/sensor/own/hits_body", "/world/vessels/own/sensor/detections",
              "/sensor/own/detections_body", "/world/vessels/own/tracks/ellipses",
              "/world/vessels/own/tracks/velocity", "/tracking_events/own"]:
        assert p in paths, p
    assert any(p.startswith("/plots/tracking/own/omega/") for p in paths)
    assert any(p.startswith("/plots/tracking/own/modes/") for p in paths)


def test_thesis_6_1_scenario_converges():
    """tasks/thesis_6_1_tracking.toml through the runner (seed 1): the ASC's own sensor tracks the
    1.5 m/s, 0.03 rad/s target from ~107 m; at 110 s V̂ and ω̂ are within 0.05 m/s and 0.004 rad/s
    (thesis: 1.5723, 0.0312)."""
    from pathlib import Path

    from mjasc.runs.runner import Runner
    from mjasc.runs.scenario import load_scenario

    sc = load_scenario(Path(__file__).parents[1] / "tasks" / "thesis_6_1_tracking.toml")
    runner = Runner(sc, None, progress=False)
    perception = runner.agents[0].perception
    perception.keep_history = True
    res = runner.run()
    p = res.summary["vessels"]["asc"]["perception"]
    assert p["tracks_confirmed"] == 1 and p["tracks_lost"] == 0
    (track,) = perception.tracks()
    assert abs(track.speed_m_s - 1.5) < 0.05 and abs(track.turn_rate_rad_s - 0.03) < 0.004
    pos, _, _ = runner.sim.traffic.state(track.time_s)
    assert np.hypot(*(track.position_m - pos[0])) < 0.5
    h = perception.history_arrays()
    assert h["t"][0] < 1.5  # tracking from the first scans, ~107 m away


@pytest.mark.parametrize("seed", [0, 1])
def test_boat_crossing_close_in_front_of_a_wall_leaves_no_phantom_and_keeps_its_track(seed):
    """A 2 m boat sails at 0.7 m/s along a quay wall 20 m ahead, its side 0.5 m from the wall (its
    returns join the wall's cluster in most scans). Before the fix its returns were mapped as wall
    (cells where it had been, a trail of phantom polygons) and its track starved and was lost.
    Now: after it has passed, no mapped polygon reaches into the water where it sailed, the wall is
    mapped, and once confirmed its track keeps one id while in view."""
    from mjasc.core.geometry import point_in_polygon

    wall = PolygonObstacle("wall", np.array([[20.0, -80.0], [22.0, -80.0], [22.0, 80.0], [20.0, 80.0]]))
    n_steps = int(50 / DT) + 1
    X = truth(n_steps, DT, [[17.5, -35.0]], [math.pi / 2], [0.7], lambda t: 0.0)  # y: −35 → 0
    bench = Bench(1, statics=[wall], seed=seed, radius=2.0)
    ids = []
    for k in range(n_steps):
        bench.step(k * DT, X[k, :, :2])
        near = [e.track_id for e in bench.p.tracks() if np.hypot(*(e.position_m - X[k, 0, :2])) < 3.0]
        ids.append(near[0] if near else None)
    first = next(k for k, i in enumerate(ids) if i is not None)
    assert first * DT < 15.0
    assert set(ids[first:]) == {ids[first]}
    # the water the boat sailed through (up to 6 m behind where it is now), clear of the wall's cells
    lane = np.stack(np.meshgrid(np.arange(15.0, 18.6, 0.5), np.arange(-33.0, -6.0, 0.5)), -1).reshape(-1, 2)
    polys = bench.p.static_polygons()
    assert not any(point_in_polygon(lane, p).any() for p in polys)
    wall_face = np.column_stack([np.full(20, 20.5), np.linspace(-30.0, 30.0, 20)])
    covered = np.zeros(len(wall_face), dtype=bool)
    for p in polys:
        covered |= point_in_polygon(wall_face, p)
    assert covered.mean() > 0.8


def test_non_finite_detections_are_dropped_and_counted_before_the_tracker(monkeypatch):
    """A NaN centre (a diverged or absurd scene) is taken out at the detection boundary: the tracker
    keeps tracking the sound detections and the summary counts what was dropped."""
    import dataclasses

    from mjasc.perception import fleet as fleet_module

    real = fleet_module.packed_batch  # (the detections of a sensing pass with returns)

    def poisoned(*args, **kwargs):
        batch = real(*args, **kwargs)
        if len(batch.centres_m) == 0:
            return batch
        centres = batch.centres_m.copy()
        centres[0] = np.nan
        return dataclasses.replace(batch, centres_m=centres, extended=np.zeros_like(batch.extended))

    monkeypatch.setattr(fleet_module, "packed_batch", poisoned)
    monkeypatch.setattr(fleet_module.PerceptionFleet, "map_in_pass", False)  # (the map step after the poisoning)
    bench = Bench(0, sensor=SensorConfig(rate_hz=5.0, clutter_per_scan=0.0),
                  statics=[CircleObstacle("a", (20.0, 0.0), 1.0), CircleObstacle("b", (-20.0, 5.0), 1.0)])
    for k in range(40):
        bench.step(k * 0.2, np.zeros((0, 2)))
    s = bench.p.summary()
    assert s["non_finite_detections_dropped"] == s["scans"] == 40
    tracks = bench.p.tracks()
    assert len(tracks) == 1 and np.all(np.isfinite(tracks[0].position_m))
