"""The record tick's compiled per-vessel arithmetic (mjasc.runs.record_kernels) gives the bits of the
numpy form it replaced, kept here as the reference, on the demo's own states."""

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
        got = (np.empty(hull_body.shape), np.empty((6, n)))
        record_rows(st.position_m, st.velocity_m_s, h, np.cos(h), np.sin(h), hull_body,
                    np.array(speed_ref, dtype=float), st.thrust_n, xte, *got)
        for g, w in zip(got, _reference(st, hull_body, speed_ref, xte)):
            assert g.shape == w.shape and g.tobytes() == w.tobytes()  # (NaN bits included)
        seen.append(st.time_s)

    runner.observe("record", observe)
    runner.run()
    assert len(seen) > 200
