"""The link's compiled decision (mjasc.cooperation.link_kernels) against the numpy form it
replaced in CommsNetwork._decide_one, bit for bit: distances, arrival times, outcomes."""

import numpy as np
import pytest

from mjasc.cooperation.comms import PRESETS, NetworkConfig
from mjasc.cooperation.link_kernels import DELIVERED, LOST, LOST_OUT_OF_RANGE, UNSURE, decide_pairs


def _numpy_form(cfg, x, y, times, pos, u):
    d = np.hypot(x - pos[0], y - pos[1])
    out_of_range = d >= cfg.range_m
    lost = out_of_range | (u[:, 0] < cfg.loss_at(d))
    arrival = times + cfg.base_delay_s + d / cfg.propagation_speed_m_s + u[:, 1] * cfg.jitter_s
    return d, arrival, lost, out_of_range


def _kernel_form(cfg, x, y, times, pos, u):
    out = np.empty((3, x.size))
    unsure = decide_pairs(np.column_stack([x, y, times]), float(pos[0]), float(pos[1]), u, cfg.range_m,
                          cfg.loss_probability, cfg.loss_exponent, cfg.base_delay_s, cfg.propagation_speed_m_s,
                          cfg.jitter_s, out)
    d, arrival, outcome = out[0], out[1], out[2].tolist()
    assert unsure == outcome.count(UNSURE)
    at = [j for j, o in enumerate(outcome) if o == UNSURE]
    for j, gone in zip(at, (u[at, 0] < cfg.loss_at(d[at])).tolist()):
        outcome[j] = LOST if gone else DELIVERED
    outcome = np.array(outcome)
    return d, arrival, outcome != DELIVERED, outcome == LOST_OUT_OF_RANGE, unsure


CONFIGS = [PRESETS["radio"], PRESETS["acoustic"],
           NetworkConfig(range_m=300.0, loss_probability=0.1, loss_exponent=2.5),
           NetworkConfig(range_m=500.0, loss_probability=0.0, loss_exponent=3.0, jitter_s=0.0)]


@pytest.mark.parametrize("cfg", CONFIGS)
def test_decide_pairs_matches_numpy(cfg):
    rng = np.random.default_rng(7)
    for _ in range(200):
        m = int(rng.integers(1, 12))
        x, y = rng.uniform(-1.5, 1.5, m) * cfg.range_m, rng.uniform(-1.5, 1.5, m) * cfg.range_m
        times = np.sort(rng.uniform(0.0, 300.0, m))
        pos = rng.uniform(-200.0, 200.0, 2)
        u = rng.random((m, 2))
        ref = _numpy_form(cfg, x, y, times, pos, u)
        got = _kernel_form(cfg, x, y, times, pos, u)
        for a, b in zip(ref, got[:4]):
            np.testing.assert_array_equal(a, b)
            assert a.tobytes() == b.tobytes() or a.dtype == bool


def test_a_uniform_on_the_loss_probability_is_left_to_numpy():
    cfg = NetworkConfig(range_m=300.0, loss_probability=0.1, loss_exponent=2.5)
    x, y = np.array([120.0, 40.0, 0.0]), np.array([35.0, -80.0, 0.0])
    times, pos = np.array([1.0, 1.0, 1.0]), np.zeros(2)
    p = cfg.loss_at(np.hypot(x, y))
    for u0 in (p, np.nextafter(p, 0.0), np.nextafter(p, 1.0)):
        u = np.column_stack([u0, np.full(3, 0.5)])
        ref = _numpy_form(cfg, x, y, times, pos, u)
        got = _kernel_form(cfg, x, y, times, pos, u)
        assert got[4] == 3  # all three too close to call in the kernel
        for a, b in zip(ref, got[:4]):
            np.testing.assert_array_equal(a, b)


