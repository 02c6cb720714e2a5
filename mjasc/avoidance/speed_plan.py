"""The own vessel's planned progress γ(t) along its path under a velocity correction.

While a velocity correction runs the virtual target moves at its desired speed V_d until the
correction's goal time, and at the mission speed after it (docs/thesis.md §4); without one the
vessel keeps the mission speed. :func:`correction_profile` is that speed profile as collision
prediction takes it (a function of absolute time, or the constant speed itself);
:func:`correction_terms` its numbers for the compiled planned trajectory
(:mod:`~mjasc.avoidance.intent_plan`). SI units, absolute simulation times [s].

The plan steps from V_d to the mission speed at the goal time; a hull does not. A correction
faster than the mission speed (a pass first, up to the top speed) ends with the vessel still at
V_d, and it sheds the difference over seconds and metres. With ``decel_m_s2`` > 0 the profile
predicts that: after the goal time the speed falls linearly from V_d to the mission speed at
``decel_m_s2``, which puts the vessel (V_d − v_m)² / (2 a) further along than the plan
(docs/avoidance.md, "Hardening": the 50-vessel fleet, a pass ending 4.0 m — predicted — behind a
slower team mate in the same lane, 2.6 m in fact). The broadcast plan keeps the step, and a
yield's end (the hull gathering way behind the plan) is not modelled: doing both, in the
prediction and the broadcast, cost hull contacts in the stressed bottleneck (same section).
"""

from __future__ import annotations

import numpy as np

from mjasc.avoidance.decision import Correction

__all__ = ["correction_profile", "correction_terms"]


def correction_profile(correction: Correction | None, t_now: float, gamma_now: float, mission_speed_m_s: float,
                       decel_m_s2: float = 0.0):
    """γ(t) [m] for t ≥ t_now under ``correction``: its V_d until its goal time, the mission speed
    after; None → the mission speed [m/s] itself (a constant profile). ``decel_m_s2`` > 0: a V_d
    above the mission speed falls to it at that deceleration after the goal time (module
    docstring); 0: at once, as planned."""
    terms = correction_terms(correction, t_now, mission_speed_m_s)
    if terms[0] == 0:
        return terms[1]
    _, v_d, span, v_m, t_start = terms
    excess = v_d - v_m
    if decel_m_s2 > 0.0 and excess > 0.0:
        tau = excess / decel_m_s2  # the time the hull takes to shed the excess [s]
        t_goal = float(correction.law.t_goal)  # (t_start, unless the goal has passed: then t_now)
        s0 = min(max(t_now - t_goal, 0.0), tau)  # what was shed before t_now [s of shedding]
        shed0 = excess * s0 - 0.5 * decel_m_s2 * s0 * s0  # (0 before the goal: the same numbers)

        def gamma_slowing(t):
            t = np.asarray(t, dtype=float)
            s = np.clip(t - t_goal, 0.0, tau)
            return (gamma_now + v_d * np.clip(t - t_now, 0.0, span) + v_m * np.maximum(t - t_start, 0.0)
                    + excess * s - 0.5 * decel_m_s2 * s * s) - shed0

        return gamma_slowing

    def gamma_fn(t):
        t = np.asarray(t, dtype=float)
        return gamma_now + v_d * np.clip(t - t_now, 0.0, span) + v_m * np.maximum(t - t_start, 0.0)

    return gamma_fn


def correction_terms(correction: Correction | None, t_now: float, mission_speed_m_s: float) -> tuple:
    """The numbers of :func:`correction_profile` as planned (the step at the goal, what the team is
    told; ``decel_m_s2`` = 0): ``(0, v_m)`` without a correction, else
    ``(1, V_d, span, v_m, t_start)`` for
    γ(t) = γ_now + V_d·clip(t − t_now, 0, span) + v_m·max(t − t_start, 0)."""
    v_m = float(mission_speed_m_s)
    if correction is None:
        return 0, v_m
    t_g, v_d = correction.law.t_goal, max(correction.law.desired_speed, 0.0)
    return 1, v_d, max(t_g - t_now, 0.0), v_m, max(t_g, t_now)
