"""IMMBank: the IMM trackers of many targets updated in one call (thesis §3.2.1, docs/thesis.md §2) — the
track list, the time handling, coasting, gating, restarts and the start-up rows; the cycle's
arithmetic is one compiled call (:mod:`mjasc.perception.imm.compiled_cycle`).

Choices beyond the thesis that live here (parameters of :class:`IMMConfig`):

* **Variable sample time.** Each track has its own last time; a cycle to t runs with Ts = t − that
  time, and the Markov matrix with p(Ts) (:mod:`mjasc.perception.imm.markov`), so a cycle with
  Ts = 0 mixes nothing (predict(t) then update(z, t) is one cycle). When every track's last cycle
  was at the same time no per-track time arrays are built.
* **Coasting.** A cycle without a measurement (missed, occluded, or rejected) is steps 1–2, the
  prediction of step 3, and ``μ_j = c̄_j``.
* **Negative speed.** After an update, a model whose V came out negative is re-parametrized
  exactly, ``(θ, V) → (θ + π, −V)`` (the same velocity vector), with the V row and column of its
  covariance negated (Jacobian ``diag(1, 1, 1, −1)``; P_VV unchanged). The combined V is a convex
  combination of non-negative speeds, hence ≥ 0.
* **Initialization.** A new track runs the start-up constant-velocity filter
  (:mod:`mjasc.perception.imm.startup`) until it hands over to the IMM.
* **Gating.** A measurement is rejected (the track coasts) if it is not finite, or if it lies
  outside the chi-square (2 dof) gate ``−2 ln(1 − gate_probability)`` of *every* model's predicted
  measurement (the union of the model gates holds at least ``gate_probability`` of the IMM's
  predictive mixture). After ``restart_after_gated`` consecutive gated measurements the track is
  restarted from the latest one (a lost track heals itself).

Rejections are logged (debug: each rejected measurement; info: each restart) on the logger
``mjasc.perception.imm``.

What the bank hands out — track ids, states, covariances, estimates, the per-row fields — is
:class:`~mjasc.perception.imm.bank_views.BankViews`, the base class holding the read-only views; the
arrays its cycles write into are :class:`~mjasc.perception.imm.cycle_buffers.CycleBuffers`; its
per-track arrays and start-up filters live in :class:`~mjasc.perception.imm.row_buffers.RowBuffers`
(a birth writes spare rows, a drop compacts in place: :func:`~mjasc.perception.imm.row_buffers.append_rows`,
:func:`~mjasc.perception.imm.row_buffers.keep_rows`, bound as the bank's ``_append`` and ``keep_rows``).
"""

from __future__ import annotations

import logging

import numpy as np

from mjasc.perception.imm.bank_kernels import (ACCEPTED, GATED, NON_FINITE, NOT_MEASURED, REJECTION_REASONS, RESTARTED,
                                                measurements, settled_rows, settled_rows_into)
from mjasc.perception.imm.bank_views import BankViews
from mjasc.perception.imm.config import IMMConfig
from mjasc.perception.imm.compiled_cycle import imm_cycle
from mjasc.perception.imm.cycle_buffers import CycleBuffers
from mjasc.perception.imm.markov import CycleConstants, cycle_steps
from mjasc.perception.imm.measured_cycle import measured_cycle
from mjasc.perception.imm.predictive import PredictiveDensity
from mjasc.perception.imm.row_fields import SEQUENTIAL_MODELS
from mjasc.perception.imm.startup import StartupFilters, _polar_jacobians
from mjasc.perception.imm.row_buffers import append_rows, home_rows, keep_rows
from mjasc.perception.imm.startup_rows import (gather_startup, gather_startup_into, handover_rows, settled_startup,
                                               settled_startup_into)

logger = logging.getLogger("mjasc.perception.imm")

__all__ = ["IMMBank", "REJECTION_REASONS", "ACCEPTED", "NOT_MEASURED", "NON_FINITE", "GATED", "RESTARTED"]

