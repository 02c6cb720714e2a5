"""Campaign files and per-run randomization: validation names the field; the draws are a pure
function of (base_seed, k) in a fixed order; over many runs their sample moments match the sigmas;
with every sigma 0 run k is the scenario with seed base_seed + k."""

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mjasc.campaigns.perturbation import (
    CampaignError,
    Randomization,
    draw_perturbations,
    load_campaign,
    parse_campaign,
    randomized_scenario,
)
from mjasc.physics.currents import SumCurrent, UniformCurrent
from mjasc.runs.scenario import parse_scenario

TASKS = Path(__file__).resolve().parent.parent / "tasks"
#: The base scenario of these tests (independent of the shipped files): three Otters, a ferry on
#: constant-velocity motion, a uniform current.
BASE = """
name = "base"
duration_s = 60.0
[current]
type = "uniform"
velocity_m_s = [0.1, 0.2]
[[vessels]]
name = "alpha"
type = "otter"
position_m = [0.0, 12.0]
controller = { type = "path_following", waypoints = [[0.0, 12.0], [150.0, 12.0]] }
[[vessels]]
name = "bravo"
type = "otter"
heading_deg = 179.0
controller = { type = "path_following", waypoints = [[0.0, 0.0], [150.0, 0.0]] }
[[vessels]]
name = "charlie"
type = "otter"
position_m = [0.0, -12.0]
controller = { type = "path_following", waypoints = [[0.0, -12.0], [150.0, -12.0]] }
[[moving_obstacles]]
name = "ferry"
radius_m = 4.0
position_m = [105.0, 80.0]
heading_deg = -90.0
speed_m_s = 1.2
"""
SIGMAS = dict(vessel_position_sigma_m=2.0, vessel_heading_sigma_deg=5.0, current_velocity_sigma_m_s=0.05,
              traffic_heading_sigma_deg=10.0, traffic_speed_sigma_m_s=0.1)


@pytest.fixture(scope="module")
def base_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("base") / "base.toml"
    path.write_text(BASE)
    return str(path)


def campaign_dict(base_path, **kw) -> dict:
    d = {"scenario": base_path, "runs": 4, "base_seed": 3, "randomize": dict(SIGMAS), "outputs": {"recordings": False}}
    d.update(kw)
    return d


@pytest.fixture(scope="module")
def base_campaign(base_path):
    return parse_campaign(campaign_dict(base_path))


# ---------------------------------------------------------------------- validation
BAD = {
    "runs: missing": lambda d: d.pop("runs"),
    "runs: must be ≥ 1": lambda d: d.update(runs=0),
    "runs: must be an integer": lambda d: d.update(runs=2.5),
    "base_seed: must be ≥ 0": lambda d: d.update(base_seed=-1),
    "base_seed: must be an integer": lambda d: d.update(base_seed="0"),
    "duration_s: must be > 0": lambda d: d.update(duration_s=0),
    "scenario: missing": lambda d: d.pop("scenario"),
    "scenario: must be a path string": lambda d: d.update(scenario=3),
    "scenario: ": lambda d: d.update(scenario="no_such_file.toml"),
    "campaign.seeds: unknown field": lambda d: d.update(seeds=3),
    "randomize.vessel_position_sigma_m: must be ≥ 0": lambda d: d["randomize"].update(vessel_position_sigma_m=-1.0),
    "randomize.traffic_speed_sigma_m_s: must be a number": lambda d: d["randomize"].update(traffic_speed_sigma_m_s="x"),
    "randomize.current_velocity_sigma_m_s: must be finite":
        lambda d: d["randomize"].update(current_velocity_sigma_m_s=float("nan")),
    "randomize.wind_sigma: unknown field": lambda d: d["randomize"].update(wind_sigma=1.0),
    "randomize: must be a table": lambda d: d.update(randomize=1.0),
    "outputs.recordings: must be true or false": lambda d: d["outputs"].update(recordings="yes"),
    "outputs.video: unknown field": lambda d: d["outputs"].update(video=True),
}


@pytest.mark.parametrize("message", BAD)
def test_bad_campaign_names_the_field(message, base_path):
    d = campaign_dict(base_path)
    BAD[message](d)
    with pytest.raises(CampaignError) as exc:
        parse_campaign(d)
    assert message in str(exc.value)


def test_a_bad_scenario_is_reported_under_the_scenario_field(tmp_path):
    (tmp_path / "bad.toml").write_text('name = "x"\nduration_s = -1\n[[vessels]]\ntype = "otter"\n')
    (tmp_path / "c.toml").write_text('scenario = "bad.toml"\nruns = 2\n')
    with pytest.raises(CampaignError, match=r"c\.toml: scenario: .*bad\.toml: duration_s: must be > 0"):
        load_campaign(tmp_path / "c.toml")
    from mjasc.campaigns.spec import load_campaign_spec  # (the command line's reader: the same file named)

    with pytest.raises(CampaignError, match=r"c\.toml: scenario bad\.toml: duration_s: must be > 0"):
        load_campaign_spec(tmp_path / "c.toml")


