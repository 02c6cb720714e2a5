"""The run metrics fold each record tick's clearances into their running minima block by block
(a static obstacle's column, the moving obstacles', the vessels'); this checks them bit for bit
against the readable form — every clearance of the tick stacked into one matrix, then the minimum
— on the demo's own states (a polygon, a circle, a moving obstacle and three vessels)."""

from pathlib import Path

import numpy as np

from mjasc.core.geometry import distance_to_polygon, point_in_polygon
from mjasc.physics.obstacles import PolygonObstacle
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def _norm(d: np.ndarray) -> np.ndarray:
    return np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1])


def _reference_update(ref: dict, m, states, xte: np.ndarray, traffic) -> None:
    """The metrics' update as one stacked clearance matrix per tick (the form it replaces)."""
    pos = states.position_m
    if ref["last"] is not None:
        ref["distance"] += np.hypot(*(pos - ref["last"]).T)
    ref["last"] = pos.copy()
    ok = np.isfinite(xte)
    a = np.abs(np.where(ok, xte, 0.0))
    ref["xte_sum"] += a
    ref["xte_count"] += ok
    ref["xte_max"] = np.maximum(ref["xte_max"], a)
    columns = []
    for o in m.static:
        if isinstance(o, PolygonObstacle):
            d = distance_to_polygon(pos, o.vertices)
            d = np.where(point_in_polygon(pos, o.vertices), -d, d)
        else:
            d = np.hypot(*(pos - o.centre).T) - o.radius_m
        columns.append(d - m.radii)
    tpos = traffic[0]
    if len(tpos):
        columns.extend((_norm(pos[:, None] - tpos[None]) - m.radii[:, None] - m._traffic_radii[None]).T)
    pair = _norm(pos[:, None] - pos[None]) - m.radii[:, None] - m.radii[None]
    np.fill_diagonal(pair, np.inf)
    clearance = np.column_stack(columns + [pair]) if columns else pair
    ref["min_clear"] = np.minimum(ref["min_clear"], clearance)


def test_running_minima_block_by_block_equal_the_stacked_matrix_bit_for_bit():
    sc = load_scenario(TASKS / "demo.toml").with_overrides(duration_s=40.0)
    runner = Runner(sc, None, progress=False)
    m = None
    ref = {}

    def observe(event):
        nonlocal m
        if m is None:
            m = runner.metrics
            n = len(m.names)
            ref.update(last=None, distance=np.zeros(n), xte_sum=np.zeros(n), xte_count=np.zeros(n, dtype=int),
                       xte_max=np.zeros(n), min_clear=np.full(m._min_clear.shape, np.inf))
        xte = np.array([o.status.cross_track_m if o and o.status else np.nan for o in runner.last_outputs])
        _reference_update(ref, m, event.states, xte, runner.sim.traffic_state())

    runner.observe("record", observe)
    runner.run()
    assert len(m.static) == 2 and any(isinstance(o, PolygonObstacle) for o in m.static) and len(m._traffic_radii)
    assert np.isfinite(ref["min_clear"]).sum() > 0
    for name, ours in (("distance", m.distance), ("xte_sum", m._xte_sum), ("xte_count", m._xte_count),
                       ("xte_max", m._xte_max), ("min_clear", m._min_clear)):
        assert np.array_equal(ours, ref[name], equal_nan=True), name
        assert ours.tobytes() == ref[name].tobytes(), name


def test_deferred_ticks_equal_tick_by_tick_updates_bit_for_bit():
    """A run without recording defers its record ticks (``RunMetrics.defer``: the traffic evaluated
    at the kept times, the ticks folded in chunks of ``DEFER_TICKS``); fed the same ticks one
    :meth:`update` at a time (the traffic read as ``Simulation.traffic_state``, as a recording run
    does), or mixed (an update folds the deferred ticks first), the metrics are the same bits."""
    from mjasc.runs.metrics import DEFER_TICKS, RunMetrics

    sc = load_scenario(TASKS / "demo.toml").with_overrides(duration_s=60.0)
    runner = Runner(sc, None, progress=False)
    ticks = []

    def observe(event):
        xte = [o.status.cross_track_m if o and o.status else np.nan for o in runner.last_outputs]
        ticks.append((event.states, xte, runner.sim.traffic_state()))

    runner.observe("record", observe)
    summary = runner.run().summary
    assert len(ticks) > DEFER_TICKS  # (a chunk folded during the run, the rest at the summary)
    now, later, mixed = (RunMetrics(runner.world, sc, runner.sim.traffic) for _ in range(3))
    for k, (states, xte, traffic) in enumerate(ticks):
        now.update(states, np.array(xte), traffic)
        later.defer(states, xte)
        if k % 7 == 3:
            mixed.update(states, np.array(xte), traffic)
        else:
            mixed.defer(states, xte)
    for m in (later, mixed, runner.metrics):
        m.flush()
        for name in ("distance", "_xte_sum", "_xte_count", "_xte_max", "_min_clear", "_last_pos"):
            assert getattr(m, name).tobytes() == getattr(now, name).tobytes(), name
    for m in (later, mixed):
        assert m.summary(1.0, 60.0)["vessels"] == now.summary(1.0, 60.0)["vessels"]
    assert not summary["collisions"]


