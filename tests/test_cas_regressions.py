"""Runs that collided in campaigns before the CAS hardening (tests/cas_regressions/, each file as
`mjasc extract` wrote it): with the hardened CAS none touches a hull, and the mechanism that fixed
it is the one that acted (a lane change where no detour exists, a checked speed choice where the
first choice ran into another target)."""

from pathlib import Path

import numpy as np
import pytest

from mjasc.runs.runner import Runner, run_scenario
from mjasc.runs.scenario import load_scenario
from tests.helpers import avoidance_events

CASES = Path(__file__).resolve().parent / "cas_regressions"

#: file → (vessel, the avoidance action that must have acted or None, hull clearance it must keep [m]).
#: Since the detection accounts for the sensor's lost returns (steadier tracks: see
#: docs/avoidance.md, "Hardening") the first choice in imazu19_seed94 no longer runs into the other
#: target: it stays as a no-contact check; the checked choice and the lane change are still
#: exercised by imazu21_seed100 and overtaken_82 (and tests/test_lane_change.py). demo_run14 is
#: withdrawn (cas_regressions/withdrawn/: its ferry sailed through the pontoon, an impossible run
#: that scenarios and campaign draws now reject; tests/test_plausibility.py keeps it).
EXPECT = {
    "overtaken_82": ("own", "lane_change", 1.0),
    "imazu19_seed94": ("own", None, 0.5),
    "imazu21_seed100": ("own", "checked_choice", 0.5),
    # Found by tasks/campaigns/thesis_stress.toml: perception under 30 % dropout (the detection's
    # lost-returns model and the grazed-wall continuation fixed them; no CAS action to check) and
    # the emergency slow-down that now looks again every second.
    "crossing_stressed_seed5": ("alpha", None, 0.5),
    "bottleneck_stressed_seed5": ("charlie", None, 0.0),
    "head_on_seed4": ("bravo", "emergency", 0.3),
    "dock_stressed_seed2": ("vessel2", "emergency", 0.3),
    # The §6.4.3 bottleneck's team funnel: a give-way team mate stops (all way off) instead of
    # going around with a U-turn (seed 7), and the overtaking team mate keeps out of the way
    # (COLREG rule 13; seed 1). Seed 1 passes hull to hull: the bounding circles of the two
    # catamarans overlap by 0.25 m while their hulls stay apart, hence the negative bound.
    "bottleneck_seed7": ("bravo", "emergency", 2.0),
    # (Since the team clearance check of session 60 seed 1 takes another course — alpha keeps 3.22 m and
    # no longer needs its emergency stop — a no-contact check; the stop is tested in test_avoidance.py.)
    "bottleneck_seed1": ("alpha", None, 1.0),
    # No speed plan cleared every track: the one keeping the most distance is taken (an emergency
    # stop in the ferry's path, demo run 3; a slow-down into a second crossing target, Imazu 16).
    "imazu16_seed150": ("own", "checked_choice", 1.0),
    # demo_run3 stays a no-contact check: since an occluded detection grows a track's radius
    # (docs/perception.md, "Static structures") charlie's track of the ferry has its 4 m radius
    # from the pontoon's end on and no speed plan runs short (charlie–ferry 3.00 m; it was 1.92 m
    # after the checked choice).
    "demo_run3": ("charlie", None, 1.0),
    # A team mate's track not yet matched to its broadcast (30 % packet loss) sent charlie onto a
    # 98 m detour it then sailed for 88 s, into the crossing ship's path: a detour whose causes are
    # gone is withdrawn when the mission path is clear.
    "crossing_stressed_seed12": ("charlie", "withdrawn", 2.0),
    # A re-plan 7 m from the pontoon asked for a 92° turn: the saturated turn kept the hull at
    # 0.55 m/s (a full differential leaves forward thrust) and it advanced into the pontoon. A sharp
    # turn on a detour now takes all way off on the heading first, then turns slowly. The hull
    # circles overlap (the vessel passes the pontoon's corner at a crawl); the hulls stay apart.
    # Since an occluded detection grows a track's radius the re-plan no longer swaps sides and no
    # sharp turn is asked (vessel2–pontoon +2.64 m; it was −0.67 m with the sharp turn): a no-contact
    # check now; a sharp turn still acts in bottleneck_current_reversal_14 (turned away).
    "dock_stressed_seed9": ("vessel2", None, -0.9),
    # The §6.2 dock as shipped, seed 11 (and 15): a 165° turn beside the quay went the long way round,
    # a slow arc through east into the moored vessel3 (−1.45 m), once a re-plan moved by a few
    # centimetres (an occluded detection grows a track's radius). Static tracks' outlines now count
    # in that choice and the short way is taken: no long way to check (turn_away stays 0). The file
    # sets vessel2's slow_down_decel_m_s2 = 0 (the prediction without the pass-end lag, merged the
    # same day): with the lag the re-plan no longer asks for that turn and the case could not fail.
    "dock_seed11": ("vessel2", "sharp_turn", -0.5),
    # §6.4.3 under 30 % dropout + 30 % packet loss: island fragments tracked as 7–8 m targets.
    # Seed 11: one centred inside the mapped face, made a static disc of its bounding radius, closed
    # the gap between the islands and bravo re-planned into the south island: it is static and no
    # larger than the mapped structure around its centre (the map holds the structure). Seed 2: one beside the north island (not inside its mapped slivers)
    # made charlie re-plan from inside the merged safety region; the detour ran into the south
    # island: such a detour is refused and the vessel stops, looking again every second.
    # (Seed 2 reached its refusal again once the allocation stopped a turning hull's push ahead; in
    # between it had taken another course on every machine, pinned or not. Seed 11 no longer reaches
    # its fragment since then: a no-contact check; in_structure is tested in tests/test_avoidance.py.)
    # (Since session 62 the planner refuses that detour itself — the islands' regions would merge with the
    # fragment's over charlie — before the structure check sees it: counted as a failed re-plan.)
    "bottleneck_stressed_seed2": ("charlie", "replan_failed", 1.0),
    "bottleneck_stressed_seed11": ("bravo", None, 1.0),
    # Seed 4: a re-plan beside the north island's corner (around charlie's stale copy, 30 % of the
    # messages lost) asked alpha for a 161° turn, taken the long way round away from the island; the
    # saturated turn advanced the Delfim 5 m onto bravo, stopped beside it (−1.18 m, hull contact):
    # the turn is held while the hull closes on a slow track within its collision distance. The
    # bounding circles still overlap (−0.81 m) while alpha creeps round in place; the hulls stay apart.
    # (Since session 67's round start-up gate — a new track's second detection is taken north–south too — the run
    # takes another course: no sharp turn, 3.40 m clear; a no-contact check. dock_stressed_seed297 holds a turn.)
    "bottleneck_stressed_seed4": ("alpha", None, 1.0),
    # Found on held-out seeds (thesis_stress's families on seeds 21–40, not used to tune the guard):
    # the §6.2 dock as shipped, seed 24 — vessel2's sharp turns beside the moored vessel3 swept it
    # into vessel3 (−1.49 m); the guard held the turn 38 times and the hulls stayed apart (the
    # bounding circles overlapped by 0.47 m). Since the allocation stopped a turning hull's push
    # ahead no sharp turn is held there (1.8 m clear): a no-contact check.
    "dock_seed24": ("vessel2", None, -1.0),
    # Held-out seeds again: the stressed §6.4.3 bottleneck's seeds 31, 33 and 37 touched (−0.99,
    # −0.81, −0.48 m) with hulls told to stop or to turn slowly while their turn saturated the
    # propellers: the full differential pushed them ahead at 0.5–0.7 m/s. The differential now stays
    # within the reverse thrust while a hull is faster than its reference (guidance/following_law.py;
    # tests/test_path_following.py), and a held sharp turn goes on in place. 31 and 37 keep their
    # other causes (the own vessel predicted on its path; a three-vessel tangle): their bounding
    # circles still overlap, the hulls stay apart.
    "bottleneck_stressed_seed31": ("alpha", None, -0.5),
    "bottleneck_stressed_seed33": ("bravo", None, 1.0),
    # (Seed 37 since session 62: alpha's re-plans in the gap are refused — mapped structure may not merge with
    # other regions over it — and it waits stopped among the others: −1.40 m of circle overlap, the hulls apart.)
    "bottleneck_stressed_seed37": ("alpha", None, -1.6),
    # Held-out seeds 41–60: the stressed bottleneck's seed 41 (bravo, stopped for alpha, turned
    # towards a fresh detour 120° off its heading and crept at up to 0.45 m/s into alpha, −1.28 m)
    # and the §6.2 dock as shipped, seed 46 (vessel2 into the moored vessel3, −1.08 m).
    "bottleneck_stressed_seed41": ("bravo", None, 1.0),
    "dock_seed46": ("vessel2", None, 1.0),
    # The velocity-obstacle method (compare_methods, team_vs_traffic run 19): released whenever the
    # path's velocity left the VO though it still passed the head-on target on the forbidden side,
    # own_1 steered back towards the target three times and met it. It now holds the manoeuvre until
    # the target is past (rule 8 (d)); the hold is the mechanism that must act.
    "vo_team_vs_traffic_19": ("own_1", "colreg_hold", 1.0),
    # The velocity-obstacle method again (a team against three crossing and head-on targets in a
    # current, 22 % dropout, 45 % packet loss): own_1, off its path after a give-way manoeuvre,
    # tested only the LOS velocity (pointing back at the path), which missed the head-on target the
    # path runs 4.6 m from until 15 m range. The path's own motion is now tested too (the conflict
    # it alone finds is counted as path_conflict) and own_1 passes port to port.
    "vo_team_lossy_current_10": ("own_1", "path_conflict", 1.0),
    # A 162° sharp turn 3.9 m from an island's corner, in a current setting onto it, turned the short
    # way with the bow through the corner and gathered way into the island: such a turn now goes
    # the long way round, away from mapped structure (turn_away).
    "bottleneck_current_reversal_14": ("own", "turn_away", 1.0),
    # A user-style harbour exit under traffic_rule = "colreg" (the file's header): bravo's detour
    # around the ferry, planned without alpha (a team mate it gives way to is never gone around),
    # cleared the yielding alpha by 0.36 m on its path; bravo, turning onto it at 2.1 m/s, sailed
    # 2.9 m off it into alpha. A fresh detour is now checked against such team mates with the
    # planner's margin (replan_margin_m): alpha conflicts on it and bravo stops.
    "harbour_colreg_team_seed11": ("bravo", "emergency", 2.0),
    # The velocity-obstacle method in a 23.9 m gap between islands: passing the head-on target port
    # to port left ~0.7 m beside the starboard island; with nothing admissible the cheapest choice
    # was forbidden and flipped across the target's line and back until contact. The vessel now
    # departs from rule 14 when every allowed velocity collides (rule 2 (b)) and keeps the side it
    # takes (colreg_departure): it passes starboard to starboard.
    "vo_bottleneck_wrong_side_19": ("own", "colreg_departure", 1.0),
    # A station-keeping leader in a strong current, its short line ending in the track of a ferry
    # coming down it: it passed first towards a goal beyond the line's end and stopped there in the
    # ferry's way. No pass beyond a path's end; the lane change is held — the line continued for the
    # whole hold, no step back before the ferry has passed — and alpha meets the ferry port to port.
    "target_tracking_current_16": ("alpha", "lane_change", 1.0),
    # The 50-vessel showcase's first 50 s (tasks/fleet_50.toml, seed 1): v009 passed a crossing boat
    # first at up to 2.93 m/s, its goal 4.0 m (predicted) behind v001 sailing at 0.9 m/s in the same
    # lane; the plan stepped to the mission speed at the goal, the hull ran 1.2 m past it (0.19 m).
    # Prediction now sheds a pass's extra speed at slow_down_decel_m_s2 (no action to count). Since
    # the same day's track-radius change (docs/perception.md) the fleet no longer reaches that pass:
    # v009 keeps 3.78 m with the lag or without it, so this is a no-contact check; the lag itself is
    # tested in tests/test_pass_end_lag.py.
    "fleet_50_seed1_pass_end": ("v009", None, 1.0),
    # A team mate's stop moved its plan by less than track_deviation_m but by more than the last
    # prediction's clearance to it: the vessel predicts again (test_a_stop_moving_a_plan_within_the_deviation…).
    # (alpha–bravo circles overlap by 0.18 m, the hulls apart; 0.61 m since session 62's refusals in the gap.)
    "bottleneck_stressed_seed56": ("alpha", None, -0.8),
    # An emergency stop for the oncoming vessel in its path, chosen without a check because a team
    # mate conflicted too: the stop is now weighed against keeping way (mjasc/avoidance/keep_way.py;
    # tests/test_keep_way.py). bravo–oncoming circles overlapped by 0.10 m, the hulls apart; 0.11 m clear since way
    # once kept is left for the stop only when the stop is predicted the margin better (session 63).
    "head_on_seed71": ("bravo", "checked_choice", -0.5),
    # The same moment on seed 167 (and 182): the stop won 2.4 s before the oncoming vessel arrived, because keeping
    # way's predicted miss had deepened past the safety distance; way once kept now stays kept unless the stop is
    # predicted to miss the stranger by 0.5 m more. Circles −0.16 m, the hulls apart.
    "head_on_seed167": ("bravo", "checked_choice", -0.5),
    # A new conflict's pass first chosen over the running yield it undid: alpha, yielding to bravo's (unmatched) track
    # ahead, saw only the oncoming stranger and passed into bravo. The running correction is now an option of the
    # checked choice, looked at again every second when kept though it collides (tests/test_running_correction.py).
    # (168 and 205 with alpha's withdraw_offset_m = 0: the obsolete detour's withdrawal of session 65, below, acts
    # first there and alpha would not reach the checked choice they were kept for; their headers say what it gives.)
    "head_on_stressed_seed168": ("alpha", "checked_choice", 1.0),
    # Alpha, stopped for team mate bravo on a detour into bravo's lane, took a pass first for the oncoming stranger
    # into bravo five times (the stop's worst miss, the stranger 30 s ahead, within 0.5 m of the pass's), stopping
    # again further in each time, into the stranger's lane. A running stop for a team mate is no longer left for a
    # plan into it sooner than the stop's own collision (tests/test_colliding_choice.py). Circles 0.15 m apart.
    "head_on_stressed_seed205": ("alpha", "checked_choice", 0.0),
    # The root of 168, 205 and 286: alpha's detour, planned around the stranger on its early estimates, turned into the
    # lane the stranger then took, and alpha, giving way to bravo, crept along it. A detour sailed under a velocity
    # correction that now leads into a track it went around is withdrawn when the mission path is clear by
    # replan_margin_m (test below). Alpha keeps 1.78 m.
    "head_on_stressed_seed286": ("alpha", "withdrawn", 1.0),
    # Two team mates stopped in the §6.4.3 gap, their stops ending together, both stood on (rule 13 against rule 15);
    # the one standing on at the last resort did not say so in its broadcast. Now it does, and the later name gives
    # way (test below). Bounding circles 0.62 m apart.
    "bottleneck_seed146": ("alpha", None, 0.3),
    # Alpha in the §6.4.3 gap re-planned with both islands' safety regions merged around it (joined by a crossing
    # vessel's swept area) and shrunk to a blob: the detour ran into the north island (seeds 166 as shipped, 108 and
    # 40 stressed). Mapped structure no longer merges over the vessel, and an island's region the vessel is within is
    # grown by less instead of scaled (tests/test_replanning_safety_regions.py). Seed 40: circles −0.25 m, hulls apart.
    "bottleneck_seed166": ("alpha", None, 1.0),
    "bottleneck_stressed_seed108": ("alpha", None, 1.0),
    "bottleneck_stressed_seed40": ("alpha", None, -0.6),
    # The §6.3 vessel yielding to the crossing vessel predicted (periodically) while its track was flagged static for
    # a moment, re-planned around it as a static outline and sailed into where it was going. A track flagged static
    # that still has speed and has moved from where first seen is predicted moving (test below). 5.89 m.
    "velocity_correction_stressed_seed273": ("asc", None, 5.0),
    # Two team mates deployed 4 m apart across each other's transits, each refusing the lane because of the other's
    # broadcast plan (the crossing rule), drifted together stopped. Team mates are not crossing threats (0.10 m), and
    # since session 68 the two, stopped inside each other's collision distance for deadlock_s, move apart (the
    # mission completes: test below). Circles 0.03 m apart (they drift together on the current while they wait).
    "go_to_formation_deployment_5": ("alpha", "separate", -0.25),
    # The stressed dock, seed 297: a sharp turn the guard held beside the moored vessel3, released 57° off its aim point,
    # was sailed as an arc at mission speed into vessel3 (−0.91 m). A held turn now goes on in place to within 20° of
    # its aim point (test below). Circles −0.15 m, the hulls apart.
    "dock_stressed_seed297": ("vessel2", "turn_held", -0.5),
    # Session 69: a give-way team mate stopped ahead, its broadcast saying so — standing on sailed into it
    # (seed 27 an open case since session 62; 70 and 234 found in session 67). It is given way to now: the
    # pairs wait with their bounding circles just apart or overlapping a little, the hulls apart.
    "bottleneck_stressed_seed27": ("alpha", "stopped_mate_ahead", 0.0),
    "bottleneck_stressed_seed70": ("alpha", "stopped_mate_ahead", -0.5),
    "bottleneck_stressed_seed234": ("alpha", "stopped_mate_ahead", 0.0),
}
SLOW = {"crossing_stressed_seed5", "crossing_stressed_seed12", "bottleneck_stressed_seed5", "bottleneck_seed7", "bottleneck_seed1",
        "demo_run3", "bottleneck_stressed_seed2", "bottleneck_stressed_seed11", "bottleneck_stressed_seed4",
        "bottleneck_stressed_seed31", "bottleneck_stressed_seed33", "bottleneck_stressed_seed37",
        "bottleneck_stressed_seed41",
        "harbour_colreg_team_seed11",
        "target_tracking_current_16", "fleet_50_seed1_pass_end", "bottleneck_stressed_seed56",
        "bottleneck_seed166", "bottleneck_stressed_seed108", "bottleneck_stressed_seed40", "head_on_stressed_seed168",
        "head_on_stressed_seed205", "head_on_stressed_seed286", "bottleneck_seed146", "go_to_formation_deployment_5",
        "bottleneck_stressed_seed27", "bottleneck_stressed_seed70", "bottleneck_stressed_seed234"}


