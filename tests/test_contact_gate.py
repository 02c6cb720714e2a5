"""The contact gate (mjasc.physics.contact_gate): steps without MuJoCo's collision detection while no
two bodies can touch give the bits of steps with it — contacts with hulls, walls, a circular island
and traffic included —, the gate never closes on a step whose collision finds a contact, and it is
closed on most steps of a thesis scene."""

import collections
from pathlib import Path

import mujoco
import numpy as np
import pytest

import mjasc.physics.simulation as simulation
from mjasc.physics.contact_gate import ContactGate, contacts_possible
from mjasc.runs.runner import Runner
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"
FIELDS = ("qpos", "qvel", "qacc", "act", "qfrc_applied", "qfrc_constraint", "mocap_pos", "mocap_quat", "efc_force")


@pytest.fixture
def gate_answers(monkeypatch):
    """Counts of the compiled step's answers (1: no two bodies can touch, 2: some may)."""
    counts = collections.Counter()
    prepare = simulation.prepare_step

    def counted(*args):
        ready = prepare(*args)
        counts[int(ready)] += 1
        return ready

    monkeypatch.setattr(simulation, "prepare_step", counted)
    return counts


def _demo_into_contact():
    """The demo's world with alpha driving north into the pontoon's south wall (y = 28 m), bravo
    into the buoy (a cylinder at (130, −28), r 1.5 m) and charlie stopped in the ferry's track."""
    runner = Runner(load_scenario(TASKS / "demo.toml"), None, progress=False)
    sim = runner.sim
    sim.reset([[75.0, 21.0, np.pi / 2], [130.0, -36.0, np.pi / 2], [105.0, 66.0, 0.0]],
              [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    sim.set_commands([[1.0, 1.0], [1.0, 1.0], [0.0, 0.0]])
    return sim


def _contact_pairs(sim) -> set:
    d, owner = sim.data, sim.world.geom_owner
    return {tuple(sorted((owner[c.geom1], owner[c.geom2]))) for c in d.contact[: d.ncon]}


def test_gated_steps_have_the_bits_of_ungated_ones_through_contacts(gate_answers):
    gated, plain = _demo_into_contact(), _demo_into_contact()
    plain.contact_gating = False
    assert gated.contact_gate.usable and gated.contact_gating
    flags = gated.model.opt.disableflags
    seen, open_with_contact = set(), 0
    for step in range(700):  # (14 s: every vessel in contact for a while, the gate closed before)
        gate_answers.clear()
        gated.step(1)
        plain.step(1)
        for field in FIELDS:
            assert getattr(gated.data, field).tobytes() == getattr(plain.data, field).tobytes(), (step, field)
        assert gated.data.ncon == plain.data.ncon, step
        if plain.data.ncon:  # a step whose collision found contacts ran it: the gate was open
            assert gate_answers[2] == 1, step
            open_with_contact += 1
            assert _contact_pairs(gated) == _contact_pairs(plain)
            seen |= _contact_pairs(plain)
        assert gated.model.opt.disableflags == flags  # (restored after each block)
    assert {("alpha", "pontoon"), ("bravo", "buoy"), ("charlie", "ferry")} <= seen
    assert open_with_contact > 50


def test_the_gate_closes_away_from_contacts_and_opens_before_them(gate_answers):
    sim = _demo_into_contact()
    answers = []
    for _ in range(700):
        gate_answers.clear()
        sim.step(1)
        answers.append((gate_answers[2] == 1, sim.data.ncon > 0))
    opened = [i for i, (may_touch, _) in enumerate(answers) if may_touch]
    touched = [i for i, (_, contact) in enumerate(answers) if contact]
    assert answers[0] == (False, False)  # (every hull starts clear of everything: the gate is closed)
    assert touched and opened[0] < touched[0]


def test_the_gate_is_closed_on_most_steps_of_a_thesis_scene(gate_answers):
    runner = Runner(load_scenario(TASKS / "thesis_6_4_crossing.toml").with_overrides(duration_s=40.0), None,
                    progress=False)
    assert runner.sim.contact_gate.usable
    runner.run()
    assert gate_answers[1] >= 0.95 * (gate_answers[1] + gate_answers[2]) and gate_answers[1] > 1000


def test_runs_with_and_without_the_gate_give_the_same_summary():
    def summary(gating: bool) -> dict:
        runner = Runner(load_scenario(TASKS / "thesis_6_2_dock.toml").with_overrides(duration_s=30.0), None,
                        progress=False)
        runner.sim.contact_gating = gating
        out = runner.run().summary
        q = runner.sim.data.qpos.tobytes()
        return {k: v for k, v in out.items() if k not in ("timing_s", "wall_time_s", "real_time_factor")}, q

    (a, qa), (b, qb) = summary(True), summary(False)
    assert qa == qb
    for name in a["vessels"]:
        for v in (a, b):
            v["vessels"][name].get("perception", {}).pop("mean_tracking_us", None)
            v["vessels"][name].get("perception", {}).pop("mean_sense_us", None)
    assert a == b


def test_a_closed_gate_means_no_contact_at_random_placements():
    """Bodies placed at random near each other, the pontoon's walls, the buoy and the ferry: wherever
    the gate says no two can touch (even with no slack) MuJoCo's collision finds nothing; and it
    does not say "may touch" everywhere."""
    sim = _demo_into_contact()
    m, d, gate = sim.model, sim.data, ContactGate(sim.model, slack_m=0.0)
    rng = np.random.default_rng(5)
    anchors = np.array([[75.0, 26.0], [55.0, 33.0], [130.0, -28.0], [105.0, 70.0], [90.0, 0.0]])
    closed = 0
    for _ in range(3000):
        centre = anchors[rng.integers(len(anchors))]
        d.qpos[sim.world.qpos_adr[:, :2]] = centre + rng.uniform(-7.0, 7.0, (sim.n_vessels, 2))
        d.qpos[sim.world.qpos_adr[:, 2]] = rng.uniform(-np.pi, np.pi, sim.n_vessels)
        d.mocap_pos[sim.world.mocap_id, :2] = [105.0, 70.0] + rng.uniform(-8.0, 8.0, 2)
        possible = contacts_possible(d.qpos, d.mocap_pos, gate.table, gate.pairs)
        mujoco.mj_forward(m, d)
        if not possible:
            closed += 1
            assert d.ncon == 0
    assert 300 < closed < 2900


def test_the_gates_origins_are_mujocos_body_positions():
    sim = _demo_into_contact()
    m, d, gate = sim.model, sim.data, sim.contact_gate
    rng = np.random.default_rng(6)
    welds = sorted({int(w) for w in m.body_weldid[m.geom_bodyid][(m.geom_contype | m.geom_conaffinity) != 0] if w})
    for _ in range(100):
        d.qpos[:] = rng.uniform(-200.0, 200.0, m.nq)
        d.mocap_pos[:] = rng.uniform(-200.0, 200.0, (m.nmocap, 3))
        mujoco.mj_kinematics(m, d)
        contacts_possible(d.qpos, d.mocap_pos, gate.table, gate.pairs)
        assert np.abs(gate.table[:gate.n_moving, 22:25] - d.xpos[welds]).max() < 1e-9


def test_mujoco_does_not_collide_bodies_that_cannot_move():
    """The gate leaves out pairs of weld groups without dofs (mocap traffic against structures):
    MuJoCo skips them (its documentation, "Collision detection", filter 3)."""
    sim = _demo_into_contact()
    m, d = sim.model, sim.data
    d.qpos[sim.world.qpos_adr[:, :2]] = [[0.0, -100.0], [20.0, -100.0], [40.0, -100.0]]  # (far from all)
    d.mocap_pos[sim.world.mocap_id, :2] = [75.0, 28.0]  # the ferry across the pontoon's wall
    mujoco.mj_forward(m, d)
    assert d.ncon == 0
    d.qpos[sim.world.qpos_adr[0, :2]] = [75.0, 28.0]  # a hull there too: contacts
    mujoco.mj_forward(m, d)
    assert d.ncon > 0


@pytest.mark.parametrize("xml, why", [
    ("<geom type='plane' size='5 5 1'/><body><joint type='slide' axis='1 0 0'/><geom size='1'/></body>", "plane"),
    ("<body><freejoint/><geom size='1'/></body><geom size='1' pos='5 0 0'/>", "joint"),
    ("<body><joint type='hinge' axis='0 0 1' pos='1 0 0'/><geom size='1'/></body><geom size='1' pos='5 0 0'/>",
     "joint"),
    ("<body><joint type='slide' axis='1 0 0'/><geom size='1'/><body><joint type='slide' axis='0 1 0'/>"
     "<geom size='1'/></body></body>", "moving parent"),
])
def test_what_the_gate_cannot_bound_keeps_it_open(xml, why):
    gate = ContactGate(mujoco.MjModel.from_xml_string(f"<mujoco><worldbody>{xml}</worldbody></mujoco>"))
    assert not gate.usable and why in gate.reason and gate.pairs.shape == (0, 2)


def test_a_switched_off_gate_never_disables_contacts():
    sim = _demo_into_contact()
    sim.contact_gating = False
    flags = []
    sim._opt = _Recorder(sim.model.opt, flags)
    sim.step(20)
    assert not any(f & int(mujoco.mjtDisableBit.mjDSBL_CONTACT) for f in flags)
    sim.contact_gating = True
    sim.step(1)
    assert flags[-2] & int(mujoco.mjtDisableBit.mjDSBL_CONTACT) and not flags[-1] & int(
        mujoco.mjtDisableBit.mjDSBL_CONTACT)  # (closed for the step, restored after it)


class _Recorder:
    """An MjOption stand-in that records the disable flags written through it."""

    def __init__(self, opt, log):
        object.__setattr__(self, "_opt", opt)
        object.__setattr__(self, "_log", log)

    def __getattr__(self, name):
        return getattr(self._opt, name)

    def __setattr__(self, name, value):
        if name == "disableflags":
            self._log.append(int(value))
        setattr(self._opt, name, value)
