"""Markov switching between the IMM's models over a variable sample time, and the other constants
of one cycle of sample time Ts (docs/thesis.md §2, step 1; :mod:`mjasc.perception.imm`).

The Markov matrix ``p`` (:meth:`IMMConfig.markov_matrix_array`) is given per
``markov_reference_dt_s`` (T_ref, 1 s: the thesis's Ts); a cycle of Ts uses
``p(Ts) = p^(Ts/T_ref) = V diag(λ^(Ts/T_ref)) V⁻¹`` (the eigen-decomposition; the config requires
real, positive eigenvalues), clipped at 0 and renormalized per row. So a cycle with Ts = 0 mixes
nothing (p(0) = I), p(T_ref) is exactly the given matrix, and p(a) p(b) = p(a + b).

Each track of a bank has its own last time; :func:`cycle_steps` turns the time of a cycle into
every track's Ts and the constants of the cycle (:class:`CycleConstants`), without building
per-track arrays when all tracks share one Ts (the common case: one scan updates every track).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.perception.imm.config import IMMConfig

__all__ = ["MarkovPower", "CycleConstants", "cycle_steps"]


class MarkovPower:
    """p(Ts) = p^(Ts/T_ref) = V diag(λ^(Ts/T_ref)) V⁻¹, vectorized over tracks, cached per scalar Ts."""

    def __init__(self, config: IMMConfig):
        p = config.markov_matrix_array()
        lam, vec = np.linalg.eig(p)
        self._lam = lam.real
        self._vec = vec.real
        self._vec_inv = np.linalg.inv(vec).real
        self._t_ref = config.markov_reference_dt_s
        self._p_ref = p
        self._cache: dict[float, np.ndarray] = {}

    def _from_power(self, dt: np.ndarray) -> np.ndarray:
        powers = self._lam ** (np.asarray(dt, dtype=float)[..., None] / self._t_ref)  # (..., r)
        m = (self._vec * powers[..., None, :]) @ self._vec_inv
        m = np.clip(m, 0.0, None)
        return m / m.sum(axis=-1, keepdims=True)

    def scalar(self, dt: float) -> np.ndarray:
        """(r, r) matrix for one Ts (exactly the given matrix at T_ref, identity at 0)."""
        m = self._cache.get(dt)
        if m is None:
            if dt == self._t_ref:
                m = self._p_ref
            elif dt == 0.0:
                m = np.eye(self._lam.size)
            else:
                m = self._from_power(dt)
            if len(self._cache) > 256:
                self._cache.clear()
            self._cache[dt] = m
        return m

    def per_track(self, dt: np.ndarray) -> np.ndarray:
        """(n, r, r) matrices for per-track Ts."""
        return self._from_power(dt)


class CycleConstants:
    """What a cycle of sample time Ts needs besides the tracks' own arrays, in the form of
    :func:`mjasc.perception.imm.compiled_cycle.imm_cycle`: the tuple ``(p(Ts), Ts, Ts ω_j,
    (Q_θ, Q_V)·Ts)`` of arrays with one row shared by every track (cached per Ts: a bank run at
    a fixed rate computes it once), or one row per track."""

    def __init__(self, config: IMMConfig):
        self.markov = MarkovPower(config)
        self._omega = np.asarray(config.turn_rates_rad_s, dtype=float)
        self._q_unit = np.array([config.heading_noise_rad2_s, config.speed_noise_m2_s3])
        self._steps: dict[float, tuple] = {}

    def scalar(self, dt: float) -> tuple:
        """(p(Ts), Ts, Ts ω_j, (Q_θ, Q_V)·Ts) for one Ts, shapes (1, r, r), (1,), (1, r), (1, 2); cached."""
        step = self._steps.get(dt)
        if step is None:
            step = (self.markov.scalar(dt)[None], np.array([dt]), (dt * self._omega)[None], (self._q_unit * dt)[None])
            if len(self._steps) > 256:
                self._steps.clear()
            self._steps[dt] = step
        return step

    def per_track(self, dt: np.ndarray) -> tuple:
        """The same for per-track Ts (n,): (n, r, r), (n,), (n, r), (n, 2)."""
        col = dt[:, None]
        return (self.markov.per_track(dt), dt, col * self._omega, col * self._q_unit)


def cycle_steps(t_last: np.ndarray, t_common: float | None, ids: np.ndarray, t_s, consts: CycleConstants):
    """Time step of a cycle to t_s (scalar or (n,) absolute times [s]) of tracks last cycled at
    t_last (n,) [s] (``t_common``: that time when all share it, else None; ``ids`` (n,) name the
    tracks in errors).

    Returns (t0, t, dt, dtm, step): t0 the float time when it is one for all tracks (else
    None); t (n,) and dt (n,) the new times and steps, or None when t0 is given and every
    track's last cycle was at the same time (then dtm = that common step; the caller builds
    the arrays only if it needs them); dtm the step as a float when all tracks share it, else
    None; step the matching constants (:class:`CycleConstants`). ValueError if a
    time is not finite, of the wrong shape, or earlier than a track's last cycle.
    """
    if type(t_s) is float or np.ndim(t_s) == 0:
        t0 = float(t_s)
        if not math.isfinite(t0):
            raise ValueError(f"t_s: must be finite, got {t_s!r}")
        tc = t_common
        if tc is not None:
            d = t0 - tc
            if d < 0.0:
                raise ValueError(f"t_s: earlier than the last cycle of track(s) {ids.tolist()}")
            return t0, None, None, d, consts.scalar(d)
        t = np.full(t_last.shape, t0)
    else:
        t0 = None
        t = np.asarray(t_s, dtype=float)
        if t.shape != t_last.shape:
            raise ValueError(
                f"t_s: need a scalar or one time per track {t_last.shape}, got shape {t.shape}"
            )
        if not np.all(np.isfinite(t)):
            raise ValueError("t_s: times must be finite")
    dt = t - t_last
    lo, hi = dt.min(), dt.max()
    if lo < 0.0:
        bad = ids[dt < 0]
        raise ValueError(f"t_s: earlier than the last cycle of track(s) {bad.tolist()}")
    if lo == hi:
        d = float(lo)
        return t0, t, dt, d, consts.scalar(d)
    return t0, t, dt, None, consts.per_track(dt)
