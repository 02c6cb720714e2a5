"""CycleBuffers: the preallocated arrays an IMM bank's cycles write into
(:class:`mjasc.perception.imm.bank.IMMBank`, :mod:`mjasc.perception.imm.subset`) — two sides, so a
cycle never overwrites its own inputs, and no arrays are made per cycle, birth or drop.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CycleBuffers"]


class CycleBuffers:
    """Room for what :func:`imm_cycle` writes for up to ``cap`` tracks × r models: two sides
    ``(s, P, μ, x)`` and ``d2_min``. A bank's state lives in the first n rows of one side (its
    ``_side``; None: in arrays of its own); a cycle writes the first n rows of the other side, so its
    inputs are never overwritten by it. Births write into the state side's spare rows and drops
    compact into the other side (no arrays made per birth or drop, nor per number of tracks)."""

    def __init__(self, cap: int, r: int):
        self.cap = cap
        self.sides = tuple((np.zeros((cap, r, 4)), np.zeros((cap, r, 4, 4)), np.zeros((cap, r)), np.zeros((cap, 4)))
                           for _ in range(2))
        self.d2_min = np.zeros(cap)
        self._views: dict[tuple[int, int], tuple] = {}

    def views(self, side: int, n: int) -> tuple:
        """The first n rows of ``side``: (s, P, μ, x, d2_min) (the same view objects every time)."""
        v = self._views.get((side, n))
        if v is None:
            if len(self._views) > 64:
                self._views.clear()
            s, P, mu, x = self.sides[side]
            v = self._views[(side, n)] = (s[:n], P[:n], mu[:n], x[:n], self.d2_min[:n])
        return v