def test_every_regression_file_is_checked():
    assert sorted(p.stem for p in CASES.glob("*.toml")) == sorted(EXPECT)


@pytest.mark.parametrize("name", [pytest.param(n, marks=[pytest.mark.slow] if n in SLOW else [])
                                  for n in sorted(EXPECT)])
def test_a_case_that_collided_keeps_clear(name):
    vessel, action, bound = EXPECT[name]
    summary = run_scenario(load_scenario(CASES / f"{name}.toml")).summary
    assert summary["status"] == "completed"
    assert not summary["any_collision"], summary["collisions"]
    v = summary["vessels"][vessel]
    assert v["min_clearance_to_any_m"] > bound, v["min_clearance_m"]
    if action is not None:
        assert v["avoidance"]["actions"][action] >= 1, v["avoidance"]["actions"]


@pytest.mark.slow
def test_two_team_mates_stopped_in_each_others_way_move_apart_and_complete_the_mission():
    """go_to_formation_deployment_5: alpha and charlie, deployed 4.5 m apart across each other's
    transits, stopped for each other at 0.6 s and stayed stopped to the end of the 320 s run (the
    mission did not complete). Stopped inside each other's collision distance for ``deadlock_s``,
    alpha (the earlier name) sails away from charlie (mjasc/avoidance/separation.py); then right of
    way settles them and the team reaches its formation poses and follows its paths."""
    summary = run_scenario(load_scenario(CASES / "go_to_formation_deployment_5.toml")).summary
    assert summary["mission"]["mission_completed"], summary["mission"]
    actions = {name: v["avoidance"]["actions"]["separate"] for name, v in summary["vessels"].items()}
    assert actions == {"alpha": 1, "bravo": 0, "charlie": 0}  # (charlie, the later name, is no longer stuck at 90 s)
    assert not summary["any_collision"]


