"""The static map in the recording (mjasc.perception.recording, standard detail): the polygons the
avoidance built last are drawn when newer than the drawing, at most every MAP_LOG_PERIOD_S; a map
that changed but was not built is built for the drawing at most every MAP_BUILD_PERIOD_S; full
detail draws the map at every change. A real StaticMap and Recorder; the drawn rows are read back
from the recorder's buffer."""

import numpy as np
import pytest

from mjasc.perception.recording import MAP_BUILD_PERIOD_S, MAP_LOG_PERIOD_S, PerceptionLog
from mjasc.perception.static_map import StaticMap
from mjasc.runs.recording import Recorder

ENTITY = "world/vessels/alpha/static_map"


def grow(m: StaticMap, x0: float) -> None:
    """Map a 3-cell wall segment at x = x0 (three scans: min_hits)."""
    for _ in range(3):
        m.add_scan(np.array([[x0 + 0.5, 0.5], [x0 + 0.5, 1.5], [x0 + 0.5, 2.5]]))


def drawn(rec: Recorder) -> list[tuple[float, int]]:
    """(time, number of polygons) of every drawing of the map buffered so far."""
    times, rows, _ = rec._strips.get((ENTITY, 0.4), ([], [], []))
    return [(t, len(r)) for t, r in zip(times, rows)]


@pytest.fixture
def rec(tmp_path):
    r = Recorder(tmp_path / "r.rrd", "map-drawing", 0, detail="standard")
    yield r
    r.close()


def test_the_drawing_shows_what_the_avoidance_built_and_builds_only_a_stale_map(rec):
    m, log = StaticMap(1.0, 3), PerceptionLog()
    grow(m, 10.0)
    log._log_map(rec, 0.0, m, "world/vessels/alpha", False)  # first drawing: built now
    assert drawn(rec) == [(0.0, 1)] and m.built_polygons()[0] == m.version
    grow(m, 30.0)  # the map changes; nobody builds it
    for t in np.arange(MAP_LOG_PERIOD_S, MAP_BUILD_PERIOD_S, MAP_LOG_PERIOD_S):
        log._log_map(rec, float(t), m, "world/vessels/alpha", False)
    assert drawn(rec) == [(0.0, 1)]  # nothing built for the drawing before the build period
    assert m.built_polygons()[0] != m.version
    polygons = m.polygons()  # the avoidance builds it: drawn at the next due drawing, as built
    log._log_map(rec, MAP_BUILD_PERIOD_S - 1.0, m, "world/vessels/alpha", False)
    assert drawn(rec)[-1] == (MAP_BUILD_PERIOD_S - 1.0, len(polygons)) and len(polygons) == 2
    version = m.version
    grow(m, 50.0)
    log._log_map(rec, MAP_BUILD_PERIOD_S + 2.0, m, "world/vessels/alpha", False)  # not stale yet: nothing
    assert len(drawn(rec)) == 2 and m.built_polygons()[0] == version
    log._log_map(rec, 2.0 * MAP_BUILD_PERIOD_S - 1.0, m, "world/vessels/alpha", False)  # stale: built now
    assert drawn(rec)[-1] == (2.0 * MAP_BUILD_PERIOD_S - 1.0, 3) and m.built_polygons()[0] == m.version
    log._log_map(rec, 3.0 * MAP_BUILD_PERIOD_S, m, "world/vessels/alpha", False)  # unchanged: no drawing
    assert len(drawn(rec)) == 3


def test_full_detail_draws_the_map_at_every_change(tmp_path):
    rec = Recorder(tmp_path / "r.rrd", "map-drawing", 0, detail="full")
    m, log = StaticMap(1.0, 3), PerceptionLog()
    for k, x in enumerate((10.0, 30.0, 50.0)):
        grow(m, x)
        log._log_map(rec, float(k), m, "world/vessels/alpha", True)
    assert drawn(rec) == [(0.0, 1), (1.0, 2), (2.0, 3)]
    rec.close()


def test_a_map_built_empty_after_the_drawing_is_drawn_empty_not_built_again(rec):
    """The avoidance built the map after every cell was carved free, and the map changed since: the
    drawing shows the empty map it built (a row without strips) and builds nothing of its own."""
    m, log = StaticMap(1.0, 3), PerceptionLog()
    grow(m, 10.0)
    log._log_map(rec, 0.0, m, "world/vessels/alpha", False)
    n = 720
    angles = -np.pi + (np.arange(n) + 0.5) * 2.0 * np.pi / n
    for _ in range(50):  # every beam sees through to 150 m: the wall's cells are carved free
        m.carve(np.zeros(2), angles, np.full(n, 150.0), np.zeros(n, dtype=bool), 150.0)
        if m.n_occupied == 0:
            break
    assert m.n_occupied == 0
    assert m.polygons() == []  # the avoidance builds the empty map
    version = m.version
    grow(m, 30.0)  # then the map changes again, unbuilt
    log._log_map(rec, MAP_LOG_PERIOD_S, m, "world/vessels/alpha", False)
    assert drawn(rec) == [(0.0, 1), (MAP_LOG_PERIOD_S, 0)] and m.built_polygons() == (version, [])
