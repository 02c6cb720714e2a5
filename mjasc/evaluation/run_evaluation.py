"""The evaluation of one run against the truth: every encounter of a vessel with non-team traffic
(closest approach, near miss, COLREG role and compliance) and every vessel's tracking quality.

:class:`RunEvaluator` is a runner observer of the record slot (``Runner.observe("record", ev)``):
it samples the true states of the vessels and of the moving obstacles (traffic), and each vessel's
confirmed tracks, at the record rate. :meth:`RunEvaluator.summary` then evaluates:

* **encounters** — for each (vessel, traffic object) pair that comes within ``encounter_range_m``
  while closing: the onset (first such time), the closest approach (CPA: the minimum centre distance
  and its time; the separation = CPA distance − both radii, negative = overlap), whether it was a
  near miss (separation below ``near_miss_m``), the own vessel's COLREG role at the onset
  (:func:`mjasc.evaluation.colreg.classify`) and its compliance over [onset, CPA + ``after_cpa_s``]
  (:func:`mjasc.evaluation.colreg.judge_compliance`);
* **tracking** — per vessel with perception, GOSPA of its confirmed tracks against the truth objects
  (the other vessels and the traffic; those outside its sensor's range and field of view, and its
  static tracks, optional: never missed, never false), identity switches, time to confirm
  (:class:`mjasc.evaluation.tracking_metrics.TrackingScore`);
* **cost** (:meth:`RunEvaluator.cost`, given the reference run's trace) — per vessel with a path, the
  path-length and time cost against the same mission without traffic
  (:mod:`mjasc.evaluation.mission_cost`; the evaluator's :class:`ProgressTrace` samples γ).

World frame ENU, SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import check_params, param
from mjasc.evaluation.colreg import ColregConfig, classify, judge_compliance
from mjasc.evaluation.mission_cost import ProgressTrace, mission_cost, zero_cost
from mjasc.evaluation.track_samples import TrackSamples
from mjasc.evaluation.tracking_metrics import TrackingScore, flat_rows
from mjasc.evaluation.traffic_truth import traffic_at

__all__ = ["EvaluationConfig", "RunEvaluator"]


@dataclass(frozen=True)
class EvaluationConfig:
    """How a run is judged (not seen by the vessels)."""

    encounter_range_m: float = param(130.0, positive=True, unit="m",
                                     doc="an encounter starts when the traffic comes this close while closing; its "
                                         "COLREG role is judged then — keep it beyond the sensors' range, before "
                                         "the vessel can react")
    near_miss_m: float = param(1.0, nonneg=True, unit="m",
                               doc="a closest approach with less separation (hull circles) is a near miss")
    after_cpa_s: float = param(10.0, nonneg=True, unit="s", doc="compliance is judged until this long after CPA")
    gospa_cutoff_m: float = param(10.0, positive=True, unit="m", doc="GOSPA's cut-off c")
    gospa_order: float = param(2.0, minimum=1.0, doc="GOSPA's order p")
    colreg: ColregConfig = param(default_factory=ColregConfig, doc="role and compliance thresholds")
    cost_tolerance_m: float = param(0.5, nonneg=True, unit="m",
                                    doc="mission cost: run and reference are compared where the run's progress "
                                        "was this much short of its final progress (a vessel loitering at its "
                                        "path's end creeps on by millimetres)")

    def __post_init__(self):
        check_params(self, "evaluation")


def _course(velocity, heading) -> np.ndarray:
    """Course over ground [rad] where the speed exceeds 0.1 m/s, else the heading."""
    v = np.asarray(velocity, dtype=float)
    speed = np.hypot(v[..., 0], v[..., 1])
    return np.where(speed > 0.1, np.arctan2(v[..., 1], v[..., 0]), heading)


class RunEvaluator:
    """Runner observer (record slot) that evaluates a run (module docstring).

    At each record tick it only keeps the samples (the vessels' headings and velocities, copied
    into growing arrays; each vessel's confirmed tracks as ids, positions and static flags; and the
    :class:`ProgressTrace`: the times, the positions and γ); :meth:`summary` evaluates them at once — the traffic at the record times
    (:func:`~mjasc.evaluation.traffic_truth.traffic_at`), the tracking scores flat
    (:meth:`TrackingScore.add_rows`) — the same numbers as reading the traffic and scoring each
    tick as it comes."""

    def __init__(self, runner, config: EvaluationConfig | None = None):
        self.config = config if config is not None else EvaluationConfig()
        world = runner.world
        self.vessel_names = list(world.vessel_names)
        self.vessel_radii = np.array([t.radius_m for t in world.vessel_types])
        self.traffic_names = [o.name for o in world.moving_obstacles]
        self.traffic_radii = np.array([o.radius_m for o in world.moving_obstacles])
        n = len(self.vessel_names)  # per tick: headings (k, n) [rad], velocities (k, n, 2) [m/s], rows 0 … k − 1
        self._h, self._v, self._k = np.empty((256, n)), np.empty((256, n, 2)), 0  # (times, positions: self.progress)
        self._p_made = None  # (ticks, positions (k, n, 2) [m]) of self.progress.p: _positions
        self._traffic_set = runner.sim.traffic  # (evaluated at the record times at the end: _traffic)
        self._traffic_made = None  # (ticks, positions, headings, velocities) of _traffic
        self._scores: dict[int, TrackingScore] = {}
        self._tracks: dict[int, list] = {}  # vessel → per tick (track ids (k,), positions (k, 2))
        self._scored = 0  # ticks already in self._scores
        self.progress = ProgressTrace(runner)
        self._perceptions = []
        for i, agent in enumerate(runner.agents):
            if agent.perception is not None:
                sensor = getattr(agent.perception, "sensor_config", None)
                rng = float(getattr(sensor, "max_range_m", math.inf))
                fov = math.radians(float(getattr(sensor, "fov_deg", 360.0)))
                self._scores[i] = TrackingScore(self.config.gospa_cutoff_m, self.config.gospa_order, rng, fov)
                self._tracks[i] = []
                self._perceptions.append((i, agent.perception))
        # Built-in trackers of one fleet: every vessel's confirmed tracks in one compiled call per tick
        # (TrackSamples), each vessel's taken when scored; plugin trackers: one call each.
        self._owner_of: dict[int, int] = {}
        trackers = [(i, p.tracker) for i, p in self._perceptions if p.method is None]
        if trackers and len(trackers) == len(self._perceptions) and \
                len({id(p.fleet) for _, p in self._perceptions}) == 1 and \
                len({id(tr.fleet) for _, tr in trackers}) == 1:
            self._owner_of = {i: tr.owner for i, tr in trackers}
        self._moving = TrackSamples()  # per tick: every vessel's confirmed tracks (with _owner_of)

    def __call__(self, event) -> None:
        s = event.states
        k = self._k
        if k == self._h.shape[0]:  # (full: twice the room)
            self._h = np.concatenate([self._h, np.empty_like(self._h)])
            self._v = np.concatenate([self._v, np.empty_like(self._v)])
        self._h[k] = s.heading_rad
        self._v[k] = s.velocity_m_s
        self._k = k + 1
        self.progress(event)  # (the record times: the traffic is evaluated at them at the end, _traffic)
        if self._owner_of:
            self._moving.add(self._perceptions[0][1].tracker.fleet, s.time_s)  # (tracker: after the flush)
            return
        for i, perception in self._perceptions:
            self._tracks[i].append(perception.scored_tracks(s.time_s))

    def _traffic(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The traffic's positions (k, M, 2), headings (k, M), velocities (k, M, 2) at the record
        ticks: the numbers of ``Simulation.traffic_state`` there, evaluated at the record times in
        one pass (:func:`~mjasc.evaluation.traffic_truth.traffic_at`; kept until a new tick)."""
        k = len(self.progress.t)
        if self._traffic_made is None or self._traffic_made[0] != k:
            a = traffic_at(self._traffic_set, self.progress.t)
            self._traffic_made = (k, a[:, :, 0:2].copy(), a[:, :, 2].copy(), a[:, :, 3:5].copy())
        return self._traffic_made[1:]

    def _positions(self) -> np.ndarray:
        """``self.progress.p`` as one array (k, n, 2) [m] (kept until a new tick)."""
        k = len(self.progress.p)
        if self._p_made is None or self._p_made[0] != k:
            self._p_made = (k, np.array(self.progress.p, dtype=float).reshape(k, len(self.vessel_names), 2))
        return self._p_made[1]

    def _score(self) -> None:
        """Score every tick not yet scored (:meth:`TrackingScore.add_rows`)."""
        k0, k1 = self._scored, len(self.progress.t)
        if not self._scores or k1 <= k0:
            return
        moving = self._moving.of(self._owner_of.values(), k0, k1) if self._owner_of else None
        t = self.progress.t[k0:k1]
        p = self._positions()[k0:k1]
        xy = np.concatenate([p, self._traffic()[0][k0:k1]], axis=1)
        ids = self.vessel_names + self.traffic_names
        radii = np.concatenate([self.vessel_radii, self.traffic_radii])
        for i, score in self._scores.items():
            others = [k for k in range(len(ids)) if k != i]
            if moving is not None:
                counts, track_ids, track_xy, static = moving[self._owner_of[i]]
            else:
                tracks = self._tracks[i][k0:k1]
                counts, track_ids, track_xy = flat_rows([ti for ti, _, _ in tracks], [tx for _, tx, _ in tracks])
                static = np.concatenate([np.zeros(0, dtype=bool)] + [ts for _, _, ts in tracks])
            score.add_rows(t, p[:, i], [ids[k] for k in others], xy[:, others], counts, track_ids, track_xy,
                           radii[others], static, self._h[k0:k1, i])
        self._scored = k1

    # ------------------------------------------------------------------ evaluation
    def encounters(self) -> list[dict]:
        """One entry per (vessel, traffic object) encounter (module docstring)."""
        if not self.progress.t or not self.traffic_names:
            return []
        cfg = self.config
        t = np.array(self.progress.t)
        k = len(t)
        p, h, v = self._positions(), self._h[:k], self._v[:k]
        q, qh, w = self._traffic()
        out = []
        for i, name in enumerate(self.vessel_names):
            for j, other in enumerate(self.traffic_names):
                rel = q[:, j] - p[:, i]
                rng = np.hypot(rel[:, 0], rel[:, 1])
                closing = np.sum(rel * (w[:, j] - v[:, i]), axis=1) < 0.0
                near = np.flatnonzero((rng <= cfg.encounter_range_m) & (closing | (rng <= cfg.encounter_range_m / 2)))
                if near.size == 0:
                    continue
                k0 = int(near[0])
                k_cpa = k0 + int(np.argmin(rng[k0:]))
                sep = float(rng[k_cpa] - self.vessel_radii[i] - self.traffic_radii[j])
                own_course = float(_course(v[k0, i], h[k0, i]))
                tgt_course = float(_course(w[k0, j], qh[k0, j]))
                role = classify(p[k0, i], own_course, float(np.hypot(*v[k0, i])), q[k0, j], tgt_course,
                                float(np.hypot(*w[k0, j])), cfg.colreg)
                k1 = int(np.searchsorted(t, t[k_cpa] + cfg.after_cpa_s, side="right"))
                sl = slice(k0, max(k1, k_cpa + 1))
                judged = judge_compliance(role, t[sl], p[sl, i], h[sl, i], v[sl, i], q[sl, j], w[sl, j], cfg.colreg)
                out.append({"vessel": name, "other": other, "onset_s": round(float(t[k0]), 3),
                            "onset_range_m": round(float(rng[k0]), 3), "cpa_time_s": round(float(t[k_cpa]), 3),
                            "cpa_distance_m": round(float(rng[k_cpa]), 3), "separation_m": round(sep, 3),
                            "near_miss": sep < cfg.near_miss_m, "collision": sep < 0.0, "role": role,
                            "compliant": judged.compliant, "compliance_issues": list(judged.reasons),
                            "acted": judged.acted,
                            "action_range_m": None if judged.action_range_m is None else round(judged.action_range_m, 3)})
        return out

    def cost(self, reference: ProgressTrace | None) -> dict:
        """Per vessel with a path, the cost against ``reference`` (the same mission without traffic;
        None: the run had no traffic and is its own reference), :func:`mission_cost`."""
        if reference is None:
            return zero_cost(self.progress, self.config.cost_tolerance_m)
        return mission_cost(self.progress, reference, self.config.cost_tolerance_m)

    def summary(self) -> dict:
        """``{"encounters": [...], "tracking": {vessel: {...}}}``."""
        self._score()
        return {"encounters": self.encounters(),
                "tracking": {self.vessel_names[i]: s.summary() for i, s in self._scores.items()}}