@pytest.mark.slow
def test_three_team_mates_stuck_together_move_apart_one_at_a_time(tmp_path):
    """A user's review of the way out: bravo deployed beside alpha and charlie too (-17, 14.2 m,
    heading -80°), all three inside each other's collision distance. The first form moved alpha and
    bravo away from charlie at once; each was stopped at the start of its leg by the other, frozen
    there with the leg counted as running, and the two touched 19 times (none with the rule off). Now
    the earliest name of all stuck together goes first, on a leg that ends no nearer another team
    mate, and the team completes its mission without contact."""
    text = (CASES / "go_to_formation_deployment_5.toml").read_text()
    bravo = "position_m = [30.78663102741843, -16.080994747691925]\nheading_deg = -22.262997016342613"
    assert text.count(bravo) == 1
    path = tmp_path / "three_stuck.toml"
    path.write_text(text.replace(bravo, "position_m = [-17.0, 14.2]\nheading_deg = -80.0"))
    summary = run_scenario(load_scenario(path)).summary
    assert not summary["any_collision"], summary["collisions"][:3]
    assert summary["mission"]["mission_completed"], summary["mission"]
    actions = {name: v["avoidance"]["actions"]["separate"] for name, v in summary["vessels"].items()}
    assert actions == {"alpha": 1, "bravo": 0, "charlie": 0}


