"""The discs around tracked boats whose returns never reach their vessel's static map (world ENU,
SI): a tracked disc is the track's radius + ``DISC_MARGIN_M`` + 2σ of its position, at most
``DISC_MARGIN_MAX_M`` beyond the radius, centred where the track is predicted at the scan's time.

The built-in tracker's discs are made for a whole sensing pass in compiled loops
(:func:`tracker_discs`: :mod:`mjasc.perception.tracked_disc_kernels`, called by
:class:`mjasc.perception.fleet.PerceptionFleet`); a plugin tracker's come from its track estimates
(:func:`estimate_discs`).
"""

from __future__ import annotations

import numpy as np

from mjasc.perception.tracked_disc_kernels import disc_courses, disc_rows_at, disc_table, pass_discs

__all__ = ["DISC_MARGIN_M", "DISC_MARGIN_MAX_M", "disc_margin", "estimate_discs", "tracker_discs"]

#: A tracked disc (returns kept out of the map) is the track's radius + this + 2σ of its position [m]
DISC_MARGIN_M = 1.0
#: ... at most this beyond its radius (a long-coasting track must not blank a whole wall) [m].
DISC_MARGIN_MAX_M = 2.5


def disc_margin(P: np.ndarray) -> np.ndarray:
    """(k,) how far a tracked disc reaches beyond the track's radius [m]: ``DISC_MARGIN_M`` + 2σ
    along the major axis of each position covariance P (k, 2, 2), at most ``DISC_MARGIN_MAX_M``."""
    tr_ = 0.5 * (P[:, 0, 0] + P[:, 1, 1])
    lam = tr_ + np.sqrt(np.maximum(tr_**2 - (P[:, 0, 0] * P[:, 1, 1] - P[:, 0, 1] ** 2), 0.0))
    return np.minimum(DISC_MARGIN_M + 2.0 * np.sqrt(lam), DISC_MARGIN_MAX_M)


def estimate_discs(tracks, t_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Centres (k, 2) and radii (k,) [m] of the tracked discs of a plugin tracker's confirmed
    tracks (:class:`~mjasc.core.estimates.TrackEstimate`): the moving ones (not ``is_static``)
    predicted to t_s along their constant-turn motion (not before their own time), radius +
    :func:`disc_margin` — what the compiled discs are for the built-in tracker."""
    moving = [e for e in tracks if not e.is_static]
    if not moving:
        return np.zeros((0, 2)), np.zeros(0)
    c = np.array([e.predict_positions(np.array([max(t_s, e.time_s)]))[0] for e in moving])
    P = np.array([e.position_covariance for e in moving], dtype=float).reshape(-1, 2, 2)
    return c, np.array([e.radius_m for e in moving], dtype=float) + disc_margin(P)


def tracker_discs(ft, owner_slot: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres (q, 2) [m], radii (q,) [m] and slots (q,) of the discs of a
    :class:`~mjasc.perception.tracking.fleet.FleetTracker`'s confirmed moving tracks for a sensing
    pass of S slots: ``owner_slot`` the slot of each of its owners (−1: not in the pass), ``times``
    (S,) the slots' scan times [s]; ordered by slot (within one, in row order). One compiled call
    on the IMM bank's arrays (:func:`~mjasc.perception.tracked_disc_kernels.pass_discs`), or, for a
    bank whose ω̂ numpy sums in blocks (``prediction_arrays`` None), the bank's ``estimate_fields``
    between the kernels."""
    mg, S = ft.mgmt, times.shape[0]
    bank = ft.bank.prediction_arrays()
    if bank is not None:
        return pass_discs(mg._confirmed, mg._static, mg._moved, ft.owner, owner_slot, times, *bank, mg._radius,
                          DISC_MARGIN_M, DISC_MARGIN_MAX_M, S)
    (rows, slots), t_s = disc_rows_at(mg._confirmed, mg._static, mg._moved, ft.owner, owner_slot, times)
    t, pos, th, v, w, P = ft.bank.estimate_fields(rows)
    dt, th = disc_courses(t_s, t, th, w)
    return disc_table(pos, dt, v, np.cos(th), np.sin(th), mg._radius, rows, P, DISC_MARGIN_M, DISC_MARGIN_MAX_M,
                      slots, S)
