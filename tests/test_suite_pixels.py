"""What a pixel observation of the suite shows: the task's reference drawn into the MuJoCo scene
(mjasc/suite/pixel_scene.py) and the heading-up camera, without changing anything else.

The markers are visual only: an episode's observations, rewards, discounts and physics are the same
bits with and without them, and the range sensor never sees them. They are where the task's
reference is, at every reset and (formation slots) after every step.
"""

import mujoco
import numpy as np
import pytest

import mjasc  # noqa: F401  (picks MUJOCO_GL before mujoco renders)
import mjasc.suite.common as common
import mjasc.suite.otter as otter
import mjasc.suite.otter_team as otter_team
from mjasc import suite
from mjasc.suite.pixel_scene import (HEADING_UP_AHEAD_M, HEADING_UP_SPAN_M, REFERENCE_GEOM_GROUP,
                                     SLOT_RADIUS_M, path_polyline, reference_pool)


def _episode(domain, task, seed, steps=40):
    """Observations, rewards, discounts and (qpos, qvel) of ``steps`` random-action steps."""
    env = suite.load(domain, task, task_kwargs={"random": seed})
    rng = np.random.default_rng(seed)
    rows, time_step = [], env.reset()
    for _ in range(steps):
        p = env.physics.data
        rows.append((dict(time_step.observation), time_step.reward, time_step.discount, p.qpos.copy(), p.qvel.copy()))
        if time_step.last():
            break
        time_step = env.step(rng.uniform(-1.0, 1.0, env.action_spec().shape))
    ngeom = env.physics.model.ngeom
    env.close()
    return rows, ngeom


def _without_markers(monkeypatch):
    """Build the suite's models as before the markers: no pool, nothing drawn."""
    monkeypatch.setattr(common, "add_reference_pool", lambda root, n_lines, n_slots=0: {})
    for module, name in ((otter, "draw_reference"), (otter_team, "draw_reference"), (otter_team, "draw_slots")):
        monkeypatch.setattr(module, name, lambda *args: None)


@pytest.mark.parametrize("domain,task,seed", [("otter", "path_following_hard", 3), ("otter", "station_keeping", 1),
                                              ("otter", "collision_avoidance_hard", 5),
                                              ("otter_team", "formation_hard", 4)])
def test_markers_leave_every_episode_bit_identical(domain, task, seed, monkeypatch):
    with_markers, ngeom_with = _episode(domain, task, seed)
    with monkeypatch.context() as m:
        _without_markers(m)
        without, ngeom_without = _episode(domain, task, seed)
    assert ngeom_with > ngeom_without  # (the markers were there in one run only)
    assert len(with_markers) == len(without)
    for (obs_a, r_a, d_a, q_a, v_a), (obs_b, r_b, d_b, q_b, v_b) in zip(with_markers, without):
        assert obs_a.keys() == obs_b.keys()
        for key in obs_a:
            assert obs_a[key].tobytes() == obs_b[key].tobytes(), key
        assert (r_a, d_a) == (r_b, d_b)
        assert q_a.tobytes() == q_b.tobytes() and v_a.tobytes() == v_b.tobytes()


def test_range_sensor_does_not_see_the_markers():
    """A marker standing across the bow's beams at the ray height is invisible to the range sensor
    (its geom group), though a ray cast into every group hits it."""
    env = suite.load("otter", "collision_avoidance", task_kwargs={"random": 0})
    env.reset()
    physics, task = env.physics, env.task
    m, d = physics.model.ptr, physics.data.ptr
    before = task.range_sensor(physics).cast(d)[0].copy()
    piece = reference_pool(m)[0]
    psi, xy = physics.heading(0), physics.position(0)
    bow = np.array([np.cos(psi), np.sin(psi)])
    m.geom_pos[piece] = [*(xy + 3.0 * bow), 0.0]
    m.geom_quat[piece] = [np.cos(0.5 * psi), 0.0, 0.0, np.sin(0.5 * psi)]
    m.geom_size[piece] = [0.2, 6.0, 1.0]  # 12 m wide, 2 m high: across every ray ahead
    m.geom_rbound[piece] = np.linalg.norm(m.geom_size[piece])
    m.geom_aabb[piece, 3:] = m.geom_size[piece]
    mujoco.mj_forward(m, d)
    np.testing.assert_array_equal(task.range_sensor(physics).cast(d)[0], before)
    assert m.geom_group[piece] == REFERENCE_GEOM_GROUP and m.geom_contype[piece] == m.geom_conaffinity[piece] == 0
    origin = np.array([*xy, 0.1])
    hit = np.zeros(1, dtype=np.int32)
    dist = mujoco.mj_ray(m, d, origin, np.array([*bow, 0.0]), None, 1, int(physics.world.hull_body_id[0]), hit)
    assert hit[0] == piece and dist == pytest.approx(2.8)
    env.close()


