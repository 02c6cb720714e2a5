"""Tracking methods by name (``[vessels.tracking] method``): the default is the built-in batched IMM bit
for bit; ``filterpy_imm`` (filterpy's IMMEstimator per track) tracks constant-velocity and
constant-turn targets to the bank's accuracy and runs a whole scenario; a plugin tracker gets only
its own sensor's target detections; one-line errors naming the field."""

from __future__ import annotations

import copy
import dataclasses
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mjasc.core.estimates import TrackEstimate
from mjasc.perception.detection import Detections
from mjasc.perception.imm import IMMBank, IMMConfig
from mjasc.perception.tracking import MultiTargetTracker, TrackingConfig, parse_tracking_options
from mjasc.perception.tracking.method import IMMMethod
from mjasc.plugins import StageContext, TrackingMethod, available, register, unregister
from mjasc.plugins.registry import parse_tracking_table
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import ScenarioError, parse_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"
DT = 0.2  # 5 Hz scans
VAR = 0.1  # thesis §6.1: measurement variance 0.1 m²


def _doc(name: str, method: str | None = None, duration_s: float | None = None, **tracking) -> dict:
    doc = tomllib.loads((TASKS / f"{name}.toml").read_text())
    doc.setdefault("outputs", {}).update(video=False, recording=False)
    if duration_s is not None:
        doc["duration_s"] = duration_s
    for v in doc["vessels"]:
        if "tracking" in v or "sensor" in v:
            t = v.setdefault("tracking", {})
            t.update(copy.deepcopy(tracking))
            if method is not None:
                t["method"] = method
    return doc


def _fields(e: TrackEstimate) -> tuple:
    return (e.track_id, e.time_s, *e.position_m.tolist(), e.heading_rad, e.speed_m_s, e.turn_rate_rad_s, e.radius_m,
            *e.position_covariance.ravel().tolist(), e.is_static, e.team_member)


def _strip(summary):
    if isinstance(summary, dict):
        return {k: _strip(v) for k, v in summary.items()
                if k not in {"wall_time_s", "real_time_factor", "timing_s"} and not k.endswith("_us")}
    return summary


# --------------------------------------------------------------------------- the default, bit for bit
def test_default_method_is_the_builtin_tracker_bit_for_bit():
    """The §6.4.1 crossing (3 team vessels, a ship, avoidance, comms) for 60 s: with and without
    ``method = "imm"`` every vessel's tracks at every tracking slot and the summary are identical,
    and the parsed options are the TrackingConfig of before."""
    runs = []
    for method in (None, "imm"):
        sc = parse_scenario(_doc("thesis_6_4_crossing", method, duration_s=60.0))
        choice = sc.vessels[0].options["tracking"]
        assert choice.name == "imm" and choice.options == TrackingConfig() == parse_tracking_options({})
        runner = Runner(sc, None, progress=False)
        seen = []
        runner.observe("tracking", lambda ev, r=runner, s=seen: s.append(
            [[_fields(e) for e in a.perception.tracks()] for a in r.agents]))
        res = runner.run()
        runs.append((seen, _strip(res.summary)))
    assert runs[0][0] == runs[1][0] and len(runs[0][0]) > 200
    assert any(e[-1] is not None for step in runs[0][0] for v in step for e in v)  # team mates were marked
    assert runs[0][1] == runs[1][1]


def test_imm_method_on_its_own_is_the_multi_target_tracker():
    """Built outside a perception, ``imm`` is a MultiTargetTracker behind the plugin interface."""
    rng = np.random.default_rng(3)
    method = IMMMethod(StageContext("own", None), TrackingConfig(confirm_hits=3))
    ref = MultiTargetTracker(TrackingConfig(confirm_hits=3))
    for k in range(60):
        z = np.array([[10.0 + 1.5 * k * DT, 5.0], [-20.0, 40.0 - 1.0 * k * DT]]) + rng.normal(0, 0.3, (2, 2))
        det = _detections(k * DT, z)
        method.update(k * DT, None, det)
        ref.step(k * DT, det, det.origin_m)
    assert [_fields(e) for e in method.tracks()] == [_fields(e) for e in ref.estimates()] and len(method.tracks()) == 2