# ---------------------------------------------------------------------- which cross-track errors count
def _out(e, finished=False):
    from types import SimpleNamespace

    return SimpleNamespace(status=SimpleNamespace(cross_track_m=e, finished=finished))


def test_cross_track_counts_only_while_a_path_is_followed():
    """The statistics leave out a finished path's drift and the approach onto a mission leg that
    puts the vessel 5 m or more farther off its line (counted again from its first tick within 1 m
    of its leg); a path that begins at the vessel, a leg re-drawn a little way on (a station's
    moving line, the error changing by less than 5 m) and a vessel without a mission count."""
    from types import SimpleNamespace

    from mjasc.runs.metrics import APPROACH_JUMP_M, ON_PATH_BAND_M, CrossTrackGate

    near, redrawn, far, again = object(), object(), object(), object()
    mission = SimpleNamespace(leg_path=near)
    agents = [SimpleNamespace(mission=None), SimpleNamespace(mission=mission)]
    gate = CrossTrackGate(2)
    assert np.isnan(gate.counted([None, None], agents)).all()  # before the first control tick
    assert gate.counted([_out(0.3), _out(-0.4)], agents) == [0.3, -0.4]  # a leg beginning at the vessel
    mission.leg_path = redrawn  # the line re-drawn 4 m away: how far the vessel lags it, counted
    assert gate.counted([_out(0.3), _out(4.0)], agents)[1] == 4.0
    mission.leg_path = object()  # and again, 8 m: 4 m more than the tick before, counted
    assert gate.counted([_out(0.3), _out(-8.0)], agents)[1] == -8.0
    mission.leg_path = near  # back on a line
    assert gate.counted([_out(0.3), _out(0.1)], agents)[1] == 0.1
    mission.leg_path = far  # a phase change: the new line 27 m away
    got = gate.counted([_out(0.2), _out(27.0)], agents)
    assert got[0] == 0.2 and np.isnan(got[1])
    mission.leg_path = again  # re-drawn while approaching: still the approach
    assert np.isnan(gate.counted([_out(0.2), _out(-2 * APPROACH_JUMP_M)], agents)[1])
    assert np.isnan(gate.counted([_out(0.2), _out(2 * ON_PATH_BAND_M)], agents)[1])
    assert gate.counted([_out(0.2), _out(0.9 * ON_PATH_BAND_M)], agents)[1] == 0.9 * ON_PATH_BAND_M  # on it
    assert gate.counted([_out(0.2), _out(3.0)], agents)[1] == 3.0  # off it later: a following error, counted
    got = gate.counted([_out(5.0, finished=True), _out(0.1)], agents)  # past its path's end: drifting
    assert np.isnan(got[0]) and got[1] == 0.1


def test_a_contact_between_two_record_ticks_is_counted_at_its_step():
    """Contacts are read at every physics step (Simulation.touches), not at the record tick's instant: a
    bump of one step between two ticks — MuJoCo's contacts are instants — went uncounted (a stressed dock run:
    vessel2 glanced off the moored vessel3 at 46.02 s, between the ticks at 46.0 and 46.1, and the summary said
    no collision). A pair touching in two consecutive record periods is one contact."""
    from mjasc.runs.metrics import RunMetrics

    sc = load_scenario(TASKS / "thesis_6_2_dock.toml").with_overrides(duration_s=1.0)
    runner = Runner(sc, None, progress=False)
    m = RunMetrics(runner.world, sc, runner.sim.traffic)
    owner = runner.world.geom_owner
    g2 = next(g for g, o in enumerate(owner) if o == "vessel2")
    g3 = next(g for g, o in enumerate(owner) if o == "vessel3")
    assert m.check_contacts({}) == []
    assert m.check_contacts({(g3, g2): 46.02}) == [("vessel2", "vessel3")]  # (nothing touching at the tick)
    assert m.check_contacts({(g2, g3): 46.12}) == []  # the same contact, on into the next period
    assert m.check_contacts({}) == []
    assert m.check_contacts({(g2, g3): 51.3}) == [("vessel2", "vessel3")]  # a new one
    assert m.collisions == [{"time_s": 46.02, "between": ["vessel2", "vessel3"]},
                            {"time_s": 51.3, "between": ["vessel2", "vessel3"]}]


def test_the_simulation_notes_every_step_s_contacts():
    """Two Otters driven into each other: the steps' contacts are noted with the step's time (not a record
    tick's), and the run's collision time is the first touching step's."""
    from mjasc.runs.scenario import parse_scenario

    v = {"type": "otter", "heading_deg": 0.0, "controller": {"type": "none", "commands": [1.0, 1.0]}}
    doc = {"name": "bump", "duration_s": 6.0, "seed": 1, "outputs": {"recording": False},
           "vessels": [{**v, "name": "a", "position_m": [0.0, 0.0]},
                       {**v, "name": "b", "position_m": [4.0, 0.0], "controller": {"type": "none", "commands": [0.0, 0.0]}}]}
    summary = Runner(parse_scenario(doc), None, progress=False).run().summary
    (first, *_) = summary["collisions"]
    assert first["between"] == ["a", "b"] and 0.5 < first["time_s"] < 6.0
    assert abs(first["time_s"] / 0.02 - round(first["time_s"] / 0.02)) < 1e-6  # a physics step's time
