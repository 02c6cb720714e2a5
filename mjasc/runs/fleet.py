"""Fleet scenarios: a large formation of Otters sailing a common path among crossing traffic.

:func:`formation_among_traffic` builds a :class:`~mjasc.runs.scenario.Scenario` (and
:func:`formation_among_traffic_doc` the scenario document, the dict a TOML file holds) for any
number of vessels; ``benchmarks/bench_fullstack.py`` runs fleets of 3 to 100 with it and
``scripts/make_fleet_scenario.py`` writes ``tasks/fleet_50.toml`` from it.

Geometry (world ENU, SI). The formation is a grid of ``rows × columns`` Otters, columns
``column_spacing_m`` apart across the track, rows ``row_spacing_m`` apart along it; the front row
starts at x = 0, the grid is centred on y = 0, and the fleet sails east. Vessel (r, c) follows the
reference path — a straight line east from the origin, ``path_length_m`` long — translated by

    d_rc = (−r · row_spacing_m, (c − (columns − 1)/2) · column_spacing_m)

so every path has the same length L and equal path parameters γ/L mean "in formation" (the
coordination controller's consensus variable, :mod:`mjasc.cooperation.coordination`): the grid
stays rigid while the team agrees. Every vessel has the whole onboard stack: a range sensor (360
beams, 120 m), IMM tracking, collision avoidance and the comms link (radio preset).

Traffic. ``crossings`` boats (default one per ten vessels, at least two) cross the track,
alternately southbound and northbound, at ``crossing_speed_m_s``. Boat k crosses the centre line
at time t_k = ``first_crossing_s`` + k · ``crossing_interval_s`` at x_k = v t_k + ``crossing_lead_m``:
``crossing_lead_m`` ahead of where the front row would be at full speed, so it passes close ahead
of the front row and through the path of the columns on its far side — the vessels it threatens
predict the conflict and slow down to let it pass (velocity correction: a vessel always yields to
traffic outside its team), then the coordination law closes the formation up again. One more
boat sails the opposite way along the formation's port side, ``passing_clearance_m`` outside its
edge (tracked by every vessel that sees it, no conflict).
"""

from __future__ import annotations

import math

__all__ = ["formation_among_traffic", "formation_among_traffic_doc"]


def formation_among_traffic_doc(n_vessels: int = 50, *, columns: int | None = None, column_spacing_m: float = 15.0,
                                row_spacing_m: float = 18.0, speed_m_s: float = 1.5, duration_s: float = 120.0,
                                seed: int = 1, crossings: int | None = None, crossing_speed_m_s: float = 1.5,
                                first_crossing_s: float = 25.0, crossing_interval_s: float = 20.0,
                                crossing_lead_m: float = 25.0, passing_clearance_m: float = 30.0,
                                beams: int = 360, sensor_range_m: float = 120.0, recording: bool = True,
                                name: str | None = None) -> dict:
    """The scenario document (module docstring) of ``n_vessels`` Otters in a grid of ``columns``
    columns (default ⌈√n⌉) among traffic: a plain dict of TOML values, ready for
    :func:`mjasc.runs.scenario.parse_scenario` or a TOML writer."""
    n = int(n_vessels)
    if n < 1:
        raise ValueError(f"n_vessels: must be ≥ 1, got {n_vessels}")
    cols = int(columns) if columns is not None else math.ceil(math.sqrt(n))
    if not 1 <= cols <= n:
        raise ValueError(f"columns: must be in [1, n_vessels], got {columns}")
    rows = math.ceil(n / cols)
    n_cross = max(2, n // 10) if crossings is None else int(crossings)
    half_width = 0.5 * (cols - 1) * column_spacing_m
    depth = (rows - 1) * row_spacing_m
    length = round(speed_m_s * duration_s * 1.5 + depth + 100.0, 1)
    vessels = []
    for i in range(n):
        r, c = divmod(i, cols)
        x0, y0 = -r * row_spacing_m, (c - 0.5 * (cols - 1)) * column_spacing_m
        x0, y0 = round(x0, 3) + 0.0, round(y0, 3) + 0.0  # no -0.0 in the file
        vessels.append({
            "name": f"v{i:03d}", "type": "otter", "position_m": [x0, y0], "speed_m_s": 1.0,
            "controller": {"type": "path_following", "waypoints": [[x0, y0], [round(x0 + length, 3), y0]],
                           "speed_m_s": speed_m_s},
            "sensor": {"beams": beams, "max_range_m": sensor_range_m},
            "tracking": {},
            "avoidance": {"window_s": 40.0, "safety_distance_m": 1.5},
            "comms": {"max_speed_correction": 0.4, "error_scale_m": 10.0},
        })
    traffic = []
    for k in range(n_cross):
        t_k = first_crossing_s + k * crossing_interval_s
        x_k = speed_m_s * t_k + crossing_lead_m
        south = k % 2 == 0  # southbound boats start north of the track
        y_start = crossing_speed_m_s * t_k * (1.0 if south else -1.0)
        traffic.append({"name": f"crossing{k}", "radius_m": 3.0, "position_m": [round(x_k, 3), round(y_start, 3)],
                        "heading_deg": -90.0 if south else 90.0, "speed_m_s": crossing_speed_m_s})
    traffic.append({"name": "passing", "radius_m": 4.0,
                    "position_m": [round(speed_m_s * duration_s + 150.0, 3),
                                   round(half_width + passing_clearance_m, 3)],
                    "heading_deg": 180.0, "speed_m_s": 1.2})
    return {
        "name": name or f"fleet_{n}",
        "description": (f"{n} Otters in a {rows}×{cols} formation ({row_spacing_m:g} m rows, {column_spacing_m:g} m "
                        f"columns) on a common path, every vessel sensing, tracking, avoiding and on comms; "
                        f"{n_cross} boats cross ahead, one passes alongside"),
        "duration_s": float(duration_s),
        "seed": int(seed),
        "rates": {"physics_hz": 50.0, "control_hz": 10.0, "sensing_hz": 5.0, "tracking_hz": 5.0, "comms_hz": 1.0,
                  "record_hz": 5.0, "prediction_period_s": 5.0},
        "comms": {"preset": "radio", "range_m": 500.0, "loss_probability": 0.05},
        "outputs": {"recording": bool(recording), "video": False, "video_camera": "top_down"},
        "vessels": vessels,
        "moving_obstacles": traffic,
    }


def formation_among_traffic(n_vessels: int = 50, **options):
    """The :class:`~mjasc.runs.scenario.Scenario` of :func:`formation_among_traffic_doc` (same options)."""
    from mjasc.runs.scenario import parse_scenario

    doc = formation_among_traffic_doc(n_vessels, **options)
    return parse_scenario(doc, f"<{doc['name']}>")
