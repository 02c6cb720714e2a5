"""The compiled per-beam loops of a scan (mjasc.perception.scan_kernels) against the numpy form
RangeSensor.cast / scan had (kept here as the reference), bit for bit, on random casts with
misses, NaN and out-of-range distances, repeated clutter beams and every draw present or not."""

import math

import numpy as np
import pytest

from mjasc.perception.range_sensor import CLUTTER_GEOM
from mjasc.perception.scan_kernels import clean_hits, scan_points, scan_returns


def _numpy_clean(dist, gid, max_range_m):
    miss = gid < 0
    miss |= dist < 0
    miss |= dist > max_range_m
    if miss.any():
        return np.where(miss, -1.0, dist), np.where(miss, -1, gid)
    return dist.copy(), gid.copy()


def _numpy_scan(dist, gid, std, z, p, u, beams_c, rho_c, min_r, max_r):
    """RangeSensor.scan's numpy form after the cast; z / u / beams_c None: that draw is not made."""
    dist, gid = dist.copy(), gid.copy()
    hit = gid >= 0
    if z is not None:
        dist = np.where(hit, dist + std * z, dist)
    if u is not None:
        hit &= u >= p
    if beams_c is not None:
        nearer = ~hit[beams_c] | (rho_c < dist[beams_c])
        b, rho = beams_c[nearer], rho_c[nearer]
        dist[b] = rho
        hit[b] = True
        gid[b] = CLUTTER_GEOM
    hit &= dist >= min_r
    hit &= dist <= max_r
    gid = np.where(hit, gid, -1)
    ranges = np.where(hit, dist, max_r)
    return ranges, hit, gid, np.flatnonzero(hit)


def _numpy_points(ranges, beams, angles, origin, yaw):
    a = angles[beams]
    r = ranges[beams]
    body = np.empty((beams.size, 2))
    bx, by = body[:, 0], body[:, 1]
    np.multiply(r, np.cos(a), out=bx)
    np.multiply(r, np.sin(a), out=by)
    cy, sy = math.cos(yaw), math.sin(yaw)
    world = np.empty((beams.size, 2))
    world[:, 0] = origin[0] + cy * bx - sy * by
    world[:, 1] = origin[1] + sy * bx + cy * by
    return body, world


def _raw_cast(rng, n, max_r):
    dist = rng.uniform(-0.5, 1.2 * max_r, n)
    gid = rng.integers(-1, 9, n).astype(np.int32)
    dist[gid < 0] = -1.0
    special = rng.random(n)
    dist[special < 0.02] = np.nan
    dist[(special > 0.02) & (special < 0.04)] = max_r  # exactly at the range limit
    dist[(special > 0.04) & (special < 0.05)] = 0.0
    return dist, gid


def _same(a, b):
    assert a.dtype == b.dtype and a.shape == b.shape
    np.testing.assert_array_equal(a, b)
    assert a.tobytes() == b.tobytes()


@pytest.mark.parametrize("seed", range(40))
def test_scan_kernels_equal_the_numpy_form(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.choice([1, 2, 7, 360, 720]))
    max_r, min_r = 150.0, float(rng.choice([0.0, 1.0, 5.0]))
    dist, gid = _raw_cast(rng, n, max_r)
    d_ref, g_ref = _numpy_clean(dist, gid, max_r)
    d, g = clean_hits(dist, gid, max_r)
    _same(d, d_ref)
    _same(g, g_ref)
    std, p = float(rng.choice([0.0, 0.05, 3.0])), float(rng.choice([0.0, 0.02, 0.5]))
    z = rng.standard_normal(n) if rng.random() < 0.7 else None
    u = rng.random(n) if rng.random() < 0.7 else None
    k = int(rng.integers(0, 2 * n + 2)) if rng.random() < 0.7 else 0
    beams_c = rng.integers(0, n, size=k) if k else None  # repeated beams among them
    rho_c = rng.uniform(min_r, max_r, size=k) if k else None
    ref = _numpy_scan(d_ref, g_ref, std, z, p, u, beams_c, rho_c, min_r, max_r)
    none = np.zeros(0)
    got = scan_returns(d, g, std, none if z is None else z, p, none if u is None else u,
                       np.zeros(0, dtype=np.int64) if beams_c is None else beams_c, none if rho_c is None else rho_c,
                       min_r, max_r, CLUTTER_GEOM)
    for a, b in zip(got, ref):
        _same(a, b)
    _same(d, d_ref)  # the inputs are left as they were
    angles = -math.pi + (np.arange(n) + 0.5) * 2.0 * math.pi / n
    origin, yaw = rng.uniform(-1e3, 1e3, 2), float(rng.uniform(-4.0, 4.0))
    body_ref, world_ref = _numpy_points(ref[0], ref[3], angles, origin, yaw)
    a = angles[got[3]]
    body, world = scan_points(got[0], got[3], np.cos(a), np.sin(a), origin[0], origin[1], math.cos(yaw), math.sin(yaw))
    _same(body, body_ref)
    _same(world, world_ref)


@pytest.mark.parametrize("beams, fov_deg", [(720, 360.0), (361, 120.0), (1, 30.0)])
def test_fan_directions_equal_numpys_cosine_and_sine(beams, fov_deg):
    """fan_directions (math.cos / math.sin in the kernel) against the numpy form RangeSensor.fire had,
    np.cos / np.sin of np.add(angles, yaw), on sensors' fans at random, large and exact headings
    (the equality of numpy's float64 cos / sin and the C library's: docs/architecture.md)."""
    from mjasc.perception.scan_kernels import fan_directions

    fov = math.radians(fov_deg)
    angles = -0.5 * fov + (np.arange(beams) + 0.5) * fov / beams
    rng = np.random.default_rng(beams)
    yaws = [0.0, -0.0, math.pi, -math.pi, 1e-300, 123.456, -1e4]
    yaws += rng.uniform(-math.pi, math.pi, 300).tolist() + rng.normal(0.0, 50.0, 50).tolist()
    vec = np.full((beams, 3), 7.0)
    for yaw in yaws:
        fan_directions(angles, yaw, vec)
        a = np.add(angles, yaw)
        assert np.array_equal(vec[:, 0], np.cos(a)) and np.array_equal(vec[:, 1], np.sin(a)), yaw
        assert np.all(vec[:, 2] == 7.0)
    many = rng.uniform(-1e3, 1e3, 200_000)  # random angles, one "fan"
    out = np.zeros((many.size, 3))
    fan_directions(many, 0.25, out)
    assert np.array_equal(out[:, 0], np.cos(many + 0.25)) and np.array_equal(out[:, 1], np.sin(many + 0.25))
