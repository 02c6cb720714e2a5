"""Standard manoeuvring trials of one hull in still water: speed, turning circle, zig-zag, stopping.

The trials follow the IMO manoeuvring standards (Resolution MSC.137(76), MSC/Circ.1053) adapted to
a twin-propeller craft **without a rudder**: the "rudder" is a *differential propeller command*.
A trial sails one vessel alone in still water (``build_world`` + :class:`~mjasc.physics.simulation.Simulation`,
the scene's physics step, no current) from rest at the origin, heading east (ψ = 0).

Commands (normalized shaft speeds in [−1, 1], port then starboard, held constant per phase):

* **"rudder" definition.** A pair (p, s) is read as a mean command ``m = (p + s)/2`` and a
  differential ``δ = (p − s)/2`` (the "rudder angle"). p > s turns the hull to starboard
  (clockwise, ψ decreasing: the port propeller at +y pushes harder), p < s to port.
  **"Rudder amidships"** for that pair is the equal command c₀ on both shafts giving the *same total
  thrust*, ``2 T(c₀) = T(p) + T(s)`` with the vessel's T(c) = k n|n| (thrusters.py); for the
  default (1.0, 0.2), c₀ = 0.7211. The approach of the turning circle and the zig-zag sails straight
  at (c₀, c₀), so that "putting the rudder over" only redistributes the thrust between the shafts
  (a yaw moment, no change of surge force) — the standard's "engine setting unchanged". (With the
  mean *command* m instead, the quadratic thrust law would add 44 % thrust at the execute and the
  vessel would speed up in the turn, unlike a ship.)

Trials and their defaults (used for ``port``/``starboard`` when not given; each missing value
independently takes its kind's default):

``speed``           (1.0, 1.0). From rest, hold (p, s) until steady.
                    ``steady_speed`` [m/s], ``t63`` [s] = time from rest to (1 − e⁻¹) ≈ 63.2 % of
                    the steady speed (linearly interpolated between physics steps).
``turning-circle``  (1.0, 0.2): m = 0.6, δ = 0.4, a steady turn to starboard. Approach straight at
                    (c₀, c₀) until steady, then execute (p, s) at the "execute point" and hold.
                    ``advance`` / ``transfer`` [m] = displacement along / across the approach course
                    when the heading has changed by 90°; ``tactical_diameter`` [m] = transfer at 180°;
                    ``steady_speed``, ``steady_yaw_rate`` [rad/s, magnitude], ``steady_drift_angle_deg``
                    once the turn is steady; ``steady_diameter`` [m] from a least-squares circle fitted
                    to the track over one full steady revolution (geometry, not U/r, so that
                    ``steady_diameter ≈ 2 U / |r|`` is a check, not an identity).
``zigzag``          (1.0, 0.2), angle 20°: the "20°/20°" zig-zag with the rudder angle replaced by the
                    differential δ = (p − s)/2 = ±0.4 about m = 0.6. Approach straight at (c₀, c₀);
                    execute (p, s); when the heading has deviated by 20° from the approach course,
                    execute the mirror pair (s, p); when it has deviated 20° to the other side, (p, s)
                    again; stop at that third execute. ``overshoot_1_deg`` = largest deviation beyond
                    20° after the first counter-execute (the first overshoot angle), ``overshoot_2_deg``
                    the same after the second; ``initial_turning_time`` [s] from the first execute to
                    the first 20° check (= the second execute); ``time_to_third_execute`` likewise.
``stopping``        (−1.0, −1.0): the IMO crash stop. Approach straight at full ahead (1, 1) until
                    steady, then execute (p, s) — full astern by default; (0, 0) is coasting (shafts
                    stopped). Both must be ≤ 0. "Stopped" is surge speed u ≤ 0.05 m/s (headway lost),
                    interpolated between steps. ``stopping_distance`` [m] = track reach (distance
                    sailed along the track from the execute point), ``head_reach`` [m] along the
                    approach course, ``lateral_deviation`` [m], ``stopping_time`` [s].

``tightest-turn``   at a speed U (default: the hull's cruise speed; ``--speed``), the tightest steady turn
                    the hull sails in still water (:mod:`mjasc.physics.steady_turn`: one propeller
                    at its limit, the other's command solved for U from the equations of motion;
                    ``--port`` / ``--starboard`` are not taken). From rest, the solved commands are
                    held until steady and for one revolution: ``closed_form_diameter`` [m] = 2 U / r
                    of the solve, ``steady_diameter`` [m] the circle fitted to the simulated track,
                    ``steady_speed``, ``steady_yaw_rate``, ``steady_drift_angle_deg`` of the
                    simulated hull (the two agree to a few tenths of a per cent).
                    ``min_mission_turn_radius`` [m]: half the closed-form diameter rounded up to
                    the centimetre, the smallest ``turn_radius_m`` a go-to-formation mission takes
                    at that cruise speed (the value the scenario check's error names).

Steady state (:data:`mjasc.physics.trial_track.STEADY`): sampled every ``sample_s``, the state is steady when, over the last
``window_s``, the spread (max − min) of u and v is below ``velocity_tol_m_s`` and that of r below
``yaw_rate_tol_rad_s``; a phase gives up at ``max_time_s`` and the result then says
``steady_state_reached: False``. For a first-order response with time constant τ the remaining error
is at most tol / (1 − e^(−window/τ)): with the defaults ≈ 2·10⁻⁴ m/s for the Delfim (τ ≈ 2.1 s).

Every result holds ``kind``, ``vessel``, ``port``, ``starboard`` (the manoeuvre's commands),
``approach_commands`` where there is an approach, ``timestep_s`` and ``steady_state_reached``; SI
units, rounded (m and m/s to 4 decimals, s to 3, angles to 2 in degrees, rad/s to 6).
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.config_tables import number
from mjasc.physics.trial_measures import course_frame, crossing_time, fit_circle, path_length, row_at_level
from mjasc.physics.trial_track import TrialTrack, amidships_command, new_track

__all__ = ["TRIAL_KINDS", "DEFAULT_COMMANDS", "run_trial", "UNITS"]

#: The unit of each numeric result of :func:`run_trial` (printed by ``mjasc trial``).
UNITS = {"timestep_s": "s", "port": "(command in [-1, 1])", "starboard": "(command in [-1, 1])",
         "approach_commands": "(commands in [-1, 1])", "approach_speed": "m/s", "steady_speed": "m/s",
         "steady_surge": "m/s", "steady_yaw_rate": "rad/s", "t63": "s", "advance": "m", "transfer": "m",
         "tactical_diameter": "m", "steady_diameter": "m", "steady_drift_angle_deg": "deg", "time_to_90_deg": "s",
         "time_to_180_deg": "s", "initial_turning_time": "s", "time_to_third_execute": "s",
         "overshoot_1_deg": "deg", "overshoot_2_deg": "deg", "zigzag_angle_deg": "deg", "head_reach": "m",
         "lateral_deviation": "m", "stopping_distance": "m", "stopping_time": "s", "speed": "m/s",
         "closed_form_diameter": "m", "min_mission_turn_radius": "m"}

TRIAL_KINDS = ("speed", "turning-circle", "zigzag", "stopping", "tightest-turn")

#: Default (port, starboard) command of the manoeuvre of each trial kind.
DEFAULT_COMMANDS = {
    "speed": (1.0, 1.0),
    "turning-circle": (1.0, 0.2),
    "zigzag": (1.0, 0.2),
    "stopping": (-1.0, -1.0),
    "tightest-turn": (None, None),  # (solved for, not given)
}

#: Approach command of the stopping trial: full ahead.
STOPPING_APPROACH = (1.0, 1.0)
#: Surge speed [m/s] at or below which a stopping vessel counts as stopped (headway lost).
STOPPED_SURGE_M_S = 0.05
#: Upper bound on a manoeuvre phase (turn to 180°, zig-zag, stop) [s].
MANOEUVRE_MAX_TIME_S = 600.0

ONE_MINUS_INV_E = 1.0 - math.exp(-1.0)


# ---------------------------------------------------------------------- helpers
def _validate_command(value, flag: str) -> float:
    """A normalized propeller command: a finite number in [-1, 1]."""
    c = number(value, flag)
    if not -1.0 <= c <= 1.0:
        raise ValueError(f"{flag}: must be in [-1, 1] (normalized shaft speed), got {c:g}")
    return c


def _r(x, nd):
    return None if x is None else round(float(x), nd)


# ---------------------------------------------------------------------- trials
def _speed(track: TrialTrack, p: float, s: float) -> dict:
    track.command(p, s)
    steady = track.sail_until_steady()
    rows = track.array()
    speed = np.hypot(rows[:, 4], rows[:, 5])
    u_inf, r_inf = rows[-1, 4], rows[-1, 6]
    u_steady = float(speed[-1])
    t63 = crossing_time(rows[:, 0], speed, ONE_MINUS_INV_E * u_steady) if u_steady > 0 else None
    return {
        "steady_speed": _r(u_steady, 4),
        "steady_surge": _r(u_inf, 4),
        "steady_yaw_rate": _r(abs(r_inf), 6),
        "t63": _r(t63, 3),
        "steady_state_reached": steady,
    }


def _approach(track: TrialTrack, commands: tuple[float, float]) -> tuple[bool, int, np.ndarray, float, float]:
    """Sail straight to steady state; returns (steady, execute row index, execute xy, ψ0, speed)."""
    track.command(*commands)
    steady = track.sail_until_steady()
    i0 = len(track.rows) - 1
    t, x, y, psi, u, v, r = track.rows[i0]
    return steady, i0, np.array([x, y]), psi, math.hypot(u, v)


def _turning_circle(track: TrialTrack, p: float, s: float) -> dict:
    if p == s:
        raise ValueError(f"--port/--starboard: a turning circle needs different commands, got {p:g} and {s:g} "
                         "(equal commands sail straight)")
    m = amidships_command(track, p, s)
    ok_approach, i0, xy0, psi0, u0 = _approach(track, (m, m))
    t0 = track.rows[i0][0]
    track.command(p, s)
    dt = track.sim.timestep_s
    # Turn until the heading has changed by 180°, then until steady.
    while abs(track.last[3] - psi0) < math.pi:
        if track.last[0] - t0 > MANOEUVRE_MAX_TIME_S:
            raise ValueError(f"--port/--starboard: ({p:g}, {s:g}) did not turn the vessel through 180° within "
                             f"{MANOEUVRE_MAX_TIME_S:g} s (differential too small)")
        track.step(max(1, round(0.25 / dt)))
    ok_turn = track.sail_until_steady()
    # One full steady revolution for the circle fit.
    r_now = track.last[6]
    if abs(r_now) < 1e-6:
        raise ValueError(f"--port/--starboard: ({p:g}, {s:g}) gives no steady turn (yaw rate {r_now:.2g} rad/s)")
    i_steady = len(track.rows) - 1
    period = 2.0 * math.pi / abs(r_now)
    track.step(math.ceil(period / dt) + 1)
    turn = track.array(i0)
    direction = -1.0 if turn[-1, 6] < 0 else 1.0  # ψ decreasing = clockwise = starboard
    change = direction * (turn[:, 3] - psi0)
    with_change = np.column_stack([turn, change])
    at90 = row_at_level(with_change, 7, 0.5 * math.pi)
    at180 = row_at_level(with_change, 7, math.pi)
    adv90, tr90 = course_frame(psi0, xy0, at90[1:3])
    _, tr180 = course_frame(psi0, xy0, at180[1:3])
    steady_rows = track.array(i_steady)
    _, radius = fit_circle(steady_rows[:, 1:3])
    u, v, r = steady_rows[:, 4].mean(), steady_rows[:, 5].mean(), steady_rows[:, 6].mean()
    return {
        "approach_commands": [m, m],
        "approach_speed": _r(u0, 4),
        "turn_direction": "starboard" if direction < 0 else "port",
        "advance": _r(adv90, 4),
        "transfer": _r(abs(tr90), 4),
        "tactical_diameter": _r(abs(tr180), 4),
        "time_to_90_deg": _r(at90[0] - t0, 3),
        "time_to_180_deg": _r(at180[0] - t0, 3),
        "steady_speed": _r(math.hypot(u, v), 4),
        "steady_yaw_rate": _r(abs(r), 6),
        "steady_drift_angle_deg": _r(math.degrees(abs(math.atan2(v, u))), 2),
        "steady_diameter": _r(2.0 * radius, 4),
        "steady_state_reached": ok_approach and ok_turn,
    }


def _zigzag(track: TrialTrack, p: float, s: float, angle_deg: float) -> dict:
    if p == s:
        raise ValueError(f"--port/--starboard: a zig-zag needs different commands, got {p:g} and {s:g} "
                         "(the differential (port − starboard)/2 is the rudder angle)")
    if not 0.0 < angle_deg < 90.0:
        raise ValueError(f"zigzag_angle_deg: must be in (0, 90), got {angle_deg}")
    m = amidships_command(track, p, s)
    ok_approach, i0, xy0, psi0, u0 = _approach(track, (m, m))
    t0 = track.rows[i0][0]
    alpha = math.radians(angle_deg)
    # Deviation measured positive towards the side (p, s) turns to: p > s turns to starboard (ψ ↓).
    side = -1.0 if p > s else 1.0
    pairs = [(p, s), (s, p)]
    executes = [t0]
    extremes = [0.0, 0.0]  # largest deviation beyond the check angle after execute 2 and 3
    track.command(*pairs[0])
    target = +1.0  # the sign of the deviation we are waiting for
    while len(executes) < 4:
        if track.last[0] - t0 > MANOEUVRE_MAX_TIME_S:
            raise ValueError(f"--port/--starboard: ({p:g}, {s:g}) did not complete the {angle_deg:g}° zig-zag "
                             f"within {MANOEUVRE_MAX_TIME_S:g} s (differential too small)")
        track.step()
        dev = side * (track.last[3] - psi0)
        k = len(executes)
        if k >= 2:
            # overshoot after execute k (k = 2, 3): beyond the check angle on the side just left
            prev_side = -target
            extremes[k - 2] = max(extremes[k - 2], prev_side * dev - alpha)
        if target * dev >= alpha:
            executes.append(track.last[0])
            track.command(*pairs[(len(executes) - 1) % 2])
            target = -target
    return {
        "approach_commands": [m, m],
        "approach_speed": _r(u0, 4),
        "zigzag_angle_deg": angle_deg,
        "first_turn": "starboard" if side < 0 else "port",
        "overshoot_1_deg": _r(math.degrees(extremes[0]), 2),
        "overshoot_2_deg": _r(math.degrees(extremes[1]), 2),
        "initial_turning_time": _r(executes[1] - t0, 3),
        "time_to_third_execute": _r(executes[2] - t0, 3),
        "definition": (f"{angle_deg:g}°/{angle_deg:g}° zig-zag: 'rudder' = differential command "
                       f"±{abs(p - s) / 2:g} about mean command {(p + s) / 2:g}; approach straight at "
                       f"({m:g}, {m:g}) (same total thrust); execute ({p:g}, {s:g}), counter-execute "
                       f"({s:g}, {p:g}) at ±{angle_deg:g}° heading deviation from the approach course; "
                       "overshoot = largest heading deviation beyond the check angle after a counter-execute"),
        "steady_state_reached": ok_approach,
    }


def _stopping(track: TrialTrack, p: float, s: float) -> dict:
    for value, flag in ((p, "--port"), (s, "--starboard")):
        if value > 0:
            raise ValueError(f"{flag}: a stopping trial's command must be ≤ 0 (−1 full astern, 0 coasting), "
                             f"got {value:g}")
    ok_approach, i0, xy0, psi0, u0 = _approach(track, STOPPING_APPROACH)
    t0 = track.rows[i0][0]
    track.command(p, s)
    while track.last[4] > STOPPED_SURGE_M_S:
        if track.last[0] - t0 > MANOEUVRE_MAX_TIME_S:
            raise ValueError(f"--port/--starboard: ({p:g}, {s:g}) did not stop the vessel within "
                             f"{MANOEUVRE_MAX_TIME_S:g} s")
        track.step()
    rows = track.array(i0)
    # Interpolate the stop inside the last step (u falls through the threshold).
    stop = row_at_level(np.column_stack([rows, -rows[:, 4]]), 7, -STOPPED_SURGE_M_S)
    xy = np.vstack([rows[:-1, 1:3], stop[1:3]])
    head, lateral = course_frame(psi0, xy0, stop[1:3])
    return {
        "approach_commands": list(STOPPING_APPROACH),
        "approach_speed": _r(u0, 4),
        "stopping_distance": _r(path_length(xy), 4),
        "head_reach": _r(head, 4),
        "lateral_deviation": _r(abs(lateral), 4),
        "stopping_time": _r(stop[0] - t0, 3),
        "stopped_when": f"surge speed ≤ {STOPPED_SURGE_M_S} m/s",
        "steady_state_reached": ok_approach,
    }


def _tightest_turn(track: TrialTrack, speed_m_s: float | None) -> dict:
    from mjasc.physics.steady_turn import smallest_turn_radius_m, tightest_turn

    vtype = track.sim.world.vessel_types[0]
    speed = vtype.cruise_speed_m_s if speed_m_s is None else number(speed_m_s, "--speed")
    if not speed > 0:
        raise ValueError(f"--speed: must be > 0, got {speed:g}")
    turn = tightest_turn(track.sim.hydro, track.sim.thrusters, speed)
    if turn is None:
        raise ValueError(f"--speed: the hull sails no steady turn at {speed:g} m/s (its top speed "
                         f"{vtype.top_speed_m_s:g} m/s is reached only straight)")
    p, s = turn.commands
    track.command(p, s)
    ok = track.sail_until_steady()
    i_steady = len(track.rows) - 1
    track.step(math.ceil(2.0 * math.pi / turn.yaw_rate_rad_s / track.sim.timestep_s) + 1)
    rows = track.array(i_steady)
    _, radius = fit_circle(rows[:, 1:3])
    u, v, r = rows[:, 4].mean(), rows[:, 5].mean(), rows[:, 6].mean()
    return {
        "speed": _r(speed, 4),
        "port": _r(p, 6), "starboard": _r(s, 6),  # (sailed unrounded)
        "turn_direction": "port",
        "closed_form_diameter": _r(2.0 * turn.radius_m, 4),
        "min_mission_turn_radius": smallest_turn_radius_m(turn),
        "steady_speed": _r(math.hypot(u, v), 4),
        "steady_yaw_rate": _r(abs(r), 6),
        "steady_drift_angle_deg": _r(math.degrees(abs(math.atan2(v, u))), 2),
        "steady_diameter": _r(2.0 * radius, 4),
        "steady_state_reached": ok,
    }


def run_trial(kind: str, vessel_name: str, port: float | None = None, starboard: float | None = None,
              *, zigzag_angle_deg: float = 20.0, speed_m_s: float | None = None) -> dict:
    """Run one standard manoeuvring trial of ``vessel_name`` (a built-in name, or a vessel folder's
    path relative to the current folder) in still water; see the module docstring for each kind's
    procedure, defaults and returned keys.

    kind: one of :data:`TRIAL_KINDS`. port / starboard: constant normalized propeller commands in
    [−1, 1] of the manoeuvre (``None`` = the kind's default in :data:`DEFAULT_COMMANDS`).
    speed_m_s: the tightest turn's speed [m/s] (``None``: the hull's cruise speed; only that kind).
    Raises ValueError naming ``--port`` / ``--starboard`` / ``--speed`` / ``--vessel`` / ``kind`` on bad input.
    """
    if kind not in TRIAL_KINDS:
        raise ValueError(f"kind: unknown trial {kind!r}; one of {', '.join(TRIAL_KINDS)}")
    if kind == "tightest-turn":
        if port is not None or starboard is not None:
            raise ValueError("--port/--starboard: the tightest turn's commands are solved for, not given "
                             "(choose its speed with --speed)")
        try:
            track = new_track(vessel_name)
        except ValueError as exc:
            raise ValueError(f"--vessel: {exc}") from None
        body = _tightest_turn(track, speed_m_s)
        return {"kind": kind, "vessel": vessel_name, "timestep_s": track.sim.timestep_s, **body}
    if speed_m_s is not None:
        raise ValueError(f"--speed: only the tightest-turn trial takes a speed, not {kind}")
    default_p, default_s = DEFAULT_COMMANDS[kind]
    p = _validate_command(default_p if port is None else port, "--port")
    s = _validate_command(default_s if starboard is None else starboard, "--starboard")
    try:
        track = new_track(vessel_name)
    except ValueError as exc:
        raise ValueError(f"--vessel: {exc}") from None
    if kind == "speed":
        body = _speed(track, p, s)
    elif kind == "turning-circle":
        body = _turning_circle(track, p, s)
    elif kind == "zigzag":
        body = _zigzag(track, p, s, float(zigzag_angle_deg))
    else:
        body = _stopping(track, p, s)
    return {"kind": kind, "vessel": vessel_name, "port": p, "starboard": s,
            "timestep_s": track.sim.timestep_s, **body}