def test_markers_follow_each_episodes_reference():
    """Path following: the drawn pieces join the path's chord points at every reset (the world poses
    too, not only the model's), the rest hidden. Formation: a disc on every slot after every step."""
    env = suite.load("otter", "path_following", task_kwargs={"random": 0})
    for _ in range(2):
        env.reset()
        env.step(np.zeros(2))
        m, d = env.physics.model.ptr, env.physics.data.ptr
        pool, points = reference_pool(m), path_polyline(env.task.path)
        used = pool[:len(points) - 1]
        np.testing.assert_allclose(d.geom_xpos[used, :2], 0.5 * (points[:-1] + points[1:]), atol=1e-9)
        assert np.all(m.geom_rgba[used, 3] == 1.0) and np.all(m.geom_rgba[pool[len(used):], 3] == 0.0)
        path = env.task.path
        off = [abs(path.cross_track_error(p, path.project(p))) for p in d.geom_xpos[used, :2]]
        assert max(off) < 0.1  # the chords' middles: ≤ 9 cm off the arcs
    env.close()
    env = suite.load("otter_team", "formation_hard", task_kwargs={"random": 1})
    env.reset()
    for _ in range(3):
        env.step(np.zeros(6))
        t, d = float(env.physics.data.time), env.physics.data.ptr
        slots = reference_pool(env.physics.model.ptr, "slot")
        assert len(slots) == 3
        for i, g in enumerate(slots):
            np.testing.assert_array_equal(d.geom_xpos[g, :2], env.task.slot_position(i, t))
        assert env.physics.model.geom_size[slots[0], 0] == SLOT_RADIUS_M
    env.close()


def test_markers_come_after_everything_and_cameras_keep_their_ids():
    env = suite.load("otter", "collision_avoidance", task_kwargs={"random": 0})
    m = env.physics.model.ptr
    body = m.body("reference").id
    pool = reference_pool(m)
    assert body == m.nbody - 1 and list(pool) == list(range(m.ngeom - len(pool), m.ngeom))
    assert [m.camera(i).name for i in range(m.ncam)] == ["top_down", "overview", "basin", "otter/chase",
                                                         "otter/onboard", "otter/follow", "otter/heading_up"]
    env.close()
    env = suite.load("otter_team", "formation", task_kwargs={"random": 0})
    m = env.physics.model.ptr
    names = [m.camera(i).name for i in range(m.ncam)]
    assert names[:7] == ["top_down", "overview", "basin", "otter0/chase", "otter0/onboard", "otter0/follow",
                         "otter0/heading_up"]
    assert names.index("otter1/chase") == 7 and names.index("otter2/heading_up") == m.ncam - 1
    env.close()


@pytest.mark.parametrize("seed", [0, 3])
def test_heading_up_camera_turns_with_the_hull(seed):
    """Bow up the image, looking straight down, HEADING_UP_SPAN_M across, centred ahead of the hull."""
    env = suite.load("otter", "path_following", task_kwargs={"random": seed})
    env.reset()
    for _ in range(5):
        env.step(np.array([0.8, -0.2]))  # turning
    physics = env.physics
    cam = physics.model.ptr.camera("otter/heading_up")
    xmat = physics.data.ptr.cam_xmat[cam.id].reshape(3, 3)
    psi = physics.heading(0)
    np.testing.assert_allclose(xmat[:, 1], [np.cos(psi), np.sin(psi), 0.0], atol=1e-9)  # image up: the bow
    np.testing.assert_allclose(xmat[:, 2], [0.0, 0.0, 1.0], atol=1e-9)  # looking down (−z)
    centre = physics.data.ptr.cam_xpos[cam.id]
    hull = physics.data.ptr.xpos[physics.world.hull_body_id[0]]
    np.testing.assert_allclose(centre[:2] - hull[:2], HEADING_UP_AHEAD_M * np.array([np.cos(psi), np.sin(psi)]),
                               atol=1e-9)
    assert 2 * (centre[2] - hull[2]) * np.tan(np.radians(0.5 * cam.fovy[0])) == pytest.approx(HEADING_UP_SPAN_M)
    env.close()


