"""The plugin registry: methods by name in the scenario, options validated from their declaration,
one-line errors, and a method registered in code running a scenario."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from mjasc.avoidance.request import AvoidanceRequest
from mjasc.core.config_tables import param
from mjasc.plugins import AvoidanceMethod, ControlMethod, CoordinationMethod, available, method_class, register, unregister
from mjasc.runs.scenario import ScenarioError, parse_scenario

BASE = {
    "name": "p", "duration_s": 4.0, "seed": 1,
    "vessels": [{"name": "a", "type": "otter", "position_m": [0, 0], "heading_deg": 0,
                 "controller": {"type": "path_following", "waypoints": [[0, 0], [100, 0]]},
                 "sensor": {}, "avoidance": {}}],
}


def _doc(avoidance: dict) -> dict:
    import copy

    d = copy.deepcopy(BASE)
    d["vessels"][0]["avoidance"] = avoidance
    return d


@dataclass(frozen=True)
class StopOptions:
    stop_below_m: float = param(20.0, positive=True, unit="m", doc="stop when a track is closer than this")


class StopNearTracks(AvoidanceMethod):
    """Stops the vessel while any track is within ``stop_below_m``: a test method."""

    method = "test_stop"
    Options = StopOptions

    def control(self, t, nav, guidance, report, team=None):
        import numpy as np

        near = any(np.hypot(*(tr.position_m - nav.position_m)) < self.options.stop_below_m for tr in report.tracks)
        return AvoidanceRequest("avoidance:yield", 0.0) if near else AvoidanceRequest()


@pytest.fixture
def stop_method():
    register("avoidance", StopNearTracks)
    yield StopNearTracks
    unregister("avoidance", "test_stop")


def test_default_method_is_the_thesis_and_listed():
    choice = parse_scenario(_doc({"gain_k": 1.0})).vessels[0].options["avoidance"]
    assert choice.name == "thesis" and choice.options.gain_k == 1.0
    assert "thesis" in available("avoidance")
    assert method_class("avoidance", "thesis").__name__ == "CollisionAvoidance"


def test_unknown_method_is_one_line_error_naming_the_field():
    with pytest.raises(ScenarioError, match=r"vessels\[0\]\.avoidance\.method: unknown avoidance method 'nope' "
                                            r"\(available: .*thesis"):
        parse_scenario(_doc({"method": "nope"}))


def test_method_options_are_validated_from_their_declaration(stop_method):
    choice = parse_scenario(_doc({"method": "test_stop", "stop_below_m": 5})).vessels[0].options["avoidance"]
    assert choice.options == StopOptions(5.0)
    with pytest.raises(ScenarioError, match=r"vessels\[0\]\.avoidance\.stop_below_m: must be > 0"):
        parse_scenario(_doc({"method": "test_stop", "stop_below_m": -1}))
    with pytest.raises(ScenarioError, match=r"vessels\[0\]\.avoidance\.gain_k: unknown field"):
        parse_scenario(_doc({"method": "test_stop", "gain_k": 1}))


def test_register_rejects_a_class_of_the_wrong_stage():
    with pytest.raises(ValueError, match="is not an AvoidanceMethod"):
        register("avoidance", dict, "bad")
    with pytest.raises(ValueError, match="unknown stage"):
        available("sailing")


def test_the_interface_cannot_be_built_without_its_control_method():
    class Half(AvoidanceMethod):
        method = "half"

    with pytest.raises(TypeError, match="abstract"):
        Half(None, None)


def test_a_registered_method_runs_a_scenario_and_stops_for_traffic(stop_method, tmp_path):
    """A head-on boat 60 m ahead: the test method stops the vessel once its track is within 20 m
    (it sails less far than with a threshold it never reaches); the summary names the method."""
    from mjasc.runs.runner import run_scenario

    def scenario(avoidance):
        d = _doc(avoidance)
        d["duration_s"] = 30.0
        d["outputs"] = {"recording": False}
        d["moving_obstacles"] = [{"name": "boat", "radius_m": 1.0, "position_m": [60, 0], "heading_deg": 180,
                                  "speed_m_s": 0.5}]
        return parse_scenario(d)

    stop = run_scenario(scenario({"method": "test_stop"}), tmp_path / "stop").summary
    never = run_scenario(scenario({"method": "test_stop", "stop_below_m": 0.01}), tmp_path / "never").summary
    assert stop["vessels"]["a"]["avoidance"]["method"] == "test_stop"
    assert stop["vessels"]["a"]["distance_m"] < 0.8 * never["vessels"]["a"]["distance_m"]
    assert not stop["any_collision"]


class HalfSpeed(CoordinationMethod):
    """Halves the mission speed and broadcasts nothing: a test coordination method."""

    method = "test_half"

    def exchange(self, t_s, nav, gamma_m, guidance=None, plan=None):
        self.sent = getattr(self, "sent", 0) + 1

    def speed_correction(self, t_s, nav, gamma_m):
        self.last_factor = 0.5
        return 0.5

    def team_picture(self, t_s):
        return None


def test_a_registered_coordination_method_sets_the_speed(tmp_path):
    """A coordination method halving the mission speed: the vessel sails about half as far as with
    factor 1 (the thesis law alone in its team gives 1)."""
    from mjasc.runs.runner import run_scenario

    register("coordination", HalfSpeed)
    try:
        def run(comms, name):
            d = _doc({})
            del d["vessels"][0]["avoidance"]
            d["duration_s"] = 40.0
            d["outputs"] = {"recording": False}
            d["vessels"][0]["comms"] = comms
            return run_scenario(parse_scenario(d), tmp_path / name).summary["vessels"]["a"]

        half, full = run({"method": "test_half"}, "half"), run({}, "full")
    finally:
        unregister("coordination", "test_half")
    assert half["coordination"]["method"] == "test_half" and full["coordination"]["method"] == "thesis"
    assert 0.4 < half["distance_m"] / full["distance_m"] < 0.65


def test_example_package_adds_a_method_through_its_entry_point(tmp_path):
    """examples/cpa_brake installed as a package (its own pyproject.toml): mjasc finds its method
    through the entry point in a fresh interpreter, validates its options and runs a head-on
    scenario with it, braking for the boat."""
    import json
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    target = tmp_path / "site"
    src = tmp_path / "cpa_brake"  # a copy: the build writes into the source folder
    shutil.copytree(root / "examples" / "cpa_brake", src)
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target), str(src)],
                   check=True, capture_output=True, cwd=tmp_path, timeout=600)
    scenario = tmp_path / "headon.toml"
    scenario.write_text('''name = "headon"
duration_s = 40.0
seed = 3
[outputs]
recording = false
[[vessels]]
name = "a"
type = "otter"
position_m = [0, 0]
heading_deg = 0
controller = { type = "path_following", waypoints = [[0, 0], [150, 0]] }
sensor = {}
avoidance = { method = "cpa_brake", safety_distance_m = 6.0 }
[[moving_obstacles]]
name = "boat"
radius_m = 1.0
position_m = [70, 1]
heading_deg = 180
speed_m_s = 0.6
''')
    env = {"PYTHONPATH": f"{target}:{root}", "PATH": "/usr/bin:/bin", "MUJOCO_GL": "osmesa"}
    code = ("import json, mjasc; from mjasc.plugins import available; "
            "print(json.dumps(available('avoidance'))); "
            f"r = mjasc.run_scenario(mjasc.load_scenario({str(scenario)!r}), {str(tmp_path / 'out')!r}); "
            "print(json.dumps(r.summary['vessels']['a']['avoidance']))")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, env=env,
                         cwd=tmp_path).stdout.splitlines()
    assert "cpa_brake" in json.loads(out[0])
    summary = json.loads(out[1])
    assert summary["method"] == "cpa_brake" and summary["brakes"] >= 1
    # without the package the same file is a one-line error naming the field
    bad = subprocess.run([sys.executable, "-m", "mjasc", "run", str(scenario)], capture_output=True, text=True,
                         env={**env, "PYTHONPATH": str(root)}, cwd=tmp_path)
    assert bad.returncode != 0
    assert "vessels[0].avoidance.method: unknown avoidance method 'cpa_brake'" in bad.stderr


def test_suite_cas_baseline_takes_any_registered_method(stop_method):
    """The suite's collision-avoidance baseline runs the vessel's pipeline with the method named:
    ``CASPolicy(env, method=...)`` and ``make_policy(env, "cas:NAME")``; an unknown name is an error."""
    from mjasc import suite
    from mjasc.suite.baselines import CASPolicy, make_policy

    env = suite.load("otter", "collision_avoidance", task_kwargs={"random": 1})
    policy = make_policy(env, "cas:test_stop", seed=1)
    time_step = env.reset()
    for _ in range(30):
        time_step = env.step(policy(time_step))
    assert type(policy.agent.avoidance) is StopNearTracks
    assert policy.agent.avoidance.options == StopOptions()
    with pytest.raises(ValueError, match="method: unknown avoidance method 'nope'"):
        CASPolicy(env, method="nope")


class PurePursuit(ControlMethod):
    """Pure pursuit of the path point a lookahead ahead: a test control method (heading P-loop by
    differential thrust, common thrust from the speed reference)."""

    method = "test_pursuit"

    def steer(self, nav, guidance, speed_ref_m_s, course_ref_rad, dt_s):
        import numpy as np

        from mjasc.core.frames import wrap_angle
        from mjasc.guidance.path_following import PathFollowingStatus

        path = self.path
        self.gamma_m = path.project(nav.position_m, gamma_hint=self.gamma_m, search_window_m=20.0)
        target = path.point(min(self.gamma_m + 8.0, path.length))
        los = float(np.arctan2(*(target - nav.position_m)[::-1]))
        err = float(wrap_angle(los - nav.heading_rad))
        common = float(np.clip(speed_ref_m_s / self.context.vessel.top_speed_m_s, 0.0, 1.0))
        diff = float(np.clip(1.5 * err - 2.0 * nav.body_velocity[2], -0.6, 0.6))
        cmd = np.clip([common - diff, common + diff], -1.0, 1.0)  # port, starboard: starboard up turns left
        status = PathFollowingStatus(self.gamma_m, path.cross_track_error(nav.position_m, self.gamma_m),
                                     float(path.tangent_angle(self.gamma_m)), los, speed_ref_m_s,
                                     self.gamma_m >= path.length - 0.5)
        return cmd, status


def test_a_registered_control_method_follows_the_path(tmp_path):
    """A pure-pursuit controller chosen by `[vessels.controller] type`: from 6 m off a straight path
    it converges onto it and progresses along it; its summary cross-track comes from its status."""
    from mjasc.runs.runner import run_scenario

    register("control", PurePursuit)
    try:
        d = _doc({})
        del d["vessels"][0]["avoidance"]
        d["vessels"][0]["position_m"] = [0, 6]
        d["vessels"][0]["controller"] = {"type": "test_pursuit", "waypoints": [[0, 0], [300, 0]]}
        d["duration_s"] = 90.0
        d["outputs"] = {"recording": False}
        sc = parse_scenario(d)
        assert sc.vessels[0].options["control"].name == "test_pursuit"
        result = run_scenario(sc, tmp_path / "pursuit")
    finally:
        unregister("control", "test_pursuit")
    a = result.summary["vessels"]["a"]
    assert a["distance_m"] > 60.0
    assert a["max_cross_track_m"] >= 5.0 and a["mean_cross_track_m"] < 2.5
    assert a["control"] == {"method": "test_pursuit"}  # (a plugin's summary, as every stage's)
    with pytest.raises(ScenarioError, match=r"vessels\[0\]\.controller\.type: unknown control method 'test_pursuit'"):
        parse_scenario(d)


class DocumentedHooks(AvoidanceMethod):
    method = "test_hooks"  # (and no docstring: `mjasc list` shows an empty description)

    def control(self, t, nav, guidance, report, team=None):
        return AvoidanceRequest()

    def log(self, recorder, t_s, vessel_name):  # the signature docs/plugins.md shows (no guidance keyword)
        self.logged = getattr(self, "logged", 0) + 1
        recorder.scalar(f"plots/test_hooks/{vessel_name}", t_s, 1.0)

    def summary(self):
        import numpy as np

        if getattr(self, "fail", False):
            raise KeyError("a bug")
        return {"method": self.method, "logged": np.int64(getattr(self, "logged", 0)), "gain": np.float32(0.5),
                "trace": np.arange(3)}


def test_a_plugin_with_the_documented_hooks_runs_recorded_and_its_summary_is_kept(tmp_path, monkeypatch, capsys):
    """docs/plugins.md's ``log(recorder, t, vessel_name)`` works in a recorded run (the runner
    passed a guidance keyword it does not take); a summary of numpy numbers is written as JSON
    numbers; a summary that raises costs the run nothing but that entry; a class without a
    docstring lists."""
    import json

    from mjasc.cli import main
    from mjasc.runs.runner import run_scenario

    register("avoidance", DocumentedHooks)
    try:
        d = _doc({"method": "test_hooks"})
        res = run_scenario(parse_scenario(d), tmp_path / "a")
        written = json.loads((tmp_path / "a" / "summary.json").read_text())["vessels"]["a"]["avoidance"]
        assert written["logged"] > 0 and written == {"method": "test_hooks", "logged": written["logged"],
                                                     "gain": 0.5, "trace": [0, 1, 2]}
        assert res.summary["vessels"]["a"]["avoidance"]["logged"] == written["logged"]
        monkeypatch.setattr(DocumentedHooks, "fail", True, raising=False)
        run_scenario(parse_scenario(d), tmp_path / "b")
        written = json.loads((tmp_path / "b" / "summary.json").read_text())
        assert written["status"] == "completed"
        assert written["vessels"]["a"]["avoidance"] == {"method": "test_hooks",
                                                        "summary_error": "KeyError: 'a bug'"}
        assert main(["list"]) == 0
        assert "avoidance test_hooks" in capsys.readouterr().out
    finally:
        unregister("avoidance", "test_hooks")


def test_a_method_that_cannot_be_built_is_one_line_before_the_run(tmp_path):
    """An abstract method (its control not written) is rejected when the scenario loads, naming the
    field; a constructor that raises is a ConfigError naming the stage, method and vessel, raised
    when the run is set up (before anything runs)."""
    from mjasc.core.config_tables import ConfigError
    from mjasc.runs.runner import Runner

    class Unfinished(AvoidanceMethod):
        """No control."""
        method = "test_unfinished"

    class Fragile(AvoidanceMethod):
        """Its constructor fails."""
        method = "test_fragile"

        def __init__(self, context, options=None):
            raise ValueError("need a sensor range\nof at least 500 m")

        def control(self, t, nav, guidance, report, team=None):
            return AvoidanceRequest()

    register("avoidance", Unfinished)
    register("avoidance", Fragile)
    try:
        with pytest.raises(ScenarioError, match=r"^vessels\[0\]\.avoidance\.method: the avoidance method "
                                                r"'test_unfinished' \(.*Unfinished\) does not implement control$"):
            parse_scenario(_doc({"method": "test_unfinished"}))
        sc = parse_scenario(_doc({"method": "test_fragile"}))
        with pytest.raises(ConfigError) as info:
            Runner(sc, tmp_path, progress=False)
        assert str(info.value).endswith("for vessel 'a': could not be built: ValueError: need a sensor range of at "
                                        "least 500 m") and "\n" not in str(info.value)
        assert not any(tmp_path.iterdir())
    finally:
        unregister("avoidance", "test_unfinished")
        unregister("avoidance", "test_fragile")


def test_register_refuses_names_that_would_clash_or_cannot_be_written():
    """A method registered under a built-in's name would take over every vessel using the default;
    another class under a taken name would silently replace it; a name must be one a scenario can
    write (and a function is not a method class)."""
    from mjasc.core.config_tables import ConfigError

    class Clash(AvoidanceMethod):
        """A test method."""
        method = "thesis"

        def control(self, t, nav, guidance, report, team=None):
            return AvoidanceRequest()

    with pytest.raises(ConfigError, match=r"'thesis' is a built-in avoidance method"):
        register("avoidance", Clash)
    for bad in (123, "my brake", "../x", ""):
        with pytest.raises(ConfigError, match=r"name"):
            register("avoidance", Clash, name=bad)
    with pytest.raises(ConfigError, match=r"is not an AvoidanceMethod \(an avoidance method must"):
        register("avoidance", lambda: None)
    register("avoidance", Clash, name="test_clash")
    try:
        register("avoidance", Clash, name="test_clash")  # (the same class again: fine)
        other = type("Other", (Clash,), {"__doc__": "Another."})
        with pytest.raises(ConfigError, match=r"another avoidance method .*Clash\) is registered under 'test_clash'"):
            register("avoidance", other, name="test_clash")
        register("avoidance", other, name="test_clash", replace=True)
        assert method_class("avoidance", "test_clash") is other
        from mjasc.runs.runner import run_scenario  # (an alias: the summary names the method the scenario chose)

        summary = run_scenario(parse_scenario({**_doc({"method": "test_clash"}), "duration_s": 1.0})).summary
        assert summary["vessels"]["a"]["avoidance"]["method"] == "test_clash"
    finally:
        unregister("avoidance", "test_clash")


@pytest.mark.parametrize("answer, message", [
    (lambda: None, r"avoidance method 'test_answering' of vessel 'a': control\(\) returned NoneType, expected an "
                   r"AvoidanceRequest"),
    (lambda: ("mission", None), r"of vessel 'a': control\(\) returned tuple"),
    (lambda: AvoidanceRequest("braking"), r"AvoidanceRequest\.mode: must be one of mission, .*got 'braking'"),
    (lambda: AvoidanceRequest("avoidance:yield", float("nan")), r"speed_override_m_s: must be None or a finite"),
    (lambda: AvoidanceRequest("avoidance:steer", 1.0, course_override_rad=float("inf")),
     r"course_override_rad: must be None or a finite angle"),
])
def test_a_plugin_s_wrong_answer_stops_the_run_naming_what_is_wrong(answer, message):
    """A forgotten ``return`` ran as "mission"; NaN overrides and unknown modes were taken as given;
    a tuple failed deep in the control pass: each is now the run's error, naming the method and
    the vessel or the request's field."""
    from mjasc.runs.runner import RunFailed, run_scenario

    class Answering(AvoidanceMethod):
        """Answers what the test says."""
        method = "test_answering"

        def control(self, t, nav, guidance, report, team=None):
            return answer()

    register("avoidance", Answering)
    try:
        with pytest.raises(RunFailed, match=message):
            run_scenario(parse_scenario({**_doc({"method": "test_answering"}), "duration_s": 1.0}))
    finally:
        unregister("avoidance", "test_answering")


