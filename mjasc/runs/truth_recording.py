"""What a run records of the truth: the recorder opened with its blueprint, and at each record tick
every vessel's hull, position and plot series, the trails, the traffic, the link's messages and the
current field.

The runner owns one :class:`TruthRecording` when the scenario asks for a recording; the components
draw their own state into the same :class:`~mjasc.runs.recording.Recorder` (``agent.log``). A vessel
never reads any of this: it is the observer's view of the world (ENU metres, radians, seconds of
simulation time).
"""

from __future__ import annotations

import numpy as np

from mjasc.core.geometry import hull_outline
from mjasc.runs.blueprint import OTHERS, view_vessels
from mjasc.runs.fleet_columns import ColumnGroup, FleetColumns
from mjasc.runs.record_kernels import record_rows
from mjasc.runs.static_scene import log_static_scene

__all__ = ["TruthRecording", "body_hulls", "TRAIL_PERIOD_S", "TRAIL_SEGMENT_S", "WORLD_SERIES", "PLOT_SERIES"]

#: A trail point is kept (for the recording and the video) every this many seconds [s].
TRAIL_PERIOD_S = 1.0
#: The recording re-writes a vessel's whole trail this often; in between only the newest part [s].
TRAIL_SEGMENT_S = 30.0
#: The per-vessel world entities written at each record tick (hull, position) or trail point:
#: kind → entity template (the vessels without views share one, as PLOT_SERIES).
WORLD_SERIES = {"hull": "world/vessels/{}/hull", "position": "world/vessels/{}/position",
                "trail": "world/vessels/{}/trail", "trail_recent": "world/vessels/{}/trail/recent"}
#: The per-vessel plot series written at each record tick: kind → entity template. The vessels
#: without views share one entity per kind at standard detail (Recorder.batch_scalars).
PLOT_SERIES = {"speed": "plots/speed/{}/actual", "speed_ref": "plots/speed/{}/reference",
               "thrust_port": "plots/thrust/{}/port", "thrust_starboard": "plots/thrust/{}/starboard",
               "heading": "plots/heading/{}", "cross_track": "plots/cross_track/{}"}


def body_hulls(agents) -> np.ndarray:
    """Every vessel's hull outline in its body frame (FLU, metres about the reference point), (n, 6, 2)."""
    return np.array([hull_outline(a.vessel.length_m, a.vessel.beam_m, np.zeros(2), 0.0) for a in agents])


