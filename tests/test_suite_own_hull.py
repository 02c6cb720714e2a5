"""The dm_control suite sails a user's own hull: ``task_kwargs={"vessel": ...}`` (mjasc/suite/vessel_choice.py).

Without ``vessel`` every domain sails its own hull as before (the same bits as naming it); a
renamed copy of the Otter's folder sails the Otter's episode bit for bit; the example hull
(examples/my_hull: the Otter + 25 kg) keeps the specs' shapes and accelerates from rest more
slowly, in the ratio of the surge masses; bad input is one line naming the key and the reason;
``render_episode``, ``mjasc render --vessel`` and the baselines' table take it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mjasc import suite
from mjasc.physics.currents import UniformCurrent
from mjasc.physics.vessels import VESSELS_DIR
from mjasc.suite import otter_team
from tests.test_own_hull import copy_vessel, edit

ROOT = Path(__file__).resolve().parent.parent
HULL = ROOT / "examples" / "my_hull" / "hulls" / "otter_payload"
SHORT = 2.0  # episode time limit [s]: 20 control steps


def episode(domain, task, seed=3, **task_kwargs):
    """(observations (steps + 1, size), rewards (steps,), observation keys) of one episode under
    seeded random actions."""
    env = suite.load(domain, task, task_kwargs={"random": seed, "time_limit": SHORT, **task_kwargs})
    rng = np.random.default_rng(seed)
    time_step = env.reset()
    rows, rewards = [np.concatenate([np.ravel(v) for v in time_step.observation.values()])], []
    while not time_step.last():
        time_step = env.step(rng.uniform(-1.0, 1.0, env.action_spec().shape))
        rows.append(np.concatenate([np.ravel(v) for v in time_step.observation.values()]))
        rewards.append(time_step.reward)
    keys = list(time_step.observation)
    env.close()
    return np.array(rows), np.array(rewards), keys


def assert_same_bits(a, b):
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


# ------------------------------------------------------------------ the built-in hulls are unchanged
@pytest.mark.parametrize("domain,task,name", [("otter", "path_following", "otter"),
                                              ("otter", "collision_avoidance_hard", "otter"),
                                              ("delfim", "station_keeping", "delfim"),
                                              ("otter_team", "formation", "otter")])
def test_without_vessel_the_domain_sails_its_own_hull_bit_for_bit(domain, task, name):
    default = episode(domain, task)
    assert_same_bits(default, episode(domain, task, vessel=name))
    assert default[2] == episode(domain, task, vessel=name)[2]


def test_a_built_in_name_sails_that_hull_as_its_own_domain():
    """The otter domain with vessel="delfim" is the delfim domain, bit for bit."""
    assert_same_bits(episode("otter", "path_following_hard", vessel="delfim"), episode("delfim", "path_following_hard"))


def test_a_renamed_copy_of_the_otter_sails_the_otters_episodes_bit_for_bit(tmp_path, monkeypatch):
    copy = copy_vessel(VESSELS_DIR / "otter", tmp_path / "hulls" / "lab_otter")
    for domain, task in (("otter", "path_following"), ("otter", "collision_avoidance"), ("otter", "station_keeping")):
        assert_same_bits(episode(domain, task, vessel=str(copy)), episode(domain, task))
    # the team: the same values under the copy's names (the prefixes are the hull's name)
    team = episode("otter_team", "formation_hard", vessel=copy)  # (an os.PathLike works too)
    otters = episode("otter_team", "formation_hard")
    assert_same_bits(team, otters)
    assert team[2] == [k.replace("otter", "lab_otter", 1) for k in otters[2]]
    # relative to the current folder, as mjasc trial --vessel
    monkeypatch.chdir(tmp_path)
    assert_same_bits(episode("otter", "station_keeping", vessel="hulls/lab_otter"), episode("otter", "station_keeping"))


# ------------------------------------------------------------------ the example hull
@pytest.mark.parametrize("domain,task", [("otter", "collision_avoidance"), ("delfim", "path_following"),
                                         ("otter_team", "formation")])
def test_an_episode_with_the_example_hull_runs_with_the_same_spec_shapes(domain, task):
    own = suite.load(domain, task, task_kwargs={"random": 0, "time_limit": SHORT, "vessel": str(HULL)})
    builtin = suite.load(domain, task, task_kwargs={"random": 0, "time_limit": SHORT})
    assert own.task.vessel.name == "otter_payload"
    assert own.action_spec() == builtin.action_spec()
    own_spec, builtin_spec = own.observation_spec(), builtin.observation_spec()
    assert [s.shape for s in own_spec.values()] == [s.shape for s in builtin_spec.values()]
    n = own.physics.n_vessels
    names = own.physics.world.vessel_names
    assert names == (["otter_payload"] if n == 1 else [f"otter_payload{i}" for i in range(n)])
    assert all(own.physics.model.name2id(f"{name}/chase", "camera") >= 0 for name in names)
    time_step, total = own.reset(), 0.0
    while not time_step.last():
        time_step = own.step(np.full(own.action_spec().shape, 0.5))
        assert all(np.all(np.isfinite(v)) for v in time_step.observation.values())
        assert 0.0 <= time_step.reward <= 1.0
        total += time_step.reward
    assert own.physics.data.time == pytest.approx(SHORT)
    if domain == "otter_team":  # one policy per vessel: the prefixes are read from the observation
        assert list(otter_team.agent_observation(time_step.observation, 2)) == \
            [k.removeprefix("otter2_") for k in builtin_spec if k.startswith("otter2_")]
        assert otter_team.joint_policy([lambda o: np.ones(2)] * 3)(time_step).shape == (6,)
    own.close()
    builtin.close()


def test_the_example_hull_is_deterministic_per_seed_and_not_the_otter():
    for domain, task in (("otter", "path_following_hard"), ("otter_team", "formation")):
        own = episode(domain, task, vessel=str(HULL))
        assert_same_bits(own, episode(domain, task, vessel=str(HULL)))
        assert not np.array_equal(own[0], episode(domain, task)[0])


def surge_from_rest(vessel, seconds=2.0):
    """Surge speeds u [m/s] at each control step from rest, in still water, under full ahead."""
    env = suite.load("otter", "station_keeping", task_kwargs={"random": 0, "vessel": vessel})
    env.reset()
    physics = env.physics
    physics.configure_episode(UniformCurrent((0.0, 0.0)))
    physics.data.qvel[:] = 0.0
    physics.data.act[:] = 0.0
    u = []
    for _ in range(int(round(seconds / env.control_timestep()))):
        env.step(np.ones(2))
        u.append(physics.body_velocity(0)[0])
    env.close()
    return np.array(u)


def test_the_payload_hull_accelerates_more_slowly_from_rest_by_its_surge_mass():
    """The same propellers and X_u, M_11 = 110.5 kg against the Otter's 85.5 kg (examples/my_hull):
    from rest under the same action the loaded hull is slower at every step; its speed is at least
    the ratio 85.5/110.5 of the Otter's (exactly so at the start; less damping on the slower hull)."""
    heavy, light = surge_from_rest(str(HULL)), surge_from_rest(None)
    assert np.all(light > 0.0) and np.all(heavy < light)
    ratio = heavy / light
    assert np.all((ratio >= 85.5 / 110.5 - 1e-9) & (ratio < 1.0))
    assert ratio[0] == pytest.approx(85.5 / 110.5, rel=0.02)
    assert np.all(np.diff(ratio) > 0)  # the gap closes toward the same top speed