def test_campaign_file_resolves_the_scenario_relative_to_itself(tmp_path):
    sub = tmp_path / "campaigns"
    sub.mkdir()
    (tmp_path / "s.toml").write_text(BASE)
    (sub / "c.toml").write_text('scenario = "../s.toml"\nruns = 5\nduration_s = 12.5\n[randomize]\n'
                                'vessel_heading_sigma_deg = 1\n')
    c = load_campaign(sub / "c.toml")
    assert c.name == "c" and c.runs == 5 and c.base_seed == 0 and c.recordings is False
    assert c.scenario.duration_s == 12.5 and Path(c.scenario_path) == (tmp_path / "s.toml").resolve()
    assert c.randomize == Randomization(vessel_heading_sigma_deg=1.0)
    with pytest.raises(CampaignError, match="no such campaign file"):
        load_campaign(sub / "missing.toml")
    (sub / "broken.toml").write_text("runs = = 3")
    with pytest.raises(CampaignError, match="not valid TOML"):
        load_campaign(sub / "broken.toml")


@pytest.mark.parametrize("path", [p for p in sorted((TASKS / "campaigns").glob("*.toml"))  # the perturbation-format files
                                  if "families" not in tomllib.loads(p.read_text())], ids=lambda p: p.name)
def test_every_shipped_campaign_loads(path):
    c = load_campaign(path)
    assert c.runs >= 1 and c.scenario.vessels


def test_overrides_are_validated(base_campaign):
    assert base_campaign.with_overrides(runs=7).runs == 7
    assert base_campaign.with_overrides(duration_s=5.0).scenario.duration_s == 5.0
    with pytest.raises(CampaignError, match="runs: must be ≥ 1"):
        base_campaign.with_overrides(runs=0)


# ---------------------------------------------------------------------- determinism
def _state(sc):
    return (sc.seed, np.array([[*v.position_m, v.heading_rad] for v in sc.vessels]),
            sc.current.velocity(np.zeros((1, 2)), 0.0),
            np.array([[o.heading_rad, o.speed_m_s] for o in sc.moving_obstacles]))


def test_run_k_is_deterministic_and_runs_differ(base_campaign):
    base = base_campaign.scenario
    before = _state(base)
    a, b, other = (randomized_scenario(base, base_campaign, 2), randomized_scenario(base, base_campaign, 2),
                   randomized_scenario(base, base_campaign, 3))
    for x, y in zip(_state(a), _state(b)):
        np.testing.assert_array_equal(x, y)
    assert a.seed == 5 and other.seed == 6
    assert not np.allclose(_state(a)[1], _state(other)[1])
    for x, y in zip(before, _state(base)):  # the base scenario is untouched
        np.testing.assert_array_equal(x, y)
    assert a.raw["seed"] == 5 and a.raw["randomization"]["run"] == 2 and "randomization" not in base.raw


def test_one_sigma_does_not_change_another_quantitys_draw(base_campaign):
    base = base_campaign.scenario
    full = draw_perturbations(base, base_campaign.randomize, 0, 11)
    only_pos = draw_perturbations(base, Randomization(vessel_position_sigma_m=2.0), 0, 11)
    np.testing.assert_array_equal(full.vessel_offset_m, only_pos.vessel_offset_m)
    assert np.all(only_pos.vessel_heading_offset_deg == 0) and np.all(only_pos.current_offset_m_s == 0)


def test_zero_sigmas_give_the_scenario_with_seed_base_seed_plus_k(base_campaign):
    base = base_campaign.scenario
    sc = randomized_scenario(base, Randomization(), 4, base_seed=10)
    assert sc.seed == 14 and sc.vessels == base.vessels and sc.moving_obstacles == base.moving_obstacles
    assert sc.current is base.current
    # A seeded current is rebuilt as if the file said seed = base_seed + k.
    raw = dict(base.raw)
    raw["current"] = {"type": "gauss_markov", "mean_velocity_m_s": [0.1, 0.0], "time_constant_s": 30.0,
                      "sigma_m_s": 0.1}
    gm = parse_scenario(raw, "gm.toml")
    expected = parse_scenario({**raw, "seed": 14}, "gm.toml")
    got = randomized_scenario(gm, Randomization(), 4, base_seed=10)
    t = np.linspace(0, 100, 11)
    v = lambda s: np.array([s.current.velocity(np.zeros((1, 2)), ti)[0] for ti in t])  # noqa: E731
    np.testing.assert_array_equal(v(got), v(expected))
    assert not np.array_equal(v(got), v(gm))


