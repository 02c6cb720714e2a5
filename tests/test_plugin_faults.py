"""A plugin's wrong answers and its own bugs end the run with one line naming the method, the
vessel and the place — at every stage and hook a plugin author writes (a review found several that
failed deep inside the runner, named no one, or ran on with a negative speed factor)."""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, replace

import pytest

from mjasc.avoidance.request import AvoidanceRequest, PathSwitch
from mjasc.core.config_tables import param
from mjasc.core.estimates import TrackEstimate
from mjasc.plugins import AvoidanceMethod, CoordinationMethod, TrackingMethod, register, unregister
from mjasc.runs.runner import RunFailed, run_scenario
from mjasc.runs.scenario import ScenarioError, parse_scenario

_VESSEL = {"type": "otter", "heading_deg": 0, "sensor": {}}
BASE = {"name": "p", "duration_s": 1.5, "seed": 1, "outputs": {"recording": False},
        "vessels": [{**_VESSEL, "name": "a", "position_m": [0, 0],
                     "controller": {"type": "path_following", "waypoints": [[0, 0], [100, 0]]}},
                    {**_VESSEL, "name": "b", "position_m": [0, 20],
                     "controller": {"type": "path_following", "waypoints": [[0, 20], [100, 20]]}}]}


def _doc(stage_key: str, table: dict, vessels=(0,)) -> dict:
    d = copy.deepcopy(BASE)
    for i in vessels:
        d["vessels"][i][stage_key] = dict(table)
    return d


@pytest.fixture
def registered():
    """Register test methods; unregistered after the test."""
    done = []

    def add(stage, cls):
        register(stage, cls)
        done.append((stage, cls.method))
        return cls

    yield add
    for stage, name in done:
        unregister(stage, name)


def _run_fails(doc, pattern):
    with pytest.raises(RunFailed, match=pattern) as caught:
        run_scenario(parse_scenario(doc))
    assert "\n" not in str(caught.value)


class _Keeps(AvoidanceMethod):
    method = "test_keeps"

    def control(self, t, nav, guidance, report, team=None):
        return AvoidanceRequest()


@pytest.mark.parametrize("answer, pattern", [
    ("str", r"avoidance method 'test_predicts' of vessel 'a': predict\(\) returned str, expected an AvoidanceRequest"),
    (None, r"of vessel 'a': predict\(\) returned NoneType"),
])
def test_a_wrong_prediction_answer_names_the_method_and_vessel(registered, answer, pattern):
    """predict()'s answer went unchecked: a str failed in the agent ('str' object has no attribute
    'path_switch'), naming nothing."""

    class Predicts(_Keeps):
        method = "test_predicts"

        def predict(self, t, nav, guidance, report, team=None):
            return answer

    registered("avoidance", Predicts)
    _run_fails(_doc("avoidance", {"method": "test_predicts"}), pattern)
    # with two vessels on the method: predict_many's answers are checked too, naming the vessel
    _run_fails(_doc("avoidance", {"method": "test_predicts"}, vessels=(0, 1)), pattern)


def test_an_exception_inside_a_plugin_names_it_and_its_line(registered):
    class Raises(_Keeps):
        method = "test_raises"

        def control(self, t, nav, guidance, report, team=None):
            if t > 0.5:
                return 1 / 0
            return AvoidanceRequest()

    registered("avoidance", Raises)
    _run_fails(_doc("avoidance", {"method": "test_raises"}, vessels=(1,)),
               r"^ZeroDivisionError at t = 0\.[56]00 s: division by zero \(avoidance method 'test_raises' of "
               r"vessel 'b': test_plugin_faults\.py:\d+\)")


def test_a_call_with_the_wrong_signature_names_the_method(registered):
    """The TypeError of a call the method cannot take was placed in mjasc's own file, naming no one."""

    class WrongSignature(_Keeps):
        method = "test_wrong_signature"

        def control(self, t, nav):  # noqa: D102 - the author forgot the other arguments
            return AvoidanceRequest()

    registered("avoidance", WrongSignature)
    _run_fails(_doc("avoidance", {"method": "test_wrong_signature"}),
               r"WrongSignature\.control\(\) takes 3 positional arguments but 6 were given \(avoidance method "
               r"'test_wrong_signature' of vessel 'a': its signature does not take mjasc's call at \w+\.py:\d+; "
               r"docs/plugins\.md lists each method's arguments\)")


