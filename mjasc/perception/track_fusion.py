"""Team-shared perception: fusing the team's broadcast tracks with a vessel's own (issue 12).

With ``share_tracks = true`` in ``[vessels.comms]`` a vessel puts its confirmed own tracks (not
team mates, not tracks it got from the team: only what its own sensor confirmed) in each
broadcast as :class:`~mjasc.core.estimates.SharedTrack` values, nearest first, at most
``share_max_tracks`` (:func:`shareable`). A receiver with sharing on fuses the newest tracks of
every team mate with its own each time it builds its :class:`~mjasc.core.estimates.PerceptionReport`
(:class:`TeamTrackFusion`):

1. **Prediction to the receiver's time** t (a shared track was estimated at t_b ≤ its send time;
   τ = t − t_b, stale ones, τ > ``share_max_age_s``, are dropped). Constant turn with the sender's
   ω̂ (straight line when ω̂ ≈ 0), velocity v = v_x + i v_y as a complex number::

       x(t) = x_b + v (e^{iωτ} − 1) / (iω),        v(t) = v e^{iωτ}
       P(t) = P_b + (σ_v² τ² + q τ³ / 3) I           (moving tracks; static ones: P_b)

   σ_v (:data:`VELOCITY_STD_M_S`) is the velocity uncertainty the message does not carry and q
   (:data:`ACCEL_PSD`) the white-acceleration spectral density: the delay grows the covariance.

2. **Gating** (Mahalanobis on position) of every team track j against every own track i::

       d²_ij = (x_i − x_j)ᵀ (P_i + P_j + σ_c² I)⁻¹ (x_i − x_j) ≤ γ       (γ = ``share_gate``)

   σ_c = (r_i + r_j)/4 allows for the two sensors seeing different sides of the object (a
   cluster's centre lies on the seen side). A global nearest neighbour
   (``scipy.optimize.linear_sum_assignment`` on d²) picks the pairs.

3. **Covariance intersection** (Julier & Uhlmann 1997) of each pair, own a, team b::

       P⁻¹ = ω P_a⁻¹ + (1 − ω) P_b⁻¹
       x   = P (ω P_a⁻¹ x_a + (1 − ω) P_b⁻¹ x_b)
       ω   = argmin_{ω∈[0,1]} det P  =  argmax det(P_b⁻¹ + ω (P_a⁻¹ − P_b⁻¹))

   For 2 × 2 matrices det(B + ωD) = det B + ω (B₀₀D₁₁ + B₁₁D₀₀ − B₀₁D₁₀ − B₁₀D₀₁) + ω² det D, a
   quadratic: ω is its maximiser on [0, 1] in closed form (end points or the vertex; ω = ½ on a tie). CI is
   consistent whatever the (unknown) correlation of the two estimates: if P_a ≥ E[ẽ_a ẽ_aᵀ] and
   P_b ≥ E[ẽ_b ẽ_bᵀ], then P ≥ E[ẽ ẽᵀ]. The velocity is the own and the team velocity weighted by
   their share of the fused information, w_a = ω tr P_a⁻¹ / (ω tr P_a⁻¹ + (1 − ω) tr P_b⁻¹) (the
   message carries no velocity covariance); the fused track keeps the own id, ω̂ and radius.

4. **Unmatched team tracks** are added as tracks of their own (``source = "team:<sender>"``, id
   ``TEAM_TRACK_ID_BASE · (k + 1) + sender's id``, k the sender's index in the sorted team), which
   collision prediction treats like an own track — unless they are the receiver itself or a team
   mate: checked when the message arrives (:meth:`TeamTrackFusion.receive`), a team track within
   ``team_match_distance_m`` (or its radius + the receiver's) of the receiver's own position, or of
   a team mate's broadcast position with the track taken back to that broadcast's time, is dropped.

Senders are fused one after the other (sorted by name): a second team mate's track of an object
that only the team saw is fused with the first one's added track (CI again), not added twice.

World frame ENU, SI units, absolute simulation times [s].
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mjasc.core.assignment import linear_sum_assignment
from mjasc.core.estimates import SharedTrack, TrackEstimate

__all__ = ["ACCEL_PSD", "VELOCITY_STD_M_S", "TEAM_TRACK_ID_BASE", "FusionSettings", "TeamTrackFusion",
           "covariance_intersection", "predict_shared", "shareable", "fuse"]

#: σ_v [m/s]: velocity uncertainty of a shared track (not in the message), grows P by σ_v² τ².
VELOCITY_STD_M_S = 0.3
#: q [m²/s³]: white-acceleration spectral density of a moving shared track, grows P by q τ³/3.
ACCEL_PSD = 0.05
#: Added team tracks get ids TEAM_TRACK_ID_BASE · (sender index + 1) + the sender's id.
TEAM_TRACK_ID_BASE = 1_000_000
#: Floor on a covariance's diagonal [m²] (an estimate is never exact).
MIN_VARIANCE_M2 = 1e-4


@dataclass(frozen=True)
class FusionSettings:
    """What ``[vessels.comms]`` says about track sharing: at most ``max_tracks`` sent per message,
    team tracks older than ``max_age_s`` [s] dropped, gate ``gate`` on d² (χ²₂), and the team-mate
    gate ``team_match_distance_m`` [m]."""

    max_tracks: int = 8
    max_age_s: float = 3.0
    gate: float = 9.21
    team_match_distance_m: float = 5.0


# ---------------------------------------------------------------------------- sending
def shareable(tracks, own_position_m, max_tracks: int) -> tuple[SharedTrack, ...]:
    """The tracks a vessel may send: its own confirmed tracks that are not team mates and did not
    come from the team, nearest first (to ``own_position_m``), at most ``max_tracks``."""
    own = [e for e in tracks if e.team_member is None and e.source is None]
    if not own or max_tracks <= 0:
        return ()
    xy = np.array([e.position_m[:2] for e in own], dtype=float)
    d = np.hypot(*(xy - np.asarray(own_position_m, dtype=float)[:2]).T)
    out = []
    for k in np.argsort(d, kind="stable")[:max_tracks].tolist():
        e = own[k]
        v = e.speed_m_s
        out.append(SharedTrack(int(e.track_id), float(e.time_s), np.array(e.position_m[:2], dtype=float),
                               np.array([v * np.cos(e.heading_rad), v * np.sin(e.heading_rad)]),
                               float(e.turn_rate_rad_s), float(e.radius_m),
                               np.array(e.position_covariance, dtype=float).reshape(2, 2), bool(e.is_static)))
    return tuple(out)


# ---------------------------------------------------------------------------- the math over arrays
def _arrays(tracks) -> tuple:
    """(t (m,), x (m, 2), v (m, 2), ω (m,), r (m,), P (m, 2, 2), static (m,)) of shared tracks."""
    m = len(tracks)
    t = np.array([s.time_s for s in tracks], dtype=float)
    x = np.array([s.position_m for s in tracks], dtype=float).reshape(m, 2)
    v = np.array([s.velocity_m_s for s in tracks], dtype=float).reshape(m, 2)
    w = np.array([s.turn_rate_rad_s for s in tracks], dtype=float)
    r = np.array([s.radius_m for s in tracks], dtype=float)
    p = np.array([s.position_covariance for s in tracks], dtype=float).reshape(m, 2, 2)
    st = np.array([s.is_static for s in tracks], dtype=bool)
    return t, x, v, w, r, p, st


def predict_shared(t_b, x, v, w, p, static, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shared tracks (arrays, see :func:`_arrays`) predicted to ``t_s``: positions (m, 2),
    velocities (m, 2), covariances (m, 2, 2) (module docstring, step 1). τ < 0 (a track newer than
    t_s) is predicted backwards the same way, with the covariance grown by |τ|."""
    tau = t_s - np.asarray(t_b, dtype=float)
    vc = v[:, 0] + 1j * v[:, 1]
    wt = w * tau
    small = np.abs(wt) < 1e-6
    rot = np.exp(1j * wt)
    with np.errstate(divide="ignore", invalid="ignore"):
        disp = np.where(small, vc * tau * (1 + 0.5j * wt), vc * (rot - 1) / (1j * np.where(small, 1.0, w)))
    moving = ~np.asarray(static, dtype=bool)
    disp = np.where(moving, disp, 0.0)
    vel = np.where(moving, vc * rot, 0.0)
    a = np.abs(tau)
    grow = np.where(moving, VELOCITY_STD_M_S ** 2 * a ** 2 + ACCEL_PSD * a ** 3 / 3.0, 0.0)
    pp = np.array(p, dtype=float) + grow[:, None, None] * np.eye(2)
    return (x + np.stack([disp.real, disp.imag], axis=-1), np.stack([vel.real, vel.imag], axis=-1), pp)


