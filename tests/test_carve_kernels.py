"""StaticMapStore.carve on its compiled loops (mjasc.perception.carve_kernels) against the numpy
form it had (kept here as the reference), bit for bit: random stores of several members (cell
sizes, margins), full and partial fans of 1 to 720 beams, cells between beams, on the fan's edges,
at the sensor and beyond the range, returns on mapped cells."""

import copy
import math

import numpy as np
import pytest

from mjasc.perception.carve_kernels import HALF_EXTENT_CELLS
from mjasc.perception.static_map import StaticMapConfig, StaticMapStore, _cell_keys


def _numpy_carve(self, members, origins_m, beam_angles_world, ranges_m, hit, max_range_m, full_circle,
                 range_noise_std_m, hit_points_world):
    """StaticMapStore.carve's numpy form."""
    q = len(members)
    counts = np.zeros(q, dtype=np.int64)
    n = self._n
    if n == 0 or q == 0:
        return counts
    nb = np.array([np.size(a) for a in beam_angles_world], dtype=np.int64)
    slot = np.full(self._version.size, -1)
    slot[np.asarray(members, dtype=np.int64)] = np.where(nb > 0, np.arange(q), -1)
    rows = np.flatnonzero(slot[self._member[:n]] >= 0)
    if rows.size == 0:
        return counts
    qi = slot[self._member[rows]]
    mem = self._member[rows]
    o = np.asarray(origins_m, dtype=float).reshape(q, 2)
    cell = self._cell_m[mem]
    rel = (self._cells[rows] + 0.5) * cell[:, None] - o[qi]
    r = np.hypot(rel[:, 0], rel[:, 1])
    half = HALF_EXTENT_CELLS * cell
    far = r + half
    live = (far < np.asarray(max_range_m, dtype=float)[qi]) & (r > half)
    if not live.any():
        return counts
    rows, qi, rel, r, half, far = rows[live], qi[live], rel[live], r[live], half[live], far[live]
    a0 = np.array([a[0] if np.size(a) else 0.0 for a in beam_angles_world], dtype=float)
    a1 = np.array([a[-1] if np.size(a) else 0.0 for a in beam_angles_world], dtype=float)
    dth_m = np.where(nb > 1, (a1 - a0) / np.maximum(nb - 1, 1), 2.0 * math.pi)
    centre_m = 0.5 * (a0 + a1)
    dth, centre, nbr, a0r = dth_m[qi], centre_m[qi], nb[qi], a0[qi]
    bearing = np.arctan2(rel[:, 1], rel[:, 0]) - centre
    bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi + centre - a0r
    ext = np.maximum(half / r, 0.5 * dth)
    lo = np.ceil((bearing - ext) / dth - 1e-9)
    hi = np.floor((bearing + ext) / dth + 1e-9)
    fc = np.asarray(full_circle, dtype=bool)[qi]
    shift = np.where(fc, np.floor(lo / nbr) * nbr, 0.0)
    lo, hi = lo - shift, hi - shift
    hi = np.where(fc, np.minimum(hi, lo + nbr - 1), hi)
    inside = fc | ((lo >= 0) & (hi <= nbr - 1))
    if not inside.all():
        rows, qi, lo, hi, bearing, far, fc, dth, nbr = (
            a[inside] for a in (rows, qi, lo, hi, bearing, far, fc, dth, nbr))
    if rows.size == 0:
        return counts
    nearest = np.rint(bearing / dth)
    nearest = np.where(fc, np.mod(nearest, nbr), nearest)
    empty = hi < lo
    lo = np.where(empty, np.clip(nearest, 0, nbr - 1), lo).astype(np.int64)
    hi = np.where(empty, lo, hi).astype(np.int64)
    fans, start = [], np.zeros(q, dtype=np.int64)
    at = 0
    for k in range(q):
        rho = np.where(np.asarray(hit[k], dtype=bool), np.asarray(ranges_m[k], dtype=float), math.inf)
        fans.append(rho)
        if full_circle[k]:
            fans.append(rho)
        start[k] = at
        at += rho.size * (2 if full_circle[k] else 1)
    fans.append(np.full(1, math.inf))
    edges = np.empty(2 * lo.size, dtype=np.int64)
    edges[0::2], edges[1::2] = start[qi] + lo, start[qi] + hi + 1
    seen = np.minimum.reduceat(np.concatenate(fans), edges)[0::2]
    noise = np.asarray(range_noise_std_m, dtype=float)
    free = seen > far + self._margin[self._member[rows]] + 3.0 * noise[qi]
    pts = [np.asarray(p, dtype=float).reshape(-1, 2) for p in hit_points_world if p is not None]
    if free.any() and sum(p.shape[0] for p in pts):
        pm = np.concatenate([np.full(np.asarray(p).reshape(-1, 2).shape[0], int(m), dtype=np.int64)
                             for m, p in zip(members, hit_points_world) if p is not None])
        now = self._find(_cell_keys(pm, self._cells_of(pm, np.concatenate(pts))))
        free &= ~np.isin(rows, now[now >= 0])
    rows = rows[free]
    if rows.size:
        self._set_scores(rows, np.maximum(self._score[rows] - self._miss[self._member[rows]], 0.0))
        counts += np.bincount(qi[free], minlength=q)
    return counts