def test_a_tiny_loss_probability_is_left_to_numpy_for_a_tiny_uniform():
    cfg = NetworkConfig(range_m=1000.0, loss_probability=0.0, loss_exponent=104.0)
    x, y, times, pos = np.array([1.0, 500.0]), np.array([0.0, 0.0]), np.array([1.0, 1.0]), np.zeros(2)
    u = np.array([[0.0, 0.5], [0.0, 0.5]])  # p(1 m) = 1e-312 (subnormal): left to numpy; p(500 m) = 2^-104
    ref = _numpy_form(cfg, x, y, times, pos, u)
    got = _kernel_form(cfg, x, y, times, pos, u)
    assert got[4] == 1
    for a, b in zip(ref, got[:4]):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("cfg", CONFIGS)
def test_decide_segments_matches_decide_pairs_receiver_by_receiver(cfg):
    """The fleet's pass (every receiver's segment of the log in one call, one draw of all the
    uniforms) against decide_pairs per receiver with its own draw: the same pairs, bits, counts."""
    from mjasc.cooperation.link_kernels import decide_segments

    rng = np.random.default_rng(3)
    for trial in range(100):
        team, n = int(rng.integers(2, 7)), int(rng.integers(1, 15))
        log = np.array([rng.uniform(-1.5, 1.5, n) * cfg.range_m, rng.uniform(-1.5, 1.5, n) * cfg.range_m,
                        np.sort(rng.uniform(0.0, 300.0, n)), rng.integers(0, team, n)], dtype=float)
        hears = rng.random((team, team)) < (1.0 if trial % 2 else 0.6)
        np.fill_diagonal(hears, False)
        segs = []
        for r in sorted(rng.choice(team, int(rng.integers(1, team + 1)), replace=False).tolist()):
            k0 = int(rng.integers(0, n))
            segs.append((r, k0, int(rng.integers(k0, n + 1)), *rng.uniform(-200.0, 200.0, 2)))
        # the reference: receiver by receiver, each drawing its own uniforms
        draw = np.random.default_rng(trial)
        ref_pairs, ref_out, ref_offered = [], [], np.zeros((team, team), dtype=np.int64)
        ref_counts = np.zeros((len(segs), 3), dtype=np.int64)
        for j, (r, k0, k1, px, py) in enumerate(segs):
            ks = [k for k in range(k0, k1) if hears[r, int(log[3, k])]]
            if not ks:
                continue
            u = draw.random((len(ks), 2))
            out = np.empty((3, len(ks)))
            decide_pairs(np.ascontiguousarray(log[:3, ks].T), px, py, u, cfg.range_m, cfg.loss_probability,
                         cfg.loss_exponent, cfg.base_delay_s, cfg.propagation_speed_m_s, cfg.jitter_s, out)
            for k, code in zip(ks, out[2]):
                ref_offered[int(log[3, k]), r] += 1
                ref_counts[j] += (1, code in (LOST, LOST_OUT_OF_RANGE), code == LOST_OUT_OF_RANGE)
            ref_pairs += [(k, j) for k in ks]
            ref_out.append(out)
        m = len(ref_pairs)
        u = np.random.default_rng(trial).random((m, 2))
        offered, counts = np.zeros((team, team), dtype=np.int64), np.zeros((len(segs), 3), dtype=np.int64)
        pairs, out = np.empty((2, m), dtype=np.int64), np.empty((3, m))
        unsure = decide_segments(log, np.array(segs, dtype=float).reshape(-1, 5), hears, u, cfg.range_m,
                                 cfg.loss_probability, cfg.loss_exponent, cfg.base_delay_s, cfg.propagation_speed_m_s,
                                 cfg.jitter_s, offered, counts, pairs, out)
        assert [tuple(p) for p in pairs.T.tolist()] == ref_pairs
        if m:
            assert np.concatenate(ref_out, axis=1).tobytes() == out.tobytes()
        assert unsure == int(np.count_nonzero(out[2] == UNSURE))
        assert np.array_equal(offered, ref_offered) and np.array_equal(counts, ref_counts)