_TINY_PROB = 1e-300  # floor when min_mode_probability = 0: keeps every μ_j, c̄_j > 0 (no 0/0)
_EYE2 = np.eye(2)
_ALL, _NONE = np.ones(1, dtype=bool), np.zeros(1, dtype=bool)  # ``use`` of imm_cycle: every row, none
_NO_Z = np.zeros((1, 2))  # z of a cycle without measurements (not read)
_NO_VAR = np.zeros(0)  # (gather_startup: no per-row steps or σ²)
_NO_IDS = np.zeros(0, dtype=np.int64)  # (born_into: the next ids)
_NO_ROWS, _NO_FLAGS = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool)  # (settled_rows: no start-up rows)


class IMMBank(BankViews, PredictiveDensity):
    """Many IMM trackers updated in one call: arrays (n_tracks, r, 4) and (n_tracks, r, 4, 4).

    Each track has an integer id (``track_ids``), its own last time, model states, covariances and
    mode probabilities; all share one :class:`IMMConfig`. Rows of every per-track array follow
    ``track_ids``. Typical use by a track manager::

        bank.predict(t)                              # coast every track to t
        d2 = bank.mahalanobis_squared(detections)    # (n_tracks, m), for data association
        ok = bank.gate(detections)                   # d2 ≤ chi-square gate
        ... assign detections → z (n_tracks, 2), mask (n_tracks,) ...
        accepted = bank.update(z, t, mask)           # unmeasured / rejected tracks coast
        tid = bank.add_track(z_new, t); bank.remove_track(tid)
        estimates = bank.estimates(radius_m=...)     # list[TrackEstimate]

    A new track starts in a constant-velocity start-up filter and joins the IMM once its speed is
    determined (``velocity_initialized``); its estimate is meaningful from the first measurement.
    """

    def __init__(self, config: IMMConfig = IMMConfig()):
        if not isinstance(config, IMMConfig):
            raise ValueError(f"config: expected an IMMConfig, got {type(config).__name__}")
        self.config = config
        r = config.n_models
        self._r = r
        self._omega = np.asarray(config.turn_rates_rad_s, dtype=float)
        self._compiled_fields = r <= SEQUENTIAL_MODELS  # row_fields' ω̂ sums as numpy does
        mu0 = (
            np.full(r, 1.0 / r)
            if config.initial_mode_probabilities is None
            else np.asarray(config.initial_mode_probabilities, dtype=float)
        )
        mu0 = np.maximum(mu0, _TINY_PROB)
        self._mu0 = mu0 / mu0.sum()
        self._consts = CycleConstants(config)  # per Ts: p(Ts), Ts, Ts ω_j, Q·Ts
        self._R = float(config.measurement_variance_m2)
        self._R_cov = self._R * _EYE2
        self._var = np.array([self._R])  # σ² of every row (imm_cycle's var)
        self._Pc_stale = False  # combined covariances are computed when read
        self._cyc = None  # CycleBuffers with room for the tracks (grown when full)
        self._side = None  # the side of _cyc holding _s, _P, _mu, _x (None: arrays of their own)
        self._sub_cycles: dict[int, CycleBuffers] = {}  # CycleBuffers per subset size (mjasc.perception.imm.subset)
        self._t_common = None  # the time of every track's last cycle when they share it [s]
        self._flagged = True  # _n_gated or _reasons may be non-zero
        self._floor = max(config.min_mode_probability, _TINY_PROB)
        self._gate = config.gate_threshold
        self._next_id = 0
        self._ids = np.zeros(0, dtype=np.int64)
        self._s = np.zeros((0, r, 4))  # per-model states, θ unwrapped in a common chart per track
        self._P = np.zeros((0, r, 4, 4))
        self._mu = np.zeros((0, r))
        self._t = np.zeros(0)
        self._x = np.zeros((0, 4))  # combined estimate, kept current; θ unwrapped (wrap to read)
        self._Pc = np.zeros((0, 4, 4))
        self._startup = StartupFilters(config)  # the start-up CV filters, rows aligned with these
        self._sv2 = float(self._startup.speed_var0)  # (σ_v0² of a new row's filter)
        self._q_cv = float(self._startup.acceleration_noise)  # (its white-acceleration intensity)
        self._n_gated = np.zeros(0, dtype=np.int64)
        self._reasons = np.zeros(0, dtype=np.int8)
        self._mv = None  # per-row measurement variances of the current update (None: config's)
        self._rv = ()  # the row buffers' views the per-track arrays were last set to
        self._rb = None  # RowBuffers holding the per-track arrays and start-up filters (made on the first birth)

    _PER_TRACK = ("_ids", "_s", "_P", "_mu", "_t", "_x", "_Pc", "_n_gated", "_reasons")

    # ------------------------------------------------------------------ track list
    def add_track(self, z, t_s: float, track_id: int | None = None, measurement_variance: float | None = None) -> int:
        """Start a track from its first position measurement z (2,) [m] at time t_s [s].

        Returns its id (``track_id`` if given, else the next free integer). ValueError if z or
        t_s is not finite or the id is taken. ``measurement_variance``: σ² of z [m²] (default
        the config's ``measurement_variance_m2``).
        """
        z = np.asarray(z, dtype=float).reshape(-1)
        if z.shape != (2,) or not np.all(np.isfinite(z)):
            raise ValueError(f"z: need a finite [x, y] position in metres, got {z!r}")
        if not np.isfinite(t_s):
            raise ValueError(f"t_s: must be finite, got {t_s!r}")
        if track_id is not None and np.any(self._ids == track_id):
            raise ValueError(f"track_id: {track_id} is already in the bank")
        var = None if measurement_variance is None else np.array([float(measurement_variance)])
        return int(self.add_tracks(z[None, :], float(t_s), var, None if track_id is None else [int(track_id)])[0])

    def add_tracks(self, z, t_s, measurement_variance=None, track_ids=None) -> np.ndarray:
        """Start k tracks at once from first measurements z (k, 2) [m] at t_s (scalar or (k,) [s]),
        with σ² ``measurement_variance`` (k,) [m²] (None: the config's); ids ``track_ids`` (k,) or
        the next free integers, in row order. Returns the ids. Each new row is what
        :meth:`add_track` would have made of it. ValueError on non-finite input."""
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        k = z.shape[0]
        t = np.asarray(t_s, dtype=float)
        if t.shape != (k,):
            t = np.broadcast_to(t, (k,))
        if not (np.isfinite(z).all() and np.isfinite(t).all()):
            raise ValueError("add_tracks: z and t_s must be finite")
        if track_ids is None:
            ids = np.arange(self._next_id, self._next_id + k, dtype=np.int64)
        else:
            ids = np.asarray(track_ids, dtype=np.int64).reshape(k)
        if k == 0:
            return ids
        self._next_id = max(self._next_id, int(ids.max()) + 1)
        self._append(np.ascontiguousarray(z), np.ascontiguousarray(t, dtype=float), ids,
                     None if measurement_variance is None else np.ascontiguousarray(measurement_variance, dtype=float))
        return ids

    def append_tracks(self, z, t, measurement_variance=None) -> None:
        """:meth:`add_tracks` for a caller that has checked its input: z (k ≥ 1, 2) finite [m], t (k,)
        finite float array [s], ``measurement_variance`` (k,) float array [m²] or None; the ids are
        the next k integers. The same rows as :meth:`add_tracks`."""
        id0 = self._next_id
        self._next_id += z.shape[0]
        self._append(z, t, _NO_IDS, meas_var=measurement_variance, id0=id0)

    # a birth writes into spare rows, a drop compacts in place: functions of the bank in
    # mjasc.perception.imm.row_buffers, bound here as its methods
    _append = append_rows
    _rows_home = home_rows
    keep_rows = keep_rows

    def _start(self, rows, z, meas_var=None):
        """(Re)start tracks ``rows`` from measurements z (k, 2): CV filter at z, v = 0 ± σ_v0;
        meas_var (k,) per-row σ² of z, or None for the config's."""
        self._startup.start(rows, z, self._R, meas_var)
        self._n_gated[rows] = 0
        self._handover(rows)

    def _handover(self, rows, xc=None, cv_P=None):
        """Refresh the estimate of start-up tracks ``rows``; move those ready into the IMM. xc (k, 4),
        cv_P (k, 4, 4): their filters' ``x[rows]``, ``P[rows]`` when the caller has them. (|v|, atan2
        and J P Jᵀ of :func:`cv_to_polar` numpy's, the rest one compiled call: :func:`handover_rows`.)"""
        st = self._startup
        if xc is None:
            xc, cv_P = st.x[rows], st.P[rows]
        vx, vy = xc[:, 2], xc[:, 3]
        speed = np.hypot(vx, vy)
        J = _polar_jacobians(xc, speed)
        st.n_active -= handover_rows(rows, xc, speed, np.arctan2(vy, vx), J @ cv_P @ J.transpose(0, 2, 1), cv_P,
                                     st.n_meas, st.snr2, st.max_updates, st.active, self._x, self._Pc, self._s,
                                     self._P, self._mu, self._mu0)

    def add_process_noise(self, rows, heading_var_rad2=0.0, speed_var_m2_s2=0.0) -> None:
        """Manoeuvre handling: add ``heading_var_rad2`` to P_θθ and ``speed_var_m2_s2`` to P_VV of
        every model of the tracks in ``rows`` (bool (n,) or indices), as an extra process-noise
        input ΔQ = diag(0, 0, Δθ², ΔV²) at this cycle (Bar-Shalom, Li & Kirubarajan 2001, §11.2:
        adjustable-level process noise, switched on by a manoeuvre detector; see
        :mod:`mjasc.perception.tracking.manoeuvre`). Scalars or one value per selected row. A track in the start-up
        constant-velocity filter gets ``speed_var_m2_s2`` on both velocity components. Tracks not
        selected, and the equations of the cycle, are unchanged."""
        idx = np.arange(self._ids.size)[rows]
        if idx.size == 0:
            return
        dth = np.broadcast_to(np.asarray(heading_var_rad2, dtype=float), idx.shape)
        dv = np.broadcast_to(np.asarray(speed_var_m2_s2, dtype=float), idx.shape)
        if not (np.all(np.isfinite(dth)) and np.all(dth >= 0) and np.all(np.isfinite(dv)) and np.all(dv >= 0)):
            raise ValueError("add_process_noise: heading_var_rad2 and speed_var_m2_s2 must be finite and ≥ 0")
        self.add_process_noise_rows(idx, dth, dv)

    def add_process_noise_rows(self, idx, dth, dv) -> None:
        """:meth:`add_process_noise` for a caller that has checked its arrays: the rows ``idx`` (k ≥ 1,)
        int, distinct, and their variances dth, dv (k,) float, finite and ≥ 0 (a manoeuvre detector's)."""
        warm = self._startup.active[idx]
        full = idx[~warm]
        if full.size:
            self._P[full, :, 2, 2] += dth[~warm, None]
            self._P[full, :, 3, 3] += dv[~warm, None]
            self._Pc_stale = True
        w = idx[warm]
        if w.size:
            self._startup.add_speed_variance(w, dv[warm])
            self._Pc[w] = self._startup.polar(w)[1]

    def remove_track(self, track_id: int) -> None:
        """Drop a track (ValueError if unknown)."""
        keep = np.ones(self._ids.size, dtype=bool)
        keep[self.index_of(track_id)] = False
        self.keep_rows(keep)

    def update_rows(self, rows, z, t_s, mask=None, measurement_variance=None) -> np.ndarray:
        """:meth:`update` of the tracks in ``rows`` (indices, k) only — z (k, 2), mask and
        measurement_variance (k,) as there, t_s scalar or (k,); the other tracks are untouched
        (:mod:`mjasc.perception.imm.subset`). Returns (k,) bool, the rows used."""
        from mjasc.perception.imm.subset import put_rows, take_rows

        sub = take_rows(self, rows)
        used = sub.update(z, t_s, mask, measurement_variance)
        put_rows(self, rows, sub)
        return used

    # ------------------------------------------------------------------ time handling
    def _times(self, t_s):
        """Time step of a cycle to t_s: (t0, t, dt, dtm, step) (:func:`~mjasc.perception.imm.markov.cycle_steps`)."""
        return cycle_steps(self._t, self._t_common, self._ids, t_s, self._consts)

    def _own_state(self, n: int) -> CycleBuffers:
        """Cycle buffers with room for n tracks holding the state in one side (the state copied
        there when it was elsewhere or the buffers were full)."""
        cyc = self._cyc
        if cyc is None or cyc.cap < n:
            cyc = CycleBuffers(n + max(16, n // 2), self._r)
        n0 = self._ids.size
        side = 0 if self._side is None or cyc is not self._cyc else self._side
        out = cyc.views(side, n0)
        if out[0] is not self._s:
            for a, o in zip((self._s, self._P, self._mu, self._x), out):
                o[...] = a
            self._s, self._P, self._mu, self._x = out[:4]
        self._cyc, self._side = cyc, side
        return cyc

    def _free_side(self) -> tuple:
        """(side index, its first n rows (s, P, μ, x, d2_min)): where a cycle writes."""
        n = self._ids.size
        cyc = self._cyc
        if cyc is None or cyc.cap < n:
            cyc = self._own_state(n)
        side = 1 if self._side == 0 else 0
        return side, cyc.views(side, n)

    def _coast(self, step) -> tuple:
        """Every track's IMM cycle without measurement (mixed and predicted s, P; μ = c̄; x) with
        the constants ``step``: a free side of the cycle buffers, valid until the next cycle."""
        side = self._free_side()[1]
        imm_cycle(self._s, self._P, self._mu, *step, _NO_Z, self._var, _NONE, self._floor, self._gate, *side)
        return side[:4]

    # ------------------------------------------------------------------ public cycle
    def predict(self, t_s) -> None:
        """Coast every track to time t_s (scalar or (n,) absolute times [s]): an IMM cycle
        without measurement (μ_j ← c̄_j); start-up tracks run their CV prediction."""
        if self._ids.size == 0:
            return
        t0, t, dt, dtm, step = self._times(t_s)
        warm = self._startup.active
        side, (sp, Pp, cbar, x, _) = self._free_side()
        imm_cycle(self._s, self._P, self._mu, *step, _NO_Z, self._var, _NONE, self._floor, self._gate, sp, Pp, cbar,
                  x, _)
        self._Pc_stale = True
        if self._startup.n_active:
            if t is None:
                dt = np.full(self._ids.size, dtm)
            rows = warm.nonzero()[0]  # the start-up rows keep their (unused) IMM state; x is set below
            sp[rows], Pp[rows], cbar[rows] = self._s[rows], self._P[rows], self._mu[rows]
            self._s, self._P, self._mu, self._x = sp, Pp, cbar, x
            self._side = side
            self._startup.predict(rows, dt[rows])
            s, P = self._startup.polar(rows)
            self._x[rows], self._Pc[rows] = s, P
        else:
            self._s, self._P, self._mu, self._x = sp, Pp, cbar, x
            self._side = side
        self._set_times(t0, t)

    def _set_times(self, t0, t):
        """Record the time of the cycle just run (see ``_times``)."""
        if t is None:
            self._t.fill(t0)
        else:
            self._t = t
        self._t_common = t0

    def update(self, z, t_s, mask=None, measurement_variance=None) -> np.ndarray:
        """One IMM cycle for every track at time t_s (scalar or (n,) [s]).

        z: (n, 2) measured positions [m], one row per track (row order of ``track_ids``).
        mask: (n,) bool, True where the row carries a measurement (default: all rows). Rows that
        are unmeasured, not finite or outside the gate are not used: the track coasts to t_s.
        Returns (n,) bool, True where the row was used (updated, or restarted from it after
        ``restart_after_gated`` gated rows in a row); ``rejection_reasons`` says why not.
        measurement_variance: optional (n,) σ² per row [m²] (R = σ² I₂ for that row's
        measurement, e.g. from the detection that produced it); default the config's.
        """
        n = self._ids.size
        z = np.asarray(z, dtype=float)
        if z.shape != (n, 2):
            raise ValueError(f"z: need shape ({n}, 2) (one [x, y] per track), got {z.shape}")
        if n == 0:
            return np.zeros(0, dtype=bool)
        if measurement_variance is not None:
            mv = np.array(measurement_variance, dtype=float)  # (a copy: unusable σ² are replaced in it)
            if mv.shape != (n,):
                raise ValueError(f"measurement_variance: need shape ({n},), got {mv.shape}")
        else:
            mv = None
        if mask is None:
            measured = np.ones(n, dtype=bool)
        else:
            measured = np.asarray(mask, dtype=bool)
            if measured.shape != (n,):
                raise ValueError(f"mask: need shape ({n},), got {measured.shape}")
        return self._measured_cycle(z, t_s, measured, mv, np.empty(n, dtype=bool), np.empty(n, dtype=bool))

    def update_measured(self, z, t_s, measured, measurement_variance=None) -> np.ndarray:
        """:meth:`update` for a caller that has checked its arrays: z (n, 2) float, ``measured`` (n,)
        bool, ``measurement_variance`` (n,) float or None — changed in place (its unusable σ²
        replaced by the config's, as :meth:`update` does in its copy); n ≥ 1. The same cycle and
        result as :meth:`update`, without the checks and copies."""
        n = self._ids.size
        rb = self._rb
        if rb is not None and rb.cap >= n:  # (the row buffers' scratch rows: no arrays made)
            finite, use = rb.scratch_flags(n)[:2]
        else:
            finite, use = np.empty(n, dtype=bool), np.empty(n, dtype=bool)
        return self._measured_cycle(z, t_s, measured, measurement_variance, finite, use)

    def _measured_cycle(self, z, t_s, measured, mv, finite, use) -> np.ndarray:
        """The cycle of :meth:`update` / :meth:`update_measured` on checked arrays: the finite rows
        and the rows used written into ``finite`` / ``use`` (n,) and unusable σ² in ``mv`` replaced
        by the config's, in one compiled pass; then one IMM cycle (of every row when all are used).
        With the row buffers' scratch rows, those and the cycle's front are one compiled call
        (:func:`~mjasc.perception.imm.measured_cycle.measured_cycle`)."""
        rb = self._rb
        n = z.shape[0]
        if rb is not None and rb.cap >= n:
            t0, t, dt, dtm, step = cycle_steps(self._t, self._t_common, self._ids, t_s, self._consts)  # (_times)
            out, side = self._free_side()
            st = self._startup
            every_true = rb.scratch_flags(n)[2]
            every, common, k = measured_cycle(
                z, measured, self._var if mv is None else mv, mv is not None, self._R, finite, use, every_true,
                self._s, self._P, self._mu, *step, self._floor, self._gate, *side, st.n_active, st.active, st.x, st.P,
                _NO_VAR if t is None else dt, dtm if t is None else 0.0, rb.w_rows, rb.w_x, rb.w_P, rb.w_dt, rb.w_F,
                rb.w_z, rb.w_use, rb.w_var)
            if common:
                self._accept(out, side, t0, t)
                return np.ones(n, dtype=bool)
            if every:
                use = finite = measured = every_true
            return self._settle(z, out, side, t0, t, dt, dtm, use, finite, measured, mv,
                                rb.w_rows[:k] if st.n_active else None)
        return self._separate_cycle(z, t_s, measured, mv, finite, use)

    def _separate_cycle(self, z, t_s, measured, mv, finite, use) -> np.ndarray:
        """:meth:`_measured_cycle` through the separate calls (the measurement check, then
        :meth:`_cycle`): the path without the row buffers' scratch rows, and the fused call's
        reference in the tests."""
        all_used = measurements(z, measured, mv if mv is not None else self._var, mv is not None, self._R, finite, use)
        self._mv = mv
        try:
            if all_used:
                ok = self._cycle(z, t_s)
                return np.ones(z.shape[0], dtype=bool) if ok is None else ok
            return self._cycle(z, t_s, use, finite, measured)
        finally:
            self._mv = None

    def update_finite(self, z, t_s):
        """:meth:`update`'s fast path, for a caller that has checked that every row of z (n, 2) [m]
        is a finite measurement (no mask, the config's σ²): one IMM cycle at t_s (scalar or (n,)
        [s]). Returns None when every row was used, else the (n,) bool of the used rows (the
        others were gated, or restarted the track: ``rejection_reasons``)."""
        return self._cycle(z, t_s)

    def _cycle(self, z, t_s, use=None, finite=None, measured=None):
        """The IMM cycle behind ``update``: rows of z (n, 2) where ``use`` (None: every row is a
        finite measurement). Returns the (n,) bool array of used rows, or None when every row was
        used."""
        n = self._ids.size
        t0, t, dt, dtm, step = cycle_steps(self._t, self._t_common, self._ids, t_s, self._consts)  # (_times)
        out, side = self._free_side()
        mv = self._mv
        d2_min = side[4]
        imm_cycle(self._s, self._P, self._mu, *step, z, self._var if mv is None else mv,
                  _ALL if use is None else use, self._floor, self._gate, *side)

        if (
            use is None
            and not self._startup.n_active
            and (d2_min.item() if n == 1 else np.maximum.reduce(d2_min)) <= self._gate
        ):  # the common case: every track measured and accepted
            self._accept(out, side, t0, t)
            return None
        rb = self._rb
        if use is None:
            scratch = rb is not None and rb.cap >= n
            use = finite = measured = rb.scratch_flags(n)[2] if scratch else np.ones(n, dtype=bool)
        return self._settle(z, out, side, t0, t, dt, dtm, use, finite, measured, mv, None)

    def _accept(self, out, side, t0, t) -> None:
        """The end of a cycle whose every track was measured and accepted (no start-up rows): the new
        state from ``side``, the cycle's times (``out``: the free side's index; t0, t of ``cycle_steps``)."""
        self._s, self._P, self._mu, self._x = side[:4]
        self._side = out
        self._Pc_stale = True
        if self._flagged:  # some track has consecutive gated rows or a rejection reason
            self._n_gated.fill(0)
            self._reasons.fill(0)
            self._flagged = False
        if t is None:
            self._t.fill(t0)
        else:
            self._t = t
        self._t_common = t0

    def _settle(self, z, out, side, t0, t, dt, dtm, use, finite, measured, mv, rows_w) -> np.ndarray:
        """The end of the general cycle: a mix of updated, coasting, start-up and restarted tracks (t
        None: every row at t0), ``side`` written by the IMM cycle with the used rows ``use`` (n,) of
        z (n, 2) and σ² mv (n,) or None; ``rows_w``: the start-up rows when already gathered into the
        row buffers' scratch rows (:func:`~mjasc.perception.imm.measured_cycle.measured_cycle`), else
        None. Returns the (n,) bool array of used rows."""
        n = self._ids.size
        d2_min = side[4]
        rb = self._rb
        scratch = rb is not None and rb.cap >= n  # (the row buffers' scratch rows for the flags: no arrays made)
        warm = self._startup.active
        any_warm = self._startup.n_active > 0
        # the cycle updated the rows ``use & (d2_min <= gate)`` of the IMM rows, coasted the others; the
        # start-up rows keep their (unused) IMM state, their x is set by the hand-over below
        s_new, P_new, mu_new, x_new, _ = side
        if any_warm:  # the start-up filters' cycle (StartupFilters.update_rows): the products numpy's
            st = self._startup
            if rows_w is not None:  # (gathered already)
                rows = rows_w
                xc, Pc, dtw, F, zw, use_w, var_w = rb.scratch_rows(rows.size)
            else:
                rows_w = rows = warm.nonzero()[0]  # (still the start-up rows at the hand-over below)
                k = rows.size
                if rb is not None and rb.cap >= k:  # (gathered into the row buffers' scratch rows: no arrays made)
                    gather_startup_into(rows, st.x, st.P, _NO_VAR if t is None else dt, dtm if t is None else 0.0, z,
                                        use, _NO_VAR if mv is None else mv, mv is not None, rb.w_x, rb.w_P, rb.w_dt,
                                        rb.w_F, rb.w_z, rb.w_use, rb.w_var)
                    xc, Pc, dtw, F, zw, use_w, var_w = rb.scratch_rows(k)
                else:
                    xc, Pc, dtw, F, zw, use_w, var_w = gather_startup(rows, st.x, st.P, _NO_VAR if t is None else dt,
                                                                      dtm if t is None else 0.0, z, use,
                                                                      _NO_VAR if mv is None else mv, mv is not None)
            xc_w = (F @ xc[..., None])[..., 0]
            P_w = F @ Pc @ F.transpose(0, 2, 1)  # (= np.swapaxes(F, 1, 2))
        limit = self.config.restart_after_gated
        if any_warm:  # (the start-up filters updated, then inside, ok, the start-up rows, rejections: one compiled call)
            args = (rows, xc_w, P_w, dtw**3, dtw, self._q_cv, zw, self._var if mv is None else var_w, use_w,
                    self._gate, st.x, st.P, st.n_meas, d2_min, use, finite, measured, self._s, self._P, self._mu,
                    s_new, P_new, mu_new, self._n_gated, limit)
            if scratch:  # (the codes written into the bank's own, the flags into scratch rows)
                _, _, _, inside, restart, ok = rb.scratch_flags(n)
                reasons, used = self._reasons, np.empty(n, dtype=bool)
                n_restart = settled_startup_into(*args, inside, ok, reasons, restart, used)
            else:
                inside, reasons, restart, used, n_restart = settled_startup(*args)
        else:  # (inside, ok, rejections: one compiled pass)
            rows_w = _NO_ROWS
            args = (d2_min, self._gate, use, finite, measured, _NO_ROWS, _NO_FLAGS, _NO_FLAGS, self._s, self._P,
                    self._mu, s_new, P_new, mu_new, self._n_gated, limit)
            if scratch:
                _, _, _, inside, restart, ok = rb.scratch_flags(n)
                reasons, used = self._reasons, np.empty(n, dtype=bool)
                n_restart = settled_rows_into(*args, inside, ok, reasons, restart, used)
            else:
                inside, reasons, restart, used, n_restart = settled_rows(*args)
        self._s, self._P, self._mu, self._x = s_new, P_new, mu_new, x_new
        self._side = out
        self._Pc_stale = True

        if t is None:  # (_set_times(t0, t) without its call)
            self._t.fill(t0)
            t = self._t  # (for the log below)
        else:
            self._t = t
        self._t_common = t0
        if any_warm:
            self._handover(rows_w, xc_w, P_w)
        if n_restart:
            rows = restart.nonzero()[0]
            self._start(rows, z[rows], None if mv is None else mv[rows])
            reasons[rows] = RESTARTED
            for k in rows:
                logger.info(
                    "IMM track %d restarted at t=%.3f s from z=%s after %d gated measurements",
                    self._ids[k], t[k], z[k], limit,
                )
        self._reasons = reasons
        self._flagged = True
        if logger.isEnabledFor(logging.DEBUG):
            gated = use & ~inside
            for k in (measured & ~finite).nonzero()[0]:
                logger.debug(
                    "IMM track %d at t=%.3f s: rejected z=%s (%s)",
                    self._ids[k], t[k], z[k], REJECTION_REASONS[NON_FINITE],
                )
            for k in (gated & ~restart).nonzero()[0]:
                logger.debug(
                    "IMM track %d at t=%.3f s: rejected z=%s (%s; min d²=%.4g > gate %.4g)",
                    self._ids[k], t[k], z[k], REJECTION_REASONS[GATED], d2_min[k], self._gate,
                )
        return used
