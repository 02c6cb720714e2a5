"""Which points lie in one of their owner's discs (world ENU, metres): the compiled loop behind
:func:`mjasc.perception.fleet.inside_owned` (returns and detections of a tick's scans against the
discs of the tracks their own vessel follows).

Points and discs are grouped by owner (small ints, ascending); point ``sp[q] + i`` of owner q
(i < its n_p[q] points) is inside when ``(p_x − c_x)² + (p_y − c_y)² ≤ r²`` for one of the owner's
discs ``sd[q] + j`` (j < n_d[q]; ``sp``, ``sd`` the groups' starts). This is the numpy form the
function had (every pair of a block, ``((p − c)**2).sum(-1) <= r**2``; kept in
``tests/test_owned_discs.py`` as the reference), so the answers are the same; the loop stops at a
point's first disc that holds it.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["inside_owned_discs", "inside_discs"]


@kernel
def _in_a_disc(px, py, centres, radii, start, stop):
    """The point (px, py) [m] lies in one of the discs ``start`` … ``stop − 1``."""
    for b in range(start, stop):
        dx, dy = px - centres[b, 0], py - centres[b, 1]
        r = radii[b]
        if dx * dx + dy * dy <= r * r:
            return True
    return False


@kernel
def inside_owned_discs(points, point_owner, centres, radii, disc_owner):
    """(k,) bool: point k of ``points`` (k, 2) [m] (owners ``point_owner`` (k,)) lies in one of its
    owner's discs, ``centres`` (q, 2) [m] / ``radii`` (q,) [m] owned by ``disc_owner`` (q,)."""
    k = points.shape[0]
    out = np.zeros(k, dtype=np.bool_)
    if k == 0 or centres.shape[0] == 0:
        return out
    no = max(point_owner.max(), disc_owner.max()) + 1
    n_p = np.zeros(no, dtype=np.int64)
    n_d = np.zeros(no, dtype=np.int64)
    for o in point_owner:
        n_p[o] += 1
    for o in disc_owner:
        n_d[o] += 1
    sp = 0
    sd = 0
    for q in range(no):
        for a in range(sp, sp + n_p[q]):
            out[a] = _in_a_disc(points[a, 0], points[a, 1], centres, radii, sd, sd + n_d[q])
        sp += n_p[q]
        sd += n_d[q]
    return out


@kernel
def inside_discs(points, centres, radii):
    """(k,) bool: point k of ``points`` (k, 2) [m] lies in one of the discs ``centres`` (q, 2) [m] /
    ``radii`` (q,) [m] (every point and disc of one owner)."""
    k = points.shape[0]
    out = np.zeros(k, dtype=np.bool_)
    for a in range(k):
        out[a] = _in_a_disc(points[a, 0], points[a, 1], centres, radii, 0, centres.shape[0])
    return out