@pytest.mark.parametrize("events, pattern", [
    (["STOP"], r"avoidance method 'test_events' of vessel 'a': drain_events\(\)\[0\] is 'STOP', expected a "
               r"\(t \[s\], text\) pair"),
    (None, r"drain_events\(\) returned NoneType, expected a list of \(t \[s\], text\) \(\[\] for none\)"),
])
def test_wrong_events_name_the_method(registered, events, pattern):
    class Events(_Keeps):
        method = "test_events"

        def drain_events(self):
            return events

    registered("avoidance", Events)
    _run_fails(_doc("avoidance", {"method": "test_events"}), pattern)


class _Half(CoordinationMethod):
    method = "test_factor"
    factor = 0.5
    picture = None

    def exchange(self, t_s, nav, gamma_m, guidance=None, plan=None):
        pass

    def speed_correction(self, t_s, nav, gamma_m):
        return self.factor

    def team_picture(self, t_s):
        return self.picture


@pytest.mark.parametrize("factor", [None, "0.5", -3.0, math.nan, math.inf, True])
def test_a_coordination_factor_must_be_finite_and_not_negative(registered, factor):
    """A factor of −3 or NaN sailed on silently (the boats made 23.9 m in 20 s instead of 10 m);
    None and a str failed deep in the agent."""
    registered("coordination", type("BadFactor", (_Half,), {"factor": factor, "__doc__": "bad factor"}))
    _run_fails(_doc("comms", {"method": "test_factor"}, vessels=(0, 1)),
               r"coordination method 'test_factor' of vessel 'a': speed_correction\(\) returned .*, expected a finite "
               r"factor ≥ 0")


def test_a_coordination_team_picture_must_be_a_team_picture(registered):
    registered("coordination", type("BadPicture", (_Half,), {"picture": {"b": None}, "__doc__": "bad picture"}))
    doc = _doc("comms", {"method": "test_factor"}, vessels=(0, 1))
    doc["vessels"][0]["avoidance"] = {}
    _run_fails(doc, r"coordination method 'test_factor' of vessel 'a': team_picture\(\) returned dict, expected a "
                    r"TeamPicture")


def test_a_good_factor_still_runs(registered):
    registered("coordination", _Half)
    summary = run_scenario(parse_scenario(_doc("comms", {"method": "test_factor"}, vessels=(0, 1)))).summary
    assert summary["status"] == "completed"


class _OneTrack(TrackingMethod):
    method = "test_one_track"
    change: dict = {}

    def update(self, t_s, nav, detections):
        self.t = t_s

    def tracks(self):
        track = TrackEstimate(7, self.t, [50.0, 0.0], 0.0, 0.0, 0.0, 1.0)
        return (replace(track, **self.change),)


def test_a_track_id_handed_on_twice_is_refused(registered):
    class Twice(_OneTrack):
        def tracks(self):
            return super().tracks() * 2

    registered("tracking", Twice)
    _run_fails(_doc("tracking", {"method": "test_one_track"}),
               r"tracking method 'test_one_track' of vessel 'a': tracks\(\) holds track id 7 twice")


@pytest.mark.parametrize("change, pattern", [
    ({"speed_m_s": -2.0}, r"tracks\(\)\[0\]\.speed_m_s \(track 7\) must be a finite number ≥ 0, got -2\.0"),
    ({"radius_m": math.nan}, r"tracks\(\)\[0\]\.radius_m \(track 7\) must be a finite number ≥ 0, got nan"),
    ({"heading_rad": math.inf}, r"tracks\(\)\[0\]\.heading_rad \(track 7\) must be a finite number, got inf"),
    ({"position_covariance": [[1.0, 0.0]]}, r"tracks\(\)\[0\]\.position_covariance \(track 7\) must be a finite "
                                            r"\(2, 2\)"),
    # accepted until a review: a stale stamp blinded the avoidance (no decision, a contact), an asymmetric or
    # negative covariance changed the velocity obstacles' answers
    ({"time_s": -1e9}, r"tracks\(\)\[0\]\.time_s \(track 7\) must be in \[0, 0\] s \(the run's start to the scan's "
                       r"time: when the estimate was made\), got -1000000000\.0"),
    ({"position_covariance": [[1.0, 0.5], [0.0, 1.0]]},
     r"tracks\(\)\[0\]\.position_covariance \(track 7\) must be symmetric and positive semi-definite"),
    ({"position_covariance": [[-4.0, 0.0], [0.0, -4.0]]},
     r"tracks\(\)\[0\]\.position_covariance \(track 7\) must be symmetric and positive semi-definite"),
])
def test_a_track_s_numbers_are_checked_where_the_tracker_hands_them_on(registered, change, pattern):
    """A NaN radius was taken and failed later in the thesis avoidance's prediction, naming the wrong
    index and no tracker."""
    registered("tracking", type("BadTrack", (_OneTrack,), {"change": change, "__doc__": "bad track"}))
    _run_fails(_doc("tracking", {"method": "test_one_track"}),
               r"tracking method 'test_one_track' of vessel 'a': " + pattern)