# ---------------------------------------------------------------------- what each sigma does
def test_draws_are_applied_as_stated(base_campaign):
    base = base_campaign.scenario
    d = draw_perturbations(base, base_campaign.randomize, base_campaign.base_seed, 1)
    sc = randomized_scenario(base, base_campaign, 1)
    for v0, v1, dp, dh in zip(base.vessels, sc.vessels, d.vessel_offset_m, d.vessel_heading_offset_deg):
        np.testing.assert_allclose(v1.position_m, v0.position_m + dp, atol=1e-12)
        dpsi = math.remainder(v1.heading_rad - v0.heading_rad - math.radians(dh), 2 * math.pi)
        assert dpsi == pytest.approx(0, abs=1e-12)
        assert v1.path is v0.path  # the mission is unchanged: a displaced start is a cross-track error
    assert isinstance(sc.current, UniformCurrent)
    np.testing.assert_allclose(sc.current.velocity_m_s, base.current.velocity_m_s + d.current_offset_m_s, atol=1e-15)
    assert sc.current_config == {"type": "uniform", "velocity_m_s": list(sc.current.velocity_m_s)}
    ferry0, ferry1 = base.moving_obstacles[0], sc.moving_obstacles[0]
    assert ferry1.heading_rad == pytest.approx(ferry0.heading_rad + math.radians(d.traffic_heading_offset_deg[0]))
    assert ferry1.speed_m_s == pytest.approx(ferry0.speed_m_s + d.traffic_speed_offset_m_s[0])


def test_non_uniform_current_gets_a_uniform_offset_added(base_path):
    raw = parse_campaign(campaign_dict(base_path)).scenario.raw
    raw = {**raw, "current": {"type": "vortex", "centre_m": [50.0, 0.0], "core_radius_m": 20.0, "max_speed_m_s": 0.4}}
    base = parse_scenario(raw, "vortex.toml")
    r = Randomization(current_velocity_sigma_m_s=0.2)
    sc = randomized_scenario(base, r, 0, base_seed=1)
    d = draw_perturbations(base, r, 1, 0)
    assert isinstance(sc.current, SumCurrent) and sc.current_config["type"] == "sum"
    pts = np.random.default_rng(0).uniform(-50, 150, (20, 2))
    np.testing.assert_allclose(sc.current.velocity(pts, 3.0) - base.current.velocity(pts, 3.0),
                               np.tile(d.current_offset_m_s, (20, 1)), atol=1e-14)


def test_traffic_on_a_path_keeps_its_heading_and_speed_is_clipped_at_zero(base_path):
    raw = parse_campaign(campaign_dict(base_path)).scenario.raw
    raw = {**raw, "moving_obstacles": [
        {"name": "barge", "radius_m": 3.0, "waypoints": [[100.0, 50.0], [0.0, 50.0]], "speed_m_s": 0.05},
        {"name": "ferry", "radius_m": 4.0, "position_m": [110.0, 90.0], "heading_deg": -90.0, "speed_m_s": 0.05}]}
    base = parse_scenario(raw, "traffic.toml")
    r = Randomization(traffic_heading_sigma_deg=30.0, traffic_speed_sigma_m_s=1.0)
    speeds, headings = [], []
    for k in range(200):
        sc = randomized_scenario(base, r, k)
        barge, ferry = sc.moving_obstacles
        assert barge.heading_rad == base.moving_obstacles[0].heading_rad and barge.path is not None
        speeds.append([barge.speed_m_s, ferry.speed_m_s])
        headings.append(ferry.heading_rad)
    speeds = np.array(speeds)
    assert speeds.min() == 0.0 and (speeds == 0).mean() > 0.3  # P(0.05 + N(0,1) < 0) ≈ 0.48
    assert np.std(headings) == pytest.approx(math.radians(30.0), rel=0.15)


