"""A 2-D ray-casting range sensor (a lidar/radar-like fan) on one vessel, using MuJoCo's ``mj_multiRay``.

Geometry (world ENU, body FLU, docs/architecture.md): the fan is centred on the bow (body angle 0,
positive to port) and spans ``fov_deg``; beam k points at body angle
``a_k = −fov/2 + (k + ½)·fov/n`` (a 360° fan: ``a_k = −π + (k + ½)·2π/n``, no duplicated beam).
Rays start at the x, y of the vessel's ``sensor_mount`` site and are cast **horizontally at the
world height** ``ray_height_m`` (default 0.1 m): inside the contact band 0 ≤ z ≤ 0.15 m that every
collision hull and obstacle spans (assets/README.md), not at the mast height, where rays would pass
over low hulls. The vessel's own body is excluded (``bodyexclude``), only geom groups 0 (obstacles)
and 3 (vessel collision hulls) are seen (``world.SENSOR_GEOM_GROUPS``), and each ray returns the
first surface it meets: occlusion is MuJoCo's. Only the beams that can meet a geom are cast (the
others read as misses, as MuJoCo would answer them: :mod:`mjasc.perception.beam_culling`).

Imperfections, per scan, all drawn from the caller's ``numpy.random.Generator``:

* range noise: a true return at range ρ reads ``ρ + ε``, ``ε ~ N(0, range_noise_std_m²)``;
* dropout: each true return is lost with probability ``dropout_probability``;
* clutter: ``K ~ Poisson(clutter_per_scan)`` false returns on random beams at ranges uniform in
  ``[min_range_m, max_range_m]``; a false return replaces its beam's reading only when it is nearer
  than the true return (a single-return sensor reports the first echo).

Returns nearer than ``min_range_m`` are discarded (the sensor's blind zone, e.g. spray on the hull).
A scan reads the MuJoCo state as it is (the runner scans after a physics step: geometry is that of
the last ``mj_step1``, at most one physics step old).

Defaults (a small ASC's 2-D scanning radar/lidar, stated in docs/perception.md): 720 beams over 360°
(0.5° spacing: 0.87 m between beams at 100 m, so a 5 m obstacle is hit by ~6 beams there), 150 m
range (the thesis starts tracking at ~100 m), 5 Hz, 5 cm range noise, 2 % dropout, 0.5 clutter
returns per scan.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, dataclass_from_table, param, show
from mjasc.physics.vessel_contract import CONTACT_BAND_M
from mjasc.perception.beam_culling import candidate_geoms, fan_candidates, scatter_hits
from mjasc.perception.scan_kernels import clean_hits, fan_directions

__all__ = ["SensorConfig", "Scan", "RangeSensor", "parse_sensor_options", "check_sensor", "CLUTTER_GEOM"]

#: ``Scan.geom_ids`` value of a false (clutter) return; −1 means no return.
CLUTTER_GEOM = -2
_DEFAULT_GROUPS = np.array([1, 0, 0, 1, 0, 0], dtype=np.uint8)  # = world.SENSOR_GEOM_GROUPS


@dataclass(frozen=True)
class SensorConfig:
    """Range sensor parameters (SI units; angles in degrees because people write them), each
    declared once with its bounds, unit and doc; the relation min_range_m < max_range_m and the
    open bound of dropout_probability are :func:`check_sensor`."""

    beams: int = param(720, minimum=1, maximum=100_000,
                       doc="number of rays per scan (≤ 100,000: a 3-D lidar's scan is of that order)")
    fov_deg: float = param(360.0, positive=True, maximum=360.0, unit="deg", phrase="must be in (0, 360]",
                           doc="field of view, centred on the bow (0 < fov ≤ 360)")
    max_range_m: float = param(
        150.0, minimum=10.0, maximum=100_000.0, unit="m",
        phrase="must be ≥ 10 m and ≤ 100 km",
        doc="returns beyond are not reported (≥ 10 m, a short-range lidar; the thesis tracks from ~100 m; "
            "≤ 100 km, a radar's reach)")
    min_range_m: float = param(1.0, nonneg=True, unit="m", phrase="must be ≥ 0 and < max_range_m",
                               doc="blind zone; nearer returns are discarded (≥ 0, < max_range_m)")
    rate_hz: float = param(5.0, positive=True, unit="Hz",
                           doc="scans per second (a scan is taken at a sensing slot once 1/rate_hz has passed)")
    range_noise_std_m: float = param(0.05, nonneg=True, unit="m", doc="1-σ range noise of a true return")
    dropout_probability: float = param(0.02, nonneg=True, phrase="must be in [0, 1)",
                                       doc="probability that a true return is lost, per beam, in [0, 1)")
    clutter_per_scan: float = param(0.5, nonneg=True, phrase="must be ≥ 0 and ≤ beams",
                                    doc="mean number of false returns per scan (Poisson; ≤ beams: one per beam is "
                                        "a scan of clutter, and each is drawn on its own)")
    ray_height_m: float = param(
        0.1, minimum=CONTACT_BAND_M[0], maximum=CONTACT_BAND_M[1], unit="m",
        phrase=f"must be in [{CONTACT_BAND_M[0]:g}, {CONTACT_BAND_M[1]:g}] m, the contact band every hull and "
               f"obstacle spans (above or below it the rays pass every hull)",
        doc="world height z of the horizontal rays (inside the 0–0.15 m contact band)")

    def __post_init__(self):
        check_params(self, "sensor")
        check_sensor(self, "sensor")

    @property
    def beam_spacing_rad(self) -> float:
        """Angle between neighbouring beams [rad]."""
        return math.radians(self.fov_deg) / self.beams

    @property
    def full_circle(self) -> bool:
        """True when the fan closes on itself (the first and last beams are neighbours)."""
        return self.fov_deg >= 360.0 - 1e-9


def check_sensor(c: SensorConfig, where: str) -> None:
    """The checks of a :class:`SensorConfig` beyond its fields' declared bounds: min_range_m <
    max_range_m, dropout_probability < 1, clutter_per_scan ≤ beams (ConfigError naming
    ``f"{where}.{key}"``)."""
    def bad(key, reason, value):
        raise ConfigError(f"{where}.{key}: {reason}, got {show(value)}")

    if not c.min_range_m < c.max_range_m:
        bad("min_range_m", "must be ≥ 0 and < max_range_m", c.min_range_m)
    if not c.dropout_probability < 1.0:
        bad("dropout_probability", "must be in [0, 1)", c.dropout_probability)
    if not c.clutter_per_scan <= c.beams:
        bad("clutter_per_scan", f"must be ≥ 0 and ≤ beams ({c.beams}; the false returns of a scan are drawn one "
                                f"by one: 1e7 stalled a run)", c.clutter_per_scan)


def parse_sensor_options(table: dict, where: str = "sensor") -> SensorConfig:
    """Validate a scenario's ``[vessels.sensor]`` table (None: all defaults) into a :class:`SensorConfig`.

    Unknown keys, wrong types and out-of-range values raise ValueError naming ``f"{where}.{key}"``
    (:func:`mjasc.core.config_tables.dataclass_from_table`).
    """
    return dataclass_from_table(SensorConfig, {} if table is None else table, where, check=check_sensor)


@dataclass(frozen=True)
class Scan:
    """One scan. Body-frame quantities are in the sensor's frame: origin at the mount's x, y,
    x forward, y to port (the hull's FLU axes; the mount sits on the centre line).

    time_s: MuJoCo time of the scan [s].
    origin_m: (2,) world x, y of the sensor [m]; heading_rad: its yaw (the hull's heading) [rad].
    angles_body: (n,) beam angles in the body frame [rad].
    ranges: (n,) measured range [m]; ``max_range_m`` where there is no return (see ``hit``).
    hit: (n,) bool, True where the beam has a return (true or clutter).
    hit_beams: (k,) indices of the beams with a return, ascending.
    hit_points_body: (k, 2) returns in the sensor frame [m]; hit_points_world: (k, 2) in the world.
    geom_ids: (n,) geom hit (diagnostics, the simulator's truth: never use it downstream);
        −1 no return, ``CLUTTER_GEOM`` for a false return.
    """

    time_s: float
    origin_m: np.ndarray
    heading_rad: float
    angles_body: np.ndarray
    ranges: np.ndarray
    hit: np.ndarray
    hit_beams: np.ndarray
    hit_points_body: np.ndarray
    hit_points_world: np.ndarray
    geom_ids: np.ndarray
    max_range_m: float
    beam_spacing_rad: float
    full_circle: bool


class RangeSensor:
    """Ray-casting range sensor attached to one body (usable on its own, e.g. for RL observations).

    ``RangeSensor(model, config, body_id_to_exclude, mount_site_id)``; ``scan(data, rng)`` → :class:`Scan`.
    ``rng`` None gives a noise-free, dropout-free, clutter-free scan (the geometry only).
    """

    def __init__(self, model, config: SensorConfig, body_id_to_exclude: int, mount_site_id: int,
                 geomgroup: np.ndarray | None = None):
        if not isinstance(config, SensorConfig):
            raise ValueError(f"config: expected a SensorConfig, got {type(config).__name__}")
        if not 0 <= int(mount_site_id) < model.nsite:
            raise ValueError(f"mount_site_id: no site {mount_site_id} in the model ({model.nsite} sites)")
        if not -1 <= int(body_id_to_exclude) < model.nbody:
            raise ValueError(f"body_id_to_exclude: no body {body_id_to_exclude} in the model")
        self.model = model
        self.config = config
        self._body_id = int(body_id_to_exclude)
        self.site_id = int(mount_site_id)
        groups = np.array(_DEFAULT_GROUPS if geomgroup is None else geomgroup, dtype=np.uint8)  # (a copy)
        if groups.shape != (mujoco.mjNGROUP,):
            raise ValueError(f"geomgroup: expected {mujoco.mjNGROUP} flags (one per geom group), got shape "
                             f"{list(groups.shape)}")
        groups.flags.writeable = False  # (the culling's candidate geoms are chosen from it once)
        self._geomgroup = groups
        n = config.beams
        fov = math.radians(config.fov_deg)
        self.angles_body = -0.5 * fov + (np.arange(n) + 0.5) * fov / n
        #: cosines and sines of ``angles_body`` (numpy's, taken once: a scan's returns gather them)
        self.cos_body, self.sin_body = np.cos(self.angles_body), np.sin(self.angles_body)
        self.beam_spacing_rad = config.beam_spacing_rad
        self.full_circle = config.full_circle
        self._vec = np.zeros((n, 3))
        self._vec_flat = self._vec.reshape(-1)
        self._geomid = np.zeros(n, dtype=np.int32)
        self._dist = np.zeros(n)
        self._pnt = np.zeros(3)
        self._pnt[2] = config.ray_height_m
        self._yaw = math.nan  # the heading [rad] _vec's directions are for
        self._data = None  # the MjData whose mount pose views are kept (_xpos, _xmat, _geom_xpos)
        #: the geoms a beam can meet and their bounding radii (None: the whole fan is cast; beam_culling)
        self._culling = candidate_geoms(model, self._geomgroup, self._body_id)
        self._mark = np.zeros(n, dtype=np.bool_)
        self._beams = np.zeros(n, dtype=np.int64)
        self._vec_c = np.zeros((n, 3))
        self._dist_c = np.zeros(n)
        self._gid_c = np.zeros(n, dtype=np.int32)
        self._compact: dict[int, tuple] = {}  # m → the compact cast's views of m beams
        #: beams the last :meth:`fire` cast (the others could meet nothing: beam_culling), beams cast by
        #: all fires, and how many fires
        self.last_beams_cast = self.beams_cast = self.fans_cast = 0
        self._batch = None  # the ScanBatch of scan() on its own

    @property
    def body_id(self) -> int:
        """The body whose geoms the fan never sees (the own hull; −1: none)."""
        return self._body_id

    @property
    def geomgroup(self) -> np.ndarray:
        """The geom groups the fan sees (``mjNGROUP`` flags, read-only: fixed with the sensor)."""
        return self._geomgroup

    def pose(self, data) -> tuple[np.ndarray, float]:
        """World x, y [m] and yaw [rad] of the sensor mount in ``data``."""
        xm = data.site_xmat[self.site_id]
        return data.site_xpos[self.site_id, :2].copy(), math.atan2(xm[3], xm[0])

    def fire(self, data, dist: np.ndarray, geom_ids: np.ndarray) -> tuple[float, float, float]:
        """Cast the fan in ``data`` (``mj_multiRay``) into ``dist`` (n,) [m] and ``geom_ids`` (n,)
        int32 as MuJoCo leaves them (−1 where nothing is hit within the cutoff); returns the world
        x, y [m] and yaw [rad] of the sensor."""
        if data is not self._data:
            self._data = data
            self._xpos, self._xmat = data.site_xpos[self.site_id], data.site_xmat[self.site_id]
            self._geom_xpos, self._geom_xmat = data.geom_xpos, data.geom_xmat
        xm, pnt = self._xmat, self._pnt
        yaw = math.atan2(xm[3], xm[0])
        x, y = float(self._xpos[0]), float(self._xpos[1])
        pnt[0], pnt[1] = x, y
        c = self.config
        culling = self._culling
        if culling is not None:  # only the beams that can meet a geom (beam_culling: the same bits)
            ids, radii, boxes = culling
            m = fan_candidates(x, y, yaw, self.angles_body, self.full_circle, self._geom_xpos, self._geom_xmat, ids,
                               radii, boxes, c.max_range_m, self._mark, self._beams, self._vec_c, dist, geom_ids)
            if m:
                views = self._compact.get(m)
                if views is None:
                    views = self._compact[m] = (self._vec_c[:m].reshape(-1), self._gid_c[:m], self._dist_c[:m])
                vec_c, gid_c, dist_c = views
                mujoco.mj_multiRay(self.model, data, pnt, vec_c, self._geomgroup, 1, self._body_id, gid_c, dist_c,
                                   None, m, c.max_range_m)
                scatter_hits(self._beams, m, dist_c, gid_c, dist, geom_ids)
        else:  # (every beam: a plane in the seen groups)
            if yaw != self._yaw:  # the world directions of the beams (kept while the heading stays the same)
                fan_directions(self.angles_body, yaw, self._vec)
                self._yaw = yaw
            mujoco.mj_multiRay(self.model, data, pnt, self._vec_flat, self._geomgroup, 1, self._body_id, geom_ids,
                               dist, None, c.beams, c.max_range_m)
            m = c.beams
        self.last_beams_cast = m
        self.beams_cast += m
        self.fans_cast += 1
        return x, y, yaw

    def draw(self, rng: np.random.Generator | None, normals: np.ndarray, uniforms: np.ndarray,
             clutter_beams: list, clutter_ranges_m: list) -> tuple[bool, bool]:
        """A scan's draws from ``rng`` (None: none), in this order (:func:`scan_kernels.scan_returns`
        applies them): the range noise's normals into ``normals`` (n,), the dropout's uniforms into
        ``uniforms`` (n,), the clutter's count, beams (appended to ``clutter_beams``) and ranges [m]
        (appended to ``clutter_ranges_m``). Returns whether the normals and the uniforms were drawn.

        The clutter's k beams and k ranges are drawn one at a time, the numbers (and the stream
        after them) of ``rng.integers(0, n, size=k)`` and ``rng.uniform(min, max, size=k)``
        (tests/test_range_sensor.py), without numpy's per-call size handling; a range is
        ``min + (max − min)·rng.random()``, numpy's own uniform formula (one double per draw), in
        a third of ``rng.uniform``'s time."""
        if rng is None:
            return False, False
        c = self.config
        has_normals = has_uniforms = False
        if c.range_noise_std_m > 0:
            rng.standard_normal(out=normals)
            has_normals = True
        if c.dropout_probability > 0:
            rng.random(out=uniforms)
            has_uniforms = True
        if c.clutter_per_scan > 0:
            k = int(rng.poisson(c.clutter_per_scan))
            if k:
                integers, random, n = rng.integers, rng.random, c.beams
                for _ in range(k):
                    clutter_beams.append(integers(0, n))
                lo, span = c.min_range_m, c.max_range_m - c.min_range_m
                for _ in range(k):
                    clutter_ranges_m.append(lo + span * random())
        return has_normals, has_uniforms

    def cast(self, data) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """The true (noise-free) first-hit distances (n,) (−1: nothing within range), geom ids (n,),
        origin (2,) and yaw of one scan."""
        x, y, yaw = self.fire(data, self._dist, self._geomid)
        # mj_multiRay: geom −1 and distance −1 when nothing is hit within the cutoff
        dist, gid = clean_hits(self._dist, self._geomid, self.config.max_range_m)
        return dist, gid, np.array([x, y]), yaw

    def scan(self, data, rng: np.random.Generator | None) -> Scan:
        """One scan (a :class:`~mjasc.perception.scan_batch.ScanBatch` of one)."""
        if self._batch is None:
            from mjasc.perception.scan_batch import ScanBatch

            self._batch = ScanBatch()
        self._batch.add(self, data, rng)
        return self._batch.take().scans[0]


def sensor_for_vessel(world, vessel_index: int, config: SensorConfig) -> RangeSensor:
    """The range sensor of vessel ``vessel_index`` of a :class:`mjasc.physics.world.World` (at its ``sensor_mount``)."""
    name = world.vessel_names[vessel_index]
    site = mujoco.mj_name2id(world.model, mujoco.mjtObj.mjOBJ_SITE, f"{name}/sensor_mount")
    if site < 0:
        raise ValueError(f"vessel MJCF: site {name}/sensor_mount missing (contract in assets/README.md)")
    from mjasc.physics.world import SENSOR_GEOM_GROUPS

    return RangeSensor(world.model, config, int(world.hull_body_id[vessel_index]), site, SENSOR_GEOM_GROUPS)