def test_every_stage_gets_the_same_context_fields():
    """docs/plugins.md: the context holds the mass matrix, the propeller arm, the team's names and
    the sensor for every stage (avoidance, tracking and coordination had no mass and a zero arm,
    control no team and no sensor)."""
    import numpy as np

    from mjasc.guidance.path_following import PathFollower
    from mjasc.runs.runner import Runner

    seen = {}

    def keep(stage):
        def from_context(cls, context, options):
            seen[stage] = context
            return base[stage].from_context.__func__(cls, context, options)
        return classmethod(from_context)

    base = {"avoidance": StopNearTracks, "control": PathFollower}
    spy_avoidance = type("SpyAvoidance", (StopNearTracks,), {"method": "test_spy_a", "from_context": keep("avoidance")})
    spy_control = type("SpyControl", (PathFollower,), {"method": "test_spy_c", "__doc__": "Spy.",
                                                         "from_context": keep("control")})
    register("avoidance", spy_avoidance)
    register("control", spy_control)
    try:
        d = _doc({"method": "test_spy_a"})
        d["vessels"][0]["controller"]["type"] = "test_spy_c"
        d["vessels"].append({"name": "b", "type": "otter", "position_m": [0, 30], "heading_deg": 0,
                             "controller": {"type": "path_following", "waypoints": [[0, 30], [100, 30]]}})
        d["comms"] = {"topology": "leader_followers", "leader": "a"}
        for v in d["vessels"]:
            v["comms"] = {}
        Runner(parse_scenario(d), None, progress=False)
    finally:
        unregister("avoidance", "test_spy_a")
        unregister("control", "test_spy_c")
    for stage in ("avoidance", "control"):
        c = seen[stage]
        assert c.total_mass is not None and np.shape(c.total_mass) == (3, 3), stage
        assert c.propeller_lateral_m > 0.1 and c.team_names == ("a", "b") and c.sensor is not None, stage