class TruthRecording:
    """The run's recorder and the truth it writes each record tick (module docstring).

    ``path``: the ``.rrd`` to write; ``extent``: the scene's (lower-left, upper-right) corners [m]
    (the blueprint's framing and the current's arrow grid); ``agents``, ``world``, ``network``: the
    runner's, read for names, sensor ranges, control addresses and moving obstacles."""

    def __init__(self, path, scenario, agents, world, network, extent):
        from mjasc.runs.recording import Recorder, default_blueprint, vessel_colour

        sc = scenario
        lo, hi = extent
        names = tuple(a.name for a in agents)
        bp = default_blueprint(
            extent_m=float(np.max(hi - lo)), extent_xy=(lo, hi), vessels=names,
            perception=any(a.perception is not None for a in agents),
            avoidance=any(a.avoidance is not None for a in agents),
            coordination=any(a.coordination is not None for a in agents), detail=sc.outputs.recording_detail,
            starts_xy={v.name: v.position_m for v in sc.vessels},
            sensor_range_m={a.name: a.perception.sensor_config.max_range_m for a in agents
                            if a.perception is not None},
            comms=network is not None, mission=sc.mission is not None)
        self.recorder = rec = Recorder(path, sc.name, sc.seed, bp, detail=sc.outputs.recording_detail)
        rec.colours = {a.name: vessel_colour(i) for i, a in enumerate(agents)}
        rec.set_vessels(names, view_vessels(names))
        self._world, self._network = world, network
        self._entities = self._entity_names(names, world)
        self._hull_body = body_hulls(agents)
        self._columns, self._groups = self._fleet_columns(len(names))
        self._group_rows = len(self._groups) * len(self._entities["hull"])  # rows a record tick adds to the groups
        #: Does :meth:`record` need the traffic's state (moving obstacles to draw)?
        self.needs_traffic = bool(self._entities["moving"])
        # the moving obstacles' positions [m] per record tick, read by the recorder's flush
        self._moving = FleetColumns({"xy": (len(world.moving_obstacles), 2)}, capacity=256)
        self._moving_group = ColumnGroup(self._moving, "xy", None, len(world.moving_obstacles))
        self._trail = FleetColumns({"xy": (len(names), 2)}, capacity=128)  # the fleet's positions [m] at its points
        self._trail_cut = 0  # index of the trail point where the recording's ``trail/recent`` starts
        self._current_grid, self._current_scale = log_static_scene(rec, sc, lo, hi, PLOT_SERIES)
        self._current_times: list[float] = []
        self._comms_log = None
        if network is not None and tuple(network.team) == names:
            from mjasc.cooperation.recording import CommsLog

            self._comms_log = CommsLog(names)
            if self._comms_log.lines:
                network.keep_outcomes()
        rec.event(0.0, f"scenario {sc.name!r} seed {sc.seed}: {len(sc.vessels)} vessel(s), "
                       f"{len(sc.static_obstacles)} static and {len(sc.moving_obstacles)} moving obstacle(s)")

    def _entity_names(self, names: tuple[str, ...], world) -> dict[str, tuple[str, ...]]:
        """The recording's per-vessel entities, one tuple (in vessel order) per kind."""
        kinds = {"command_port": "plots/commands/{}/port", "command_starboard": "plots/commands/{}/starboard"}
        out = {k: tuple(v.format(n) for n in names) for k, v in kinds.items()}
        out.update({k: self.recorder.vessel_entities(v, names) for k, v in {**WORLD_SERIES, **PLOT_SERIES}.items()})
        out["moving"] = tuple(f"world/obstacles/moving/{o.name}" for o in world.moving_obstacles)
        return out

    def _fleet_columns(self, n: int) -> tuple[FleetColumns, tuple]:
        """The per-tick rows of every vessel's hull (n, k, 2) and position (n, 2) [m] and the plot
        table (PLOT_SERIES' order, n) in preallocated arrays, and the recorder's fleet groups of the
        vessels with their own entities (the first ones) reading them: ((kind, entities, z), group)."""
        e = self._entities
        columns = FleetColumns({"hull": self._hull_body.shape, "position": (n, 2), "table": (len(PLOT_SERIES), n)},
                               capacity=256)
        n_own = len(e["hull"])
        groups = [(("strips", e["hull"], 0.2), ColumnGroup(columns, "hull", None, n_own)),
                  (("points", e["position"], 0.2), ColumnGroup(columns, "position", None, n_own))]
        groups += [(("scalar", e[kind], 0.0), ColumnGroup(columns, "table", k, n_own))
                   for k, kind in enumerate(PLOT_SERIES)]
        return columns, tuple(groups)

    def record(self, states, sim, speed_ref_m_s: np.ndarray, xte_m: np.ndarray, traffic) -> None:
        """One record tick of the truth: ``states`` (the fleet's true states), ``sim`` (commands and
        the current), each vessel's speed reference and cross-track error [m] (NaN: no path), the
        traffic's (positions, ...) as ``Simulation.traffic_state`` gives them (None when not
        :attr:`needs_traffic`)."""
        rec, t, e, columns = self.recorder, states.time_s, self._entities, self._columns
        if columns.n == 0:  # (the first row, or the first since a flush: the groups in the order of their rows)
            for (kind, entities, z), group in self._groups:
                rec.fleet_columns(kind, entities, group, z)
        i = columns.add(t)
        arrays = columns.arrays  # (table: PLOT_SERIES' order)
        record_rows(states.position_m, states.velocity_m_s, states.heading_rad, self._hull_body, speed_ref_m_s,
                    states.thrust_n, xte_m, i, arrays["hull"], arrays["position"], arrays["table"])
        if rec.batched:  # the vessels without views: one row of their batch entity per kind
            n_own = len(e["hull"])
            hulls, table = arrays["hull"][i], arrays["table"][i]
            rec.strips(WORLD_SERIES["hull"].format(OTHERS), t, list(hulls[n_own:]), z=0.2)
            rec.points(WORLD_SERIES["position"].format(OTHERS), t, states.position_m[n_own:], z=0.2)
            for template, row in zip(PLOT_SERIES.values(), table):
                rec.batch_scalars(template, t, row[n_own:])
        rec.count(self._group_rows)  # (a scalar series' NaN, no path, is left out at the flush)
        if rec.full:
            ctrl = sim.data.ctrl[self._world.ctrl_adr]
            rec.fleet_scalars(e["command_port"], t, ctrl[:, 0])
            rec.fleet_scalars(e["command_starboard"], t, ctrl[:, 1])
        trail = self._trail
        if not trail.n or t - trail.times[trail.n - 1] >= TRAIL_PERIOD_S:
            self._record_trails(t, states.position_m)
        if self.needs_traffic:
            moving = self._moving
            if moving.n == 0:  # (registered where its first row comes, as the other groups)
                rec.fleet_columns("points", e["moving"], self._moving_group, 0.3)
            k = moving.add(t)  # (before reading its array: add may grow it)
            moving.arrays["xy"][k] = traffic[0]
            rec.count(len(e["moving"]))
        if self._comms_log is not None:
            net = self._network
            self._comms_log.log(rec, t, net.drain_outcomes(), states.position_m, net.counts, net.count_changes)
        if not sim.current.is_steady and self._current_grid is not None and \
                (not self._current_times or t - self._current_times[-1] >= 2.0):
            self._current_times.append(t)
            rec.arrows("world/current", t, self._current_grid, self._current_scale * sim.current.velocity(
                self._current_grid, t))

    def finish(self, t_s: float) -> None:
        """The run ended at ``t_s`` (completed or not): what is drawn only now and then is brought
        up to date — the comms counts (:meth:`~mjasc.cooperation.recording.CommsLog.finish`)."""
        if self._comms_log is not None:
            self._comms_log.finish(self.recorder, t_s, self._network.counts)

    def _record_trails(self, t: float, positions: np.ndarray) -> None:
        """A trail point per vessel every ``TRAIL_PERIOD_S``. The recording holds each trail in two
        strips so that its size grows linearly with the run: ``trail`` (everything up to the latest
        ``TRAIL_SEGMENT_S`` boundary, re-written at each boundary) and ``trail/recent`` (from that
        boundary to now, written with every new point)."""
        trail = self._trail  # (the caller checks the period: t − the last point's time ≥ TRAIL_PERIOD_S)
        k = trail.add(t)
        xy = trail.arrays["xy"]  # (points, n, 2): a strip per vessel is xy[a:b, j], the vessels' xy[a:b].swapaxes(0, 1)
        xy[k] = positions
        if k < 1:
            return
        e = self._entities
        if t - trail.times[self._trail_cut] >= TRAIL_SEGMENT_S:  # (the points are never written again: views)
            self.recorder.vessel_strips(WORLD_SERIES["trail"], e["trail"], t, xy[:k + 1].swapaxes(0, 1), z=0.1)
            self._trail_cut = k
        self.recorder.vessel_strips(WORLD_SERIES["trail_recent"], e["trail_recent"], t,
                                    xy[self._trail_cut:k + 1].swapaxes(0, 1), z=0.1)