def _inv2(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses (…, 2, 2) and determinants (…) of 2 × 2 matrices in closed form."""
    a, b, c, d = p[..., 0, 0], p[..., 0, 1], p[..., 1, 0], p[..., 1, 1]
    det = a * d - b * c
    inv = np.stack([np.stack([d, -b], -1), np.stack([-c, a], -1)], -2) / det[..., None, None]
    return inv, det


def _floor(p: np.ndarray) -> np.ndarray:
    p = 0.5 * (p + np.swapaxes(p, -1, -2))
    return p + MIN_VARIANCE_M2 * np.eye(2)


def covariance_intersection(xa, pa, xb, pb) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Covariance intersection of pairs of estimates (module docstring, step 3), ω minimizing
    det P in closed form. xa, xb (k, 2); pa, pb (k, 2, 2) → x (k, 2), P (k, 2, 2), ω (k,)."""
    xa, xb = np.asarray(xa, dtype=float).reshape(-1, 2), np.asarray(xb, dtype=float).reshape(-1, 2)
    ia, _ = _inv2(_floor(np.asarray(pa, dtype=float).reshape(-1, 2, 2)))
    ib, _ = _inv2(_floor(np.asarray(pb, dtype=float).reshape(-1, 2, 2)))
    dd = ia - ib
    c1 = ib[:, 0, 0] * dd[:, 1, 1] + ib[:, 1, 1] * dd[:, 0, 0] - ib[:, 0, 1] * dd[:, 1, 0] - ib[:, 1, 0] * dd[:, 0, 1]
    c2 = dd[:, 0, 0] * dd[:, 1, 1] - dd[:, 0, 1] * dd[:, 1, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.where(c2 < 0, -c1 / (2 * c2), 0.0)
    vertex = np.clip(np.nan_to_num(vertex), 0.0, 1.0)
    # ½ first: on a tie (equal information, D = 0) the two estimates count equally
    cands = np.stack([np.full_like(c1, 0.5), np.zeros_like(c1), np.ones_like(c1), vertex], axis=-1)
    vals = c1[:, None] * cands + c2[:, None] * cands ** 2  # det(B + ωD) − det B
    om = cands[np.arange(len(c1)), np.argmax(vals, axis=-1)]
    info = ib + om[:, None, None] * dd
    p, _ = _inv2(info)
    p = 0.5 * (p + np.swapaxes(p, -1, -2))
    y = om[:, None] * np.einsum("kij,kj->ki", ia, xa) + (1 - om)[:, None] * np.einsum("kij,kj->ki", ib, xb)
    return np.einsum("kij,kj->ki", p, y), p, om


def _gate_d2(xa, pa, ra, xb, pb, rb) -> np.ndarray:
    """d² (n, m) between n own and m team positions (module docstring, step 2)."""
    sc = ((ra[:, None] + rb[None, :]) / 4.0) ** 2
    s = pa[:, None] + pb[None, :] + sc[..., None, None] * np.eye(2)
    inv, _ = _inv2(_floor(s))
    d = xa[:, None, :] - xb[None, :, :]
    return np.einsum("nmi,nmij,nmj->nm", d, inv, d)


# ---------------------------------------------------------------------------- one fusion
@dataclass(frozen=True)
class FusionResult:
    """The fused tracks and what happened: ``fused`` [(sender, its id, own id)], ``added``
    [(sender, its id, new id)]."""

    tracks: tuple
    fused: tuple = ()
    added: tuple = ()


def fuse(own: tuple, team: dict, t_s: float, team_order: list[str], gate: float = 9.21,
         max_age_s: float = 3.0) -> FusionResult:
    """Own tracks (TrackEstimate) fused with ``team``: sender → tuple of SharedTrack (already
    cleared of the receiver and its team mates), at time ``t_s`` (module docstring, steps 1–4).
    ``team_order``: the team's names (a sender's index in it makes the ids of its added tracks)."""
    out = list(own)
    fused, added = [], []
    for sender in sorted(team):
        shared = [s for s in team[sender] if t_s - s.time_s <= max_age_s]
        if not shared:
            continue
        tb, xb, vb, wb, rb, pb, stb = _arrays(shared)
        xb, vb, pb = predict_shared(tb, xb, vb, wb, pb, stb, t_s)
        cand = [k for k, e in enumerate(out) if e.team_member is None]
        matched = np.zeros(len(shared), dtype=bool)
        if cand:
            ea = [out[k] for k in cand]
            xa = np.array([e.position_m[:2] for e in ea], dtype=float)
            pa = np.array([e.position_covariance for e in ea], dtype=float).reshape(-1, 2, 2)
            ra = np.array([e.radius_m for e in ea], dtype=float)
            d2 = _gate_d2(xa, pa, ra, xb, pb, rb)
            d2[np.array([e.is_static for e in ea])[:, None] != stb[None, :]] = np.inf
            inside = d2 <= gate
            if inside.any():
                rows, cols = linear_sum_assignment(np.where(inside, d2, 1e12))
                ok = inside[rows, cols]
                rows, cols = rows[ok], cols[ok]
                if rows.size:
                    xf, pf, om = covariance_intersection(xa[rows], pa[rows], xb[cols], pb[cols])
                    ia, _ = _inv2(_floor(pa[rows]))
                    ib, _ = _inv2(_floor(pb[cols]))
                    ta, tbb = om * np.trace(ia, axis1=1, axis2=2), (1 - om) * np.trace(ib, axis1=1, axis2=2)
                    wa = ta / (ta + tbb)
                    for q, (i, j) in enumerate(zip(rows.tolist(), cols.tolist())):
                        e = ea[i]
                        va = e.speed_m_s * np.array([np.cos(e.heading_rad), np.sin(e.heading_rad)])
                        vf = wa[q] * va + (1 - wa[q]) * vb[j]
                        sp = float(np.hypot(*vf))
                        out[cand[i]] = replace(e, position_m=xf[q], position_covariance=pf[q], speed_m_s=sp,
                                               heading_rad=float(np.arctan2(vf[1], vf[0])) if sp > 1e-9 else e.heading_rad)
                        fused.append((sender, shared[j].track_id, e.track_id))
                    matched[cols] = True
        k_sender = team_order.index(sender) if sender in team_order else len(team_order)
        for j in np.flatnonzero(~matched).tolist():
            s = shared[j]
            sp = float(np.hypot(*vb[j]))
            new_id = TEAM_TRACK_ID_BASE * (k_sender + 1) + int(s.track_id)
            out.append(TrackEstimate(new_id, float(t_s), xb[j].copy(), float(np.arctan2(vb[j, 1], vb[j, 0])), sp,
                                     float(s.turn_rate_rad_s), float(s.radius_m), pb[j].copy(), bool(s.is_static),
                                     source=f"team:{sender}"))
            added.append((sender, int(s.track_id), new_id))
    return FusionResult(tuple(out), tuple(fused), tuple(added))


def drop_team_members(shared: tuple, t_s: float, own_position_m, own_radius_m: float, team_positions: dict,
                      match_distance_m: float) -> tuple:
    """The shared tracks that are neither the receiver (at ``own_position_m`` at ``t_s``) nor a
    team mate (``team_positions`` name → (t_b, position (2,)), the track taken back to t_b) —
    module docstring, step 4. Array code over tracks × broadcasts."""
    if not shared:
        return ()
    tb, x, v, w, r, p, st = _arrays(shared)
    xt, vt, _ = predict_shared(tb, x, v, w, p, st, t_s)
    keep = np.hypot(*(xt - np.asarray(own_position_m, dtype=float)[:2]).T) > np.maximum(match_distance_m,
                                                                                       r + own_radius_m)
    if team_positions:
        tm = np.array([float(v_[0]) for v_ in team_positions.values()])
        pm = np.array([np.asarray(v_[1], dtype=float)[:2] for v_ in team_positions.values()]).reshape(-1, 2)
        back = xt[:, None, :] - vt[:, None, :] * (t_s - tm)[None, :, None]
        near = np.hypot(back[..., 0] - pm[:, 0], back[..., 1] - pm[:, 1]) <= np.maximum(match_distance_m, r)[:, None]
        keep &= ~near.any(axis=1)
    return tuple(s for s, k in zip(shared, keep.tolist()) if k)


class TeamTrackFusion:
    """One vessel's team-shared perception state: the newest team tracks of each sender (cleared of
    the receiver and its team mates when received), the fusion into its report, the counts for the
    summary and an event when a team track is first used."""

    def __init__(self, name: str, team: list[str], radius_m: float, settings: FusionSettings):
        self.name, self.team, self.radius_m, self.settings = name, sorted(team), float(radius_m), settings
        self._tracks: dict[str, tuple] = {}
        self._sent_t: dict[str, float] = {}
        self._events: list[tuple[float, str]] = []
        self.used_fused: set = set()  # (sender, its id) fused with an own track at least once
        self.used_added: set = set()  # (sender, its id) added as a track at least once
        self.dropped_team = 0  # shared tracks dropped as the receiver or a team mate
        self.received = 0

    def receive(self, t_s: float, by_sender: dict, own_position_m, team_positions: dict) -> None:
        """``by_sender``: name → (sent time, tuple of SharedTrack), each team mate's newest message;
        a message newer than the one kept replaces its sender's tracks."""
        for sender, (sent, tracks) in by_sender.items():
            if sender == self.name or self._sent_t.get(sender) == sent:
                continue
            self._sent_t[sender] = sent
            others = {n: v for n, v in team_positions.items() if n != self.name}
            keep = drop_team_members(tuple(tracks), t_s, own_position_m, self.radius_m, others,
                                     self.settings.team_match_distance_m)
            self.received += len(tracks)
            self.dropped_team += len(tracks) - len(keep)
            self._tracks[sender] = keep

    def fuse(self, own: tuple, t_s: float) -> tuple:
        """The own tracks with the newest team tracks fused in (:func:`fuse`)."""
        team = {s: tr for s, tr in self._tracks.items() if tr}
        if not team:
            return tuple(own)
        times = [e.time_s for e in own]
        t_ref = max(times) if times else t_s
        res = fuse(tuple(own), team, t_ref, self.team, self.settings.gate, self.settings.max_age_s)
        for sender, sid, own_id in res.fused:
            if (sender, sid) not in self.used_fused:
                self.used_fused.add((sender, sid))
                self._events.append((t_s, f"team track {sender}#{sid} first used: fused with own track {own_id}"))
        for sender, sid, new_id in res.added:
            if (sender, sid) not in self.used_added:
                self.used_added.add((sender, sid))
                self._events.append((t_s, f"team track {sender}#{sid} first used: added as track {new_id} "
                                          f"(not seen by the own sensor)"))
        return res.tracks

    def drain_events(self) -> list[tuple[float, str]]:
        out, self._events = self._events, []
        return out

    def summary(self) -> dict:
        return {"team_tracks_received": self.received, "team_tracks_dropped_as_team": self.dropped_team,
                "team_tracks_fused": len(self.used_fused), "team_tracks_added": len(self.used_added)}
