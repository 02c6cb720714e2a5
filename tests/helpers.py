"""Small builders shared by the tests (not fixtures: plain functions, explicit inputs)."""

from __future__ import annotations

import numpy as np

from mjasc.avoidance.prediction import Decision, PredictedConflict
from mjasc.physics.currents import UniformCurrent
from mjasc.physics.simulation import Simulation
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import build_world


def make_sim(vessel: str = "otter", n: int = 1, current=(0.0, 0.0), spacing_m: float = 20.0, **kw) -> Simulation:
    vt = load_vessel_type(vessel)
    world = build_world([(f"v{i}", vt) for i in range(n)], **kw)
    sim = Simulation(world, current if hasattr(current, "velocity") else UniformCurrent(current))
    sim.reset(np.array([[spacing_m * i, 0.0, 0.0] for i in range(n)]))
    return sim


def hold_shaft(sim: Simulation, commands) -> None:
    """Set commands and put the shaft speeds at them directly (skips the shaft lag)."""
    sim.set_commands(commands)
    sim.data.act[sim.world.act_adr] = np.asarray(commands, dtype=float).reshape(-1, 2)


def predicted_pair(track_id: int, miss_m: float, t_c: float, t_now: float, r_col: float = 5.6) -> PredictedConflict:
    """A predicted pair (an option's prediction against one track) whose closest approach, at t_c
    [s], is ``miss_m`` [m] outside (+) or inside (−) the collision distance ``r_col`` [m]; a
    collision when it is not outside (its obstruction from ``t_now`` [s])."""
    collision = miss_m <= 0.0
    nan = float("nan")
    return PredictedConflict(track_id=track_id, t_closest_s=t_c, min_distance_m=r_col + miss_m, collision=collision,
                             t_i=t_now if collision else nan, t_f=t_c + 5.0 if collision else nan, gamma_a=0.0,
                             gamma_b=5.0, point_a=None, point_b=None, decision=Decision.VELOCITY_CORRECTION,
                             svo_polygon=None, vessel_positions=np.zeros((0, 2)), obstacle_positions=np.zeros((0, 2)),
                             times=np.zeros(0), collision_distance_m=r_col)


def avoidance_events(monkeypatch) -> list:
    """The events every vessel's collision avoidance says from now on (the test's own runs), as
    (vessel name, time [s], text) tuples appended to the returned list; the events still go where
    they went."""
    from mjasc.avoidance.system import CollisionAvoidance

    said, event = [], CollisionAvoidance._event
    monkeypatch.setattr(CollisionAvoidance, "_event",
                        lambda self, t, text: (said.append((self.name, t, text)), event(self, t, text))[1])
    return said