# --------------------------------------------------------------------------- choosing, errors
def test_methods_are_listed_and_options_validated_from_their_declaration():
    assert {"imm", "filterpy_imm"} <= set(available("tracking"))
    c = parse_tracking_table({"method": "filterpy_imm", "confirm_hits": 3, "imm": {"markov_stay_probability": 0.95}})
    assert c.name == "filterpy_imm" and c.options.confirm_hits == 3 and c.options.imm.markov_stay_probability == 0.95
    assert c.options.gate_threshold == TrackingConfig().gate_threshold


@pytest.mark.parametrize("table, message", [
    ({"method": "nope"}, r"vessels\[0\]\.tracking\.method: unknown tracking method 'nope' \(available: .*filterpy_imm"),
    ({"method": 3}, r"vessels\[0\]\.tracking\.method: "),
    ({"confirm_hits": 9}, r"vessels\[0\]\.tracking\.confirm_hits: must be ≤ confirm_window \(6\), got 9"),
    ({"method": "imm", "max_coast_s": -1}, r"vessels\[0\]\.tracking\.max_coast_s: must be > 0"),
    ({"method": "filterpy_imm", "confirm_hits": 9},
     r"vessels\[0\]\.tracking\.confirm_hits: must be ≤ confirm_window"),
    ({"method": "filterpy_imm", "manoeuvre_threshold": 3},
     r"vessels\[0\]\.tracking\.manoeuvre_threshold: unknown field"),
    ({"method": "filterpy_imm", "imm": {"min_mode_probability": 0.5}},
     r"vessels\[0\]\.tracking\.imm\.min_mode_probability: must be < 1/r"),
])
def test_bad_method_or_option_is_a_one_line_scenario_error_naming_the_field(table, message):
    doc = _doc("thesis_6_1_tracking")
    doc["vessels"][0]["tracking"] = table
    with pytest.raises(ScenarioError, match=message) as err:
        parse_scenario(doc)
    assert "\n" not in str(err.value)


# --------------------------------------------------------------------------- filterpy_imm
def test_filterpy_track_filter_equals_the_bank_at_variable_sample_times():
    """The filter of each filterpy_imm track (FilterpyIMMTracker, dt_s=None): Ts of 0.2–0.6 s,
    per-measurement σ², coasting and the probability floor give the bank's estimates to rounding."""
    from mjasc.perception.imm.filterpy_reference import FilterpyIMMTracker

    cfg = IMMConfig(gate_probability=1.0)
    rng = np.random.default_rng(1)
    t = np.concatenate([[0.0], np.cumsum(rng.choice([0.2, 0.4, 0.6], 299))])
    th = 0.3 + 0.03 * t
    z = 50.0 * np.stack([np.sin(th) - np.sin(0.3), -(np.cos(th) - np.cos(0.3))], -1) + rng.normal(0, 0.3, (300, 2))
    bank, ref = IMMBank(cfg), FilterpyIMMTracker(cfg, dt_s=None)
    worst = 0.0
    for k in range(300):
        var = 0.05 + 0.1 * rng.random()
        if k == 0:
            bank.add_track(z[k], t[k], measurement_variance=var)
            ref.update(z[k], t[k], var)
        elif k % 7 == 3:
            bank.predict(t[k])
            ref.predict(t[k])
        else:
            bank.update(z[k][None], t[k], None, np.array([var]))
            ref.update(z[k], t[k], var)
        if ref.velocity_initialized:
            d = ref.state - bank.states[0]
            d[2] = (d[2] + math.pi) % (2 * math.pi) - math.pi
            worst = max(worst, np.abs(d).max(), np.abs(ref.mode_probabilities - bank.mode_probabilities[0]).max(),
                        np.abs(ref.state_covariance - bank.state_covariances[0]).max())
    assert ref.velocity_initialized and worst < 1e-9, worst


