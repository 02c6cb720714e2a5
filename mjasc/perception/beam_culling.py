"""Which beams of a fan can meet anything: the range sensor casts only those (world ENU, metres,
radians).

On open water most beams of a fan meet nothing, yet ``mj_multiRay`` pays for every beam (two
``atan2`` for its direction, a bounding-sphere test per body, an angle test per geom: ~70 ns a
beam, ~26 µs for a 360-beam fan among a dozen geoms, twice that inside a run). A beam can only
meet a geom whose bounding sphere it crosses, and a horizontal beam from the sensor at (x, y)
crosses the bounding sphere (centre c, radius R) of a geom only where its *horizontal* crossing,
the disc of radius R about (c_x, c_y), lies on the beam:

* ρ = |c − (x, y)| ≤ R: the sensor is inside the disc, every direction can meet the geom;
* otherwise the beam's world angle φ must be within ``asin(R / ρ)`` of the bearing θ of c (the
  half-line from the sensor meets the disc exactly there);
* ρ − R > the cutoff: MuJoCo drops the geom itself (its 3-D distance is at least ρ).

A box is narrower than its sphere (the islands' and piers' walls are 0.2 m thick and up to 54 m
long, the hulls 0.4 m wide and 3.5 m long): a horizontal beam meets it only where it crosses its
footprint, the convex hull of its 8 corners projected on the water, so the beam's angle must lie
between the smallest and largest bearing of those corners (each within 90° of θ, since the sensor
is outside the bounding circle: their tangents relative to θ order them).

:func:`fan_candidates` marks, per geom of the sensor's groups (not of its own body), the beams in
that span, widened by one beam on each side (the beam angles are ``a_0 + k·Δ`` to a few ulps) and
by a relative 10⁻⁹ on R and on a box's half sizes; writes the marked beams' world directions — the same
expressions as :func:`~mjasc.perception.scan_kernels.fan_directions`, so the same bits — into a
compact array, and every beam's distance and geom as a miss (−1). The caller casts the compact
fan with ``mj_multiRay`` and :func:`scatter_hits` puts its answers back in place.

The scans are the same bits as casting every beam: ``mj_multiRay`` answers each beam on its own
(its per-call set-up depends on the sensor's position only), and a beam that crosses no bounding
disc meets nothing, which MuJoCo reports as −1 (tests/test_beam_culling.py casts both ways on
random poses). Every geom type's surface lies inside its bounding sphere but a plane's, which has
none (``geom_rbound`` 0): a sensor that can see a plane casts its whole fan
(:func:`candidate_geoms` answers None).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mjasc.core.compiled import inlined_kernel, kernel

__all__ = ["fan_candidates", "scatter_hits", "candidate_geoms"]

#: relative widening of a geom's bounding radius (the test stays conservative through rounding)
_R_WIDEN = 1e-9


def candidate_geoms(model, geomgroup: np.ndarray, body_exclude: int) -> tuple[np.ndarray, ...] | None:
    """The geoms a fan of this sensor can meet — every geom of ``geomgroup``'s groups not on body
    ``body_exclude`` (MuJoCo's own elimination drops more, never fewer) — as (ids (G,) int64,
    bounding radii (G,) [m], half sizes (G, 3) [m] of the boxes, zeros for other types), sizes
    widened; None when one of them has no bounding radius (a plane: rays would have to be cast in
    every direction, so the sensor casts its whole fan)."""
    # (a group outside 0 … mjNGROUP − 1 counts as the nearest one, as MuJoCo's ray_eliminate takes it)
    seen = np.asarray(geomgroup)[np.clip(model.geom_group, 0, mujoco.mjNGROUP - 1)] != 0
    seen &= model.geom_bodyid != body_exclude
    ids = np.flatnonzero(seen).astype(np.int64)
    rbound = model.geom_rbound[ids]
    if ids.size and not np.all(rbound > 0.0):
        return None
    box = (model.geom_type[ids] == mujoco.mjtGeom.mjGEOM_BOX)[:, None]
    halves = np.where(box, model.geom_size[ids] * (1.0 + _R_WIDEN) + _R_WIDEN, 0.0)
    # (the radius widened by 2·10⁻⁹ more: a box's widened corner, ≤ |h|(1 + ε) + √3·ε from its
    # centre, stays inside it)
    return ids, rbound * (1.0 + _R_WIDEN) + 2.0 * _R_WIDEN, np.ascontiguousarray(halves)


@inlined_kernel
def _mark_span(mark, n, full_circle, centre, lo, hi, step):
    """Mark the beams whose angle (relative to beam 0, in beam steps of ``step`` [rad]) lies in
    ``[centre + lo, centre + hi]`` [rad], one beam more on each side; returns True when that is
    every beam of a full circle."""
    if full_circle:  # (the indices wrap: one interval whatever the turn ``centre`` is given in)
        a = int(math.floor((centre + lo) / step)) - 1
        b = int(math.ceil((centre + hi) / step)) + 1
        if b - a + 1 >= n:
            return True
        for k in range(a, b + 1):
            mark[k % n] = True
        return False
    two_pi = 2.0 * math.pi
    for shift in (-two_pi, 0.0, two_pi):  # (a partial fan: the span as seen a turn either way too)
        a = max(int(math.floor((centre + shift + lo) / step)) - 1, 0)
        b = min(int(math.ceil((centre + shift + hi) / step)) + 1, n - 1)
        for k in range(a, b + 1):
            mark[k] = True
    return False


@kernel
def fan_candidates(x, y, yaw, angles_body, full_circle, geom_xpos, geom_xmat, ids, radii, boxes, cutoff_m, mark,
                   beams, vec, dist, gid):
    """Mark the beams of a fan (body angles ``angles_body`` (n,) [rad], uniformly spaced; a full
    circle wraps) of a sensor at world (x, y) [m] and heading ``yaw`` [rad] that can meet one of
    the geoms ``ids`` (world centres ``geom_xpos`` (ngeom, 3) and orientations ``geom_xmat``
    (ngeom, 9), bounding radii ``radii`` [m]; ``boxes`` (G, 3): a box's half sizes [m], zeros for
    any other type) within ``cutoff_m`` (module docstring). Writes the marked beams' indices,
    ascending, into ``beams`` (n,) and their world directions into the rows of ``vec`` (n, 3); sets
    ``dist`` (n,) to −1 and ``gid`` (n,) to −1 for every beam; ``mark`` (n,) bool is scratch.
    Returns how many beams are marked."""
    n = angles_body.shape[0]
    for i in range(n):
        mark[i] = False
        dist[i] = -1.0
        gid[i] = -1
    a0 = angles_body[0]
    step = (angles_body[n - 1] - a0) / (n - 1) if n > 1 else 2.0 * math.pi
    every = False
    for j in range(ids.shape[0]):
        g = ids[j]
        dx = geom_xpos[g, 0] - x
        dy = geom_xpos[g, 1] - y
        r = radii[j]
        rho = math.sqrt(dx * dx + dy * dy)
        if rho - r > cutoff_m:
            continue
        if rho <= r:
            every = True
            break
        centre = math.atan2(dy, dx) - yaw - a0  # the bearing of the centre from beam 0 [rad]
        hx, hy, hz = boxes[j, 0], boxes[j, 1], boxes[j, 2]
        if hx > 0.0:
            # a box: the bearings of its 8 corners about the centre's (its footprint is their hull;
            # every corner is within r < ρ of the centre, so each is within 90° of it: tan is monotonic)
            ux, uy = dx / rho, dy / rho
            tmin, tmax = math.inf, -math.inf
            for c in range(8):
                sx = hx if c & 1 else -hx
                sy = hy if c & 2 else -hy
                sz = hz if c & 4 else -hz
                ox = dx + geom_xmat[g, 0] * sx + geom_xmat[g, 1] * sy + geom_xmat[g, 2] * sz
                oy = dy + geom_xmat[g, 3] * sx + geom_xmat[g, 4] * sy + geom_xmat[g, 5] * sz
                t = (ux * oy - uy * ox) / (ux * ox + uy * oy)
                if t < tmin:
                    tmin = t
                if t > tmax:
                    tmax = t
            lo, hi = math.atan(tmin), math.atan(tmax)
        else:
            hi = math.asin(r / rho)
            lo = -hi
        if _mark_span(mark, n, full_circle, centre, lo, hi, step):
            every = True
            break
    m = 0
    for i in range(n):
        if every or mark[i]:
            beams[m] = i
            a = angles_body[i] + yaw
            vec[m, 0] = math.cos(a)
            vec[m, 1] = math.sin(a)
            vec[m, 2] = 0.0
            m += 1
    return m


@kernel
def scatter_hits(beams, m, dist_c, gid_c, dist, gid):
    """Put the compact cast's answers ``dist_c`` / ``gid_c`` (the first m) back at their beams
    ``beams`` in ``dist`` / ``gid`` (n,)."""
    for j in range(m):
        i = beams[j]
        dist[i] = dist_c[j]
        gid[i] = gid_c[j]
