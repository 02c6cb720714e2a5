"""What the suite adds to its MuJoCo scene for pixel observations: the task's reference drawn as
visual-only geoms, and a heading-up camera on every hull.

**Reference markers.** A pixel agent sees only what is in the model: the path it must follow,
the formation's lanes and slots were drawn by the video alone (:mod:`mjasc.suite.render`). Every
suite model therefore ends with one static body, ``reference``, holding a fixed pool of thin flat
boxes (:func:`add_reference_pool`); at each episode's initialisation the task lays its reference
out on them (:func:`draw_reference`: the path, the lanes, the route, the station's circle, as
straight pieces, arcs as chords) and hides the unused ones. A formation also has one disc per
slot, in its vessel's palette colour, which the task moves after every step (:func:`draw_slots`).
The markers are visual only:

* contype = conaffinity = 0 (no contact), on a body without joints (nothing of them enters the
  dynamics);
* geom group :data:`REFERENCE_GEOM_GROUP` (1, the water's): drawn by every default render
  (MuJoCo shows groups 0–2), never seen by the range sensor, which casts into groups 0 and 3 only
  (``mjasc.physics.world.SENSOR_GEOM_GROUPS``);
* after every other body and geom, so no index of the world moves (bodies, geoms, joints,
  actuators, mocap bodies keep their ids) and the physics steps bit for bit as without them
  (tests/test_suite_pixels.py).

**Cameras** added to every hull, after the vessel's own: ``follow`` (straight down, 50 m across,
north up, the hull at the centre: mode ``trackcom``) and ``heading_up`` (body-fixed, straight down,
:data:`HEADING_UP_SPAN_M` across, the bow up the image, the hull :data:`HEADING_UP_AHEAD_M` below
the centre so that more lies ahead than astern). World ENU, body FLU, SI units.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mjasc.runs.blueprint import vessel_colour

__all__ = ["REFERENCE_BODY", "REFERENCE_GEOM_GROUP", "REFERENCE_LINE_WIDTH_M", "OVER_TARGET_Z_M", "HEADING_UP_SPAN_M",
           "HEADING_UP_AHEAD_M", "SLOT_RADIUS_M", "add_hull_cameras", "add_reference_pool", "reference_pool",
           "draw_reference", "draw_slots", "path_polyline"]

#: The body holding the marker pool (the model's last body).
REFERENCE_BODY = "reference"
#: Geom group of the markers: shown by default renders (groups 0–2), not cast into by range sensors (0, 3).
REFERENCE_GEOM_GROUP = 1
#: Width of a drawn line [m]: ≥ 1 pixel of an 84 × 84 ``follow`` view (50 m across, 0.6 m per pixel).
REFERENCE_LINE_WIDTH_M = 0.8
#: Half-height of a marker box [m]; centred on the water plane, its top 5 cm above the water.
REFERENCE_HALF_HEIGHT_M = 0.05
#: Height of the centre of a line drawn over the ``target`` site [m]: the site (radius 1.5 m,
#: top 0.10 m) and its heading bar (top 0.12 m) would hide a line at the water plane within 1.5 m of
#: the station, the station's whole 1 m circle (station_keeping); this line's top is 0.15 m.
OVER_TARGET_Z_M = 0.10
#: Colour of the reference (RGBA 0–1): the video's light-blue path colour, opaque.
REFERENCE_RGBA = (0.45, 0.6, 1.0, 1.0)
#: Largest course change along one chord of an arc [rad] (15°: a 10 m turn's chord is 9 cm off the arc).
MAX_CHORD_TURN_RAD = math.radians(15.0)
#: Marker boxes per line a task draws (a path of 5 legs and 4 turns of ≤ 90° needs 29).
PIECES_PER_LINE = 40
#: A formation slot's disc [m]: the radius within which the slot's reward is full; its top 7 cm
#: above the water, over the lanes.
SLOT_RADIUS_M = 1.0
SLOT_HALF_HEIGHT_M = 0.07

#: Across the heading-up view (its vertical field of view) [m], and how far ahead of the hull's
#: origin its centre lies [m]; from HEADING_UP_HEIGHT_M up with a 45° field of view.
HEADING_UP_SPAN_M = 25.0
HEADING_UP_AHEAD_M = 6.0
HEADING_UP_FOVY_DEG = 45.0
HEADING_UP_HEIGHT_M = 0.5 * HEADING_UP_SPAN_M / math.tan(math.radians(0.5 * HEADING_UP_FOVY_DEG))


def add_hull_cameras(hull) -> None:
    """Add the ``follow`` and ``heading_up`` cameras (module docstring) to a hull body (MJCF element),
    after its own cameras."""
    # trackcom keeps the orientation it has at qpos0, where the body frame is the world frame.
    hull.add("camera", name="follow", mode="trackcom", pos=[0.0, 0.0, 60.0], xyaxes=[1, 0, 0, 0, 1, 0], fovy=45)
    # Body-fixed, looking down (−z); image up = the bow (+x body), image right = starboard (−y body).
    hull.add("camera", name="heading_up", mode="fixed", pos=[HEADING_UP_AHEAD_M, 0.0, HEADING_UP_HEIGHT_M],
             xyaxes=[0, -1, 0, 1, 0, 0], fovy=HEADING_UP_FOVY_DEG)


def add_reference_pool(root, n_lines: int, n_slots: int = 0) -> dict:
    """Append the ``reference`` body to the world of the MJCF ``root``: ``n_lines`` × PIECES_PER_LINE
    hidden boxes (``reference_piece<k>``) for lines and ``n_slots`` discs (``reference_slot<i>``,
    SLOT_RADIUS_M, vessel i's palette colour) for moving slots. Returns the model sizes it adds."""
    body = root.worldbody.add("body", name=REFERENCE_BODY)
    n = int(n_lines) * PIECES_PER_LINE
    visual = dict(group=REFERENCE_GEOM_GROUP, contype=0, conaffinity=0)
    for k in range(n):
        body.add("geom", name=f"reference_piece{k}", type="box", size=[0.01, 0.01, 0.01], pos=[0.0, 0.0, 0.0],
                 rgba=[*REFERENCE_RGBA[:3], 0.0], **visual)
    for i in range(int(n_slots)):
        body.add("geom", name=f"reference_slot{i}", type="cylinder", size=[SLOT_RADIUS_M, SLOT_HALF_HEIGHT_M],
                 pos=[0.0, 0.0, 0.0], rgba=[c / 255 for c in vessel_colour(i)] + [1.0], **visual)
    return {"nbody": 1, "ngeom": n + int(n_slots)}


def reference_pool(model, kind: str = "piece") -> np.ndarray:
    """Geom ids of the pool's line pieces (``kind="piece"``) or slot discs (``"slot"``) in ``model``
    (an ``MjModel``, or dm_control's wrapper of one: ``env.physics.model``), in order."""
    model = getattr(model, "ptr", model)  # dm_control's MjModel wraps the binding's (mj_name2id takes only that)
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, REFERENCE_BODY)
    # (an int: numpy compares an array with a MuJoCo enum element by element in Python)
    shape = int({"piece": mujoco.mjtGeom.mjGEOM_BOX, "slot": mujoco.mjtGeom.mjGEOM_CYLINDER}[kind])
    return np.flatnonzero((np.asarray(model.geom_bodyid) == body) & (np.asarray(model.geom_type) == shape))


