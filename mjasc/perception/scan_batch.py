"""The scans of several range sensors taken at one tick, post-processed in one pass (world ENU,
body FLU, SI).

A fleet's sensing slot casts every due vessel's fan (``mj_multiRay`` per vessel: each excludes its
own hull) at once, into one set of buffers: :meth:`ScanBatch.add` casts a sensor's fan
(:meth:`~mjasc.perception.range_sensor.RangeSensor.fire`) and makes its draws
(:meth:`~mjasc.perception.range_sensor.RangeSensor.draw`, from the vessel's own stream, in the
scan's order) into the next rows. :meth:`ScanBatch.take` then turns every queued cast into its
:class:`~mjasc.perception.range_sensor.Scan` with one compiled call
(:func:`mjasc.perception.scan_kernels.scan_batch`, per beam the loops of a single scan) and hands
them on as a :class:`ScanStack`: the scans, and their arrays stacked as the detection and the
map take them (each scan's arrays are views of these). A scan is the same bits whether it was
taken alone (:meth:`RangeSensor.scan` is a batch of one) or with others.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjasc.perception.pass_views import PassScan, filled_on_read
from mjasc.perception.range_sensor import CLUTTER_GEOM, RangeSensor
from mjasc.perception.scan_kernels import scan_batch

__all__ = ["ScanBatch", "ScanStack", "scan_pose", "scan_time"]

_NO_BEAMS, _NO_DRAWS = np.zeros(0, dtype=np.int64), np.zeros(0)  # no clutter in any cast of a batch


@dataclass(frozen=True, eq=False)
class ScanStack:
    """The scans of one :class:`ScanBatch` (S of them, N beams and K returns in all), their arrays
    stacked: scan s owns beams ``beam_off[s] : beam_off[s+1]`` and returns
    ``ret_off[s] : ret_off[s+1]`` (each in ascending beam order).

    ranges_m (N,) [m]; hit (N,) bool; hit_beams (K,) beam indices within each scan;
    hit_ranges_m (K,) [m]; hit_points_world (K, 2) [m]; origins_m (S, 2) [m]; cos_heading,
    sin_heading (S,): of each scan's heading (``math.cos`` / ``math.sin``); times_s (S,) [s] and
    headings_rad (S,) [rad]: each scan's ``time_s`` and ``heading_rad``; per scan (S,) its
    sensor's constants: beams, body angle of the first and last beam [rad], ``max_range_m`` [m],
    ``full_circle`` (what the map's carving takes, :meth:`~mjasc.perception.static_map.StaticMapStore.carve_stack`)."""

    scans: tuple
    beam_off: np.ndarray
    ret_off: np.ndarray
    ranges_m: np.ndarray
    hit: np.ndarray
    hit_beams: np.ndarray
    hit_ranges_m: np.ndarray
    hit_points_world: np.ndarray
    origins_m: np.ndarray
    cos_heading: np.ndarray
    sin_heading: np.ndarray
    times_s: np.ndarray
    headings_rad: np.ndarray
    n_beams: np.ndarray
    first_angle_body: np.ndarray
    last_angle_body: np.ndarray
    max_range_m: np.ndarray
    full_circle: np.ndarray


class ScanBatch:
    """Casts queued for one post-processing pass (module docstring): ``add(sensor, data, rng)``
    per due sensor, then ``take()`` → :class:`ScanStack` (the batch is empty again)."""

    def __init__(self):
        self._cap = 0
        self._has = np.zeros((2, 64), dtype=bool)  # per cast: normals drawn, uniforms drawn
        self._grow(1024)
        self._clear()
        self._const_key: tuple = ()
        self._const = None
        #: the last pass's (S, queued sensors, their constants, views of _has): kept while the table rows
        #: of the first S slots and _has stay the same (add drops it when it makes a row or grows _has)
        self._pass = None

    def _clear(self) -> None:
        self._n = 0  # casts queued
        self._end = 0  # rows they fill
        # per cast, in Python floats (one array of them all per pass, kernel_inputs): time [s], x, y [m], yaw
        # [rad], and the end of its clutter in _cb
        self._times: list = []
        self._xy: list = []
        self._yaws: list = []
        self._c_end: list = [0]
        self._cb: list = []  # every cast's clutter beams …
        self._cr: list = []  # … and ranges [m], in cast order

    def _grow(self, need: int) -> None:
        cap = max(1024, 2 * need)
        old = self._cap
        for name, dt in (("_dist", float), ("_gid", np.int32), ("_normals", float), ("_uniforms", float),
                         ("_cos", float), ("_sin", float)):
            a = np.zeros(cap, dtype=dt)
            if old:
                a[:old] = getattr(self, name)
            setattr(self, name, a)
        self._cap = cap
        #: per slot: (sensor, first row, its rows of _dist, _gid, _normals, _uniforms) whose beam cosines and
        #: sines are in place (the views made again on the new buffers)
        self._tables: list[tuple] = [(sn, a, *self._views(a, a + sn.config.beams))
                                     for sn, a, *_ in getattr(self, "_tables", ())]

    def _views(self, a: int, b: int) -> tuple:
        return self._dist[a:b], self._gid[a:b], self._normals[a:b], self._uniforms[a:b]

    def __len__(self) -> int:
        return self._n

    def add(self, sensor: RangeSensor, data, rng: np.random.Generator | None) -> None:
        """Cast ``sensor``'s fan in ``data`` now and draw its imperfections from ``rng`` (None:
        none) into the next rows."""
        k, a = self._n, self._end
        b = a + sensor.config.beams
        if b > self._cap:
            self._grow(b)
        tables = self._tables
        try:
            row = tables[k]
        except IndexError:
            row = None
        if row is None or row[0] is not sensor or row[1] != a:
            self._cos[a:b], self._sin[a:b] = sensor.cos_body, sensor.sin_body
            del tables[k:]  # the later slots' rows may have been overwritten
            self._pass = None
            row = (sensor, a, *self._views(a, b))
            tables.append(row)
        _, _, dist, gid, normals, uniforms = row
        x, y, yaw = sensor.fire(data, dist, gid)
        cb = self._cb
        has_n, has_u = sensor.draw(rng, normals, uniforms, cb, self._cr)
        self._times.append(float(data.time))
        self._xy += (x, y)
        self._yaws.append(yaw)
        self._c_end.append(len(cb))
        has = self._has
        if k >= has.shape[1]:
            self._has = has = np.concatenate([has, np.zeros_like(has)], axis=1)
            self._pass = None
        has[0, k], has[1, k] = has_n, has_u
        self._n, self._end = k + 1, b

    def _constants(self, sensors: list):
        """Per-scan parameters (S,) of the queued sensors (made again when the sensors change)."""
        key = tuple(sensors)
        if key != self._const_key or self._const is None:
            cs = [sn.config for sn in key]
            self._const_key = key
            beam_off = np.zeros(len(key) + 1, dtype=np.int64)
            np.cumsum([c.beams for c in cs], out=beam_off[1:])
            self._const = (beam_off, beam_off.tolist(), np.array([c.range_noise_std_m for c in cs], float),
                           np.array([c.dropout_probability for c in cs], float),
                           np.array([c.min_range_m for c in cs], float), np.array([c.max_range_m for c in cs], float),
                           np.diff(beam_off), np.array([sn.angles_body[0] for sn in key], dtype=float),
                           np.array([sn.angles_body[-1] for sn in key], dtype=float),
                           np.array([sn.full_circle for sn in key], dtype=bool))
        return self._const

    def take(self) -> ScanStack:
        """The queued casts as scans (module docstring); the batch is emptied."""
        args, parts = self.kernel_inputs()
        return self.stack(parts, *scan_batch(*args))

    def kernel_inputs(self) -> tuple[tuple, tuple]:
        """The arguments of :func:`~mjasc.perception.scan_kernels.scan_batch` for the queued casts,
        and what :meth:`stack` needs with its outputs (a caller may run the kernel inside a larger
        compiled call: :mod:`mjasc.perception.sense_pass`)."""
        S = self._n
        got = self._pass
        if got is None or got[0] != S:
            sensors = [row[0] for row in self._tables[:S]]  # (slot k's table row is its cast's sensor's)
            got = self._pass = (S, sensors, self._constants(sensors), self._has[0, :S], self._has[1, :S])
        _, sensors, consts, has_n, has_u = got
        beam_off, offs, noise, dropout, min_r, max_r, n_beams, first, last, full = consts
        times, yaws = self._times, self._yaws
        # one new array per pass (the stack keeps views of it): times, origins, headings, then the places the
        # kernel writes the headings' cosines and sines into
        v = np.array(times + self._xy + yaws + [0.0] * (2 * S))
        times_s, origins, headings, cos_h, sin_h = v[:S], v[S:3 * S].reshape(S, 2), v[3 * S:4 * S], \
            v[4 * S:5 * S], v[5 * S:]
        if self._cb:
            cb, cr = np.array(self._cb, dtype=np.int64), np.array(self._cr, dtype=float)
        else:
            cb, cr = _NO_BEAMS, _NO_DRAWS
        c_off = np.array(self._c_end, dtype=np.int64)
        args = (self._dist, self._gid, beam_off, noise, self._normals, has_n, dropout, self._uniforms, has_u, cb, cr,
                c_off, min_r, max_r, CLUTTER_GEOM, self._cos, self._sin, origins, headings, cos_h, sin_h)
        return args, ((times, yaws), sensors, consts, times_s, headings, origins, cos_h, sin_h)

    def stack(self, parts: tuple, floats, points, hit, geom, ints, K) -> ScanStack:
        """The :class:`ScanStack` of :meth:`kernel_inputs`' ``parts`` and the kernel's outputs
        (cos_h and sin_h written by it); the batch is emptied."""
        casts, sensors, consts, times_s, headings, origins, cos_h, sin_h = parts
        beam_off, offs, noise, dropout, min_r, max_r, n_beams, first, last, full = consts
        S = len(sensors)
        N = offs[S]
        ranges, rho, body, world, beams, ret_off = floats[:N], floats[N:N + K], points[:K], points[N:N + K], \
            ints[:K], ints[N:]
        # each scan's fields made on first read (mjasc.perception.pass_views): the same views as Scan(...) had
        src = (offs, ret_off, casts, sensors, origins, ranges, hit, beams, body, world, geom)
        scans = tuple([filled_on_read(PassScan, _scan_fields, (k, src)) for k in range(S)])
        new = object.__new__
        self._clear()
        stack = new(ScanStack)
        stack.__dict__.update(scans=scans, beam_off=beam_off, ret_off=ret_off, ranges_m=ranges, hit=hit,
                              hit_beams=beams, hit_ranges_m=rho, hit_points_world=world, origins_m=origins,
                              cos_heading=cos_h, sin_heading=sin_h, times_s=times_s, headings_rad=headings,
                              n_beams=n_beams, first_angle_body=first, last_angle_body=last, max_range_m=max_r,
                              full_circle=full)
        return stack


def _scan_fields(d: dict, k: int, src: tuple) -> None:
    """The fields of scan ``k`` of a :class:`ScanStack` (``src``: :meth:`ScanBatch.stack`'s
    arrays) into ``d``: views of the stacked arrays, as ``Scan(...)`` had them."""
    offs, ret_off, (times, yaws), sensors, origins, ranges, hit, beams, body, world, geom = src
    a, b = offs[k], offs[k + 1]
    p, q = ret_off[k:k + 2].tolist()
    sensor = sensors[k]
    d.update(time_s=times[k], origin_m=origins[k], heading_rad=yaws[k], angles_body=sensor.angles_body,
             ranges=ranges[a:b], hit=hit[a:b], hit_beams=beams[p:q], hit_points_body=body[p:q],
             hit_points_world=world[p:q], geom_ids=geom[a:b], max_range_m=sensor.config.max_range_m,
             beam_spacing_rad=sensor.beam_spacing_rad, full_circle=sensor.full_circle)


def scan_time(scan) -> float:
    """A scan's ``time_s`` (:func:`scan_pose`'s first item: the recording asks at every record
    tick) without making its other fields."""
    src = scan.__dict__.get("_src")
    if src is not None and src[0] is _scan_fields:
        k, fields = src[1]
        return fields[2][0][k]  # (times of (times, yaws))
    return scan.time_s


def scan_pose(scan) -> tuple:
    """``(time_s, origin_m, heading_rad)`` of a scan, without making the other fields of a scan of
    :meth:`ScanBatch.stack` not read yet (what a scan's detections carry of it)."""
    src = scan.__dict__.get("_src")
    if src is not None and src[0] is _scan_fields:
        k, (_, _, (times, yaws), _, origins, *_) = src[1]
        return times[k], origins[k], yaws[k]
    return scan.time_s, scan.origin_m, scan.heading_rad
