"""Multi-target tracking for one vessel: detections → IMM tracks (thesis §3.2.1, docs/thesis.md §2).

Every track of a vessel lives in one batched :class:`mjasc.perception.imm.IMMBank` (all tracks predicted
and updated in one call). One :meth:`MultiTargetTracker.step` per scan:

1. **Prediction and gating**, 2. **global nearest neighbour** association
   (:mod:`~mjasc.perception.tracking.association`): each track's combined estimate predicted to
   the scan time, chi-square gate on the innovation, ``linear_sum_assignment`` on −2 log-likelihood;
   each track takes at most one detection per scan and vice versa.
3. **Update** of every track at once: assigned tracks with their detection (and its σ²), the
   others coast (``IMMBank.update(z, t, mask, measurement_variance)``).
4. **Track management.** A track is born *tentative* from a detection that no track claimed and
   that lies outside every track's gate and disc; it is *confirmed* once it was updated in
   ``confirm_hits`` (M) of its last ``confirm_window`` (N) scans, and a tentative track that can no
   longer reach M of N is dropped silently (clutter). A confirmed track is *lost* when it was not
   updated for ``max_coast_s`` (occlusions shorter than that are coasted and recovered), when its
   1-σ position uncertainty exceeds ``max_position_std_m``, or when its predicted position is out
   of sensor range (beyond ``max_range_m + range_margin_m``). Two tracks closer than
   ``merge_fraction`` × the larger radius describe one object: the one with fewer updates goes.
5. **Radius** per track: the detections' radii, smoothed asymmetrically (quick to grow, slow to
   shrink: an elongated hull looks narrow bow-on).
6. **Static objects**: a confirmed track older than ``static_min_age_s`` whose speed estimate is
   below ``static_speed_m_s`` is static (``TrackEstimate.is_static``); it becomes moving again above
   twice that speed. **Outline from the returns**: while a track is slower than
   ``static_speed_m_s`` the world-frame returns of its detections (``step(..., points_m=...)``) are
   accumulated as the convex hull of everything seen of it (returns farther than
   ``1.5·R + 0.5 m`` from its centre — another object's, merged into one cluster — are left out);
   the accumulation restarts when the track moves (faster than twice that speed, or its centre
   more than ``outline_reset_m`` from where the accumulation started). The outline handed on
   (``TrackEstimate.outline_m``, for every confirmed track slower than ``static_speed_m_s``) is that
   hull united with its reflection through the track's centre (a hull is roughly point-symmetric
   about midships; only the side facing the sensor is ever seen at once); without returns, the
   12-gon circumscribing the track's disc.
7. **Team mates** are tracked like anything else; :meth:`set_team_positions` receives the team's
   broadcast positions ``{name: (t_b, position)}`` and each confirmed track is matched (GNN, gate
   ``team_match_distance_m``) against them, comparing the broadcast with the track's position
   extrapolated back to t_b; a match sets ``TrackEstimate.team_member``.

Events (born, confirmed, lost, with the reason) are kept for the recording.

Modules (one concept each):

* :mod:`~mjasc.perception.tracking.config` — :class:`TrackingConfig` (every parameter declared
  once), :func:`parse_tracking_options`;
* :mod:`~mjasc.perception.tracking.association` — items 1–2: prediction, gating, GNN;
* :mod:`~mjasc.perception.tracking.manoeuvre` — the manoeuvre detector (adjustable process noise);
* :mod:`~mjasc.perception.tracking.management` — items 4–6: M-of-N confirmation, coasting and
  loss, merging, radius, static test;
* :mod:`~mjasc.perception.tracking.outlines` — item 6: outlines of slow tracks from their returns;
* :mod:`~mjasc.perception.tracking.team` — item 7: team mates recognised from their broadcasts;
* :mod:`~mjasc.perception.tracking.tracker` — :class:`MultiTargetTracker`, one step per scan
  (item 3, the update), and :class:`TrackEvent`.
"""

from mjasc.perception.tracking.config import TrackingConfig, parse_tracking_options
from mjasc.perception.tracking.tracker import MultiTargetTracker, TrackEvent

__all__ = ["TrackingConfig", "MultiTargetTracker", "TrackEvent", "parse_tracking_options"]