def _detections(t, z, var=VAR, radius=2.5):
    m = z.shape[0]
    return Detections(t, np.zeros(2), 0.0, z, z.copy(), np.full(m, radius), np.full(m, var), np.full(m, 5),
                      np.hypot(*z.T), np.zeros(m, bool), np.zeros(0, int))


@pytest.mark.parametrize("omega", [0.0, 0.03])
def test_filterpy_imm_tracks_cv_and_constant_turn_targets(omega):
    """Six targets at 1.5 m/s (ω = 0: CV; 0.03 rad/s: a model of the bank), 200 m apart, detected
    every 0.2 s with σ² = 0.1 m²; over the last 30 s of 120 s every target has one confirmed track,
    and against the closed-form truth (eq. 3.2) the position error is RMS < 0.15 m (raw σ 0.32 m),
    the speed error RMS < 0.02 m/s and ω̂ within 0.005 rad/s RMS (worst < 0.04) of ω."""
    from mjasc.perception.tracking.filterpy_tracker import FilterpyIMMMethod

    n, steps = 6, 601
    rng = np.random.default_rng(0)
    p0 = np.column_stack([np.arange(n) * 200.0, np.zeros(n)])
    th0 = rng.uniform(-np.pi, np.pi, n)
    method = FilterpyIMMMethod(StageContext("own", None), None)
    err, ids = [], set()
    for k in range(steps):
        t = k * DT
        th = th0 + omega * t
        if omega == 0.0:
            xy = p0 + 1.5 * t * np.column_stack([np.cos(th0), np.sin(th0)])
        else:
            xy = p0 + 1.5 / omega * np.column_stack([np.sin(th) - np.sin(th0), -(np.cos(th) - np.cos(th0))])
        method.update(t, None, _detections(t, xy + math.sqrt(VAR) * rng.standard_normal((n, 2))))
        if t >= 90.0:
            tracks = method.tracks()
            assert len(tracks) == n
            for e in tracks:
                i = int(np.argmin(np.hypot(*(xy - e.position_m).T)))
                ids.add((i, e.track_id))
                err.append((np.hypot(*(xy[i] - e.position_m)), e.speed_m_s - 1.5, e.turn_rate_rad_s - omega))
    e = np.array(err)
    rms = np.sqrt((e**2).mean(axis=0))
    assert len(ids) == n  # one track id per target throughout
    assert rms[0] < 0.15 and rms[1] < 0.02 and rms[2] < 0.005 and np.abs(e[:, 2]).max() < 0.04, (rms, np.abs(e).max(0))
    assert method.summary()["confirmed"] == n and method.summary()["lost"] == 0


def test_scenario_with_filterpy_imm_avoids_and_reports_its_tracks(tmp_path):
    """The §6.4.1 crossing (the ship crosses the formation at ~90–100 s) with every vessel on
    filterpy_imm: the vessels track the ship and each other (team mates marked from the
    broadcasts), the avoidance still avoids (no collision), the summary names the method, and the
    recording (full detail: tracks drawn) is written."""
    doc = _doc("thesis_6_4_crossing", "filterpy_imm", duration_s=130.0)
    doc["outputs"].update(recording=True, recording_detail="full")
    sc = parse_scenario(doc)
    runner = Runner(sc, tmp_path, progress=False)
    team, ship = set(), set()

    def look(ev):
        for a in runner.agents:
            for e in a.perception.tracks():
                (team if e.team_member else ship).add((a.name, e.team_member or e.track_id))

    runner.observe("tracking", look)
    res = runner.run()
    s = res.summary
    assert not s["any_collision"]
    assert {("alpha", "bravo"), ("bravo", "alpha"), ("bravo", "charlie")} <= team
    assert {a for a, _ in ship} >= {"alpha", "bravo"}  # the ship is tracked by the threatened vessels
    for name in ("alpha", "bravo", "charlie"):
        p = s["vessels"][name]["perception"]
        assert p["tracking_method"] == "filterpy_imm" and p["tracks_confirmed"] >= 2
        assert p["tracker"]["filter_cycles"] > 0
    assert (tmp_path / "recording.rrd").stat().st_size > 0