def test_a_summary_that_is_not_a_dict_is_written_as_an_error_and_the_built_in_follower_is_named(registered):
    class Listed(_Keeps):
        method = "test_listed"

        def summary(self):
            return ["not", "a", "dict"]

    registered("avoidance", Listed)
    vessel = run_scenario(parse_scenario(_doc("avoidance", {"method": "test_listed"}))).summary["vessels"]["a"]
    assert vessel["avoidance"] == {"method": "test_listed", "summary_error": "summary() returned list, expected a dict"}
    assert vessel["control"] == {"method": "path_following"}


@pytest.mark.parametrize("summary, written", [
    # no "method": it is added first (docs/plugins.md: summary.json's avoidance.method names the method that ran)
    ({"brakes": 3}, {"method": "test_summed", "brakes": 3}),
    ({"method": "mine", "brakes": 3}, {"method": "mine", "brakes": 3}),
    # what summary.json cannot hold as it is: NaN / inf (strict JSON readers refuse them), an object's text (its
    # memory address differs between two runs of one seed) — a review found both written
    ({"cpa": {"min_m": math.inf}}, {"method": "test_summed", "summary_error": "summary() holds inf at ['cpa']['min_m']"}),
    ({"e": [1.0, math.nan]}, {"method": "test_summed", "summary_error": "summary() holds nan at ['e'][1]"}),
    ({"o": object()}, {"method": "test_summed", "summary_error": "summary() holds a object at ['o'] (only numbers, "
                                                                "strings, bools, None, lists and dicts go into "
                                                                "summary.json)"}),
    ({1: 2}, {"method": "test_summed", "summary_error": "summary() has the key 1 (not a string) at the top"}),
])
def test_a_summary_is_written_as_plain_json_with_its_method(registered, summary, written):
    class Summed(_Keeps):
        method = "test_summed"

        def summary(self):
            return summary

    registered("avoidance", Summed)
    vessel = run_scenario(parse_scenario(_doc("avoidance", {"method": "test_summed"}))).summary["vessels"]["a"]
    assert vessel["avoidance"] == written


class _NotADataclass:
    limit_m = 1.0


class _PlainOptions(_Keeps):
    method = "test_plain_options"
    Options = _NotADataclass


@dataclass(frozen=True)
class _Range:
    lo: float = param(0.0, unit="m", doc="low end")
    hi: float = param(1.0, unit="m", doc="high end")


class _Asserts(_Keeps):
    method = "test_asserts"
    Options = _Range

    @staticmethod
    def check_options(options, where):
        assert options.lo < options.hi, "lo must be < hi"


def test_options_that_cannot_be_checked_are_one_line_errors_naming_the_field(registered):
    """An Options that is not a dataclass, or a check_options raising AssertionError, was
    'mjasc: internal error'."""
    registered("avoidance", _PlainOptions)
    registered("avoidance", _Asserts)
    with pytest.raises(ScenarioError, match=r"vessels\[0\]\.avoidance\.method: the avoidance method "
                                            r"'test_plain_options' .*: its Options must be a dataclass class or None"):
        parse_scenario(_doc("avoidance", {"method": "test_plain_options"}))
    with pytest.raises(ScenarioError, match=r"vessels\[0\]\.avoidance: the avoidance method 'test_asserts' .*: its "
                                            r"options could not be checked: AssertionError: lo must be < hi"):
        parse_scenario(_doc("avoidance", {"method": "test_asserts", "lo": 2.0}))
    assert parse_scenario(_doc("avoidance", {"method": "test_asserts", "lo": 0.5})).vessels[0].options


def test_register_refuses_an_installed_package_s_method_name(monkeypatch):
    """register() silently shadowed an installed entry point of the same name."""
    from importlib import metadata

    from mjasc.plugins import registry

    group = registry.entry_point_group("avoidance")
    eps = metadata.EntryPoints([metadata.EntryPoint("test_installed", "pkg_a.brake:Brake", group)])
    monkeypatch.setattr(registry.metadata, "entry_points", lambda group=None: eps.select(group=group))

    class Impostor(_Keeps):
        method = "test_installed"

    with pytest.raises(ValueError, match=r"register\('test_installed'\): an installed package declares the avoidance "
                                         r"method 'test_installed' \(pkg_a\.brake:Brake\); give yours another name or "
                                         r"pass replace=True"):
        register("avoidance", Impostor)
    try:
        register("avoidance", Impostor, replace=True)
        assert registry.method_class("avoidance", "test_installed") is Impostor
    finally:
        unregister("avoidance", "test_installed")