# ------------------------------------------------------------------ bad input: one line, the key and the reason
def test_bad_vessels_are_one_line_errors_naming_the_key(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    broken = copy_vessel(VESSELS_DIR / "otter", tmp_path / "hulls" / "bent")
    edit(broken / "bent.xml", '<joint name="yaw" type="hinge"', '<joint name="yaw" type="slide"')
    (tmp_path / "notes.txt").write_text("")
    (tmp_path / "heron").mkdir()
    cases = [
        ("hulls/heron", r"no such vessel folder \(relative to the current folder: .*hulls/heron\), got 'hulls/heron'$"),
        ("notes.txt", r"names a file; a vessel type is the path of the vessel folder that holds it"),
        ("heron", r"must be one of delfim, otter or a vessel folder's path; a folder named so here is written "
                  r"\./heron, got 'heron'$"),
        (Path("heron"), r"the vessel folder has no heron\.xml"),
        ("ottr", r"must be one of delfim, otter or a vessel folder's path, got 'ottr'$"),
        # the contract's own message, naming the file as written
        ("hulls/bent", r"hulls/bent/bent\.xml: joint 'yaw': must be a hinge about 0 0 1, got slide$"),
        (3, r"must be a built-in vessel type's name \(delfim, otter\) or a vessel folder's path \(str or "
            r"os\.PathLike\), got int 3$"),
        ("", r"must be a built-in vessel type's name \(delfim, otter\) or a vessel folder's path, got ''$"),
    ]
    for domain, task in (("otter", "path_following"), ("delfim", "collision_avoidance"), ("otter_team", "formation")):
        for value, reason in cases:
            with pytest.raises(ValueError, match=r"^task_kwargs\.vessel: " + reason) as info:
                suite.load(domain, task, task_kwargs={"vessel": value})
            assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match=r"task_kwargs: unknown 'hull' for otter/path_following; accepted: "
                                         r"time_limit, random, vessel$"):
        suite.load("otter", "path_following", task_kwargs={"hull": "otter"})