def draw_slots(physics, slots_xy) -> None:
    """Put slot disc i at ``slots_xy[i]`` (world, [m]), in the model (for the next kinematics) and in
    the current frame's geom poses (the task moves them after a step's kinematics; the body is the
    world's frame, so a geom's world position is its position in the body)."""
    model, data = physics.model.ptr, physics.data.ptr
    ids = reference_pool(model, "slot")
    xy = np.asarray(slots_xy, dtype=float).reshape(-1, 2)
    if len(xy) != len(ids):
        raise RuntimeError(f"reference: {len(xy)} slots to draw, the model has {len(ids)} slot discs")
    model.geom_sameframe[ids] = mujoco.mjtSameFrame.mjSAMEFRAME_NONE
    model.geom_pos[ids, :2] = xy
    data.geom_xpos[ids, :2] = xy


def path_polyline(path) -> np.ndarray:
    """Points (n, 2) [m] of a :class:`mjasc.guidance.paths.Path`: its lines' ends and its arcs'
    chords, each turning the course by at most MAX_CHORD_TURN_RAD."""
    starts = np.asarray(path.segment_starts, dtype=float)
    lengths = np.diff(np.append(starts, path.length))
    gammas = [0.0]
    for start, length in zip(starts, lengths):
        kappa = float(path.curvature(float(start + 0.5 * length)))
        pieces = max(1, math.ceil(abs(kappa) * length / MAX_CHORD_TURN_RAD - 1e-9))
        gammas.extend(start + length * np.arange(1, pieces + 1) / pieces)
    return np.asarray(path.point(np.array(gammas)), dtype=float).reshape(-1, 2)


def draw_reference(physics, polylines, z_m: float = 0.0) -> None:
    """Lay the polylines (each (k, 2) world points [m]) out on the marker pool of ``physics`` (a
    dm_control Physics) as boxes REFERENCE_LINE_WIDTH_M wide, centred at height ``z_m`` (0: on the
    water plane; OVER_TARGET_Z_M: over the ``target`` site), hide the pool's other boxes. Takes
    effect at the next kinematics (the task's ``after_reset``). Raises when the pool is too small."""
    model = physics.model.ptr
    pool = reference_pool(model, "piece")
    a = np.concatenate([np.asarray(p, dtype=float)[:-1] for p in polylines]) if polylines else np.zeros((0, 2))
    b = np.concatenate([np.asarray(p, dtype=float)[1:] for p in polylines]) if polylines else np.zeros((0, 2))
    if len(a) > len(pool):
        raise RuntimeError(f"reference: {len(a)} pieces to draw, the model's pool has {len(pool)}")
    d = b - a
    yaw = np.arctan2(d[:, 1], d[:, 0])
    used, unused = pool[:len(a)], pool[len(a):]
    half_w = 0.5 * REFERENCE_LINE_WIDTH_M
    model.geom_pos[used] = np.column_stack([0.5 * (a + b), np.full(len(a), float(z_m))])
    model.geom_quat[used] = np.column_stack([np.cos(0.5 * yaw), np.zeros(len(a)), np.zeros(len(a)), np.sin(0.5 * yaw)])
    # Each piece overlaps the next by half a width at both ends: no gap at a joint.
    model.geom_size[used] = np.column_stack([0.5 * np.hypot(d[:, 0], d[:, 1]) + half_w, np.full(len(a), half_w),
                                             np.full(len(a), REFERENCE_HALF_HEIGHT_M)])
    # The pieces were compiled at the body's origin, so MuJoCo marked them as sharing its frame
    # (geom_sameframe) and would skip their own pose: say that they have their own.
    model.geom_sameframe[pool] = mujoco.mjtSameFrame.mjSAMEFRAME_NONE
    model.geom_rbound[used] = np.linalg.norm(model.geom_size[used], axis=1)
    model.geom_aabb[used, 3:] = model.geom_size[used]
    model.geom_rgba[used] = REFERENCE_RGBA
    model.geom_rgba[unused, 3] = 0.0  # (MuJoCo leaves geoms of alpha 0 out of the scene)
