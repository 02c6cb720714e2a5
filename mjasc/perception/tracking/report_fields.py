"""What a fleet tracker's reports hand on (:meth:`mjasc.perception.tracking.fleet.FleetTracker.report_rows`),
gathered for every vessel's confirmed tracks in one compiled call with few arrays returned: the
report read ~25 numpy calls and returned arrays per step (the confirmed rows grouped by vessel, the
bank's estimate fields, the columns' static flags, radii and ids, each then made a list).

:func:`report_fields` runs :func:`~mjasc.perception.tracking.step_kernels.confirmed_by_owner` and
:func:`~mjasc.perception.imm.row_fields.row_fields` (the bank's ``estimate_fields``) — the same code,
hence the same bits — and packs what the caller makes lists of into one array per type. The slow
flag is the reference's ``static | (V < static_speed)``. tests/test_tracking_report_fields.py keeps
the readable form (those calls and numpy's indexing) as the reference, bit for bit, on a real run.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.perception.imm.row_fields import row_fields
from mjasc.perception.tracking.step_kernels import confirmed_by_owner

__all__ = ["report_fields"]


@kernel
def report_fields(confirmed, owner, n_owners, x, t, mu, omega, active, Pc, static, radius, local_id, static_speed):
    """The confirmed rows (``confirmed`` (n,)) grouped by vessel ``owner`` (n,), bank order within, and
    their report fields: (ints, floats, xs, P, flags) — ints (2k + n_owners + 1,) int64: the rows, their
    ids ``local_id[rows]`` and each vessel's first position in rows (n_owners + 1); floats (5, k): times
    [s], courses in (−π, π], speeds [m/s], ω̂ [rad/s] (row_fields' of the bank's x (n, 4), t, μ, ω,
    active, Pc (n, 4, 4) current) and radii ``radius[rows]`` [m]; xs (k, 4) the wrapped states; P (k, 2,
    2) the position covariances; flags (2, k): ``static[rows]`` and slow (static or V < static_speed)."""
    rows, first = confirmed_by_owner(confirmed, owner, n_owners)
    k = rows.size
    tt, xs, th, w, P = row_fields(rows, x, t, mu, omega, active, Pc, False)
    ints = np.empty(2 * k + n_owners + 1, dtype=np.int64)
    floats = np.empty((5, k))
    flags = np.empty((2, k), dtype=np.bool_)
    for a in range(k):
        r = rows[a]
        ints[a] = r
        ints[k + a] = local_id[r]
        floats[0, a] = tt[a]
        floats[1, a] = th[a]
        floats[2, a] = xs[a, 3]
        floats[3, a] = w[a]
        floats[4, a] = radius[r]
        s = static[r]
        flags[0, a] = s
        flags[1, a] = s or xs[a, 3] < static_speed
    for o in range(n_owners + 1):
        ints[2 * k + o] = first[o]
    return ints, floats, xs, P, flags