def test_an_error_in_mjasc_while_a_plugin_is_only_held_blames_no_plugin():
    """A reviewer's probe: with a working coordination plugin, an error raised in the agent's own
    code (which holds the plugin in a local) was reported as the plugin's."""
    from mjasc.plugins.answers import plugin_at_fault

    class Held(_Half):
        method = "test_held"

    plugin = Held.__new__(Held)

    def mjasc_code():
        raise KeyError("x")

    def caller():
        c = plugin  # noqa: F841 - held, as the agent holds its coordination method
        mjasc_code()

    try:
        caller()
    except KeyError as exc:
        assert plugin_at_fault(exc, [plugin]) is None

    def calls_it_wrongly():
        c = plugin
        c.exchange()  # (the call itself fails: the frame that holds the plugin is the failing one)

    try:
        calls_it_wrongly()
    except TypeError as exc:
        assert plugin_at_fault(exc, [plugin]) is not None


def test_events_as_lists_are_taken_as_pairs(registered):
    """``drain_events`` answers of ``[t, text]`` lists worked before the check: still accepted."""
    class ListEvents(_Keeps):
        method = "test_list_events"
        sent = False

        def drain_events(self):
            if self.sent:
                return []
            self.sent = True
            return [[0.5, "hello"]]

    registered("avoidance", ListEvents)
    s = run_scenario(parse_scenario(_doc("avoidance", {"method": "test_list_events"}))).summary
    assert s["status"] == "completed"


def test_a_plugin_cannot_write_into_its_navigation(registered):
    """A stage's navigation is rows of the true states the record slot reads after the stages: a plugin
    that moved its own position (``nav.position_m += …``, meant on a copy) shifted the recorded truth —
    5 m of mission offset and a contact the summary did not count (a review). The arrays are read-only:
    the write fails the run, naming the method and the vessel."""

    class Moves(_Keeps):
        method = "test_moves"

        def control(self, t, nav, guidance, report, team=None):
            p = nav.position_m
            p += (0.0, 5.0)
            return AvoidanceRequest()

    registered("avoidance", Moves)
    _run_fails(_doc("avoidance", {"method": "test_moves"}), r"read-only \(avoidance method 'test_moves' of vessel 'a'")


@pytest.mark.parametrize("request_kw, pattern", [
    # 1e6 m/s sailed at top speed without a word (a review): a unit mistake (knots, km/h) is the likely cause
    (lambda g: {"speed_override_m_s": 1e6}, r"control\(\)'s speed_override_m_s 1e\+06 m/s is more than 1\.5 × the "
                                            r"hull's top speed \(3\.\d+ m/s\)"),
    (lambda g: {"path_switch": PathSwitch(g.path, math.nan, "detour")},
     r"control\(\)'s path_switch\.gamma_m must be a finite γ in \[0, the path's length 100\] m, got nan"),
    (lambda g: {"path_switch": PathSwitch(g.path, -50.0, "detour")},
     r"control\(\)'s path_switch\.gamma_m must be a finite γ"),
    (lambda g: {"path_switch": PathSwitch(g.path, 1.0, "oops")},
     r"control\(\)'s path_switch\.reason must be \"detour\" or \"mission\", got 'oops'"),
])
def test_an_avoidance_request_out_of_its_range_is_refused(registered, request_kw, pattern):
    class Asks(_Keeps):
        method = "test_asks"

        def control(self, t, nav, guidance, report, team=None):
            return AvoidanceRequest(**request_kw(guidance))

    registered("avoidance", Asks)
    _run_fails(_doc("avoidance", {"method": "test_asks"}), r"avoidance method 'test_asks' of vessel 'a': " + pattern)


def test_a_speed_factor_beyond_the_hull_is_refused(registered):
    """A factor of 1000 sailed at top speed without a word (a review)."""
    registered("coordination", type("Fast", (_Half,), {"factor": 1000.0, "__doc__": "fast"}))
    _run_fails(_doc("comms", {"method": "test_factor"}, vessels=(0, 1)),
               r"coordination method 'test_factor' of vessel 'a': speed_correction\(\) returned 1000\.0: 1000 × the "
               r"mission speed [\d.]+ m/s is more than 1\.5 × the hull's top speed")
