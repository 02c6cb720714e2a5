"""The record tick's compiled per-vessel arithmetic (mjasc.runs.record_kernels) gives the bits of the
numpy form it replaced, kept here as the reference, on the demo's own states and on random ones."""

import math
from pathlib import Path

import numpy as np

from mjasc.runs.record_kernels import record_rows
from mjasc.runs.runner import Runner
from mjasc.runs.truth_recording import body_hulls
from mjasc.runs.scenario import load_scenario

TASKS = Path(__file__).resolve().parents[1] / "tasks"


def _reference(states, hull_body, speed_ref, xte):
    """The hulls and the plot rows as the record tick (TruthRecording.record) computed them in numpy."""
    c, s = np.cos(states.heading_rad)[:, None], np.sin(states.heading_rad)[:, None]
    hb, pos = hull_body, states.position_m
    hulls = np.empty(hb.shape)
    hulls[..., 0] = (hb[..., 0] * c + hb[..., 1] * -s) + pos[:, None, 0]
    hulls[..., 1] = (hb[..., 0] * s + hb[..., 1] * c) + pos[:, None, 1]
    rows = (states.speed_m_s, speed_ref, states.thrust_n[:, 0], states.thrust_n[:, 1], np.degrees(states.heading_rad),
            xte)
    return hulls, np.stack([np.asarray(v, dtype=np.float64) for v in rows])


def _check(st, hull_body, speed_ref, xte, row):
    """record_rows into row ``row`` of fresh columns has the reference's bits (and leaves the other rows)."""
    h, n = st.heading_rad, len(st.heading_rad)
    # the kernel's trigonometry is the C library's: numpy's gives the same bits here (docs/architecture.md)
    assert np.cos(h).tobytes() == np.array([math.cos(v) for v in h]).tobytes()
    assert np.sin(h).tobytes() == np.array([math.sin(v) for v in h]).tobytes()
    hulls, positions, table = np.full((3, *hull_body.shape), 7.0), np.full((3, n, 2), 7.0), np.full((3, 6, n), 7.0)
    record_rows(st.position_m, st.velocity_m_s, h, hull_body, speed_ref, st.thrust_n, xte, row, hulls, positions,
                table)
    for g, w in zip((hulls[row], table[row], positions[row]), (*_reference(st, hull_body, speed_ref, xte),
                                                               st.position_m)):
        assert g.shape == w.shape and g.tobytes() == w.tobytes()  # (NaN bits included)
    others = [r for r in range(3) if r != row]
    assert (hulls[others] == 7.0).all() and (positions[others] == 7.0).all() and (table[others] == 7.0).all()


def test_record_rows_on_random_states():
    from types import SimpleNamespace

    rng = np.random.default_rng(11)
    for n in (1, 3, 17):
        hull_body = rng.normal(size=(n, 6, 2)) * 5.0
        st = SimpleNamespace(position_m=rng.normal(size=(n, 2)) * 300.0, velocity_m_s=rng.normal(size=(n, 2)),
                             heading_rad=rng.uniform(-4 * np.pi, 4 * np.pi, n), thrust_n=rng.normal(size=(n, 2)) * 50)
        st.speed_m_s = np.hypot(st.velocity_m_s[:, 0], st.velocity_m_s[:, 1])
        xte = rng.normal(size=n)
        xte[rng.random(n) < 0.3] = np.nan
        _check(st, hull_body, rng.normal(size=n), xte, row=n % 3)


def test_record_rows_have_the_bits_of_the_numpy_form():
    runner = Runner(load_scenario(TASKS / "demo.toml").with_overrides(duration_s=30.0), None, progress=False)
    hull_body = body_hulls(runner.agents)
    seen = []

    def observe(event):
        st = event.states
        h = st.heading_rad
        n = len(h)
        speed_ref = [o.speed_ref_m_s if o else 0.0 for o in runner.last_outputs]
        xte = np.array([o.status.cross_track_m if o and o.status else np.nan for o in runner.last_outputs])
        xte[len(seen) % n] = np.nan  # (a vessel without a path now and then)
        _check(st, hull_body, np.array(speed_ref, dtype=float), xte, row=len(seen) % 3)
        seen.append(st.time_s)

    runner.observe("record", observe)
    runner.run()
    assert len(seen) > 200
