"""The 22 Imazu cases: the shipped files are what the generator writes; after scaling, the
undisturbed DCPA/TCPA of every target (computed from the parsed file) is the published one times
the case's length and time scales; speed ratios and courses are kept; NED → ENU; the one-target
cases have their published COLREG roles; the Imazu campaign covers 22 cases × its seeds."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mjasc.campaigns.cpa import cpa
from mjasc.campaigns.imazu import (
    CAMPAIGN_SEEDS,
    IMAZU_CASES,
    OWN_SPEED_M_S,
    SHIP_SPEED_M_S,
    START_RANGE_M,
    scale_case,
    task_files,
)
from mjasc.campaigns.spec import load_campaign_spec, parse_campaign_spec
from mjasc.runs.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
TASKS = ROOT / "tasks"


def test_the_shipped_files_are_up_to_date_with_the_generator():
    files = task_files()
    assert len(files) == 23
    for rel, text in files.items():
        assert (TASKS / rel).read_text() == text, f"tasks/{rel} is stale: run scripts/make_imazu_tasks.py"
    assert sorted(p.name for p in (TASKS / "imazu").glob("*.toml")) == [f"imazu_{c:02d}.toml" for c in range(1, 23)]
    out = subprocess.run([sys.executable, str(ROOT / "scripts" / "make_imazu_tasks.py"), "--check"],
                         capture_output=True, text=True, cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": ""})
    assert out.returncode == 0 and "0 file(s) out of date" in out.stdout, out.stderr


@pytest.mark.parametrize("case", sorted(IMAZU_CASES))
def test_scaled_cpa_of_every_target_matches_the_scaled_table(case):
    sc = load_scenario(TASKS / "imazu" / f"imazu_{case:02d}.toml")
    s = scale_case(case)
    kind, targets, table = IMAZU_CASES[case]
    own = sc.vessels[0]
    assert own.heading_rad == pytest.approx(math.pi / 2) and own.cruise_speed_m_s == OWN_SPEED_M_S
    np.testing.assert_array_equal(own.position_m, [0.0, 0.0])
    ranges = [np.hypot(n, e) for n, e, _, _ in targets]
    lam = START_RANGE_M / max(ranges)
    tau = lam / (OWN_SPEED_M_S / SHIP_SPEED_M_S)
    assert (s.length_scale, s.time_scale) == pytest.approx((lam, tau))
    assert len(sc.moving_obstacles) == len(targets)
    own_v = np.array([0.0, OWN_SPEED_M_S])
    for o, (north, east, course, speed), (tcpa, dcpa) in zip(sc.moving_obstacles, targets, table):
        np.testing.assert_allclose(o.position_m, [lam * east, lam * north], atol=1e-3)  # NED → ENU
        yaw = math.radians(90.0 - course)  # NED course → ENU yaw
        assert math.cos(o.heading_rad - yaw) == pytest.approx(1.0, abs=1e-12)
        assert o.speed_m_s / OWN_SPEED_M_S == pytest.approx(speed / SHIP_SPEED_M_S)  # the speed ratio is kept
        v = o.speed_m_s * np.array([math.cos(o.heading_rad), math.sin(o.heading_rad)])
        t, d = cpa(o.position_m, v - own_v)
        # The table rounds to whole seconds and metres: half of that, scaled, plus the file's mm rounding.
        assert t == pytest.approx(tau * tcpa, abs=tau * 0.5 + 0.01)
        assert d == pytest.approx(lam * dcpa, abs=lam * 0.5 + 0.01)
    assert max(np.hypot(*o.position_m) for o in sc.moving_obstacles) == pytest.approx(START_RANGE_M, abs=2e-3)
    assert sc.duration_s == math.ceil(max(s.tcpa_s) + 30.0)


def test_single_target_cases_have_their_published_roles():
    assert [scale_case(c).roles for c in (1, 2, 3, 4)] == [
        ("head_on",), ("crossing_give_way",), ("overtaking",), ("crossing_stand_on",)]
    assert scale_case(5).roles == ("crossing_give_way", "head_on")


def test_the_imazu_campaign_covers_every_case_with_its_seeds():
    s = load_campaign_spec(TASKS / "campaigns" / "imazu.toml")
    assert s.runs_defined == 22 * CAMPAIGN_SEEDS
    runs = [s.run(k) for k in (0, 1, CAMPAIGN_SEEDS, 22 * CAMPAIGN_SEEDS - 1)]
    assert [r.parameters["case"] for r in runs] == [1, 1, 2, 22]
    assert [r.seed for r in runs] == [0, 1, CAMPAIGN_SEEDS, 22 * CAMPAIGN_SEEDS - 1]
    for r in runs:  # the run is the case's file with the run's seed (and the sensor written out)
        sc, ref = r.scenario(), load_scenario(TASKS / "imazu" / f"imazu_{r.parameters['case']:02d}.toml")
        assert sc.duration_s == ref.duration_s and sc.seed == r.seed
        for a, b in zip(sc.moving_obstacles, ref.moving_obstacles):
            assert (tuple(a.position_m), a.heading_rad, a.speed_m_s) == \
                (tuple(b.position_m), b.heading_rad, b.speed_m_s)
        assert sc.vessels[0].options["sensor"] == ref.vessels[0].options["sensor"]


def test_an_imazu_family_takes_current_and_sensor_laws():
    s = parse_campaign_spec({"families": [{"kind": "imazu", "parameters": {
        "case": {"grid": [3, 7]}, "current_m_s": 0.2, "current_direction_deg": 90.0, "sensor_dropout": 0.3}}]})
    assert s.runs_defined == 2
    sc = s.run(1).scenario()
    east = [[0.2, 0.0]]  # 90° clockwise from the own course (north): to starboard
    np.testing.assert_allclose(sc.current.velocity(np.zeros((1, 2)), 0.0), east, atol=1e-9)
    assert sc.vessels[0].options["sensor"].dropout_probability == 0.3 and len(sc.moving_obstacles) == 2
    assert parse_campaign_spec({"families": [{"kind": "imazu"}]}).runs_defined == 22  # default: every case
    short = parse_campaign_spec({"families": [{"kind": "imazu"}]}).with_overrides(duration_s=5.0, runs_per_point=2)
    assert short.runs_defined == 44 and short.run(43).scenario().duration_s == 5.0