@pytest.mark.slow
def test_the_detour_refusal_acts_in_the_stressed_bottleneck():
    """The refusal of bottleneck_stressed_seed2 end to end on another seed of the same file: seed 57
    has alpha refuse detours that would pass the islands too close, and every vessel keeps clear.
    Until session 62 the structure check refused them (``detour_rejected``, twice); since, the
    planner refuses first — mapped structure may not merge with another region over the vessel —
    so they count as failed re-plans (the structure check keeps its own test in test_avoidance.py).
    (Seeds 30 — found on an AMD EPYC Zen 3 machine, the same course on an Intel Xeon with AVX-512 —
    and 23 took other courses once the allocation stopped a turning hull's push ahead and an
    occluded detection grew a track's radius: docs/avoidance.md "Hardening".)"""
    scenario = load_scenario(CASES / "bottleneck_stressed_seed2.toml").with_overrides(seed=57)
    summary = run_scenario(scenario).summary
    assert summary["status"] == "completed" and not summary["any_collision"], summary["collisions"]
    v = summary["vessels"]["alpha"]
    assert v["min_clearance_to_any_m"] > 1.0, v["min_clearance_m"]
    acts = v["avoidance"]["actions"]
    assert acts["replan_failed"] + acts["detour_rejected"] >= 1, acts


