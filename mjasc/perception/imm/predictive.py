"""The IMM's predictive measurement density, for data association: per track a Gaussian mixture
over its models, ``p(z) = Σ_j c̄_j N(z; ẑ_j, S_j)`` (c̄_j the predicted mode probabilities of
docs/thesis.md §2 step 1, ẑ_j and S_j = H P_j Hᵀ + R the model's predicted position [m] and its
covariance [m²], world ENU).

The bank (:meth:`mjasc.perception.imm.bank.IMMBank.predictive_models`) gives ``zj`` (n, k, 2),
``S`` (n, k, 2, 2) and ``w`` (n, k) for its n tracks (k = r models; a track still in its start-up
filter is one component, repeated with weight 1/r); these functions reduce them to what a track
manager asks: the moment-matched Gaussian, the squared Mahalanobis distance the bank gates on (the
smallest over the models), and the mixture's log-density (an association score).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["moment_matched", "min_mahalanobis_squared", "mixture_log_likelihoods", "PredictiveDensity"]

_TWO_PI = 2.0 * math.pi


def moment_matched(zj, S, w) -> tuple[np.ndarray, np.ndarray]:
    """ẑ = Σ_j w_j ẑ_j (n, 2) and S = Σ_j w_j [S_j + (ẑ_j − ẑ)(ẑ_j − ẑ)ᵀ] (n, 2, 2)."""
    zhat = (w[:, None, :] @ zj)[:, 0, :]
    d = zj - zhat[:, None, :]
    Sm = np.einsum("nk,nkab->nab", w, S) + np.swapaxes(d, 1, 2) @ (w[..., None] * d)
    return zhat, Sm


def _mahalanobis_terms(zj, S, zs):
    """rᵀ S_j⁻¹ r (n, k, m) of detections zs (m, 2) against every component, and det S_j (n, k, 1)."""
    y = zs[None, None, :, :] - zj[:, :, None, :]  # (n, k, m, 2)
    a, b, d = S[..., 0, 0, None], S[..., 0, 1, None], S[..., 1, 1, None]
    det = a * d - b * b
    y0, y1 = y[..., 0], y[..., 1]
    return (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / det, det


def min_mahalanobis_squared(zj, S, zs) -> np.ndarray:
    """(n, m) min over the components of rᵀ S_j⁻¹ r for detections zs (m, 2); inf where not finite."""
    d2 = _mahalanobis_terms(zj, S, zs)[0].min(axis=1)
    return np.where(np.isfinite(d2), d2, np.inf)


def mixture_log_likelihoods(zj, S, w, zs) -> np.ndarray:
    """(n, m) log Σ_j w_j N(z; ẑ_j, S_j) for detections zs (m, 2); −inf where not finite."""
    d2, det = _mahalanobis_terms(zj, S, zs)
    with np.errstate(divide="ignore", invalid="ignore"):
        logp = np.log(w)[..., None] - 0.5 * (d2 + np.log(det)) - math.log(_TWO_PI)
        top = logp.max(axis=1)
        out = top + np.log(np.exp(logp - top[:, None, :]).sum(axis=1))
    return np.where(np.isfinite(out), out, -np.inf)


class PredictiveDensity:
    """The association queries of :class:`mjasc.perception.imm.bank.IMMBank` (its base class): the
    predictive density of every track at a time, without changing the bank."""

    def predictive_models(self, t_s=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The predictive measurement density of every track at t_s (scalar or (n,) [s]; default:
        each track's current time) as a mixture (:mod:`mjasc.perception.imm.predictive`), without
        changing the bank: per-model predicted positions ẑ_j (n, r, 2) [m], their covariances
        S_j = H P_j Hᵀ + R (n, r, 2, 2) [m²] and weights c̄_j (n, r); a track in the start-up
        filter gives its one prediction in every column, with weight 1/r."""
        _, t, dt, dtm, step = self._times(self._t if t_s is None else t_s)
        sp, Pp, cbar, _ = self._coast(step)
        zj = sp[..., :2].copy()
        S = Pp[..., :2, :2] + self._R_cov
        w = cbar.copy()
        if self._startup.n_active:
            if t is None:  # every track's last cycle at one time: one common step (see _times)
                dt = np.full(self._ids.size, dtm)
            rows = np.flatnonzero(self._startup.active)
            xc, Pcv = self._startup.predicted(rows, dt[rows])
            zj[rows] = xc[:, None, :2]
            S[rows] = Pcv[:, None, :2, :2] + self._R_cov
            w[rows] = 1.0 / self._r
        return zj, S, w

    def predicted_measurements(self, t_s=None) -> tuple[np.ndarray, np.ndarray]:
        """Moment-matched predicted measurement ẑ (n, 2) [m] and its covariance S (n, 2, 2) [m²]
        of every track at t_s (default: each track's current time), without changing the bank:
        ``ẑ = Σ c̄_j ẑ_j``, ``S = Σ c̄_j [S_j + (ẑ_j − ẑ)(ẑ_j − ẑ)ᵀ]``."""
        if self._ids.size == 0:
            return np.zeros((0, 2)), np.zeros((0, 2, 2))
        return moment_matched(*self.predictive_models(t_s))

    def mahalanobis_squared(self, detections, t_s=None) -> np.ndarray:
        """(n_tracks, m) squared Mahalanobis distance of detections (m, 2) [m] to each track at
        t_s (default: current times): the smallest over the track's models of rᵀS_j⁻¹r — the
        quantity ``update`` gates on. Non-finite detections give inf."""
        zs = np.asarray(detections, dtype=float).reshape(-1, 2)
        if self._ids.size == 0:
            return np.zeros((0, zs.shape[0]))
        zj, S, _ = self.predictive_models(t_s)
        return min_mahalanobis_squared(zj, S, zs)

    def log_likelihoods(self, detections, t_s=None) -> np.ndarray:
        """(n_tracks, m) log of the IMM predictive density Σ_j c̄_j N(z; ẑ_j, S_j) of each
        detection (m, 2) — an association score; −inf for non-finite detections."""
        zs = np.asarray(detections, dtype=float).reshape(-1, 2)
        if self._ids.size == 0:
            return np.zeros((0, zs.shape[0]))
        return mixture_log_likelihoods(*self.predictive_models(t_s), zs)

    def gate(self, detections, t_s=None) -> np.ndarray:
        """(n_tracks, m) bool: the detection is inside the chi-square gate of the track."""
        return self.mahalanobis_squared(detections, t_s) <= self._gate
