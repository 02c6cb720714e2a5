"""A stop held on its heading (mjasc.avoidance.control_tick.ControlTick._manoeuvre_refs): a running
velocity correction to zero speed (an emergency stop) that commands at most 0.05 m/s holds the
heading while the path's aim point 5 m ahead lies more than ``sharp_turn_deg`` off it — turning there
at zero speed saturates the differential, which keeps forward thrust (a stopping Delfim ran into a
team mate at 0.7 m/s, and one crept into another at 0.45 m/s: tests/cas_regressions/
bottleneck_stressed_seed33.toml and seed41). Otherwise the correction's references are unchanged."""

import math
import types
from types import SimpleNamespace

import numpy as np
import pytest

from mjasc.avoidance.config import AvoidanceConfig
from mjasc.avoidance.control_tick import ControlTick
from mjasc.core.navigation import OwnNavigation
from mjasc.guidance.paths import Path
from mjasc.guidance.state import GuidanceState

PATH = Path.line([0.0, 0.0], [100.0, 0.0])  # east along y = 0; γ = 10 m is (10, 0), its aim point (15, 0)


class _Law:
    def __init__(self, desired_speed, command):
        self.desired_speed, self._command = desired_speed, command

    def finished(self, t):
        return False

    def command(self, gamma, t):
        return self._command


def _refs(heading_deg, desired_speed=0.0, command=0.0, position=(10.0, 0.0)):
    system = SimpleNamespace(detour=None, _guidance=GuidanceState(PATH, 10.0, 1.0), _sharp_turn=None,
                             correction=SimpleNamespace(law=_Law(desired_speed, command), gamma_offset_m=0.0,
                                                        kind="yield"),
                             config=AvoidanceConfig(), stats={"stop_held": 0}, _stop_held=False, events=[])
    system._event = lambda t, text: system.events.append(text)
    system._aim_error = types.MethodType(ControlTick._aim_error, system)
    psi = math.radians(heading_deg)
    nav = OwnNavigation(5.0, np.array(position, dtype=float), psi, np.zeros(2), np.zeros(3))
    return ControlTick._manoeuvre_refs(system, 5.0, nav), system


def test_a_stop_whose_path_turns_away_is_held_on_its_heading():
    (override, course), system = _refs(90.0)  # the aim point 90° to starboard
    assert override == 0.0 and course == pytest.approx(math.radians(90.0))
    assert system.stats["stop_held"] == 1 and system._stop_held and len(system.events) == 1


def test_a_stop_facing_its_path_steers_as_before():
    (override, course), system = _refs(30.0)  # 30° off: within sharp_turn_deg (60°)
    assert override == 0.0 and course is None and system.stats["stop_held"] == 0


@pytest.mark.parametrize("desired, command", [(0.3, 0.0), (0.0, 0.2)])
def test_a_slow_yield_or_a_stop_still_braking_is_not_held(desired, command):
    (override, course), system = _refs(120.0, desired_speed=desired, command=command)
    assert override == command and course is None and system.stats["stop_held"] == 0


def test_the_hold_is_counted_once_while_it_lasts():
    (_, _), system = _refs(90.0)
    nav = OwnNavigation(5.1, np.array([10.0, 0.0]), math.radians(95.0), np.zeros(2), np.zeros(3))
    ControlTick._manoeuvre_refs(system, 5.1, nav)
    assert system.stats["stop_held"] == 1 and len(system.events) == 1
