"""The link's decision of one receiver's new messages as one compiled call
(:meth:`mjasc.cooperation.comms.CommsNetwork.decide_many`, a few receivers one by one).

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

__all__ = ["decide_pairs", "DELIVERED", "LOST", "LOST_OUT_OF_RANGE", "UNSURE"]

#: The outcome codes of :func:`decide_pairs`.
DELIVERED, LOST, LOST_OUT_OF_RANGE, UNSURE = 0, 1, 2, 3

#: Half-width of the band around p(d), relative, in which numpy decides the loss.
_BAND = 1e-12
#: Below this p(d) a loss (u_loss < p(d), u_loss tiny: practically never) is left to numpy too.
_TINY = 1e-290


@kernel
def decide_pairs(sent, px, py, u, range_m, p0, exponent, base_delay_s, speed_m_s, jitter_s, out):
    """Pairs k of messages ``sent`` (k, 3) = (x, y [m] of the sender, send time [s]) and one
    receiver at (px, py), uniforms u (k, 2): writes out (3, k) = (the distance d [m], the arrival
    time [s], the outcome code: DELIVERED, LOST, LOST_OUT_OF_RANGE, or UNSURE — the loss for the
    caller to decide). Returns the number of UNSURE pairs."""
    unsure = 0
    for k in range(sent.shape[0]):
        d = math.hypot(sent[k, 0] - px, sent[k, 1] - py)
        out[0, k] = d
        out[1, k] = sent[k, 2] + base_delay_s + d / speed_m_s + u[k, 1] * jitter_s
        if d >= range_m:
            out[2, k] = LOST_OUT_OF_RANGE
            continue
        p = p0 + (1.0 - p0) * (d / range_m) ** exponent
        if p > 1.0:
            p = 1.0
        band = _BAND * p
        u0 = u[k, 0]
        if u0 < p - band and p > _TINY:  # (a subnormal p is not accurate to the band: numpy decides)
            out[2, k] = LOST
        elif u0 > p + band:
            out[2, k] = DELIVERED
        else:  # (NaN too)
            out[2, k] = UNSURE
            unsure += 1
    return unsure