# ------------------------------------------------------------------ rendering and the command lines
def test_render_episode_names_the_files_after_the_hull(tmp_path):
    from mjasc.suite.render import render_episode

    out = render_episode("otter", "path_following", policy="baseline", out_dir=tmp_path, seed=2,
                         task_kwargs={"time_limit": 0.5, "vessel": str(HULL)}, camera="chase:otter_payload",
                         width=96, height=64)
    assert out.steps == 5 and out.video_path.name == "otter-path_following-otter_payload-baseline-seed2.mp4"
    assert out.rerun_path.name == "otter-path_following-otter_payload-baseline-seed2.rrd"


def test_mjasc_render_takes_vessel(tmp_path, monkeypatch, capsys):
    """--vessel is checked (relative to the current folder) before the output folder is made, and
    handed to render_episode resolved."""
    import mjasc.suite.render as render
    from mjasc.cli import main

    monkeypatch.chdir(ROOT)
    out = tmp_path / "r"
    assert main(["render", "otter", "path_following", "--vessel", "examples/my_hull/hulls/nothing",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mjasc: render --vessel: no such vessel folder") and err.count("\n") == 1
    assert not out.exists()
    seen = {}

    def fake(domain, task, **kw):
        seen.update(kw)
        raise ValueError("stop here")
    monkeypatch.setattr(render, "render_episode", fake)
    assert main(["render", "otter_team", "formation", "--vessel", "examples/my_hull/hulls/otter_payload",
                 "--out", str(out)]) == 2
    assert seen["task_kwargs"] == {"vessel": str(HULL)}


def test_baselines_table_takes_vessel(capsys):
    from mjasc.suite.baselines import evaluate, main

    with pytest.raises(SystemExit):
        main(["--seeds", "1", "--vessel", "ottr"])
    assert "--vessel: must be one of delfim, otter or a vessel folder's path, got 'ottr'" in capsys.readouterr().err
    assert evaluate("delfim", "station_keeping", "random", [4], vessel="otter") == \
        pytest.approx(evaluate("otter", "station_keeping", "random", [4]), abs=0.0)


def test_gymnasium_takes_vessel():
    """shimmy's route: the same spaces' shapes, the hull's prefixes in the team's Dict space."""
    pytest.importorskip("gymnasium")
    pytest.importorskip("shimmy")
    from mjasc.suite.gym_compat import make_gym_env

    own = make_gym_env("otter_team", "formation", task_kwargs={"time_limit": SHORT, "vessel": str(HULL)})
    builtin = make_gym_env("otter_team", "formation", task_kwargs={"time_limit": SHORT})
    assert own.action_space == builtin.action_space
    assert [s.shape for s in own.observation_space.values()] == [s.shape for s in builtin.observation_space.values()]
    obs, _ = own.reset(seed=1)
    assert "otter_payload1_slot_error" in obs
    obs, reward, terminated, truncated, _ = own.step(own.action_space.sample())
    assert 0.0 <= reward <= 1.0 and not terminated
    own.close()
    builtin.close()