# --------------------------------------------------------------------------- a plugin registered in code
class EchoTracker(TrackingMethod):
    """Every target detection of the latest scan as a confirmed, motionless track (a test method):
    records what it is given."""

    method = "test_echo"
    seen: list = []

    def update(self, t_s, nav, detections):
        EchoTracker.seen.append((self.context, t_s, nav, detections))
        self._tracks = tuple(TrackEstimate(k, t_s, c.copy(), 0.0, 0.0, 0.0, float(r))
                             for k, (c, r) in enumerate(zip(detections.centres_m, detections.radii_m)))

    def tracks(self):
        return getattr(self, "_tracks", ())


@pytest.fixture
def echo():
    EchoTracker.seen = []
    register("tracking", EchoTracker)
    yield EchoTracker
    unregister("tracking", "test_echo")


def test_a_plugin_tracker_gets_its_own_target_detections_and_navigation_only(echo):
    """§6.1 for 12 s with a registered tracker: each tracking slot calls ``update`` once with the
    vessel's own navigation and the scan's target detections (no structure, labels renumbered);
    its context holds the vessel's particulars and sensor, not the world; its tracks are the
    perception's (and the summary says which method)."""
    from mjasc.core.navigation import OwnNavigation

    doc = _doc("thesis_6_1_tracking", duration_s=12.0)
    doc["vessels"][0]["tracking"] = {"method": "test_echo"}  # a method without options: none given
    sc = parse_scenario(doc)
    runner = Runner(sc, None, progress=False)
    res = runner.run()
    seen = echo.seen
    assert len(seen) == 61 and [round(s[1], 6) for s in seen] == [round(DT * k, 6) for k in range(61)]
    ctx, t, nav, det = seen[-1]
    assert ctx.vessel_name == "asc" and ctx.sensor.max_range_m == 150.0 and not hasattr(ctx, "world")
    assert isinstance(nav, OwnNavigation) and isinstance(det, Detections)
    assert not det.extended.any() and det.labels.max() < len(det)
    p = runner.agents[0].perception
    assert [e.track_id for e in p.tracks()] == list(range(len(det)))
    assert res.summary["vessels"]["asc"]["perception"]["tracking_method"] == "test_echo"


@pytest.mark.parametrize("answer, message", [
    (lambda tracks: None, r"tracking method 'test_wrong' of vessel 'asc': tracks\(\) returned NoneType, expected a "
                          r"tuple of TrackEstimate"),
    (lambda tracks: [{"id": 1}], r"tracks\(\)\[0\] is a dict, expected a TrackEstimate"),
    (lambda tracks: [dataclasses.replace(tracks[0], position_m=np.array([1.0, 2.0, 3.0]))] if tracks else
     [TrackEstimate(0, 0.0, np.array([1.0, 2.0, 3.0]), 0.0, 0.0, 0.0, 1.0)],
     r"tracks\(\)\[0\]\.position_m must be a finite \(2,\) world x, y \[m\], got \[1\. 2\. 3\.\]"),
])
def test_a_plugin_tracker_s_wrong_answer_stops_the_run_naming_method_and_vessel(echo, answer, message):
    """tracks() returning None, dicts or a 3-D position failed deep in the perception or the
    recording; now the run's error names the method, the vessel and what is wrong."""
    from mjasc.runs.runner import RunFailed

    class Wrong(EchoTracker):
        """Answers wrongly."""
        method = "test_wrong"

        def tracks(self):
            return answer(getattr(self, "_tracks", ()))

    register("tracking", Wrong)
    try:
        doc = _doc("thesis_6_1_tracking", duration_s=2.0)
        doc["vessels"][0]["tracking"] = {"method": "test_wrong"}
        with pytest.raises(RunFailed, match=message):
            Runner(parse_scenario(doc), None, progress=False).run()
    finally:
        unregister("tracking", "test_wrong")