def test_a_coordination_plugin_s_factor_reaches_the_avoidance_guidance():
    """A coordination method returns its factor (it need not set ``last_factor``): the avoidance
    method's guidance state carries the mission speed × that factor, as with the built-in law."""
    from mjasc.runs.runner import run_scenario

    class QuietHalf(CoordinationMethod):
        """Halves the speed without telling anyone but its caller."""
        method = "test_quiet_half"

        def exchange(self, t_s, nav, gamma_m, guidance=None, plan=None):
            pass

        def speed_correction(self, t_s, nav, gamma_m):
            return 0.5

        def team_picture(self, t_s):
            return None

    speeds = []

    class Watch(AvoidanceMethod):
        """Keeps the mission speed its guidance state says."""
        method = "test_watch"

        def control(self, t, nav, guidance, report, team=None):
            speeds.append(guidance.mission_speed_m_s)
            return AvoidanceRequest()

    register("coordination", QuietHalf)
    register("avoidance", Watch)
    try:
        d = _doc({"method": "test_watch"})
        d["duration_s"] = 2.0
        d["vessels"][0]["comms"] = {"method": "test_quiet_half"}
        d["vessels"][0]["controller"]["speed_m_s"] = 1.5
        run_scenario(parse_scenario(d))
    finally:
        unregister("coordination", "test_quiet_half")
        unregister("avoidance", "test_watch")
    assert speeds and all(s == 0.75 for s in speeds)



