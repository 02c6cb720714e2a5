"""Run a scenario: build the world, step it on a multi-rate schedule, record, summarize.

One run writes one folder::

    <out>/recording.rrd    Rerun recording with its default blueprint
    <out>/summary.json     per-vessel metrics, collisions, wall time, real-time factor
    <out>/video.mp4        with video on: offscreen render (OSMesa)

    <out>/last_good_state.npy   when the physics diverged: the MuJoCo state before the bad step

A run is a pure function of the scenario and its seed. If the physics diverges (a velocity or
acceleration non-finite or beyond its vessel type's bounds, checked every physics step, or a MuJoCo
warning) or a component raises, the run stops with :class:`RunFailed`; on Ctrl-C (and SIGTERM with
``run(interruptible=True)``, as ``mjasc run`` does) with :class:`RunInterrupted`. Either way the
recording is closed first (what was recorded so far is readable) and a summary is written whose
``status`` says what happened (``diverged``, ``error``, ``interrupted``) and ``error`` why. Files
are written under a temporary name and renamed when complete (:mod:`mjasc.runs.outputs`): a
``recording.rrd`` or ``summary.json`` is never half-written. ``Simulation.set_state(np.load(
"last_good_state.npy"))`` on the same scenario's runner reproduces the divergence. A run holds its
folder locked (a second run into it meanwhile is :class:`~mjasc.runs.outputs.FolderInUse`) and,
when it starts, removes an earlier run's outputs there and a killed run's temporary files
(:func:`~mjasc.runs.outputs.clear_run_folder`): the folder never mixes two runs. An interrupt while
the outputs open removes their temporary files; from the loop's end until the summary is written
further interrupts wait (:func:`~mjasc.runs.interrupts.hold_interrupts`). An output that cannot be
written (a full disk) fails the run (``error``: the file and the reason) and leaves no temporary
file. Why a run stopped early is said in one line (:mod:`mjasc.runs.run_failures`); what its
summary holds, :mod:`mjasc.runs.run_summary`.

**Timing.** The main loop times each slot's work and the physics (``time.perf_counter``, about
0.1 µs per reading) and keeps the sums in ``Runner.stage_seconds`` (slot → seconds, plus
``"physics"``), written to summary.json as ``timing_s``; observers are not counted.

**Observers.** ``Runner.observe(slot, fn)`` calls ``fn(event)`` after every run of ``slot``
(:data:`~mjasc.runs.schedule.SLOT_ORDER`) with a :class:`~mjasc.runs.tick.SlotEvent`: figures
trace runs this way (what each vessel sensed, predicted and re-planned) without subclassing the
runner or patching its components.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mjasc.core.navigation import FleetNavigation
from mjasc.physics.simulation import PhysicsDivergence, Simulation
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import build_world
from mjasc.runs.agent_build import build_agent
from mjasc.runs.collector import pause as pause_collector
from mjasc.runs.collector import resume as resume_collector
from mjasc.runs.interrupts import (PENDING, catch_sigterm, hold_interrupts, interrupt_behind, raise_pending,
                                   release_interrupts, signal_name)
from mjasc.runs.mission_offset import MissionOffset
from mjasc.runs.outputs import (atomic_target, atomic_write_text, clear_run_folder, close_output, json_value,
                                lock_folder, os_reason, unlock_folder)
from mjasc.runs.run_failures import RunFailed, RunInterrupted, component_error
from mjasc.runs.run_summary import run_summary
from mjasc.runs.scenario import Scenario
from mjasc.runs.scene_extent import scene_extent
from mjasc.runs.schedule import SLOT_ORDER, Schedule
from mjasc.runs.tick import ONBOARD_SLOTS, SlotEvent, run_onboard_slot
from mjasc.runs.truth_recording import PLOT_SERIES, TRAIL_PERIOD_S, TRAIL_SEGMENT_S, TruthRecording, WORLD_SERIES  # noqa: F401

if TYPE_CHECKING:  # rerun and the recorder load when a recording is made (a campaign run without one skips ~0.4 s)
    from mjasc.runs.recording import Recorder

__all__ = ["Runner", "RunFailed", "RunInterrupted", "RunResult", "run_scenario", "LAST_GOOD_STATE"]

#: The MuJoCo state (``Simulation.get_state``) before the step where the physics diverged.
LAST_GOOD_STATE = "last_good_state.npy"
#: A run's outputs in its folder, the summary last (removed in this order: :func:`clear_run_folder`).
RUN_OUTPUTS = ("recording.rrd", "video.mp4", LAST_GOOD_STATE, "summary.json")


@dataclass
class RunResult:
    out_dir: Path
    summary: dict
    files: dict = field(default_factory=dict)


class Runner:
    """Executes one :class:`Scenario`. Construct, then :meth:`run`."""

    def __init__(self, scenario: Scenario, out_dir: str | Path | None = None, progress: bool | None = None):
        self.scenario = sc = scenario
        self.out_dir = Path(out_dir) if out_dir is not None else None
        self.progress = sys.stderr.isatty() if progress is None else progress
        vessels = [(v.name, load_vessel_type(v.type)) for v in sc.vessels]
        self.world = build_world(vessels, sc.static_obstacles, sc.moving_obstacles, timestep_s=1.0 / sc.rates.physics_hz)
        self.sim = Simulation(self.world, sc.current)
        self.rng = np.random.default_rng(sc.seed)
        poses = np.array([[*v.position_m, v.heading_rad] for v in sc.vessels])
        vel = np.array([[v.speed_m_s, 0.0, 0.0] for v in sc.vessels])
        self.sim.reset(poses, vel)
        team = [v.name for v in sc.vessels]
        self.network = None
        if sc.comms is not None or any("comms" in v.options for v in sc.vessels):
            from mjasc.cooperation.comms import CommsNetwork

            self.network = CommsNetwork(team, sc.comms, np.random.default_rng([sc.seed, 1_000_003]))
        self.agents = [build_agent(v, i, self.world, self.sim.hydro.total_mass[i], team, self.network, [sc.seed, i],
                                   sc.mission, [u.name for u in sc.vessels if u.controller != "none"])
                       for i, v in enumerate(sc.vessels)]
        r = sc.rates
        periods = {"control": 1 / r.control_hz, "sensing": 1 / r.sensing_hz, "tracking": 1 / r.tracking_hz,
                   "comms": 1 / r.comms_hz, "prediction": r.prediction_period_s, "record": 1 / r.record_hz}
        if sc.outputs.video:
            periods["video"] = 1 / sc.outputs.video_fps
        self.schedule = Schedule.from_periods(self.sim.timestep_s, periods)
        self.control_dt_s = self.schedule.period_steps["control"] * self.sim.timestep_s
        self.recorder: Recorder | None = None
        self.video = None
        self.metrics = None
        self.target_judge = None
        self.last_outputs = [None] * len(self.agents)
        from mjasc.runs.metrics import CrossTrackGate  # (imported where RunMetrics is: at the run)

        self._xte_gate = CrossTrackGate(len(self.agents))
        # the distance to each vessel's mission path, once a simulated second (mjasc.runs.mission_offset)
        self._offsets = MissionOffset(len(self.agents), round(self.schedule.realized_rate_hz("record")))
        self._truth: TruthRecording | None = None  # the truth's recording, when one is made
        self._observers: dict[str, list] = {slot: [] for slot in SLOT_ORDER}
        self._summary_parts: list = []  # (key, fn): parts of the summary made when the run ends (add_summary)
        #: Wall seconds spent in each slot and in the physics during :meth:`run` (observers excluded).
        self.stage_seconds: dict[str, float] = {}

    def observe(self, slot: str, fn) -> None:
        """Call ``fn(event)`` (a :class:`~mjasc.runs.tick.SlotEvent`) after every run of ``slot``."""
        if slot not in self._observers:
            raise ValueError(f"slot: unknown slot {slot!r} (known: {', '.join(SLOT_ORDER)})")
        self._observers[slot].append(fn)

    def add_summary(self, key: str, fn) -> None:
        """Put ``fn()`` (JSON-serializable) into the run's summary under ``key`` when the run ends, in
        summary.json too: an observer's results — a run's evaluation against the truth
        (:class:`~mjasc.evaluation.run_evaluation.RunEvaluator`, ``mjasc run --evaluate``, campaigns)."""
        if key in ("vessels", "status", "timing_s"):
            raise ValueError(f"key: {key!r} is the run's own summary key")
        self._summary_parts.append((key, fn))

    # ------------------------------------------------------------------ extent for views
    def extent(self) -> tuple[np.ndarray, np.ndarray]:
        """The scene's (lower-left, upper-right) corners [m] that the overview and top-down views and
        the blueprint frame (:func:`~mjasc.runs.scene_extent.scene_extent`)."""
        return scene_extent(self.scenario)

    # ------------------------------------------------------------------ slots
    def _control(self, time_s: float, navs) -> None:
        outputs = run_onboard_slot("control", self.agents, navs, self.control_dt_s)
        cmds = np.zeros((len(self.agents), 2))
        for i, (agent, out) in enumerate(zip(self.agents, outputs)):
            last = self.last_outputs[i]
            if last is not None and out.mode != last.mode and self.recorder and \
                    not getattr(agent.avoidance, "logs_mode_changes", False):  # (once in the event log)
                self.recorder.event(time_s, f"{agent.name}: mode {last.mode} → {out.mode}")
            cmds[i] = out.commands
            self.last_outputs[i] = out
        self.sim.set_commands(cmds)

    def _record(self, states) -> None:
        outputs = self.last_outputs
        plotted = [o.status.cross_track_m if o and o.status else np.nan for o in outputs]
        xte = self._xte_gate.counted(outputs, self.agents)  # (the statistics: while a path is followed)
        self._offsets.sample(states.position_m, xte, self.agents)
        truth = self._truth
        if self.target_judge is None:  # (the metrics need no traffic now: RunMetrics.defer, the same numbers)
            self.metrics.defer(states, xte)  # (folded in chunks)
            traffic = self.sim.traffic_state() if truth is not None and truth.needs_traffic else None
        else:
            xte = np.array(xte)
            traffic = self.sim.traffic_state()
            self.metrics.update(states, xte, traffic)
            self.target_judge.update(states, traffic, self.agents)
        if truth is not None:
            truth.record(states, self.sim, np.array([o.speed_ref_m_s if o else 0.0 for o in outputs], dtype=float),
                         np.asarray(plotted), traffic)

    # ------------------------------------------------------------------ main loop
    def _interrupted(self, time_s: float, stop: KeyboardInterrupt) -> tuple[str, str]:
        """The status and error of a run stopped at ``time_s`` [s] by ``stop`` (Ctrl-C or SIGTERM),
        said in the recording."""
        error = f"interrupted at t = {time_s:.3f} s ({signal_name(stop)})"
        if self.recorder:
            self.recorder.event(time_s, error, "WARN")
        return "interrupted", error

    def run(self, interruptible: bool = False) -> RunResult:
        """Run the scenario to its end. Raises :class:`RunFailed` (after writing the outputs) when
        the physics diverges or a component raises, :class:`RunInterrupted` on Ctrl-C, and with
        ``interruptible`` (the main thread only) on SIGTERM too."""
        files = {}
        lock = None
        if self.out_dir is not None:
            self.out_dir.mkdir(parents=True, exist_ok=True)
            lock = lock_folder(self.out_dir, "run")  # (one run at a time into a folder: FolderInUse)
            try:
                clear_run_folder(self.out_dir, RUN_OUTPUTS)
            except BaseException:
                unlock_folder(lock)
                raise
        try:
            return self._run(files, interruptible)
        finally:
            unlock_folder(lock)

    def _run(self, files: dict, interruptible: bool) -> RunResult:
        from mjasc.runs.metrics import RunMetrics

        sc, sim = self.scenario, self.sim
        self.metrics = RunMetrics(self.world, sc, self.sim.traffic)
        self.target_judge = None
        tt = sc.mission.track_target if sc.mission is not None else None
        if tt is not None and tt.target:
            from mjasc.evaluation.mission_judge import TargetJudge

            self.target_judge = TargetJudge(sc, self.world)
        try:  # (interrupted or failing while the outputs open: their temporary files go, nothing is left half-made)
            self._open_outputs(files)
        except BaseException:
            for out in (self.recorder, self.video):
                if out is not None:
                    try:
                        out.discard()
                    except Exception:  # noqa: BLE001 - the first error is the one to report
                        pass
            self.recorder = self.video = self._truth = None
            raise
        total_steps = int(round(sc.duration_s / sim.timestep_s))
        status, error = "completed", None
        wall0 = time.perf_counter()
        bar = None
        if self.progress:
            from tqdm import tqdm

            bar = tqdm(total=round(sc.duration_s), unit="sim s", desc=sc.name, leave=False)
        step = 0
        diverged = None
        previous = catch_sigterm() if interruptible else None
        clock = time.perf_counter
        stage = self.stage_seconds = dict.fromkeys([*self.schedule.period_steps, "physics"], 0.0)
        collector = pause_collector()  # what exists now lives for the run (mjasc.runs.collector)
        try:
            tick = self.schedule.tick
            while step <= total_steps:
                if PENDING:  # (an interrupt that landed in a finalizer: mjasc.runs.interrupts)
                    raise_pending()
                due, nxt = tick(step)  # (the slots due now, the next step with any)
                states = sim.states() if due else None
                navs = []
                if due:
                    navs = FleetNavigation.from_states(states).vessels()
                t_slot = clock()  # (each slot's time runs from the end of the one before: one clock read a slot)
                for slot in due:
                    if slot == "control":
                        self._control(states.time_s, navs)
                    elif slot in ONBOARD_SLOTS:
                        run_onboard_slot(slot, self.agents, navs, self.control_dt_s)
                    elif slot == "record":
                        self._record(states)
                        new = self.metrics.check_contacts(sim.drain_touches())
                        for pair in new:
                            if self.recorder:
                                self.recorder.event(states.time_s, f"collision: {pair[0]} ↔ {pair[1]}", "WARN")
                        for agent in self.agents:
                            for t_ev, text in agent.drain_events():
                                if self.recorder:
                                    self.recorder.event(t_ev, f"{agent.name}: {text}")
                            if self.recorder:
                                agent.log(self.recorder, states.time_s)
                    elif slot == "video" and self.video is not None:
                        self.video.add_event(SlotEvent(slot, states.time_s, states, tuple(navs), self), later=True)
                    t_end = clock()
                    stage[slot] += t_end - t_slot
                    if self._observers[slot]:
                        event = SlotEvent(slot, states.time_s, states, tuple(navs), self)
                        for fn in self._observers[slot]:
                            fn(event)
                        t_end = clock()
                    t_slot = t_end
                if nxt > total_steps:
                    break
                sim.step(nxt - step)
                stage["physics"] += clock() - t_slot
                if bar is not None:
                    bar.update(int(sim.time_s) - bar.n)
                step = nxt
            if self.video is not None:  # the last frame, held back while it rasterised: its errors the run's
                t_slot = clock()
                self.video.finish_held()
                stage["video"] += clock() - t_slot
            raise_pending()  # (one kept at the last event: the run stops as interrupted all the same)
        except PhysicsDivergence as exc:
            status, error, diverged = "diverged", str(exc), exc
            if self.recorder:
                self.recorder.event(sim.time_s, str(exc), "ERROR")
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (interrupts.Terminated)
            status, error = self._interrupted(sim.time_s, exc)
        except Exception as exc:  # noqa: BLE001 - a failed run still leaves its summary and recording
            if (stop := interrupt_behind(exc)) is not None:  # a signal inside a compiled call (interrupts)
                status, error = self._interrupted(sim.time_s, stop)
            else:
                status, error = "error", component_error(exc, sim.time_s, self.agents)
                if self.recorder:
                    self.recorder.event(sim.time_s, error, "ERROR")
        finally:
            # From here until the summary is written, further interrupts wait (hold_interrupts): a
            # second Ctrl-C or SIGTERM while the outputs close does not cost the run its summary.
            held = hold_interrupts(previous)
            try:
                resume_collector(collector)
                held.kept += PENDING  # (one kept by a finalizer the collector ran: the run's too)
                PENDING.clear()
                late = held.kept.pop(0) if held.kept else None  # (kept after the loop's last look: the run
                held.kept.clear()                                  # ends interrupted all the same)
                if late is not None and status == "completed":
                    status, error = self._interrupted(sim.time_s, late)
                if bar is not None:
                    bar.close()
                if self._truth is not None and self.recorder:  # (the counts as they stand: the summary's)
                    t_slot = clock()
                    try:
                        self._truth.finish(sim.time_s)
                    except Exception as exc:  # noqa: BLE001 - never lose the recording for its last counts
                        self.recorder.event(sim.time_s, f"the comms counts at the end not written: {exc}", "WARN")
                    stage["record"] += clock() - t_slot
                for slot, out in (("record", self.recorder), ("video", self.video)):
                    if out is not None:  # flushing the outputs is their slot's cost
                        t_slot = clock()
                        problem = close_output(out)
                        stage[slot] += clock() - t_slot
                        if problem is not None:  # (a full disk: the file is not written; the summary says so)
                            files.pop("recording" if slot == "record" else "video", None)
                            status, error = ("error", problem) if status == "completed" else (status,
                                                                                              f"{error}; {problem}")
            except BaseException:
                release_interrupts(held)
                raise
        try:
            return self._summarise(files, status, error, diverged, wall0)
        finally:
            again = release_interrupts(held)
            if again is not None and status == "completed" and sys.exc_info()[0] is None:
                raise again  # (an interrupt while a completed run closed: its outputs are whole; the caller stops)

    def _summarise(self, files: dict, status: str, error: str | None, diverged, wall0: float) -> RunResult:
        """Write the run's summary (and a divergence's last good state); the result, or RunFailed."""
        self.metrics.check_contacts(self.sim.drain_touches())  # (the steps after the last record tick)
        wall = time.perf_counter() - wall0
        summary = run_summary(self, status, error, wall, self._offsets.summary, self._summary_parts)
        if diverged is not None and diverged.last_good_state is not None:
            summary["last_good_state"] = {"time_s": round(diverged.last_good_time_s, 6)}
            if self.out_dir is not None:
                files["last_good_state"] = self.out_dir / LAST_GOOD_STATE
                with atomic_target(files["last_good_state"]) as tmp, open(tmp, "wb") as f:
                    np.save(f, diverged.last_good_state)
                summary["last_good_state"]["file"] = LAST_GOOD_STATE
        if self.out_dir is not None:
            files["summary"] = self.out_dir / "summary.json"
            try:
                atomic_write_text(files["summary"], json.dumps(summary, indent=2, default=json_value))
            except OSError as exc:  # (a full disk: said in one line, the run failed)
                raise RunFailed(f"{files['summary']}: {os_reason(exc, self.out_dir)} (the run's summary not written; "
                                f"its status: {status}{f', {error}' if error else ''})", summary) from None
        result = RunResult(self.out_dir, summary, files)
        kept = f"; partial outputs kept in {self.out_dir}" if self.out_dir is not None else ""
        if status == "interrupted":
            raise RunInterrupted(f"{error}{kept}", summary)
        if status != "completed":
            raise RunFailed(f"{error}{kept}", summary)
        return result

    def _open_outputs(self, files: dict) -> None:
        """Start the recording and the video (their files under temporary names until closed)."""
        sc = self.scenario
        if self.out_dir is not None and sc.outputs.recording:
            files["recording"] = self.out_dir / "recording.rrd"
            self._truth = TruthRecording(files["recording"], sc, self.agents, self.world, self.network, self.extent())
            self.recorder = self._truth.recorder
        if self.out_dir is not None and sc.outputs.video:
            from mjasc.runs.blueprint import vessel_colour
            from mjasc.runs.video import VideoWriter

            files["video"] = self.out_dir / "video.mp4"
            overlays = [v.path.sample(1.0) for v in sc.vessels if v.path is not None]
            # (encoded at the rate frames are taken — the requested one rounded to whole physics steps,
            # 20 fps at 50 Hz physics: 25 — so that the video plays in real time)
            self.video = VideoWriter(files["video"], self.world.model, sc.outputs.video_width, sc.outputs.video_height,
                                     self.schedule.realized_rate_hz("video"), sc.outputs.video_camera, self.extent(),
                                     overlays, title=sc.name,
                                     vessel_colours=[(v.name, vessel_colour(i)) for i, v in enumerate(sc.vessels)])


def run_scenario(scenario: Scenario, out_dir=None, progress: bool | None = None,
                 interruptible: bool = False) -> RunResult:
    return Runner(scenario, out_dir, progress).run(interruptible)
