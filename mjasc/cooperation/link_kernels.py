"""The link's decision of the receivers' new messages as one compiled call
(:meth:`mjasc.cooperation.comms.CommsNetwork.decide_many`): :func:`decide_segments` decides every
receiver's segment of the message log in one pass, on the uniforms drawn for all of them at once
(receiver then message order: the numbers a draw per receiver gives); :func:`decide_pairs` is the
same decision for one receiver (the reference its test compares with).

For each offered (message, receiver) pair, with d the distance from the sender's position at
sending to the receiver's position now, the two uniforms (u_loss, u_jitter) drawn beforehand by
numpy (in message order, as before)::

    arrival = t_sent + base_delay_s + d / propagation_speed + u_jitter · jitter_s
    lost    = d ≥ R  or  u_loss < p(d),   p(d) = min(p₀ + (1 − p₀) (d / R)^n, 1)

Bits: d is ``hypot`` of the C library (numpy's ``np.hypot`` calls the same), the arrival the
numpy form's additions in its order. The loss probability alone is not recomputed bit for bit:
numpy's ``power`` may use SIMD code that rounds differently from the C library's ``pow`` (in the
last bits). The comparison u_loss < p(d) is therefore decided here only when u_loss lies clearly
(by a relative 10⁻¹² — thousands of roundings; for a loss, p(d) not near the subnormals) on one
side of p(d); a pair within that band is marked *unsure* and the caller decides it with numpy's
:meth:`~mjasc.cooperation.comms.NetworkConfig.loss_at`,
as before. So the outcome is always numpy's. ``tests/test_link_kernels.py`` compares with the
numpy form.
"""

from __future__ import annotations

import math

from mjasc.core.compiled import kernel

__all__ = ["decide_pairs", "decide_segments", "DELIVERED", "LOST", "LOST_OUT_OF_RANGE", "UNSURE"]

#: The outcome codes of :func:`decide_pairs`.
DELIVERED, LOST, LOST_OUT_OF_RANGE, UNSURE = 0, 1, 2, 3

#: Half-width of the band around p(d), relative, in which numpy decides the loss.
_BAND = 1e-12
#: Below this p(d) a loss (u_loss < p(d), u_loss tiny: practically never) is left to numpy too.
_TINY = 1e-290


@kernel
def _decide_pair(sx, sy, st, px, py, u0, u1, range_m, p0, exponent, base_delay_s, speed_m_s, jitter_s, out, k):
    """One (message, receiver) pair: the sender at (sx, sy) [m] at sending time st [s], the
    receiver at (px, py), the uniforms (u0, u1): writes out[0, k] = d, out[1, k] = the arrival
    time, out[2, k] = the outcome code. Returns 1 when UNSURE, else 0."""
    d = math.hypot(sx - px, sy - py)
    out[0, k] = d
    out[1, k] = st + base_delay_s + d / speed_m_s + u1 * jitter_s
    if d >= range_m:
        out[2, k] = LOST_OUT_OF_RANGE
        return 0
    p = p0 + (1.0 - p0) * (d / range_m) ** exponent
    if p > 1.0:
        p = 1.0
    band = _BAND * p
    if u0 < p - band and p > _TINY:  # (a subnormal p is not accurate to the band: numpy decides)
        out[2, k] = LOST
    elif u0 > p + band:
        out[2, k] = DELIVERED
    else:  # (NaN too)
        out[2, k] = UNSURE
        return 1
    return 0


@kernel
def decide_pairs(sent, px, py, u, range_m, p0, exponent, base_delay_s, speed_m_s, jitter_s, out):
    """Pairs k of messages ``sent`` (k, 3) = (x, y [m] of the sender, send time [s]) and one
    receiver at (px, py), uniforms u (k, 2): writes out (3, k) = (the distance d [m], the arrival
    time [s], the outcome code: DELIVERED, LOST, LOST_OUT_OF_RANGE, or UNSURE — the loss for the
    caller to decide). Returns the number of UNSURE pairs."""
    unsure = 0
    for k in range(sent.shape[0]):
        unsure += _decide_pair(sent[k, 0], sent[k, 1], sent[k, 2], px, py, u[k, 0], u[k, 1], range_m, p0, exponent,
                               base_delay_s, speed_m_s, jitter_s, out, k)
    return unsure


@kernel
def decide_segments(log, segs, hears, u, range_m, p0, exponent, base_delay_s, speed_m_s, jitter_s, offered,
                    counts, pairs, out):
    """Every receiver's new messages in one pass (:meth:`~mjasc.cooperation.comms.CommsNetwork.decide_many`):
    ``log`` (4, ≥ n) = (x [m], y [m], send time [s], sender's team index) of the logged messages;
    ``segs`` (S, 5) = (receiver's team index, first, end (log columns), its x, y [m]),
    the receivers in order; ``hears`` (T, T) [receiver, sender] bool; the uniforms u (m, 2) of the
    m pairs a receiver hears, in receiver then message order (as drawn for :func:`decide_pairs`
    receiver by receiver). Writes pairs (2, m) = (log column, segment) and out (3, m) as
    :func:`decide_pairs` (the first m columns of each); adds 1 to ``offered`` [sender, receiver] per
    pair and writes the counts per segment into ``counts`` (≥ S, 3) = (offered, lost — UNSURE not
    counted —, lost out of range).
    Returns the number of UNSURE pairs."""
    m = 0
    unsure = 0
    for j in range(segs.shape[0]):
        counts[j, 0] = counts[j, 1] = counts[j, 2] = 0
    for j in range(segs.shape[0]):
        r = int(segs[j, 0])
        px, py = segs[j, 3], segs[j, 4]
        for k in range(int(segs[j, 1]), int(segs[j, 2])):
            s = int(log[3, k])
            if not hears[r, s]:
                continue
            pairs[0, m] = k
            pairs[1, m] = j
            unsure += _decide_pair(log[0, k], log[1, k], log[2, k], px, py, u[m, 0], u[m, 1], range_m, p0, exponent,
                                   base_delay_s, speed_m_s, jitter_s, out, m)
            offered[s, r] += 1
            counts[j, 0] += 1
            code = out[2, m]
            if code == LOST:
                counts[j, 1] += 1
            elif code == LOST_OUT_OF_RANGE:
                counts[j, 1] += 1
                counts[j, 2] += 1
            m += 1
    return unsure
