"""Right of way: which vessel of a conflicting pair corrects its speed (docs/thesis.md §5, thesis §4.2).

A vessel always yields (slows down) to a dynamic obstacle that is not a team mate. Between team
mates, first COLREG rule 13: a vessel coming up from more than 22.5° abaft the other's beam
(relative bearing beyond ±112.5°) is overtaking and keeps out of the way — the overtaken vessel
keeps its speed. Then rule 15: the vessel that has the other on its **starboard** side gives
way (in the FLU body frame starboard is negative body y), the other keeps its speed. The thesis
applies rule 15 alone; in the §6.4.3 bottleneck that made the vessel ahead slow down for the team
mate closing on it from its starboard quarter, which then ran into it. Both vessels evaluate the
rules on their own, without messages, so they must pick exactly one of the two in every
geometry. Where the rules pick both or neither, ties are broken in order:

1. *The other is more nearly ahead* — the vessel whose relative bearing to the other has the larger
   cosine gives way. This covers overtaking on one line (the overtaking vessel has the other dead
   ahead, the overtaken one has it dead astern: the overtaking vessel gives way, as COLREG rule 13).
2. *Course* — for pairs that are symmetric under a half turn (exactly head-on, or passing
   port-to-port / starboard-to-starboard with equal bearings), the vessel whose heading, taken in
   [0, 2π), is smaller gives way.
3. *Position* — if the headings are equal too, the vessel with the lexicographically smaller
   world (x, y) gives way.

Each step compares a quantity that swaps between the two vessels, so the pair always splits:
``gives_way(A, B) != gives_way(B, A)`` for team mates. A mirror-image (bottleneck) pair has the
other on opposite sides, so the plain starboard rule already decides it.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.frames import world_to_body

#: Relative tolerance for "exactly on the bow/stern line" and equal bearings/headings.
_TOL = 1e-9
#: A vessel seen beyond this relative bearing [rad] (22.5° abaft the beam) is overtaking (rule 13).
OVERTAKING_BEARING_RAD = np.radians(112.5)


def _point(value, name):
    p = np.asarray(value, dtype=float)
    if p.shape != (2,) or not np.all(np.isfinite(p)):
        raise ValueError(f"{name}: expected a finite point of shape (2,), got {value!r}")
    return p


def _heading(value, name):
    h = float(value)
    if not np.isfinite(h):
        raise ValueError(f"{name}: must be finite, got {value}")
    return h


def relative_bearing(own_position, own_heading, other_position) -> float:
    """Bearing of ``other_position`` from the vessel [rad], in its FLU body frame: 0 dead ahead,
    positive to port, negative to starboard, ±π dead astern."""
    own = _point(own_position, "own_position")
    rel = world_to_body(_point(other_position, "other_position") - own, _heading(own_heading, "own_heading"))
    return float(np.arctan2(rel[1], rel[0]))


def _starboard(own, own_h, other) -> bool:
    rel = world_to_body(other - own, own_h)
    return bool(rel[1] < -_TOL * np.hypot(*rel))


def gives_way(own_position, own_heading, other_position, other_heading, other_is_team: bool) -> bool:
    """True if this vessel must give way (slow down) to the other one.

    own/other_position: (2,) world ENU [m]; own/other_heading: course CCW from east [rad];
    other_is_team: the other is a team mate (else a non-team dynamic obstacle: always yield).
    """
    own = _point(own_position, "own_position")
    other = _point(other_position, "other_position")
    own_h = _heading(own_heading, "own_heading")
    other_h = _heading(other_heading, "other_heading")
    if not other_is_team:
        return True
    if np.hypot(*(other - own)) == 0.0:
        raise ValueError("other_position: coincides with own_position")
    abaft_own = abs(relative_bearing(own, own_h, other)) > OVERTAKING_BEARING_RAD  # it overtakes me
    abaft_other = abs(relative_bearing(other, other_h, own)) > OVERTAKING_BEARING_RAD  # I overtake it
    if abaft_own != abaft_other:  # COLREG rule 13: the overtaking vessel keeps out of the way
        return abaft_other
    s_own, s_other = _starboard(own, own_h, other), _starboard(other, other_h, own)
    if s_own != s_other:  # COLREG rule 15
        return s_own
    ahead_own = np.cos(relative_bearing(own, own_h, other))
    ahead_other = np.cos(relative_bearing(other, other_h, own))
    if abs(ahead_own - ahead_other) > _TOL:
        return bool(ahead_own > ahead_other)
    h_own, h_other = np.mod(own_h, 2.0 * np.pi), np.mod(other_h, 2.0 * np.pi)
    if abs(h_own - h_other) > _TOL and abs(abs(h_own - h_other) - 2.0 * np.pi) > _TOL:
        return bool(h_own < h_other)
    return bool(tuple(own) < tuple(other))