def _case(rng):
    store = StaticMapStore()
    M = int(rng.integers(1, 5))
    for _ in range(M):
        store.add_member(StaticMapConfig(cell_m=float(rng.choice([0.5, 1.0, 2.0])), min_hits=int(rng.integers(1, 4)),
                                         miss_weight=float(rng.choice([0.25, 0.5, 1.0])),
                                         carve_margin_m=float(rng.choice([0.0, 1.0]))))
    origins = rng.uniform(-60.0, 60.0, (M, 2))
    for _ in range(int(rng.integers(1, 4))):
        k = int(rng.integers(1, 400))
        mem = rng.integers(0, M, k)
        pts = origins[mem] + rng.uniform(-160.0, 160.0, (k, 2)) * rng.choice([0.05, 0.3, 1.0])
        store.add_points(mem, pts)
    members = [int(m) for m in rng.permutation(M)[: int(rng.integers(1, M + 1))]]
    args = [members, [], [], [], [], [], [], [], []]
    for m in members:
        n = int(rng.choice([0, 1, 2, 5, 90, 360, 720]))
        full = bool(rng.random() < 0.6)
        fov = 2.0 * math.pi if full else float(rng.uniform(0.2, 5.0))
        heading = float(rng.uniform(-4.0, 4.0))
        angles = heading + (-0.5 * fov + (np.arange(n) + 0.5) * fov / max(n, 1))
        max_r = float(rng.choice([60.0, 150.0]))
        ranges = rng.uniform(0.0, max_r, n) * (rng.random(n) < 0.5) + max_r * (rng.random(n) < 0.5)
        ranges = np.minimum(ranges, max_r)
        h = rng.random(n) < rng.choice([0.05, 0.3, 0.9])
        ranges = np.where(h, ranges, max_r)
        pts = origins[m] + ranges[h, None] * np.stack([np.cos(angles[h]), np.sin(angles[h])], axis=-1)
        if rng.random() < 0.3:
            pts = None
        for lst, v in zip(args[1:], (origins[m] if rng.random() < 0.8 else origins[m] + 0.3, angles, ranges, h, max_r,
                                      full, float(rng.choice([0.0, 0.05])), pts)):
            lst.append(v)
    return store, args


@pytest.mark.parametrize("seed", range(80))
def test_carve_equals_the_numpy_form(seed):
    store, args = _case(np.random.default_rng(seed))
    ref = copy.deepcopy(store)
    for _ in range(3):  # repeated carving walks scores down to 0 and flips cells free
        want = _numpy_carve(ref, *args)
        got = store.carve(*args)
        assert got.tobytes() == want.tobytes()
        for name in ("_score", "_version", "_n_occupied", "_cells", "_member", "_keys", "_key_rows"):
            assert getattr(store, name).tobytes() == getattr(ref, name).tobytes(), name
