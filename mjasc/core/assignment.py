"""The linear assignment problem, SciPy's solver loaded when first needed.

:func:`linear_sum_assignment` is :func:`scipy.optimize.linear_sum_assignment`: the least total cost
of assigning rows to columns, each used at most once. Importing ``scipy.optimize`` takes ~0.2 s
(~50 ms beyond the ``scipy.spatial`` most runs import anyway), and a run whose tracking gates never
overlap — the compiled easy blocks make every other assignment — never calls it; so it is imported
at the first call. Used by the tracker's association (:mod:`mjasc.perception.tracking.association`),
the team's track fusion (:mod:`mjasc.perception.track_fusion`) and the tracking score
(:mod:`mjasc.evaluation.tracking_metrics`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["linear_sum_assignment"]


def linear_sum_assignment(cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``scipy.optimize.linear_sum_assignment(cost)`` for ``cost`` (n, m): the row and column
    indices of the chosen pairs."""
    from scipy.optimize import linear_sum_assignment as solve

    return solve(cost)
