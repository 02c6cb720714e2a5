"""One vessel's chained mission: its phases in order, the switch from one to the next, the timeline.

The agent holds a :class:`MissionSequencer` when the scenario has a ``[mission]`` table. At each
control tick (before coordination and avoidance) :meth:`MissionSequencer.update` reads typed values
only — the vessel's navigation, its progress γ along the mission path, its perception report, its
team picture, its avoidance mode — and may return a :class:`~mjasc.missions.legs.MissionLeg`,
which the agent hands to the path follower, to avoidance and to coordination.

Rules: a phase hands over to the next only while the vessel is in mission mode (avoidance
overrides; the mission resumes where avoidance leaves it); ``follow_path`` ends at the end of the
formation path, ``go_to_formation`` at the formation pose, ``track_target`` after its duration.
The mission is completed when every phase completed. The timeline (phase, start, end, completed,
its results) goes to summary.json; the recording shows the phase as a state lane
(``missions/<vessel>``) and each leg's path.
"""

from __future__ import annotations

from mjasc.guidance.paths import Path
from mjasc.missions.config import MissionConfig, VesselMissionOptions
from mjasc.missions.follow_path import FollowPath
from mjasc.missions.go_to_formation import GoToFormation
from mjasc.missions.legs import MissionBroadcast, MissionLeg, PhaseInputs
from mjasc.missions.target_tracking import TrackTarget

__all__ = ["MissionSequencer", "PHASE_STATES", "team_mission_summary"]

PHASE_STATES = {"go_to_formation": ("go to formation", (90, 160, 230)),
                "follow_path": ("follow path", (80, 190, 120)),
                "track_target": ("track target", (230, 150, 60)),
                "done": ("mission done", (150, 150, 150))}
"""The phases as the recording's state lane shows them: label, colour."""