def test_a_control_plugin_s_events_log_and_summary_are_called(tmp_path):
    """docs/plugins.md: every method may implement drain_events, log and summary; a control
    method's were never called."""
    from mjasc.runs.runner import run_scenario

    calls = {"drain": 0, "log": 0}

    class Hooked(PurePursuit):
        """Pure pursuit that says so."""
        method = "test_hooked"

        def drain_events(self):
            calls["drain"] += 1
            return [(0.0, "hooked started")] if calls["drain"] == 1 else []

        def log(self, recorder, t_s, vessel_name):
            calls["log"] += 1

        def summary(self):
            return {"method": self.method, "drained": calls["drain"]}

    register("control", Hooked)
    try:
        d = _doc({})
        del d["vessels"][0]["avoidance"]
        d["vessels"][0]["controller"] = {"type": "test_hooked", "waypoints": [[0, 0], [300, 0]]}
        d["duration_s"] = 3.0
        summary = run_scenario(parse_scenario(d), tmp_path / "hooked").summary
    finally:
        unregister("control", "test_hooked")
    assert calls["drain"] > 1 and calls["log"] > 1
    assert summary["vessels"]["a"]["control"] == {"method": "test_hooked", "drained": calls["drain"]}


def test_a_method_name_two_installed_packages_declare_is_refused(monkeypatch):
    """Which of two entry points of one name loaded depended on the order of the path: now the
    name is an error naming both."""
    from importlib import metadata

    from mjasc.plugins import registry

    group = registry.entry_point_group("avoidance")
    eps = metadata.EntryPoints([metadata.EntryPoint("twice", "pkg_a.brake:Brake", group),
                                metadata.EntryPoint("twice", "pkg_b.brake:Brake", group)])
    monkeypatch.setattr(registry.metadata, "entry_points", lambda group=None: eps.select(group=group))
    with pytest.raises(ScenarioError, match=r"vessels\[0\]\.avoidance\.method: avoidance method 'twice' is declared "
                                            r"by more than one installed package \(pkg_a\.brake:Brake, "
                                            r"pkg_b\.brake:Brake\)"):
        parse_scenario(_doc({"method": "twice"}))


