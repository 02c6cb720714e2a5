"""Interacting Multiple Model (IMM) tracking of obstacles (thesis §3.2.1, docs/thesis.md §2).

State of a tracked object ``s = [x, y, θ, V]``: world-frame ENU position [m], course over ground
θ (CCW from east) [rad], speed over ground V ≥ 0 [m/s]. r constant-turn models (fixed turn rates
ω_j, thesis eq. 3.3), each an EKF on the position measurement ``z = [x, y] + v``, ``R = σ²·I₂``,
mixed by a Markov chain; the IMM cycle of docs/thesis.md §2 (steps 1–6), with the Gaussian likelihood in
the measurement dimension 2 (thesis eq. 3.10 is wrong, see docs/thesis.md §2).

Choices beyond the thesis (all parameters of :class:`IMMConfig`): a variable sample time (the
Markov matrix raised to Ts/T_ref), coasting, re-parametrized negative speeds, a start-up
constant-velocity filter, chi-square gating and restarts after consecutive gated measurements.
Angles are mixed as angles (one common chart per track).

Modules (one concept each):

* :mod:`~mjasc.perception.imm.config` — :class:`IMMConfig` (every parameter declared once),
  :func:`parse_imm_options`;
* :mod:`~mjasc.perception.imm.markov` — Markov matrix powers p(Ts) = p^(Ts/T_ref) and the other
  per-Ts constants of a cycle;
* :mod:`~mjasc.perception.imm.compiled_cycle` — the IMM cycle as one compiled loop over a bank's
  tracks (eq. 3.3 EKFs, mixing, mode probabilities, combination): the equations in full;
* :mod:`~mjasc.perception.imm.startup` — the start-up constant-velocity filter and its hand-over;
* :mod:`~mjasc.perception.imm.predictive` — the predictive measurement mixture for association;
* :mod:`~mjasc.perception.imm.bank` — :class:`IMMBank`, many tracks in one call (time handling,
  coasting, gating, restarts); its read-only views of the rows are
  :mod:`~mjasc.perception.imm.bank_views` (its base class), the arrays its cycles write into
  :mod:`~mjasc.perception.imm.cycle_buffers`;
* :mod:`~mjasc.perception.imm.tracker` — :class:`IMMTracker`, one target behind a scalar API;
* :mod:`~mjasc.perception.imm.filterpy_reference` — the same bank built with filterpy
  (``filterpy_imm``, ``FilterpyIMMTracker``), the reference for tests and benchmarks; the only
  module that imports filterpy (not re-exported here, so importing this package never loads it).
"""

from mjasc.perception.imm.bank import REJECTION_REASONS, IMMBank
from mjasc.perception.imm.config import IMMConfig, parse_imm_options
from mjasc.perception.imm.tracker import IMMTracker

__all__ = ["IMMConfig", "IMMBank", "IMMTracker", "REJECTION_REASONS", "parse_imm_options"]