class MissionSequencer:
    """The chained mission of one vessel (see the module docstring)."""

    def __init__(self, config: MissionConfig, vessel_name: str, formation_path: Path, cruise_speed_m_s: float,
                 top_speed_m_s: float, options: VesselMissionOptions | None = None, team_size: int = 1):
        self.name = vessel_name
        self.config = config
        opts = options if options is not None else VesselMissionOptions()
        self.phases = []
        for k, p in enumerate(config.phases):
            if p == "go_to_formation":
                self.phases.append(GoToFormation(k, config.go_to_formation, formation_path, cruise_speed_m_s,
                                                   team_size))
            elif p == "follow_path":
                self.phases.append(FollowPath(k, config.follow_path.end_band_m, formation_path, cruise_speed_m_s))
            else:
                self.phases.append(TrackTarget(k, config.track_target, vessel_name, opts.target_offset_m,
                                               cruise_speed_m_s, top_speed_m_s))
        self.current = -1
        self.timeline: list[dict] = []
        self._events: list[tuple[float, str]] = []
        self._pending_end: bool = False
        self._logged_style = False
        self._logged_state: str | None = None
        self._leg_paths: list[tuple[float, Path]] = []  # new leg paths not yet recorded
        self.leg_path: Path | None = None  # the current leg's path (for observers: the video)

    @property
    def phase(self):
        return self.phases[self.current] if 0 <= self.current < len(self.phases) else None

    @property
    def phase_name(self) -> str:
        return self.phase.name if self.phase is not None else "done"

    def begin(self, t_s: float, nav) -> MissionLeg:
        """The first phase's leg (called once, when the agent is built)."""
        return self._start(0, t_s, nav)

    def _start(self, k: int, t_s: float, nav) -> MissionLeg:
        self.current = k
        self._pending_end = False
        leg = self.phases[k].begin(t_s, nav)
        self.timeline.append({"phase": self.phases[k].name, "start_s": round(float(t_s), 3), "end_s": None,
                              "completed": False})
        self._events.append((t_s, f"mission: {self.phases[k].name} (phase {k + 1} of {len(self.phases)})"))
        self._leg_paths.append((float(t_s), leg.path))
        self.leg_path = leg.path
        return leg

    def _end(self, t_s: float, completed: bool, result: dict) -> None:
        entry = self.timeline[-1]
        entry.update(result)
        entry.update(end_s=round(float(t_s), 3), completed=bool(completed))
        self._events.append((t_s, f"mission: {entry['phase']} {'completed' if completed else 'ended, not completed'}"))

    def broadcast(self) -> MissionBroadcast:
        """The mission's part of this vessel's next team message."""
        ph = self.phase
        return ph.broadcast() if ph is not None else MissionBroadcast(len(self.phases))

    def update(self, t_s: float, nav, gamma_m: float, report, team, mode: str) -> MissionLeg | None:
        """One control tick: a new leg, or None (keep going). ``gamma_m``: progress along the
        current leg's path (mapped back from a detour by avoidance); ``team``: the
        :class:`~mjasc.cooperation.messages.TeamPicture` (None without a link); ``mode``: the
        avoidance mode of the last tick (phases hand over in ``"mission"`` mode only)."""
        ph = self.phase
        if ph is None:
            return None
        for later in self.phases[self.current:]:  # (a target-tracking phase remembers the team's tracks)
            if hasattr(later, "note_team_tracks"):
                later.note_team_tracks(report)
        mates, plans = {}, {}
        if team is not None:
            for n, it in team.intentions.items():
                b = getattr(it, "mission", None)
                if b is not None:
                    mates[n] = b
                    times = getattr(it, "plan_times_s", None)
                    if times is not None and len(times) >= 2:
                        plans[n] = (times, it.plan_points_m)
        in_mission = mode == "mission"
        leg, ended = ph.step(PhaseInputs(float(t_s), nav, float(gamma_m), report, mates, in_mission, plans))
        self._events.extend(ph.events)
        ph.events.clear()
        if ended and not self._pending_end:
            result = ph.result()
            completed = result.pop("completed")
            self._end(t_s, completed, result)
            self._pending_end = True
        if self._pending_end and in_mission:
            if self.current + 1 < len(self.phases):
                return self._start(self.current + 1, t_s, nav)
            self.current = len(self.phases)
            return None
        if leg is not None and leg.new_path:
            self._leg_paths.append((float(t_s), leg.path))
            self.leg_path = leg.path
        return leg

    # ------------------------------------------------------------------ outputs
    @property
    def completed(self) -> bool:
        return len(self.timeline) == len(self.phases) and all(e["completed"] for e in self.timeline)

    def drain_events(self) -> list[tuple[float, str]]:
        out, self._events = self._events, []
        return out

    def summary(self) -> dict:
        """``mission_completed`` and the timeline of phases (each with its results; a phase still
        running at the end of the run has ``end_s`` None and its results so far)."""
        timeline = [dict(e) for e in self.timeline]
        ph = self.phase
        if timeline and timeline[-1]["end_s"] is None and ph is not None:  # still running: its results so far
            timeline[-1].update(ph.result(), completed=False)
        return {"mission_completed": self.completed, "phase": self.phase_name, "phases": timeline}

    def log(self, recorder, t_s: float, vessel_name: str) -> None:
        """The phase as a state lane, each new leg's path as a line strip."""
        import rerun as rr

        if not self._logged_style:
            recorder.static(f"missions/{vessel_name}", rr.StateConfiguration(
                values=list(PHASE_STATES), labels=[label for label, _ in PHASE_STATES.values()],
                colors=[(*rgb, 255) for _, rgb in PHASE_STATES.values()]))
            recorder.static(f"world/vessels/{vessel_name}/mission_leg", rr.LineStrips3D.from_fields(
                colors=[(*recorder.colour(vessel_name), 200)], radii=[0.1], show_labels=[False]))
            self._logged_style = True
        state = self.phase_name
        if state != self._logged_state:
            recorder.state(f"missions/{vessel_name}", t_s, state)
            self._logged_state = state
        if self._leg_paths:
            _, path = self._leg_paths[-1]
            xy = path.sample(max(0.5, path.length / 200.0))
            recorder.strips(f"world/vessels/{vessel_name}/mission_leg", t_s, [xy], z=0.05)
            self._leg_paths.clear()


def team_mission_summary(agents) -> dict | None:
    """The team's view of its mission for summary.json: completed by all, and for go-to-formation
    the arrival spread [s] and the largest pose errors over the team (None without a mission)."""
    seqs = [a.mission for a in agents if getattr(a, "mission", None) is not None]
    if not seqs:
        return None
    out = {"phases": list(seqs[0].config.phases), "mission_completed": all(s.completed for s in seqs)}
    arrivals = [e for s in seqs for e in s.timeline if e["phase"] == "go_to_formation" and "arrival_time_s" in e]
    if arrivals and len(arrivals) == len(seqs):
        t = [e["arrival_time_s"] for e in arrivals]
        out["go_to_formation"] = {
            "arrival_spread_s": round(max(t) - min(t), 3),
            "max_position_error_m": round(max(e["position_error_m"] for e in arrivals), 3),
            "max_course_error_deg": round(max(abs(e["course_error_deg"]) for e in arrivals), 3),
            "max_heading_error_deg": round(max(abs(e["heading_error_deg"]) for e in arrivals), 3),
            "max_speed_error_m_s": round(max(abs(e["speed_error_m_s"]) for e in arrivals), 4),
            "speed_spread_m_s": round(max(e["speed_m_s"] for e in arrivals) - min(e["speed_m_s"] for e in arrivals), 4)}
    return out
