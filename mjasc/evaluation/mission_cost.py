"""The cost of traffic: each vessel's path length and time against the same mission without traffic.

The **reference** of a run is its scenario with every ``[[moving_obstacles]]`` entry removed (the
team, its paths, the static obstacles, the current and the seed kept; :func:`reference_document`),
run the same way. :class:`ProgressTrace` is a runner observer of the record slot that samples, per
vessel, the time t [s], the position p [m] (ENU) and the mission progress
γ(t) = :meth:`~mjasc.runs.agent.VesselAgent.mission_gamma_m` [m] (arc length along the vessel's
ORIGINAL mission path, also while it follows an avoidance detour; NaN for a vessel without a path).

Per vessel with a path (:func:`mission_cost`), with progress g(t) = γ(t) − γ(0), its running
maximum m(t) = max_{s ≤ t} g(s), and the distance sailed d(t) = Σ |p_k − p_{k−1}| at the record
rate:

* the run's progress P = m(t_end) − δ (δ = ``tolerance_m``: a vessel that finished its path and
  loiters at its end creeps on by millimetres; both runs are measured at the same level P);
* t(P) = the first time m reaches P, linear between samples; d(P) = d at that time;
* ``path_cost`` = d_run(P) / d_ref(P) − 1 — the extra distance sailed for the same progress
  (0: the same track length; 0.1: 10 % further);
* ``time_cost_s`` = t_run(P) − t_ref(P) — how much later than without traffic the vessel got
  as far as it got (negative: ahead of the reference).

If the reference never reached P (it is slower, or the run's vessel shortcut its path), the time
cost is None, ``progress_short_m`` = P − P_ref says by how much (P_ref = m_ref(t_end) − δ), and the
path cost compares distance per metre of progress: (d_run(P)/P) / (d_ref(P_ref)/P_ref) − 1.
The other way round, ``progress_lost_m`` = max(P_ref − P, 0) is how much less of the mission the
run's vessel made by the run's end than without traffic: the costs, taken at the run's own
progress, cannot show it (a vessel that stopped for good, or was pushed back in a collision, made
its little progress at no cost). A vessel that made
less than δ of progress has no cost (None). A run is a pure function of its scenario and seed, so a
run without traffic is its own reference: every cost is 0 exactly (:func:`zero_cost`).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.avoidance.system import CollisionAvoidance

__all__ = ["ProgressTrace", "reference_document", "mission_cost", "zero_cost"]


def reference_document(doc: dict) -> dict | None:
    """The reference scenario document of a run's document (module docstring): without its
    ``moving_obstacles``; None when it has none (the run is its own reference)."""
    if not doc.get("moving_obstacles"):
        return None
    return {k: v for k, v in doc.items() if k != "moving_obstacles"}


class ProgressTrace:
    """Runner observer (record slot): per vessel t [s], position [m] and mission progress γ [m]."""

    def __init__(self, runner):
        self.vessel_names = list(runner.world.vessel_names)
        self.has_path = [a.follower is not None for a in runner.agents]
        self.t: list[float] = []
        self.p: list[np.ndarray] = []
        self.gamma: list = []  # per tick γ (n,) [m]: a list of floats (from_samples: an array)

    @classmethod
    def from_samples(cls, vessel_names, t, position_m, gamma_m, has_path=None) -> "ProgressTrace":
        """A trace from samples: t (k,) [s], positions (k, n, 2) [m], γ (k, n) [m] (NaN: no path)."""
        self = cls.__new__(cls)
        self.vessel_names = list(vessel_names)
        g = np.asarray(gamma_m, dtype=float).reshape(len(t), len(self.vessel_names))
        self.has_path = list(np.isfinite(g).any(axis=0)) if has_path is None else list(has_path)
        self.t = [float(x) for x in t]
        self.p = list(np.asarray(position_m, dtype=float).reshape(len(t), len(self.vessel_names), 2))
        self.gamma = list(g)
        return self

    def __call__(self, event) -> None:
        s = event.states
        self.t.append(float(s.time_s))
        self.p.append(np.array(s.position_m, dtype=float))
        self.gamma.append([_mission_gamma(a) if ok else math.nan for a, ok in zip(event.runner.agents, self.has_path)])

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """t (k,), distance sailed d (k, n) [m] from the start, progress g (k, n) [m] from γ(0)."""
        t = np.asarray(self.t, dtype=float)
        if not len(t):
            n = len(self.vessel_names)
            return t, np.zeros((0, n)), np.zeros((0, n))
        p = np.asarray(self.p, dtype=float)
        step = np.hypot(*np.diff(p, axis=0).transpose(2, 0, 1)) if len(t) > 1 else np.zeros((0, p.shape[1]))
        d = np.vstack([np.zeros((1, p.shape[1])), np.cumsum(step, axis=0)])
        g = np.asarray(self.gamma, dtype=float)
        return t, d, g - g[0]


_THESIS_GAMMA = CollisionAvoidance.mission_gamma_m


def _mission_gamma(agent) -> float:
    """``agent.mission_gamma_m()`` of a vessel with a path follower, the same number: with the
    thesis avoidance method its :meth:`~mjasc.avoidance.system.CollisionAvoidance.mission_gamma_m`
    written out on the follower's path and γ (as the control tick has it,
    :func:`mjasc.runs.fleet_control.control_fleet`), without the guidance state made for it."""
    avoidance = agent.avoidance
    if avoidance is None or type(avoidance).mission_gamma_m is not _THESIS_GAMMA:
        return agent.mission_gamma_m()
    follower, d = agent.follower, avoidance.detour
    g = follower.gamma_m
    return d.mission_gamma(g) if d is not None and follower.path is d.path else g


def _reach(t: np.ndarray, m: np.ndarray, level: float) -> float | None:
    """The first time the non-decreasing ``m`` reaches ``level`` (linear between samples)."""
    k = int(np.searchsorted(m, level, side="left"))
    if k >= len(m):
        return None
    if k == 0 or m[k] == m[k - 1]:
        return float(t[k])
    return float(t[k - 1] + (level - m[k - 1]) / (m[k] - m[k - 1]) * (t[k] - t[k - 1]))


def _r(x: float | None, nd: int = 4):
    return None if x is None or not math.isfinite(x) else round(float(x), nd) + 0.0  # + 0.0: no −0.0


def zero_cost(trace: ProgressTrace, tolerance_m: float = 0.5) -> dict:
    """:func:`mission_cost` of a run against itself (a run without traffic): 0 for every vessel
    that made progress."""
    return mission_cost(trace, trace, tolerance_m, reference="self")


def mission_cost(run: ProgressTrace, ref: ProgressTrace, tolerance_m: float = 0.5,
                 reference: str = "no_traffic") -> dict:
    """``{vessel: {...}}`` for the vessels with a path (module docstring): ``progress_m`` P,
    ``reached_s`` t_run(P), ``distance_m`` d_run(P); ``ref_progress_m``, ``ref_reached_s``,
    ``ref_distance_m`` the same in the reference (at P_ref when it fell short); ``path_cost``, ``time_cost_s``,
    ``progress_short_m``; ``reference`` = how the reference was made."""
    if run.vessel_names != ref.vessel_names:
        raise ValueError(f"reference: vessels {ref.vessel_names} differ from the run's {run.vessel_names}")
    t, d, g = run.arrays()
    tr, dr, gr = ref.arrays()
    out = {}
    for i, name in enumerate(run.vessel_names):
        if not run.has_path[i] or not len(t) or not len(tr):
            continue
        m = np.fmax.accumulate(np.nan_to_num(g[:, i], nan=0.0))
        mr = np.fmax.accumulate(np.nan_to_num(gr[:, i], nan=0.0))
        level = float(m[-1]) - tolerance_m
        ref_level = float(mr[-1]) - tolerance_m
        row = {"reference": reference, "progress_m": _r(max(level, 0.0), 3), "reached_s": None, "distance_m": None,
               "ref_progress_m": _r(max(ref_level, 0.0), 3), "ref_reached_s": None, "ref_distance_m": None,
               "path_cost": None, "time_cost_s": None, "progress_short_m": None,
               "progress_lost_m": _r(max(ref_level - max(level, 0.0), 0.0), 3) if ref_level > 0.0 else None}
        out[name] = row
        if level <= 0.0:
            continue
        t_run = _reach(t, m, level)
        d_run = float(np.interp(t_run, t, d[:, i]))
        row.update(reached_s=_r(t_run, 3), distance_m=_r(d_run, 3))
        t_ref = _reach(tr, mr, level)
        if t_ref is not None:
            d_ref = float(np.interp(t_ref, tr, dr[:, i]))
            row.update(ref_reached_s=_r(t_ref, 3), ref_distance_m=_r(d_ref, 3), time_cost_s=_r(t_run - t_ref, 3),
                       path_cost=_r(d_run / d_ref - 1.0, 5) if d_ref > 0 else None)
        else:
            row["progress_short_m"] = _r(level - ref_level, 3)
            if ref_level > 0:
                t_ref = _reach(tr, mr, ref_level)
                d_ref = float(np.interp(t_ref, tr, dr[:, i]))
                row.update(ref_reached_s=_r(t_ref, 3), ref_distance_m=_r(d_ref, 3))
            if ref_level > 0 and d_ref > 0:
                row["path_cost"] = _r((d_run / level) / (d_ref / ref_level) - 1.0, 5)
    return out
