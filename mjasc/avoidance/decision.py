"""The velocity-correction choice of the decision σ (docs/thesis.md §3, §5): yield, pass first, or neither.

For a conflict σ calls a velocity correction for, the vessel yields when it can — the virtual
target's goal (γ_A − margin, t_f) holds it out of the obstructed stretch until the obstacle has
left it — and passes first otherwise — goal (γ_B + margin, t_i) — when that is allowed and
feasible within the speed limits. When neither works the caller re-plans around the swept area
(:mod:`mjasc.avoidance.replanning`). Right of way between team mates is
:mod:`mjasc.avoidance.right_of_way`; the caller applies it before asking here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjasc.avoidance.prediction import PredictedConflict
from mjasc.avoidance.velocity_correction import VelocityCorrection

__all__ = ["Correction", "velocity_correction_for", "emergency_yield"]


@dataclass
class Correction:
    """A running velocity correction: its virtual-target ``law``, ``kind`` ("yield" | "pass"), the
    track it is for, and the offset between the follower's γ and the law's γ frame (the follower's
    path can change under a running correction: a detour ends)."""

    law: VelocityCorrection
    kind: str  # "yield" | "pass"
    track_id: int
    gamma_offset_m: float = 0.0  # γ in the law's frame = follower γ + offset
    emergency: bool = False  # the slow-down of :func:`emergency_yield`: no manoeuvre cleared the conflict
    #: a yield to a stranger's track decided on its first estimates (``withdraw_new_track_s``): withdrawn
    #: when a later prediction clears it (:meth:`~mjasc.avoidance.manoeuvres.Manoeuvres._withdraw_correction`)
    withdrawable: bool = False

    @property
    def label(self) -> str:
        """What the events and the threat panel call it: its kind, or "emergency stop"."""
        return "emergency stop" if self.emergency else self.kind


def velocity_correction_for(t: float, gamma: float, c: PredictedConflict, cfg, speed_max_m_s: float,
                            pass_only: bool = False, passing: bool = False,
                            path_end_m: float = np.inf) -> Correction | None:
    """Yield if possible (not when ``pass_only``), else pass first if allowed and feasible, else None.
    ``path_end_m``: the length [m] of the path γ runs on. A pass whose goal γ_B + margin lies
    beyond it is no pass: under a correction the path is not re-drawn and the follower takes all
    way off at its end, so the vessel stops there, inside the obstructed stretch (a station-keeping
    leader in a current passed first towards a goal beyond its station and was hit there by the
    crossing ferry: tests/cas_regressions/target_tracking_current_16.toml).
    ``passing``: the vessel is already passing this track first: it goes on passing while that is
    feasible (switching to a yield halfway, and back when the next estimate moves, left a
    Delfim-class hull at neither speed in the stressed §6.4.1 crossing). ``cfg``: the
    :class:`~mjasc.avoidance.config.AvoidanceConfig` (speed_min_m_s, gain_k, correction_margin_m,
    allow_pass_first)."""
    vmin, vmax, k, m = cfg.speed_min_m_s, speed_max_m_s, cfg.gain_k, cfg.correction_margin_m
    if passing and cfg.allow_pass_first and not pass_only:
        keep = velocity_correction_for(t, gamma, c, cfg, speed_max_m_s, pass_only=True, path_end_m=path_end_m)
        if keep is not None:
            return keep
    if np.isfinite(c.t_f) and not pass_only:
        try:
            law = VelocityCorrection.yield_to(c, gamma, t, k, vmin, vmax, margin_m=m)
            if law.desired_speed >= vmin - 1e-9:
                return Correction(law, "yield", c.track_id)
        except ValueError:
            pass
    if cfg.allow_pass_first and float(c.gamma_b) + m <= float(path_end_m):
        try:
            law = VelocityCorrection.pass_first(c, gamma, t, k, vmin, vmax, margin_m=m)
            if law.feasible:
                return Correction(law, "pass", c.track_id)
        except ValueError:
            pass
    return None


def emergency_yield(t: float, gamma: float, c: PredictedConflict, cfg, speed_max_m_s: float) -> Correction:
    """When no manoeuvre clears a conflict: slow to ``emergency_speed_m_s`` (by default stop: take
    all way off, COLREG rule 8(e)) and hold it until the obstruction ends (5–30 s). The caller
    predicts again every second while it runs (a re-plan or lane change may clear the conflict a
    moment later). Creeping on at steerage way was not enough: in the §6.4.3 bottleneck two team
    mates slowed to 0.2 m/s side by side and their converging paths still brought them into contact
    half a minute later."""
    hold = float(np.clip((c.t_f if np.isfinite(c.t_f) else c.t_i) - t, 5.0, 30.0))
    vmin = cfg.emergency_speed_m_s
    law = VelocityCorrection(gamma, t, gamma + vmin * hold, t + hold, cfg.gain_k, vmin, speed_max_m_s)
    return Correction(law, "yield", c.track_id, emergency=True)