def _reference_pixels(frame) -> int:
    """Pixels of the reference's light blue as lit from above (≈ (185, 240, 255); the water is
    ≈ (30, 90, 140), the hulls gold, grey and white)."""
    r, g, b = (frame[..., k].astype(int) for k in range(3))
    return int(np.sum((b >= 220) & (g >= 180) & (r >= 130) & (r <= 215)))


@pytest.mark.parametrize("camera", ["otter/follow", "otter/heading_up", "basin"])
def test_path_is_visible_at_84_pixels(camera):
    """An 84 × 84 pixel observation shows the path (the reference's colour), which the water lacks."""
    env = suite.load("otter", "path_following", task_kwargs={"random": 0})
    env.reset()
    frame = env.physics.render(84, 84, camera_id=camera)
    assert _reference_pixels(frame) >= 25
    m = env.physics.model.ptr
    m.geom_rgba[reference_pool(m), 3] = 0.0  # the same view without the markers: no such pixel
    assert _reference_pixels(env.physics.render(84, 84, camera_id=camera)) == 0
    env.close()


@pytest.mark.parametrize("seed", [0, 2])
def test_station_circle_is_visible_over_the_target(seed):
    """station_keeping's 1 m circle lies within the target site's 1.5 m disc: drawn on the water it
    was hidden under it (no reference pixel in any view); it is drawn over the site."""
    env = suite.load("otter", "station_keeping", task_kwargs={"random": seed})
    env.reset()
    for camera in ("otter/follow", "otter/heading_up"):
        assert _reference_pixels(env.physics.render(84, 84, camera_id=camera)) >= 10, camera
    m = env.physics.model
    m.geom_rgba[reference_pool(m), 3] = 0.0  # the same view without the markers: no such pixel
    assert _reference_pixels(env.physics.render(84, 84, camera_id="otter/follow")) == 0
    env.close()


def test_reference_pool_takes_the_physics_model_as_dm_control_gives_it():
    """docs/suite.md: hide the markers with ``reference_pool(model)``; a dm_control user's model is
    ``env.physics.model``, a wrapper of MuJoCo's (mj_name2id refused it with a TypeError)."""
    env = suite.load("otter_team", "formation", task_kwargs={"random": 0})
    wrapped, raw = env.physics.model, env.physics.model.ptr
    for kind in ("piece", "slot"):
        assert list(reference_pool(wrapped, kind)) == list(reference_pool(raw, kind))
    assert len(reference_pool(wrapped, "slot")) == 3
    env.close()


@pytest.mark.parametrize("task, seed", [("station_keeping", 1), ("station_keeping", 3), ("collision_avoidance", 1)])
def test_the_heading_bar_points_along_the_heading_the_task_set(task, seed):
    """The task turned the bar's ``site_quat``, but the compiler had marked the site as turned with
    the world body, so MuJoCo drew it east–west in every episode (a reviewer measured −100.7° set,
    0° drawn): the heading to hold could not be read from pixels."""
    env = suite.load("otter", task, task_kwargs={"random": seed})
    env.reset()
    d = env.physics.named.data
    centre = d.site_xpos["target_heading"][:2] - d.site_xpos["target"][:2]
    set_deg = np.degrees(np.arctan2(centre[1], centre[0]))  # the bar starts at the disc's centre, along the heading
    xmat = d.site_xmat["target_heading"].reshape(3, 3)
    drawn_deg = np.degrees(np.arctan2(xmat[1, 0], xmat[0, 0]))  # the bar's long (x) axis
    assert abs((drawn_deg - set_deg + 180.0) % 360.0 - 180.0) < 1e-6
    if task == "station_keeping":
        assert abs((set_deg - np.degrees(env.task.station_heading_rad) + 180.0) % 360.0 - 180.0) < 1e-6
    env.close()