@pytest.mark.slow
def test_team_mates_that_both_stand_on_settle_it_by_name(monkeypatch):
    """The harbour exit, found with seed 25 (docs/avoidance.md, "Hardening"): in the cross-set stream
    alpha crabs 50° and reads bravo abaft its beam (rule 13), bravo reads alpha's course over ground
    against its own bow and finds alpha on its port side (rule 15): both stood on, neither yielded,
    and their bounding circles overlapped by 0.84 m. Each now broadcasts the team mates it stands on
    toward; bravo, whose name sorts later, gives way as soon as alpha's word arrives — here with
    seed 4 (seed 25 takes another course since the allocation stopped a turning hull's push
    ahead)."""
    events = avoidance_events(monkeypatch)
    summary = run_scenario(load_scenario(CASES / "harbour_colreg_team_seed11.toml").with_overrides(seed=4)).summary
    assert summary["status"] == "completed" and not summary["any_collision"], summary["collisions"]
    assert summary["vessels"]["bravo"]["min_clearance_m"]["alpha"] > 0.5
    said = [(name, text) for name, _, text in events]
    assert ("bravo", "team mate alpha stands on toward this vessel too (its broadcast): this vessel gives way") in said


@pytest.mark.slow
def test_a_stand_on_at_the_last_resort_is_said_and_the_later_name_gives_way(monkeypatch):
    """bottleneck_seed146: alpha's stop for bravo ends at 146.4 s and it stands on at the last resort
    (bravo abaft its beam), bravo's stop ends 0.7 s later and it stands on too (alpha on its port
    bow). Alpha's broadcast now says it stands on, and bravo gives way at once by the name rule.
    (Since session 69 a give-way mate stopped ahead is given way to, and the run takes another
    course before that moment — no contact either way, EXPECT above; that rule is held off here so
    that the file keeps exercising the name rule at the last resort.)"""
    from mjasc.avoidance import triage

    monkeypatch.setattr(triage, "stopped_ahead", lambda nav, track: False)
    events = avoidance_events(monkeypatch)
    summary = run_scenario(load_scenario(CASES / "bottleneck_seed146.toml")).summary
    assert not summary["any_collision"], summary["collisions"]
    said = [t for name, t, text in events if name == "bravo" and
            text == "team mate alpha stands on toward this vessel too (its broadcast): this vessel gives way"]
    assert any(146.0 < t < 149.0 for t in said), said


