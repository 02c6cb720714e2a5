"""BankViews: the read-only views of an IMM bank's rows — the mixin
:class:`mjasc.perception.imm.bank.IMMBank` inherits (the bank itself adds, drops and cycles the
rows; this reads them).

Track ids and row lookup, rejection codes, times, combined states, positions, courses, speeds, ω̂,
mode probabilities, covariances (combined on first read after a cycle), per-model diagnostics,
:class:`~mjasc.core.estimates.TrackEstimate` s, and the per-row fields the tracking layer reads at
once (``estimate_fields``, ``prediction_fields``: one compiled pass, :mod:`mjasc.perception.imm.row_fields`).
Properties return copies unless they say otherwise (``state_rows``, ``covariance_rows``: the bank's
own arrays).

The mixin has no state of its own; it reads the bank's per-track arrays (``_ids``, ``_t``, ``_x``,
``_s``, ``_P``, ``_mu``, ``_Pc``, ``_Pc_stale``, ``_n_gated``, ``_reasons``, ``_t_common``,
``_startup``) and constants (``_omega``, ``_compiled_fields``), set by ``IMMBank.__init__``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mjasc.core.estimates import TrackEstimate
from mjasc.perception.imm.bank_kernels import REJECTION_REASONS
from mjasc.perception.imm.compiled_cycle import turn_rate, wrap
from mjasc.perception.imm.row_fields import combine_covariance_rows, row_fields, wrapped_states

__all__ = ["BankViews"]


class BankViews:
    """The read-only views of :class:`~mjasc.perception.imm.bank.IMMBank`'s rows (a mixin: the bank's
    base class; see the module docstring for the attributes it reads)."""

    # ------------------------------------------------------------------ track list
    def __len__(self) -> int:
        return self._ids.size

    @property
    def track_ids(self) -> np.ndarray:
        """(n,) integer ids, in the row order of every per-track array."""
        return self._ids.copy()

    def index_of(self, track_id: int) -> int:
        """Row of ``track_id``; ValueError if unknown."""
        rows = (self._ids == track_id).nonzero()[0]
        if rows.size == 0:
            raise ValueError(f"track_id: no track with id {track_id}")
        return int(rows[0])

    # ------------------------------------------------------------------ combined covariances
    def _covariances(self) -> np.ndarray:
        """(n, 4, 4) combined covariances, computed on first read after a cycle."""
        if self._Pc_stale:
            combine_covariance_rows(self._s, self._P, self._mu, self._startup.active, self._Pc)
            self._Pc_stale = False
        return self._Pc

    # ------------------------------------------------------------------ rows
    @property
    def rejection_reasons(self) -> list[str]:
        """Per track, why the last ``update`` did not use its row ('' if it did)."""
        return [REJECTION_REASONS[c] for c in self._reasons]

    @property
    def rejection_codes(self) -> np.ndarray:
        """(n,) int8 index into ``REJECTION_REASONS`` for the last ``update``."""
        return self._reasons.copy()

    @property
    def consecutive_gated(self) -> np.ndarray:
        """(n,) number of consecutive gated measurements per track (for track deletion)."""
        return self._n_gated.copy()

    @property
    def times_s(self) -> np.ndarray:
        """(n,) time of each track's last cycle [s]."""
        return self._t.copy()

    @property
    def velocity_initialized(self) -> np.ndarray:
        """(n,) bool: the track runs in the IMM (False while in the start-up CV filter)."""
        return ~self._startup.active

    @property
    def states(self) -> np.ndarray:
        """(n, 4) combined [x, y, θ, V] per track (θ in (−π, π])."""
        return wrapped_states(self._x)  # (= x.copy() with x[:, 2] = wrap(x[:, 2]): one compiled pass)

    @property
    def time_rows(self) -> np.ndarray:
        """(n,) each track's last cycle time [s], the bank's own array (as :attr:`state_rows`: read
        it at once, never write it)."""
        return self._t

    @property
    def state_rows(self) -> np.ndarray:
        """(n, 4) the combined estimates [x, y, θ, V] as the bank keeps them, θ unwrapped (wrap it
        to read a course; :attr:`states` does): the bank's own array, not a copy — read it at once
        (valid until the next cycle, birth or drop), never write it."""
        return self._x

    def covariance_rows(self) -> np.ndarray:
        """(n, 4, 4) the combined covariances as the bank keeps them (computed on first read after
        a cycle): the bank's own array, not a copy — read it at once (valid until the next cycle,
        birth or drop), never write it."""
        return self._covariances()

    @property
    def common_time_s(self) -> float | None:
        """The time of every track's last cycle [s] when they share it, else None."""
        return self._t_common

    @property
    def positions(self) -> np.ndarray:
        """(n, 2) combined position [m]."""
        return self._x[:, :2].copy()

    @property
    def headings(self) -> np.ndarray:
        """(n,) combined course θ [rad], in (−π, π]."""
        return wrap(self._x[:, 2])

    @property
    def speeds(self) -> np.ndarray:
        """(n,) combined speed V ≥ 0 [m/s]."""
        return self._x[:, 3].copy()

    @property
    def turn_rates(self) -> np.ndarray:
        """(n,) ω̂ = Σ_j μ_j ω_j [rad/s] (0 for start-up tracks)."""
        return np.where(self._startup.active, 0.0, turn_rate(self._mu, self._omega))

    @property
    def mode_probabilities(self) -> np.ndarray:
        """(n, r) μ_j per track."""
        return self._mu.copy()

    @property
    def state_covariances(self) -> np.ndarray:
        """(n, 4, 4) combined covariance over x, y, θ, V."""
        return self._covariances().copy()

    @property
    def position_covariances(self) -> np.ndarray:
        """(n, 2, 2) combined covariance of the position [m²]."""
        return self._covariances()[:, :2, :2].copy()

    @property
    def model_states(self) -> np.ndarray:
        """(n, r, 4) per-model states, θ wrapped (diagnostics)."""
        s = self._s.copy()
        s[..., 2] = wrap(s[..., 2])
        return s

    @property
    def model_covariances(self) -> np.ndarray:
        """(n, r, 4, 4) per-model covariances (diagnostics)."""
        return self._P.copy()

    def estimate(self, track_id: int, radius_m: float = 0.0, **fields) -> TrackEstimate:
        """The :class:`TrackEstimate` of one track; further fields (is_static, team_member,
        outline_m) are passed through."""
        k = self.index_of(track_id)
        x = self._x[k]
        return TrackEstimate(
            track_id=int(track_id),
            time_s=float(self._t[k]),
            position_m=x[:2].copy(),
            heading_rad=float(wrap(x[2])),
            speed_m_s=float(x[3]),
            turn_rate_rad_s=0.0 if self._startup.active[k] else float(turn_rate(self._mu[k], self._omega)),
            radius_m=float(radius_m),
            position_covariance=self._covariances()[k, :2, :2].copy(),
            **fields,
        )

    def estimate_fields(self, rows) -> tuple:
        """What :meth:`estimate` reads, for the tracks ``rows`` at once: times (k,) [s], positions
        (k, 2) [m], courses (k,) in (−π, π], speeds (k,) [m/s], ω̂ (k,) [rad/s], position
        covariances (k, 2, 2) [m²] (the same numbers as :meth:`estimate`)."""
        if self._compiled_fields and type(rows) is np.ndarray and rows.dtype == np.int64:  # one compiled pass
            t, xs, th, w, P = row_fields(rows, self._x, self._t, self._mu, self._omega, self._startup.active,
                                         self._covariances(), False)
            return t, xs[:, :2], th, xs[:, 3], w, P
        x = self._x[rows]
        w = np.where(self._startup.active[rows], 0.0, turn_rate(self._mu[rows], self._omega))
        return self._t[rows], x[:, :2], wrap(x[:, 2]), x[:, 3], w, self._covariances()[rows, :2, :2]

    def positions_of(self, rows) -> np.ndarray:
        """``positions`` of the tracks ``rows`` only: (k, 2) [m]."""
        return self._x[rows, :2]

    def states_of(self, rows) -> np.ndarray:
        """``states`` of the tracks ``rows`` only: (k, 4) [x, y, θ, V], θ in (−π, π]."""
        x = self._x[rows]
        x[:, 2] = wrap(x[:, 2])
        return x

    def prediction_fields(self, rows) -> tuple:
        """What predicting the tracks ``rows`` needs, at once: combined states (k, 4) [x, y, θ, V]
        (θ in (−π, π]), covariances (k, 4, 4), times (k,) [s] and ω̂ (k,) [rad/s] (the numbers of
        ``states``, ``state_covariances``, ``times_s`` and ``turn_rates`` at those rows)."""
        if self._compiled_fields and type(rows) is np.ndarray and rows.dtype == np.int64:  # one compiled pass
            t, xs, _, w, P = row_fields(rows, self._x, self._t, self._mu, self._omega, self._startup.active,
                                        self._covariances(), True)
            return xs, P, t, w
        w = np.where(self._startup.active[rows], 0.0, turn_rate(self._mu[rows], self._omega))
        return self.states_of(rows), self._covariances()[rows], self._t[rows], w

    def prediction_arrays(self) -> tuple | None:
        """The bank's own arrays ``prediction_fields`` reads, for a compiled caller that gathers its
        rows itself (:func:`mjasc.perception.tracking.step_fusions.predicted_pairs`): (x (n, 4),
        t (n,), μ (n, r), ω (r,), start-up flags (n,), covariances (n, 4, 4), current) — read-only,
        valid until the next change of the bank; None when ω̂ is not the compiled sum (r > 7)."""
        if not self._compiled_fields:
            return None
        return self._x, self._t, self._mu, self._omega, self._startup.active, self._covariances()

    def estimates(self, radius_m: float | Mapping[int, float] = 0.0) -> list[TrackEstimate]:
        """TrackEstimate of every track; radius_m a scalar or a {track_id: radius} mapping."""
        out = []
        for tid in self._ids.tolist():
            rad = radius_m.get(tid, 0.0) if isinstance(radius_m, Mapping) else radius_m
            out.append(self.estimate(tid, rad))
        return out
