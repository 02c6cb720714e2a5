"""Small builders shared by the physics tests (not fixtures: plain functions, explicit inputs)."""

from __future__ import annotations

import numpy as np

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
