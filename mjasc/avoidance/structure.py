"""Mapped structure (islands, piers) in the avoidance's decisions: which tracks are the structure's
own returns seen as targets, and which detours run onto it (docs/avoidance.md, "Hardening").

Under sensor dropout a large structure's returns break into clusters that the tracker follows as
7–8 m targets moving by noise (the §6.4.3 islands under 30 % dropout), while the static map holds
only the slivers of the faces it has seen. :func:`structure_tracks` sorts such stranger tracks
out; :func:`detour_onto_structure` refuses a detour around a moving track that would take the
vessel onto mapped structure. Pure functions; world frame ENU, SI units, absolute times [s].
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.avoidance.static_conflicts import static_conflicts
from mjasc.core.compiled import kernel, maximum
from mjasc.core.geometry import distance_to_polygon, point_in_polygon, signed_distance_to_polygon
from mjasc.core.polygon_kernels import boundary_distance, inside_even_odd

__all__ = ["structure_tracks", "detour_onto_structure", "turn_away_from_structure"]


def structure_tracks(tracks, polygons, slow_m_s: float) -> tuple[dict[int, float], set[int]]:
    """The stranger tracks (moving, no team mate) that are a mapped structure's own returns seen as
    a target, as (inside: track id → depth [m], beside: track ids), given the mapped static
    ``polygons``.

    Inside: the track's centre lies inside a mapped polygon, ``depth`` [m] from its boundary. No
    vessel floats inside land: the track is static, and the object it stands for is no larger than
    the mapped structure around its centre — a disc of radius min(radius, depth). (As a static disc
    of its bounding radius a 7.8 m fragment of the south island's face, centred in the 2 m sliver
    the map holds of that face, closed the whole gap between the §6.4.3 islands — collision
    distance 11.4 m — and bravo re-planned into the island: seed 11. A vessel whose own returns the
    map absorbed, the demo's ferry passing the pontoon's end, sits deep in its own footprint and
    keeps about its radius.)
    Beside: slower than ``slow_m_s`` with its disc overlapping a mapped polygon — to be taken as
    static (a 7.7 m track drifting at 0.23 m/s on the north island's edge sent a detour into the
    island; a boat moored at a pontoon looks the same, so it stays an obstacle)."""
    polys = [np.asarray(p, dtype=float).reshape(-1, 2) for p in polygons or ()]
    strangers = [tr for tr in tracks if not tr.is_static and tr.team_member is None]
    if not polys or not strangers:
        return {}, set()
    centres = np.array([tr.position_m for tr in strangers], dtype=float).reshape(-1, 2)
    radii = np.array([tr.radius_m for tr in strangers], dtype=float)
    slow = np.array([tr.speed_m_s < slow_m_s for tr in strangers])
    depth = np.full(len(strangers), -1.0)
    beside = np.zeros(len(strangers), dtype=bool)
    ends = np.cumsum([p.shape[0] for p in polys])
    _structure_depths(centres, radii, slow, np.concatenate(polys), ends, depth, beside)
    depth = depth.tolist()
    return ({tr.track_id: k for tr, k in zip(strangers, depth) if k >= 0.0},
            {tr.track_id for tr, k, b in zip(strangers, depth, beside) if b and k < 0.0})


def detour_onto_structure(t: float, position_m, detour, polygons, speed_m_s: float, radius_m: float,
                          prediction_config, slack_m: float) -> str | None:
    """Why ``detour`` (a :class:`~mjasc.avoidance.replanning.Detour` planned around a moving track)
    is not to be taken, or None: its streamline passes a mapped polygon (or a static track's
    outline) closer than R_vh + safety distance (:func:`~mjasc.avoidance.static_conflicts.static_conflicts`
    at ``speed_m_s``), and closer by more than ``slack_m`` [m] than the vessel at ``position_m`` is
    now (a vessel already near a structure may still leave along it).

    Why: a re-plan from inside the merged (convex-hull) safety region of a track and the land
    beside it shrinks that region about its centre, and the streamline can run into the land. In
    the §6.4.3 bottleneck under 30 % dropout a north-island fragment made charlie (seed 2) re-plan
    from the gap; the fresh detour's own check found it crossing the south island 1.8 m ahead, and
    charlie sailed it — a 108° sharp turn whose saturated differential gathered way again — into
    the island."""
    here = np.asarray(position_m, dtype=float)[None, :2]
    for s in static_conflicts(t, detour.path, 0.0, speed_m_s, polygons, radius_m, prediction_config):
        if s.gamma_a >= detour.detour_length_m:
            continue  # on the mission path after the detour: the next prediction's business
        now = 0.0 if point_in_polygon(here, s.polygon)[0] else float(distance_to_polygon(here, s.polygon)[0])
        if s.min_distance_m < now - slack_m:
            return (f"the detour passes a mapped structure at {s.min_distance_m:.1f} m "
                    f"(γ = {s.gamma_a:.1f} m on it; the vessel is {now:.1f} m from it now)")
    return None


@kernel
def _structure_depths(centres, radii, slow, stacked, ends, depth, beside):
    """:func:`structure_tracks`' loop over the polygons (rows ``ends[p − 1] … ends[p] − 1`` of
    ``stacked``) in one compiled pass: for each, the centres' distances to its boundary and whether
    they lie inside (:func:`~mjasc.core.geometry.distance_to_polygon` and
    :func:`~mjasc.core.geometry.point_in_polygon`'s kernels), ``depth = where(inside, maximum(depth,
    d), depth)`` and ``beside |= slow & (d < radii)``, as the numpy form did."""
    start = 0
    for p in range(ends.shape[0]):
        poly = stacked[start:ends[p]]
        start = ends[p]
        d = boundary_distance(centres, poly)
        inside = inside_even_odd(centres, poly)
        for i in range(centres.shape[0]):
            if inside[i]:
                depth[i] = maximum(depth[i], d[i])
            if slow[i] and d[i] < radii[i]:
                beside[i] = True


#: A turn this far off the heading or more may be taken the long way round, away from structure [rad].
REVERSAL_RAD = math.radians(135.0)


def turn_away_from_structure(position_m, heading_rad: float, error_rad: float, polygons, probe_m: float,
                             margin_m: float) -> int:
    """The direction of a near-reversal turn beside mapped structure: +1 counter-clockwise (to
    port), −1 clockwise, 0 the shortest way (no reason to go the long way). ``error_rad`` is the
    signed turn wanted (wrapped, the shortest way); for |error| ≥ :data:`REVERSAL_RAD` the bow's
    sweep each way — points ``probe_m`` ahead at every 10° of heading passed — is measured against
    the ``polygons`` (signed distance, negative inside), and the long way is taken when its sweep
    clears them by ``margin_m`` more than the short way's and the short way's comes within
    ``probe_m``. A 162° turn 3.9 m from an island's corner taken the short way swept the bow
    through the corner and the hull, gathering way in the saturated turn, touched the island
    (tests/cas_regressions/bottleneck_current_reversal_14.toml)."""
    polys = [np.asarray(p, dtype=float).reshape(-1, 2) for p in polygons or ()]
    if abs(error_rad) < REVERSAL_RAD or not polys:
        return 0
    short = 1 if error_rad > 0.0 else -1
    p = np.asarray(position_m, dtype=float)[:2]

    def sweep(direction: int, angle: float) -> float:
        theta = float(heading_rad) + direction * np.linspace(0.0, angle, max(int(math.degrees(angle) / 10.0), 1) + 1)
        pts = p + probe_m * np.stack([np.cos(theta), np.sin(theta)], axis=-1)
        return min(float(np.min(signed_distance_to_polygon(pts, poly))) for poly in polys)

    near = sweep(short, abs(error_rad))
    far = sweep(-short, 2.0 * math.pi - abs(error_rad))
    return -short if near < probe_m and far > near + margin_m else 0
