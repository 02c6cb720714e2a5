"""Simulation.states in one compiled pass (mjasc.physics.state_kernels) gives the bits of its numpy
form (Simulation._states_numpy, kept as the reference) on a run's own states, reversing shafts included."""

from dataclasses import fields
from pathlib import Path

import numpy as np

from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def _same(a, b) -> None:
    for f in fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            assert x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes(), f.name
            assert x.flags.c_contiguous and not np.shares_memory(x, y), f.name
        else:
            assert x == y, f.name


def test_states_have_the_bits_of_the_numpy_form():
    runner = Runner(load_scenario(TASKS / "demo.toml").with_overrides(duration_s=30.0), None, progress=False)
    sim = runner.sim
    assert sim._bound
    count = 0

    def observe(event):
        nonlocal count
        _same(sim.states(), sim._states_numpy())
        count += 1

    runner.observe("control", observe)
    runner.run()
    assert count >= 300
    rng = np.random.default_rng(1)
    for _ in range(200):  # shafts in reverse and ahead, headings beyond ±π
        sim.data.act[:] = rng.uniform(-1.0, 1.0, sim.data.act.shape)
        sim._qpos3[:, 2] = rng.uniform(-20.0, 20.0, sim.n_vessels)
        sim._qvel3[:] = rng.normal(0.0, 2.0, sim._qvel3.shape)
        _same(sim.states(), sim._states_numpy())
    sim._qpos3[:, 2] = [np.pi, -np.pi, 3 * np.pi]
    _same(sim.states(), sim._states_numpy())
