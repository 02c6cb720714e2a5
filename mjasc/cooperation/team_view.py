"""The neighbours as the thesis coordination's speed law uses them
(:class:`~mjasc.cooperation.coordination.Coordination`): each team mate's newest message as
received (:class:`_Neighbour`), the team view rebuilt when a message arrives or a neighbour times
out (:class:`_TeamView`: L̄, ω_d, the active neighbours' ξ_j, ξ̇_j, send times and end values), the
extrapolated ξ̂_j and the sum of the gaps to them (compiled above 8 neighbours, :func:`_gaps`), and
the plain-float forms of numpy's sums (:func:`_sum`, :func:`_error_floats`) that keep the law's
numbers bit for bit those of its numpy form. Internal to ``mjasc.cooperation``."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from mjasc.core.compiled import kernel, maximum, minimum

if TYPE_CHECKING:
    from mjasc.cooperation.messages import TeamMessage

__all__ = []


class _Neighbour:
    """A team mate's newest message as received: send and arrival times [s], the message, and
    whether it is still heard (not timed out)."""

    __slots__ = ("sent_time_s", "received_time_s", "message", "active")

    def __init__(self, sent_time_s: float, received_time_s: float, message: TeamMessage, active: bool = True):
        self.sent_time_s, self.received_time_s, self.message, self.active = \
            sent_time_s, received_time_s, message, active


def _sum(values, n: int | None = None) -> float:
    """Σ values with numpy's summation order (sequential below 8 values, numpy's own above), so a
    plain-float sum of a few scalars equals ``np.sum`` of them bit for bit (``n``: their count,
    when the caller knows it)."""
    if (len(values) if n is None else n) >= 8:
        return float(np.add.reduce(values))
    acc = 0.0
    for v in values:
        acc += v
    return acc


def _error_floats(xis: list, own: float, l_bar: float):
    """``coordination_error``'s numbers from a few ξ̂_j in plain floats: (Σ d, mean d, spread) with
    d_j = L̄ (ξ_own − ξ̂_j), as numpy's sum, mean, max and min give them; None when a ξ̂_j is 0 or NaN
    (numpy's max / min pick among ±0 and NaN by their own rule: the caller asks numpy)."""
    hi = lo = own  # max(own, max(xis)) and min(own, min(xis)) in one pass (no NaN or zero among xis:
    for x in xis:  # the builtins' picks are the values themselves)
        if x != x or x == 0.0:
            return None
        if x > hi:
            hi = x
        if x < lo:
            lo = x
    n = len(xis)
    d = [l_bar * (own - x) for x in xis]
    total = _sum(d, n)
    return float(total), float(total / n), float(l_bar * (hi - lo))


def _law_terms(msg) -> tuple | None:
    """What the speed law reads of a team mate's message: (phase, L, v, ξ, ξ̇, ξ_end = 1 − o/L, where
    the mate stops at the end of its path), None without a path; made once per message (every
    receiver shares the same immutable message)."""
    terms = msg.__dict__.get("_law_terms", False)
    if terms is False:
        terms = None if not msg.has_path else (msg.phase, msg.path_length_m, msg.mission_speed_m_s, msg.xi,
                                               msg.xi_rate_1_s, 1.0 - msg.offset_m / msg.path_length_m)
        object.__setattr__(msg, "_law_terms", terms)
    return terms


class _TeamView:
    """The neighbours as the speed law uses them, from one vessel's neighbour table: L̄ and ω_d
    over itself and every neighbour with a path (active or not); of the active ones, ξ_j, ξ̇_j, the
    send time and the end value 1 − o_j/L_j (as lists below 8 of them, arrays above)."""

    def __init__(self, own, neighbours):
        kept, rows = [], []  # kept: the terms of every neighbour in the own phase (active or not)
        oldest = np.inf
        phase = own.phase
        for nb in neighbours:
            if nb.active and nb.sent_time_s < oldest:
                oldest = nb.sent_time_s  # (min(oldest, sent) without its call)
            terms = nb.message.__dict__.get("_law_terms", False)
            if terms is False:
                terms = _law_terms(nb.message)
            if terms is None or terms[0] != phase:  # a mate in another mission phase is not coordinated with
                continue
            kept.append(terms)
            if nb.active:
                rows.append((terms[3], terms[4], nb.sent_time_s, terms[5]))
        self.oldest_active_s = oldest
        if own.path_length_m is None:
            self.l_bar = self.omega = np.nan
        else:
            n = 1 + len(kept)
            self.l_bar = _sum([own.path_length_m] + [terms[1] for terms in kept], n) / n
            self.omega = _sum([own.mission_speed_m_s] + [terms[2] for terms in kept], n) / n / self.l_bar
        self.rows = rows
        self.n_rows = len(rows)  # (read by the speed law every control tick)
        self.arrays = np.ascontiguousarray(np.array(rows).T) if len(rows) >= 8 else None

    def xi_hat(self, t_s: float, extrapolate: bool):
        """ξ̂_j(t) of the active neighbours: ξ_j + ξ̇_j (t − t_j), not beyond the end of their path
        (``extrapolate``), else the held ξ_j; a list below 8 neighbours, else an array."""
        if self.arrays is not None:
            xi, rate, sent, x_end = self.arrays
            return np.minimum(xi + rate * (t_s - sent), np.maximum(xi, x_end)) if extrapolate else xi
        if not extrapolate:
            return [r[0] for r in self.rows]
        # min(x + ξ̇ (t − t_j), max(x, x_end)), the builtins' picks written out (as gap_sum)
        return [hi if (hi := x_end if x_end > x else x) < (ahead := x + rate * (t_s - sent)) else ahead
                for x, rate, sent, x_end in self.rows]

    def gap_sum(self, t_s: float, extrapolate: bool, own: float) -> float:
        """Σ_j (ξ_own − ξ̂_j(t)) over the active neighbours, as ``_sum`` of the gaps to
        :meth:`xi_hat` gives it (above 8 neighbours the gaps in one compiled pass, numpy's sum)."""
        if self.arrays is None:  # _sum of the gaps to xi_hat's list: below 8 values, in order
            acc = 0.0
            if extrapolate:
                for x, rate, sent, x_end in self.rows:
                    # own − min(x + ξ̇ (t − t_j), max(x, x_end)), the builtins' picks written out
                    hi = x_end if x_end > x else x
                    ahead = x + rate * (t_s - sent)
                    acc += own - (hi if hi < ahead else ahead)
            else:
                for row in self.rows:
                    acc += own - row[0]
            return acc
        xi, rate, sent, x_end = self.arrays
        gaps = np.empty(xi.size)
        _gaps(xi, rate, sent, x_end, float(t_s), float(own), bool(extrapolate), gaps)
        return float(np.add.reduce(gaps))


@kernel
def _gaps(xi, rate, sent, x_end, t_s, own, extrapolate, out):
    """ξ_own − ξ̂_j of each neighbour j into ``out``, ξ̂_j as :meth:`_TeamView.xi_hat`'s array form
    computes it (np.minimum / np.maximum: NaN propagates)."""
    for j in range(xi.size):
        x = minimum(xi[j] + rate[j] * (t_s - sent[j]), maximum(xi[j], x_end[j])) if extrapolate else xi[j]
        out[j] = own - x
