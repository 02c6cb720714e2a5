"""The thesis coordination's speed law for several vessels at once (the control tick's fleet pass):
each vessel's law as :meth:`~mjasc.cooperation.coordination.Coordination.speed_correction` works
it out, then one ``tanh`` for every follower's e_i / e_s and each one's factor in vessel order —
the same factors and states as the vessels' calls one after the other."""

from __future__ import annotations

import numpy as np

from mjasc.cooperation.link import LinkEndpoint

__all__ = ["speed_correction_many", "speed_correction_fleet", "take_in_fleet"]


def speed_correction_many(calls) -> list[float]:
    """``speed_correction`` of several vessels, ``calls`` = [(coordination, t, nav, γ)]: each
    reads its arrivals and sums its gaps, then one ``tanh`` for all of them. The same factors and
    states as the calls one after the other (the link decided before them: ``decide_link``)."""
    return _factors([call[0] for call in calls], [c._consensus(t, nav, g) for c, t, nav, g in calls])


def speed_correction_fleet(coordinations, t_s: float, positions_m, gammas_m) -> list[float]:
    """``decide_link`` then :func:`speed_correction_many` of several vessels at one time ``t_s``
    (positions (2,) world [m] and γ [m] in their order) in one pass: the link decides and delivers
    for all of them at once (:meth:`~mjasc.cooperation.link.LinkEndpoint.receive_together`), each
    takes in what arrived and sums its gaps, then one ``tanh`` for the followers. The same
    factors, states, draws and statistics (each receiver's arrivals touch only its own state, so
    delivering all of them before the laws changes nothing)."""
    arrivals = LinkEndpoint.receive_together([c.link for c in coordinations], t_s, positions_m)
    # Each vessel's law as Coordination._law works it out (written out here: no _law, _team_view,
    # xi, _factor calls per vessel and tick), then one tanh for the followers, then each factor as
    # Coordination._factor computes it — the same operations in the same order.
    n_all = len(coordinations)
    laws = [None] * n_all  # (c, view, own, e, n), None: no path
    scaled = []  # the followers' e_i / e_s
    for j, (c, arrived, g) in enumerate(zip(coordinations, arrivals, gammas_m)):
        if arrived:
            c._take(t_s, arrived)
        cfg = c.config
        view = c._team
        if view is None or t_s - view.oldest_active_s > cfg.neighbour_timeout_s:
            c._time_out(t_s)  # (nothing to time out otherwise)
        length = c.path_length_m
        if length is None:
            continue
        view = c._team
        if view is None:
            view = c._team_view()
        own = (float(g) - cfg.formation_offset_m) / length  # Coordination.xi
        n = view.n_rows
        if not n:
            e = 0.0
        elif view.arrays is None and cfg.extrapolate:  # view.gap_sum's list form, written out
            acc = 0.0
            for x, rate, sent, x_end in view.rows:
                hi = x_end if x_end > x else x
                ahead = x + rate * (t_s - sent)
                acc += own - (hi if hi < ahead else ahead)
            e = view.l_bar * acc
        else:
            e = view.l_bar * view.gap_sum(t_s, cfg.extrapolate, own)
        laws[j] = (c, view, own, e, n)
        if cfg.role != "leader":
            scaled.append(e / cfg.error_scale_m)
    th = np.tanh(scaled).tolist() if scaled else ()  # (the list as a float64 array: one call)
    out = [1.0] * n_all
    k = 0
    for j, law in enumerate(laws):
        if law is None:
            continue
        c, view, own, e, n = law
        cfg = c.config
        speed = c.mission_speed_m_s
        ff = view.omega * c.path_length_m / speed
        lead = e / n if n else 0.0
        if cfg.role == "leader":
            corr = 0.0
        else:
            corr = cfg.max_speed_correction * th[k]
            k += 1
        f = ff * (1.0 - corr)
        cap = c.top_speed_m_s / speed
        f = float(cap if cap < f else f)  # (min(f, cap): f unless cap is smaller)
        c.last_error_m, c.last_factor, c.last_xi = lead, f, own
        out[j] = f
    return out


def take_in_fleet(coordinations, t_s: float, positions_m, gammas_m, limits) -> None:
    """The comms slot's second half for several vessels at one time ``t_s``: the link decides (each
    one up to ``limits``, its own message id + 1) and delivers for all of them at once
    (:meth:`~mjasc.cooperation.link.LinkEndpoint.receive_together`), then each takes in what arrived
    and notes the formation's state, as its ``Coordination.take_in(t, nav, γ, decided=True)`` after
    ``decide_link`` does (the same draws, states and statistics: a receiver's arrivals touch only
    its own state)."""
    arrivals = LinkEndpoint.receive_together([c.link for c in coordinations], t_s, positions_m, limits)
    for c, arrived, g in zip(coordinations, arrivals, gammas_m):
        if arrived:
            c._take(t_s, arrived)
        c._time_out(t_s)
        _, lead, spread, n = c.coordination_error(t_s, g)
        length = c.path_length_m  # (c.xi(g) written out)
        c.last_xi = np.nan if length is None else (float(g) - c.config.formation_offset_m) / length
        c.last_spread_m = spread
        c.note_formation(t_s, g, lead, spread, n)


def _factors(coordinations, laws) -> list[float]:
    """Each vessel's factor from its law (None: no path, factor 1): one ``tanh`` for the
    followers' e_i / e_s (a leader keeps its feed-forward), then each one's ``_factor`` in order."""
    ask, scaled = [], []  # ask: the followers with a law; scaled: their e_i / e_s
    for k, (c, law) in enumerate(zip(coordinations, laws)):
        if law is not None and c.config.role != "leader":
            ask.append(k)
            scaled.append(law[2] / c.config.error_scale_m)
    th = dict(zip(ask, np.tanh(np.array(scaled)).tolist())) if ask else {}
    return [1.0 if law is None else c._factor(law, th.get(k)) for k, (c, law) in enumerate(zip(coordinations, laws))]