@pytest.mark.parametrize("answer, message", [
    (lambda cmd, st: cmd, r"control method 'test_bad_steer' of vessel 'a': steer\(\) returned ndarray, expected "
                          r"\(commands \(2,\), PathFollowingStatus\)"),
    (lambda cmd, st: (5.0 * cmd + 5.0, st), r"steer\(\)'s commands must be \(port, starboard\), each in \[-1, 1\]"),
    (lambda cmd, st: (cmd[:1], st), r"steer\(\)'s commands must be \(port, starboard\)"),
    (lambda cmd, st: (cmd, None), r"steer\(\)'s status is a NoneType, expected a PathFollowingStatus"),
])
def test_a_control_plugin_s_wrong_answer_stops_the_run_naming_method_and_vessel(answer, message):
    """Commands of 5.0 were clamped by MuJoCo without a word; a missing status failed in the agent:
    each is now the run's error naming the method and the vessel."""
    from mjasc.runs.runner import RunFailed, run_scenario

    class BadSteer(PurePursuit):
        """Answers wrongly."""
        method = "test_bad_steer"

        def steer(self, nav, guidance, speed_ref_m_s, course_ref_rad, dt_s):
            return answer(*super().steer(nav, guidance, speed_ref_m_s, course_ref_rad, dt_s))

    register("control", BadSteer)
    try:
        d = _doc({})
        del d["vessels"][0]["avoidance"]
        d["vessels"][0]["controller"] = {"type": "test_bad_steer", "waypoints": [[0, 0], [300, 0]]}
        d["duration_s"] = 1.0
        with pytest.raises(RunFailed, match=message):
            run_scenario(parse_scenario(d))
    finally:
        unregister("control", "test_bad_steer")