@pytest.mark.slow
def test_a_stop_moving_a_plan_within_the_deviation_is_seen():
    """The team clearance check acts where it fixed the case: in the stressed bottleneck (seed 56)
    charlie's stop moved its plan 3.4 m, under ``track_deviation_m`` (5 m), and alpha, passing first,
    did not predict again until it touched charlie. A new plan that moves more than the last
    prediction's clearance to that team mate now makes the vessel predict again
    (``predictions_on_team_clearance``)."""
    summary = run_scenario(load_scenario(CASES / "bottleneck_stressed_seed56.toml")).summary
    assert not summary["any_collision"], summary["collisions"]
    assert summary["vessels"]["alpha"]["avoidance"]["predictions_on_team_clearance"] >= 1


def _run_keeping_clear(monkeypatch, name: str) -> tuple[list, list]:
    """Run a case file, assert it keeps clear, and return the avoidance events (vessel, t, text) and
    the first vessel's (t, y [m]) at every record tick."""
    events = avoidance_events(monkeypatch)
    ys = []
    runner = Runner(load_scenario(CASES / f"{name}.toml"))
    runner.observe("record", lambda ev: ys.append((ev.time_s, float(ev.states.position_m[0, 1]))))
    summary = runner.run().summary
    assert not summary["any_collision"], summary["collisions"]
    return events, ys