def test_sample_moments_of_the_draws_match_the_sigmas(base_campaign):
    """Over n runs each draw is N(0, σ²): the sample mean lies within 4σ/√n of 0 and the sample
    standard deviation within 4/√(2n) (relative) of σ; components are uncorrelated."""
    base, r = base_campaign.scenario, base_campaign.randomize
    n = 3000
    draws = [draw_perturbations(base, r, 0, k) for k in range(n)]
    pos = np.array([d.vessel_offset_m for d in draws])  # (n, 3, 2)
    samples = {
        "vessel_position_sigma_m": pos.reshape(n, -1),
        "vessel_heading_sigma_deg": np.array([d.vessel_heading_offset_deg for d in draws]),
        "current_velocity_sigma_m_s": np.array([d.current_offset_m_s for d in draws]),
        "traffic_heading_sigma_deg": np.array([d.traffic_heading_offset_deg for d in draws]),
    }
    for name, x in samples.items():
        sigma = getattr(r, name)
        assert np.all(np.abs(x.mean(axis=0)) < 4 * sigma / math.sqrt(n)), name
        np.testing.assert_allclose(x.std(axis=0, ddof=1) / sigma, 1.0, atol=4 / math.sqrt(2 * n), err_msg=name)
    corr = np.corrcoef(np.column_stack([samples["vessel_position_sigma_m"], samples["vessel_heading_sigma_deg"],
                                        samples["current_velocity_sigma_m_s"]]).T)
    off = corr[~np.eye(len(corr), dtype=bool)]
    assert np.max(np.abs(off)) < 4 / math.sqrt(n)
    # The ferry sails many sigmas above 0: its speed draw is (practically) never clipped.
    assert base.moving_obstacles[0].speed_m_s > 6 * r.traffic_speed_sigma_m_s
    dv = np.array([d.traffic_speed_offset_m_s for d in draws])[:, 0]
    assert abs(dv.mean()) < 4 * 0.1 / math.sqrt(n) and dv.std(ddof=1) == pytest.approx(0.1, rel=4 / math.sqrt(2 * n))


def test_a_stress_family_runs_the_scenario_on_its_own_seeds_under_the_stated_conditions():
    """thesis_stress: each family's run k uses seed 1 + k whatever its place in the campaign; the
    stressed families write 30 % dropout into every sensor and 30 % loss into the link, nothing else."""
    import tomllib

    from mjasc.campaigns.spec import load_campaign_spec, parse_campaign_spec
    from mjasc.campaigns.perturbation import CampaignError

    spec = load_campaign_spec("thesis_stress")
    runs = list(spec.runs())
    assert len(runs) == 200
    by_family = {}
    for r in runs:
        by_family.setdefault(r.family, []).append(r)
    for fam, rs in by_family.items():
        assert [r.seed for r in rs] == list(range(1, 21)), fam
        docs = [tomllib.loads(r.scenario_toml) for r in rs]
        assert all(d["seed"] == r.seed for d, r in zip(docs, rs))
        for d in docs:
            dropouts = {v["sensor"].get("dropout_probability") for v in d["vessels"] if "sensor" in v}
            if fam.endswith("_stressed"):
                assert dropouts == {0.3}
                assert "comms" not in d or d["comms"]["loss_probability"] == 0.3
            else:
                assert 0.3 not in dropouts
    shipped = tomllib.loads(by_family["crossing"][4].scenario_toml)
    stressed = tomllib.loads(by_family["crossing_stressed"][4].scenario_toml)
    for v in stressed["vessels"]:
        v["sensor"].pop("dropout_probability")
    stressed["comms"]["loss_probability"] = shipped["comms"]["loss_probability"]
    assert stressed == shipped
    with pytest.raises(CampaignError, match=r"families\[0\]\.conditions\.sensor_dropout"):
        parse_campaign_spec({"families": [{"kind": "perturbation", "scenario": "thesis_6_2_dock.toml",
                                           "conditions": {"sensor_dropout": 1.5}}]}, "x.toml", "tasks")


def test_draws_that_send_traffic_through_a_structure_are_drawn_again():
    """Scripted traffic avoids nothing: a draw whose ferry would sail through the demo's pontoon is
    replaced by the next draw of the same generator; a run whose first draw is clear keeps it."""
    from mjasc.campaigns.perturbation import RANDOMIZATION_STREAM
    from mjasc.runs.plausibility import traffic_through_structure

    camp = load_campaign(TASKS / "campaigns" / "demo_monte_carlo.toml")
    base, r = camp.scenario, camp.randomize
    redrawn = 0
    for k in range(60):
        d = draw_perturbations(base, r, camp.base_seed, k)
        sc = randomized_scenario(base, camp, k)
        assert traffic_through_structure(sc.moving_obstacles, sc.static_obstacles, sc.duration_s) is None
        first = np.random.default_rng([camp.base_seed, k, RANDOMIZATION_STREAM]).standard_normal(
            2 * len(base.vessels) + len(base.vessels) + 2)  # z_pos, z_head, z_cur of the first set
        same = np.allclose(d.vessel_offset_m.ravel(), r.vessel_position_sigma_m * first[:6])
        redrawn += not same
    # ~1/3 of the demo's ferry headings (σ = 10°) meet the pontoon or the buoy within 240 s
    assert 10 <= redrawn <= 35
