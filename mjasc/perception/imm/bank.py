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

The measured cycle — ``update``, ``update_measured``, ``update_finite`` and behind them the common case
and the general end of a cycle (updated, coasting, start-up and restarted tracks) — is
:class:`~mjasc.perception.imm.bank_updates.BankUpdates`, a base class of the bank; rejections are logged
there (debug: each rejected measurement; info: each restart) on the logger ``mjasc.perception.imm``.

What the bank hands out — track ids, states, covariances, estimates, the per-row fields — is
:class:`~mjasc.perception.imm.bank_views.BankViews`, the base class holding the read-only views; the
arrays its cycles write into are :class:`~mjasc.perception.imm.cycle_buffers.CycleBuffers`; its
per-track arrays and start-up filters live in :class:`~mjasc.perception.imm.row_buffers.RowBuffers`
(a birth writes spare rows, a drop compacts in place: :func:`~mjasc.perception.imm.row_buffers.append_rows`,
:func:`~mjasc.perception.imm.row_buffers.keep_rows`, bound as the bank's ``_append`` and ``keep_rows``).
"""

from __future__ import annotations

import numpy as np

from mjasc.perception.imm.bank_kernels import (ACCEPTED, GATED, NON_FINITE, NOT_MEASURED, REJECTION_REASONS,
                                                RESTARTED)
from mjasc.perception.imm.bank_updates import BankUpdates
from mjasc.perception.imm.bank_views import BankViews
from mjasc.perception.imm.config import IMMConfig
from mjasc.perception.imm.compiled_cycle import imm_cycle
from mjasc.perception.imm.cycle_buffers import CycleBuffers
from mjasc.perception.imm.markov import CycleConstants, cycle_steps
from mjasc.perception.imm.predictive import PredictiveDensity
from mjasc.perception.imm.row_fields import SEQUENTIAL_MODELS
from mjasc.perception.imm.startup import StartupFilters
from mjasc.perception.imm.row_buffers import append_rows, home_rows, keep_rows
from mjasc.perception.imm.startup_rows import handover_polar

__all__ = ["IMMBank", "REJECTION_REASONS", "ACCEPTED", "NOT_MEASURED", "NON_FINITE", "GATED", "RESTARTED"]

_TINY_PROB = 1e-300  # floor when min_mode_probability = 0: keeps every μ_j, c̄_j > 0 (no 0/0)
_EYE2 = np.eye(2)
_NONE = np.zeros(1, dtype=bool)  # ``use`` of imm_cycle: no row
_NO_Z = np.zeros((1, 2))  # z of a cycle without measurements (not read)
_NO_IDS = np.zeros(0, dtype=np.int64)  # (born_into: the next ids)


class IMMBank(BankUpdates, BankViews, PredictiveDensity):
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
        cv_P (k, 4, 4): their filters' ``x[rows]``, ``P[rows]`` when the caller has them (C-contiguous). (One
        compiled call with :func:`cv_to_polar`'s |v|, atan2 and J P Jᵀ in numpy's bits: :func:`handover_polar`.)"""
        st = self._startup
        if xc is None:
            xc, cv_P = st.x[rows], st.P[rows]
        st.n_active -= handover_polar(rows, xc, cv_P, st.n_meas, st.snr2, st.max_updates, st.active, self._x, self._Pc,
                                      self._s, self._P, self._mu, self._mu0)

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

    def noise_arrays(self) -> tuple:
        """(t (n,) [s], P (n, r, 4, 4), start-up flags (n,)): the bank's own arrays, for a compiled caller
        that adds process noise to the P of tracks past start-up in place
        (:func:`mjasc.perception.tracking.manoeuvre.manoeuvre_noise`) and then calls :meth:`noise_added`
        — valid until the next change of the bank."""
        return self._t, self._P, self._startup.active

    def noise_added(self) -> None:
        """A caller of :meth:`noise_arrays` changed P: the combined covariances are computed again on read."""
        self._Pc_stale = True

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