@pytest.mark.slow
def test_a_detour_leading_into_its_track_is_withdrawn(monkeypatch):
    """head_on_stressed_seed286: the withdrawal that acts is the obsolete detour's (its track is still
    there, the detour now meets it, alpha yields to bravo on it), at the prediction that first finds the
    detour meeting it, and alpha, back on its lane, stays in it (within 1 m of y = 10 m) while the
    stranger passes south of it."""
    events, ys = _run_keeping_clear(monkeypatch, "head_on_stressed_seed286")
    said = [(t, text) for name, t, text in events if name == "alpha" and text.startswith("detour withdrawn")]
    assert said and said[0][1].startswith("detour withdrawn: it now leads into track(s) [120] it went around"), said
    assert 93.0 < said[0][0] < 94.0
    assert min(y for t, y in ys if 95.0 <= t <= 135.0) > 9.0


def test_a_boat_flagged_static_while_slowing_is_predicted_moving(monkeypatch):
    """velocity_correction_stressed_seed273: at the periodic prediction at 180 s the crossing vessel's
    track is flagged static (the tracker's flag lags its speed estimate, back at 0.23 m/s), but it has
    sailed far from where it was first seen: it is predicted moving, said once, and the vessel goes
    astern of it (to starboard, south of its line) instead of round its outline into its way."""
    events, ys = _run_keeping_clear(monkeypatch, "velocity_correction_stressed_seed273")
    said = [(t, text) for name, t, text in events if "flagged static by the tracker" in text]
    assert len(said) == 1 and 179.9 < said[0][0] < 180.1 and said[0][1].startswith("track(s) [268] "), said
    assert max(y for t, y in ys if 186.0 <= t <= 200.0) < -1.0


def test_a_held_sharp_turn_is_finished_in_place():
    """dock_stressed_seed297: the guard holds vessel2's turn beside vessel3 (26.8 s); the hull turns in place until it
    points within 20° of its aim point and leaves away from vessel3 — its centre never within 4 m of vessel3's (it came
    to 3.29 m, hulls touching, when the turn was released at 60°)."""
    runner = Runner(load_scenario(CASES / "dock_stressed_seed297.toml"))
    d = []
    runner.observe("record", lambda ev: d.append(float(np.hypot(*(ev.states.position_m[1] - ev.states.position_m[2])))))
    summary = runner.run().summary
    assert not summary["any_collision"] and summary["vessels"]["vessel2"]["avoidance"]["actions"]["turn_held"] >= 1
    assert min(d) > 3.9, min(d)
