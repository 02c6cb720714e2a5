"""A run's summary (``summary.json``) as a dictionary, from what the run holds when it ends.

The run's own keys (``scenario``, ``seed``, ``status``, ``error``, ``rates_hz``, the metrics' keys
with ``vessels`` among them — :meth:`~mjasc.runs.metrics.RunMetrics.summary`), each vessel's
components' own results under ``vessels.<name>.<kind>`` (the components that have a ``summary``:
perception, coordination, avoidance, mission, a control plugin; the built-in path follower named),
the team's mission and the judged target, the link matrix, the video's frames and timing, the parts
observers added (:meth:`~mjasc.runs.runner.Runner.add_summary`) and last ``timing_s`` (wall seconds
per slot and the physics).
"""

from __future__ import annotations

from mjasc.runs.outputs import component_summary

__all__ = ["run_summary"]


def run_summary(runner, status: str, error: str | None, wall_s: float, offsets, parts) -> dict:
    """The summary of ``runner`` (a :class:`~mjasc.runs.runner.Runner` whose loop has ended) with its
    ``status`` and ``error``; ``wall_s`` the run's wall time [s]; ``offsets`` the mission offsets'
    summary (:class:`~mjasc.runs.mission_offset.MissionOffset`), ``parts`` the (key, fn) pairs
    observers added."""
    sc, sim = runner.scenario, runner.sim
    summary = {"scenario": sc.name, "seed": sc.seed, "status": status, "error": error,
               "rates_hz": {s: round(runner.schedule.realized_rate_hz(s), 4) for s in runner.schedule.period_steps},
               **runner.metrics.summary(wall_s, sim.time_s, offsets)}
    for agent in runner.agents:  # components add their own per-vessel results
        for kind, comp in (("perception", agent.perception), ("coordination", agent.coordination),
                           ("avoidance", agent.avoidance), ("mission", agent.mission),
                           ("control", agent.control_plugin)):
            if comp is not None and hasattr(comp, "summary"):
                summary["vessels"][agent.name][kind] = component_summary(comp)
        if agent.follower is not None and agent.control_plugin is None:  # (the built-in follower: named)
            summary["vessels"][agent.name]["control"] = {"method": agent.follower.method}
    if sc.mission is not None:
        from mjasc.missions.sequencer import team_mission_summary

        summary["mission"] = team_mission_summary(runner.agents)
        if runner.target_judge is not None:
            summary["mission"]["track_target_truth"] = runner.target_judge.summary()
    if runner.network is not None:
        summary["comms"] = runner.network.link_matrix()
    if runner.video is not None:
        summary["video_frames"] = runner.video.frames
        summary["video_timing_s"] = {k: round(v, 4) for k, v in runner.video.seconds.items()}
    for key, fn in parts:
        summary[key] = fn()
    summary["timing_s"] = {k: round(v, 4) for k, v in runner.stage_seconds.items()}
    return summary
