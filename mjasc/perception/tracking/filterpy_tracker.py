"""The ``filterpy_imm`` tracking method: a multi-target tracker whose every track is filterpy's
``IMMEstimator`` over the thesis bank — the reference the project's batched IMM is compared with
(docs/perception.md, "Tracking methods compared"; ``benchmarks/bench_perception.py --methods``).

Per vessel and per track, in Python loops (its cost is part of the comparison):

* **filter** of each track: :class:`mjasc.perception.imm.filterpy_reference.FilterpyIMMTracker` at
  a variable sample time — the project's start-up CV filter until course and speed are
  determined, then filterpy's ``IMMEstimator`` of the seven ``KalmanFilter`` models of thesis
  Table 6.1 (EKF prediction of eq. 3.3, CV at ω = 0 and the constant-turn models), each cycle's
  Q and Markov matrix for its own Ts, R = σ² I of the detection, the probability floor, coasting
  with μ ← c̄;
* **association**: the project's gated global nearest neighbour
  (:func:`~mjasc.perception.tracking.association.association_costs`,
  :func:`~mjasc.perception.tracking.association.gnn_assign`): each track's combined estimate
  predicted to the scan, χ²₂ gate, least total d² + ln det S; a partly hidden detection's variance
  inflated by the unseen part of the track's radius;
* **management**: the project's :class:`~mjasc.perception.tracking.management.TrackManagement`
  (M-of-N confirmation, loss after ``max_coast_s``, by uncertainty or out of range, merging,
  radius, static flag); births from detections no track gated and outside every track's disc.

What it does not have (the built-in ``imm`` has): the manoeuvre detector (adjustable process
noise), the bank's own per-model gate and restart after gated measurements, the speed-sign
re-parametrization (a negative V is reported as the opposite course), outlines of slow tracks
(``outline_m`` is None). Its options are the subset of
:class:`~mjasc.perception.tracking.config.TrackingConfig` it uses, declared as there.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, show
from mjasc.core.estimates import TrackEstimate
from mjasc.perception.detection import DetectionConfig
from mjasc.perception.imm.config import IMMConfig
from mjasc.perception.imm.filterpy_reference import FilterpyIMMTracker
from mjasc.perception.imm.compiled_cycle import wrap
from mjasc.perception.tracking.association import association_costs, gnn_assign
from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.management import TrackManagement
from mjasc.plugins.stages import TrackingMethod

__all__ = ["FilterpyIMMOptions", "FilterpyIMMMethod", "check_filterpy_options"]

_TRACKING = {f.name: f for f in dataclasses.fields(TrackingConfig)}


def _as_in_tracking(name: str):
    """The field ``name`` declared as in :class:`TrackingConfig` (default, bounds, unit, doc)."""
    f = _TRACKING[name]
    if f.default_factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=f.default_factory, metadata=f.metadata)
    return dataclasses.field(default=f.default, metadata=f.metadata)


@dataclass(frozen=True)
class FilterpyIMMOptions:
    """The options of ``filterpy_imm``: the fields of :class:`TrackingConfig` it uses, with the
    same defaults, bounds and meaning (docs/perception.md, Tracking)."""

    imm: IMMConfig = _as_in_tracking("imm")
    detection: DetectionConfig = _as_in_tracking("detection")
    use_detection_variance: bool = _as_in_tracking("use_detection_variance")
    gate_probability: float = _as_in_tracking("gate_probability")
    confirm_hits: int = _as_in_tracking("confirm_hits")
    confirm_window: int = _as_in_tracking("confirm_window")
    max_coast_s: float = _as_in_tracking("max_coast_s")
    max_position_std_m: float = _as_in_tracking("max_position_std_m")
    range_margin_m: float = _as_in_tracking("range_margin_m")
    merge_fraction: float = _as_in_tracking("merge_fraction")
    static_speed_m_s: float = _as_in_tracking("static_speed_m_s")
    static_min_age_s: float = _as_in_tracking("static_min_age_s")
    radius_grow_gain: float = _as_in_tracking("radius_grow_gain")
    radius_shrink_gain: float = _as_in_tracking("radius_shrink_gain")
    team_match_distance_m: float = _as_in_tracking("team_match_distance_m")
    team_max_age_s: float = _as_in_tracking("team_max_age_s")
    map_cell_m: float = _as_in_tracking("map_cell_m")
    map_min_hits: int = _as_in_tracking("map_min_hits")

    def __post_init__(self):
        check_params(self, "tracking")
        check_filterpy_options(self, "tracking")

    gate_threshold = TrackingConfig.gate_threshold


def check_filterpy_options(c: FilterpyIMMOptions, where: str) -> None:
    """M ≤ N (ConfigError naming ``f"{where}.confirm_hits"``)."""
    if c.confirm_hits > c.confirm_window:
        raise ConfigError(f"{where}.confirm_hits: must be ≤ confirm_window ({c.confirm_window}), "
                          f"got {show(c.confirm_hits)}")


def _fmt(p) -> str:
    return f"({p[0]:.1f}, {p[1]:.1f}) m"


class FilterpyIMMMethod(TrackingMethod):
    """Multi-target tracking with one filterpy ``IMMEstimator`` per track (module docstring)."""

    method = "filterpy_imm"
    Options = FilterpyIMMOptions
    check_options = staticmethod(check_filterpy_options)

    def __init__(self, context=None, options: FilterpyIMMOptions | None = None):
        super().__init__(context, options)
        self.max_range_m = context.sensor_range_m if context is not None else math.inf
        self.mgmt = TrackManagement(self.options)
        self.filters: list[FilterpyIMMTracker] = []
        self.ids: list[int] = []
        self._next_id = 0
        self._gate = self.options.gate_threshold
        self._R = float(self.options.imm.measurement_variance_m2)
        self.counts = dict.fromkeys(("born", "confirmed", "lost", "merged"), 0)
        self.filter_cycles = 0  # IMM cycles run (updates and coasts of every track)
        self._events: list[tuple[float, str]] = []

    def __len__(self) -> int:
        return len(self.filters)

    # ------------------------------------------------------------------ one scan
    def update(self, t_s: float, nav, detections) -> None:
        o, mg = self.options, self.mgmt
        t = float(t_s)
        d = detections
        sel = np.flatnonzero(d.targets) if d is not None and len(d) else np.zeros(0, dtype=np.int64)
        z = d.centres_m[sel] if sel.size else np.zeros((0, 2))
        var = (d.variances_m2[sel] if o.use_detection_variance else np.full(sel.size, self._R)) if sel.size \
            else np.zeros(0)
        rad = d.radii_m[sel] if sel.size else np.zeros(0)
        occ = d.occluded[sel] if sel.size and d.occluded is not None else np.zeros(sel.size, dtype=bool)
        n, m = len(self.filters), z.shape[0]
        assigned = np.full(n, -1)
        claimed = np.zeros(m, dtype=bool)
        var_p = np.zeros((n, m))
        if n and m:  # 1–2: gated GNN on the combined estimates predicted to the scan
            fs = self.filters
            states = np.array([f.state for f in fs])
            covs = np.array([f.state_covariance for f in fs])
            times = np.array([f.time_s for f in fs])
            omegas = np.array([f.turn_rate for f in fs])
            var_p = var[None, :] + occ[None, :] * np.maximum(mg.cols.radius[:, None] - rad[None, :], 0.0) ** 2
            d2, cost = association_costs(states, covs, times, omegas, z, var_p, t)
            inside = d2 <= self._gate
            claimed = inside.any(axis=0)
            assigned = gnn_assign(inside, cost)
        used = np.zeros(n, dtype=bool)
        for k, f in enumerate(self.filters):  # 3: each track's filterpy IMM, one by one
            j = assigned[k]
            if j >= 0:
                used[k] = f.update(z[j], t, var_p[k, j] if o.use_detection_variance else None)
            else:
                f.predict(t)
        self.filter_cycles += n
        if n:  # 4: management — confirmation, radius, static, then losses and merges
            speeds = np.array([abs(f.speed) for f in self.filters])
            new_conf = mg.after_update(slice(None), t, used, assigned, rad, occ, speeds)
            for k in np.flatnonzero(new_conf).tolist():
                self.counts["confirmed"] += 1
                self._events.append((t, f"track {self.ids[k]} confirmed at {_fmt(self.filters[k].position)} "
                                        f"(born {t - mg.cols.born[k]:.1f} s ago)"))
            self._prune(t, None if d is None else d.origin_m)
        if m:
            self._births(t, z, var, rad, claimed)
        if self.filters:
            mg.note_moved(np.array([f.position for f in self.filters]))

    def _prune(self, t: float, origin) -> None:
        mg, n = self.mgmt, len(self.filters)
        pos = np.array([f.position for f in self.filters])
        P = np.array([f.position_covariance for f in self.filters])
        org = np.tile(np.full(2, np.nan) if origin is None else np.asarray(origin, dtype=float), (n, 1))
        conf = mg.cols.confirmed.copy()
        drop, reason, merged = mg.drops(np.arange(n), np.zeros(n, dtype=np.int64), t, pos, P, org,
                                        np.full(n, self.max_range_m))
        for go, keep in merged:
            self.counts["merged"] += 1
            self._events.append((t, f"track {self.ids[go]} merged into track {self.ids[keep]}"))
        for j in np.flatnonzero(drop & conf).tolist():
            if reason[j]:
                self.counts["lost"] += 1
                self._events.append((t, f"track {self.ids[j]} lost: {reason[j]}"))
        if drop.any():
            keep = ~drop
            mg.keep(keep)
            self.filters = [f for f, k in zip(self.filters, keep.tolist()) if k]
            self.ids = [i for i, k in zip(self.ids, keep.tolist()) if k]

    def _births(self, t: float, z, var, rad, claimed) -> None:
        """5: new tracks from the detections no track gated, outside every track's disc."""
        free = ~claimed
        if self.filters and free.any():
            pos = np.array([f.position for f in self.filters])
            dist = np.hypot(z[:, None, 0] - pos[None, :, 0], z[:, None, 1] - pos[None, :, 1])
            free &= ~(dist <= self.mgmt.cols.radius[None, :] + rad[:, None]).any(axis=1)
        new = np.flatnonzero(free)
        if new.size == 0:
            return
        for j in new.tolist():
            f = FilterpyIMMTracker(self.options.imm, dt_s=None)
            f.update(z[j], t, var[j] if self.options.use_detection_variance else None)
            self.filters.append(f)
            self.ids.append(self._next_id)
            self._next_id += 1
        self.mgmt.append(t, rad[new])
        self.counts["born"] += int(new.size)

    # ------------------------------------------------------------------ outputs
    def tracks(self) -> tuple:
        mg = self.mgmt
        out = []
        for k in np.flatnonzero(mg.cols.confirmed).tolist():
            f = self.filters[k]
            x = f.state
            th, v = float(x[2]), float(x[3])
            if v < 0.0:  # filterpy keeps V's sign free: the same velocity, the opposite course
                th, v = float(wrap(th + math.pi)), -v
            out.append(TrackEstimate(track_id=self.ids[k], time_s=f.time_s, position_m=x[:2].copy(), heading_rad=th,
                                     speed_m_s=v, turn_rate_rad_s=f.turn_rate, radius_m=float(mg.cols.radius[k]),
                                     position_covariance=f.position_covariance.copy(), is_static=bool(mg.cols.static[k])))
        return tuple(out)

    def drain_events(self) -> list[tuple[float, str]]:
        ev, self._events = self._events, []
        return ev

    def summary(self) -> dict:
        return {"method": self.method, **self.counts, "filter_cycles": self.filter_cycles}
