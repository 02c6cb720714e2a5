"""Collision prediction: temporal and spatial correlation of a vessel's plan with its tracks.

Digest §3 (thesis §3.2.2). World frame ENU, SI units, absolute simulation times [s].

1. **Time window** W = [t₀, t₀ + δ], δ = v₀/a_brake + ζ (or a fixed δ; the thesis used 30 s).
2. **Temporal correlation.** P_v(t) = the vessel's path at γ(t) (its speed profile), P_o(t) = the
   track's constant-speed, constant-turn prediction (or a team mate's broadcast plan);
   d(t) = ‖P_v(t) − P_o(t)‖ on a time grid for all tracks at once, its local minima refined in
   closed form (the CPA of linear relative motion between samples, polished on true positions).
   A collision is predicted at a minimum t_c when d(t_c) ≤ R_vh + R_ob + safety (thesis eq. 3.16
   plus the safety distance).
3. **Spatial correlation** (only after a predicted collision). The obstruction interval
   Δt_o = [t_i, t_f] ∋ t_c is the continuous span of time during which the obstacle's inflated
   disc (radius R_ob + R_vh + safety) intersects the vessel's *path ahead* (γ ≥ γ_now), not the
   vessel; [γ_A, γ_B] is the connected stretch of path covered by the union of those discs over
   [t_i, t_f] that contains γ(t_c); P_A, P_B are its end points. A static obstacle obstructs for
   ever: t_f = +inf.
4. **Decision** σ(Δt_o) (thesis eq. 3.17): t_f − t_i ≥ Δt_threshold → REPLAN, with a static
   virtual obstacle (SVO) = the swept area of the inflated disc over [t_i, t_f] as a CCW polygon;
   otherwise VELOCITY_CORRECTION. Static obstacles always → REPLAN.

Deviation from the thesis (switchable): the thesis takes t_c = the *first* local minimum of d(t)
and stops if it is not a collision. A first near miss would then hide a collision later in the
window (e.g. a path that turns back toward an obstacle). By default t_c is the first local minimum
that *is* a collision (the first minimum if none is); ``stop_at_first_minimum=True`` gives the
thesis's rule.

Modules: :mod:`~mjasc.avoidance.prediction.config` (:class:`CollisionPredictionConfig`, the
parameters), :mod:`~mjasc.avoidance.prediction.timing` (the window δ and γ(t), step 1),
:mod:`~mjasc.avoidance.prediction.motion` (:class:`TrackMotions`: many tracks' predicted positions
in one array operation), :mod:`~mjasc.avoidance.prediction.cpa` (closest approaches of many
pairs in closed form, step 2's minima), :mod:`~mjasc.avoidance.prediction.spatial` (step 3),
:mod:`~mjasc.avoidance.prediction.conflicts` (:func:`predict_conflicts` and its fleet form
:func:`predict_fleet`: steps 2–4), :mod:`~mjasc.avoidance.prediction.svo` (the static virtual
obstacle polygons).
"""

from mjasc.avoidance.prediction.config import CollisionPredictionConfig, read_window_s
from mjasc.avoidance.prediction.conflicts import (Decision, PredictedConflict, PredictionQuery, predict_conflicts,
                                                  predict_fleet)
from mjasc.avoidance.prediction.motion import TrackMotions
from mjasc.avoidance.prediction.svo import svo_polygon, swept_disc_polygon
from mjasc.avoidance.prediction.timing import SpeedProfile, gamma_of_time, prediction_window, speed_now

__all__ = ["CollisionPredictionConfig", "read_window_s", "Decision", "PredictedConflict", "PredictionQuery",
           "predict_conflicts", "predict_fleet", "TrackMotions",
           "svo_polygon", "swept_disc_polygon", "SpeedProfile", "gamma_of_time", "prediction_window", "speed_now"]
