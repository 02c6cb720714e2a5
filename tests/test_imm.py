"""Tests of mjasc.perception.imm against simulated truth (thesis eq. 3.2 / 3.3), chi-square statistics,
the thesis's §6.1 numbers, and filterpy's IMMEstimator as a reference implementation."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from scipy.stats import chi2

from mjasc.core.estimates import TrackEstimate
from mjasc.perception.imm import IMMBank, IMMConfig, IMMTracker, parse_imm_options
from mjasc.perception.imm.filterpy_reference import filterpy_imm
from mjasc.perception.imm.markov import MarkovPower

SIGMA = math.sqrt(0.1)  # thesis §6.1: measurement variance 0.1 m² per axis
SEEDS = range(5)


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def truth_eq32(n_steps, dt, speed, turn_rate, heading0=0.3, start=(0.0, 0.0)):
    """Exact solution of thesis eq. 3.2 (ẋ = V cos θ, ẏ = V sin θ, θ̇ = ω) sampled every dt.

    turn_rate: float or callable t ↦ ω (piecewise constant over each step). Rows [t, x, y, θ, V, ω].
    """
    w_of = turn_rate if callable(turn_rate) else (lambda t: turn_rate)
    x, y, th, t = start[0], start[1], heading0, 0.0
    rows = []
    for _ in range(n_steps):
        w = w_of(t)
        rows.append((t, x, y, th, speed, w))
        if abs(w) < 1e-12:
            x, y = x + speed * dt * math.cos(th), y + speed * dt * math.sin(th)
        else:
            x += speed / w * (math.sin(th + w * dt) - math.sin(th))
            y -= speed / w * (math.cos(th + w * dt) - math.cos(th))
        th, t = th + w * dt, t + dt
    return np.array(rows)


def measure(truth, seed, sigma=SIGMA):
    rng = np.random.default_rng(seed)
    return truth[:, 1:3] + rng.normal(0.0, sigma, (len(truth), 2))


def run_tracker(truth, z, config=IMMConfig()):
    trk = IMMTracker(config)
    out = []
    for k in range(len(truth)):
        trk.update(z[k], truth[k, 0])
        out.append(
            (trk.state, trk.state_covariance, trk.turn_rate, trk.mode_probabilities)
        )
    states = np.array([o[0] for o in out])
    covs = np.array([o[1] for o in out])
    return states, covs, np.array([o[2] for o in out]), np.array([o[3] for o in out])


# --------------------------------------------------------------------------- configuration
@pytest.mark.parametrize(
    "field, value",
    [
        ("turn_rates_rad_s", ()),
        ("min_mode_probability", 0.2),
        ("measurement_variance_m2", 0.0),
        ("heading_noise_rad2_s", -1.0),
        ("markov_stay_probability", 0.1),
        ("gate_probability", 0.0),
        ("init_max_updates", 0),
        ("markov_matrix", ((0.0, 1.0), (1.0, 0.0))),
    ],
)
def test_bad_config_raises_naming_the_field(field, value):
    kwargs = {field: value}
    if field == "markov_matrix":
        kwargs["turn_rates_rad_s"] = (-0.1, 0.1)
    with pytest.raises(ValueError, match=rf"^imm\.{field}: "):
        IMMConfig(**kwargs)


def test_parse_imm_options_reads_a_table_and_names_the_key():
    cfg = parse_imm_options({"turn_rates_rad_s": [-0.02, 0, 0.02], "markov_stay_probability": 0.95,
                             "markov_matrix": [[0.9, 0.05, 0.05], [0.05, 0.9, 0.05], [0.05, 0.05, 0.9]],
                             "init_max_updates": 3}, "t.imm")
    assert cfg.turn_rates_rad_s == (-0.02, 0.0, 0.02) and cfg.markov_matrix[1] == (0.05, 0.9, 0.05)
    assert cfg.init_max_updates == 3 and parse_imm_options(None) == IMMConfig()
    for table, message in [
        ({"nope": 1}, "t.imm.nope: unknown field (allowed: "),
        ({"turn_rates_rad_s": "fast"}, "t.imm.turn_rates_rad_s: must be a list, got 'fast'"),
        ({"turn_rates_rad_s": []}, "t.imm.turn_rates_rad_s: must be a non-empty list of finite turn rates"),
        ({"min_mode_probability": 0.5}, "t.imm.min_mode_probability: must be < 1/r = 0.1429 (r = 7 models), got 0.5"),
        ({"speed_noise_m2_s3": -1}, "t.imm.speed_noise_m2_s3: must be ≥ 0, got -1.0"),
        ({"init_max_updates": 2.0}, "t.imm.init_max_updates: must be an integer, got 2.0"),
        ({"gate_probability": 1.5}, "t.imm.gate_probability: must be ≤ 1.0, got 1.5"),
        ({"markov_matrix": [[1, 0]]}, "t.imm.markov_matrix: must be a non-negative 7×7 matrix"),
    ]:
        with pytest.raises(ValueError) as err:
            parse_imm_options(table, "t.imm")
        assert str(err.value).startswith(message)


def test_defaults_are_thesis_table_6_1():
    c = IMMConfig()
    assert c.turn_rates_rad_s == (-0.05, -0.03, -0.01, 0.0, 0.01, 0.03, 0.05)
    assert c.min_mode_probability == 2e-3 and c.measurement_variance_m2 == 0.1
    trk = IMMTracker()
    trk.update([0.0, 0.0], 0.0)
    np.testing.assert_allclose(trk.mode_probabilities, np.full(7, 1 / 7))
    p = c.markov_matrix_array()
    np.testing.assert_allclose(p.sum(axis=1), 1.0)
    assert c.gate_threshold == pytest.approx(chi2.ppf(0.9999, 2))


def test_markov_power_composes_over_variable_sample_times():
    """p(Ts) = p^(Ts/T_ref): p(0.4) p(0.6) = p(1) = the given matrix; p(0) = I."""
    m = MarkovPower(IMMConfig())
    np.testing.assert_allclose(m.scalar(0.4) @ m.scalar(0.6), IMMConfig().markov_matrix_array(), atol=1e-12)
    np.testing.assert_allclose(m.scalar(0.0), np.eye(7))
    np.testing.assert_allclose(m.per_track(np.array([0.4, 1.0]))[1], m.scalar(1.0), atol=1e-12)


# --------------------------------------------------------------------------- behaviour on targets
def test_constant_velocity_target_converges():
    """CV target at 1.5 m/s: 2-D position RMSE well under the raw measurement's (σ√2 = 0.45 m),
    speed within 0.05 m/s (≈ 3.5 × its steady-state 0.014 m/s RMS), ω̂ within 0.005 rad/s of 0."""
    truth = truth_eq32(200, 1.0, 1.5, 0.0)
    for seed in SEEDS:
        z = measure(truth, seed)
        x, _, w, _ = run_tracker(truth, z)
        late = slice(50, None)
        rmse = np.sqrt(np.mean(np.sum((x[late, :2] - truth[late, 1:3]) ** 2, axis=1)))
        raw = np.sqrt(np.mean(np.sum((z[late] - truth[late, 1:3]) ** 2, axis=1)))
        assert rmse < 0.25 and rmse < 0.6 * raw
        assert np.max(np.abs(x[late, 3] - 1.5)) < 0.06
        assert abs(np.mean(x[late, 3]) - 1.5) < 0.03
        assert np.sqrt(np.mean(wrap(x[late, 2] - truth[late, 3]) ** 2)) < 0.04
        assert abs(np.mean(w[late])) < 0.005


def test_thesis_ct_target_speed_and_turn_rate():
    """Thesis §6.1 target: 1.5 m/s turning at 0.03 rad/s, Ts = 1 s (thesis: V̂ = 1.5723, ω̂ = 0.0312
    from one run). Averaged over the last 100 s: |V̂ − 1.5| < 0.03 m/s (RMS error 0.014 m/s) and
    |ω̂ − 0.03| < 0.005 rad/s: ω̂ fluctuates by ±0.003 and is biased ≈ −0.003 by the Markov matrix,
    which keeps ~1 % on each of the six other models (ω̂ = Σ μ_j ω_j)."""
    truth = truth_eq32(250, 1.0, 1.5, 0.03)
    for seed in SEEDS:
        x, _, w, mu = run_tracker(truth, measure(truth, seed))
        late = slice(150, None)
        assert abs(np.mean(x[late, 3]) - 1.5) < 0.03
        assert abs(np.mean(w[late]) - 0.03) < 0.005
        assert np.argmax(np.mean(mu[late], axis=0)) == 5  # ω = 0.03 is the most probable model
        # errors no worse than the thesis's single run
        assert abs(x[-1, 3] - 1.5) < abs(1.5723 - 1.5) + 0.02


def test_manoeuvring_target_mode_probabilities_follow():
    """ω switches 0 → 0.05 (t = 100 s) → −0.03 (t = 160 s): 30 s after each switch the true
    model is the most probable on average and ω̂ follows (within 0.01 rad/s)."""

    def omega(t):
        return 0.0 if t < 100 else (0.05 if t < 160 else -0.03)

    truth = truth_eq32(240, 1.0, 1.5, omega)
    for seed in SEEDS:
        x, _, w, mu = run_tracker(truth, measure(truth, seed))
        for (a, b), j, w_true in (((60, 100), 3, 0.0), ((130, 160), 6, 0.05), ((200, 240), 1, -0.03)):
            assert np.argmax(mu[a:b].mean(axis=0)) == j
            assert abs(np.mean(w[a:b]) - w_true) < 0.01
        pos_err = np.hypot(*(x[20:, :2] - truth[20:, 1:3]).T)
        assert pos_err.max() < 1.5


def test_static_target_speed_near_zero_heading_unobservable():
    """A static target: V̂ → ~0 (the reported speed is a non-negative estimate of a zero mean
    quantity: below 0.15 m/s after 100 s), heading unobservable: σ_θ stays large (> 0.5 rad),
    position averages the noise (RMSE < 0.2 m vs σ√2 = 0.45 m raw)."""
    truth = truth_eq32(300, 1.0, 0.0, 0.0)
    for seed in SEEDS:
        x, P, _, _ = run_tracker(truth, measure(truth, seed))
        assert np.all(x[:, 3] >= 0.0)
        assert np.max(x[100:, 3]) < 0.15
        assert np.min(np.sqrt(P[100:, 2, 2])) > 0.5
        assert np.sqrt(np.mean(np.sum((x[100:, :2] - truth[100:, 1:3]) ** 2, axis=1))) < 0.2


def test_course_crossing_pi_keeps_tracking():
    """Course turning through θ = ±π (heading 2.9 rad, ω = 0.03 rad/s) and a straight run along
    θ = π with noise flipping the sign of θ each step: heading error stays small (course RMSE
    < 0.05 rad after 20 s), estimates stay wrapped and the position never jumps."""
    for truth in (truth_eq32(120, 1.0, 1.5, 0.03, heading0=2.9), truth_eq32(120, 1.0, 1.5, 0.0, heading0=math.pi)):
        for seed in SEEDS:
            x, _, _, _ = run_tracker(truth, measure(truth, seed))
            assert np.sqrt(np.mean(wrap(x[20:, 2] - truth[20:, 3]) ** 2)) < 0.05
            assert np.max(np.abs(wrap(x[20:, 2] - truth[20:, 3]))) < 0.25
            assert np.all(np.abs(x[:, 2]) <= math.pi)
            assert np.max(np.hypot(*(x[10:, :2] - truth[10:, 1:3]).T)) < 1.0


# --------------------------------------------------------------------------- consistency (NEES)
def _bank_run(truth_states, z, times, config=IMMConfig()):
    """Run one bank over N tracks (seeds); returns per-step NEES arrays (T, N) for position, θ, V."""
    n, steps = z.shape[:2]
    bank = IMMBank(config)
    for i in range(n):
        bank.add_track(z[i, 0], times[0])
    nees_pos, nees_th, nees_v = (np.full((steps, n), np.nan) for _ in range(3))
    for k in range(1, steps):
        bank.update(z[:, k], times[k])
        x, P = bank.states, bank.state_covariances
        e = x - truth_states[:, k]
        e[:, 2] = wrap(e[:, 2])
        nees_pos[k] = np.einsum("ni,nij,nj->n", e[:, :2], np.linalg.inv(P[:, :2, :2]), e[:, :2])
        nees_th[k] = e[:, 2] ** 2 / P[:, 2, 2]
        nees_v[k] = e[:, 3] ** 2 / P[:, 3, 3]
    return nees_pos, nees_th, nees_v


def _band(dof, n_runs, p=0.95):
    """Two-sided chi-square band of the ANEES of n_runs independent runs (Bar-Shalom et al.)."""
    a = (1 - p) / 2
    return chi2.ppf(a, dof * n_runs) / n_runs, chi2.ppf(1 - a, dof * n_runs) / n_runs


@pytest.mark.parametrize("omega", [0.0, 0.03])
def test_nees_consistent_on_its_own_process_model(omega):
    """Truth from the filter's own process (thesis eq. 3.3 with Q_θ, Q_V random walks, ω on a
    model), N = 100 seeds: the position ANEES (steps 50–150) lies in the 95 % chi-square band of
    100 runs [1.62, 2.41] and so does the speed's (1 dof, [0.74, 1.29]). The heading is
    conservative (ANEES ≈ 0.2 ≪ 1): the combined P_θθ carries the spread of the models' courses,
    which the Euler model cannot resolve within a step (ω_j enters position one step later)."""
    cfg = IMMConfig()
    n, steps = 100, 150
    rng = np.random.default_rng(7)
    s = np.zeros((n, steps, 4))
    s[:, 0] = [0.0, 0.0, 0.3, 1.5]
    for k in range(1, steps):
        p = s[:, k - 1]
        s[:, k, 0] = p[:, 0] + p[:, 3] * np.cos(p[:, 2])
        s[:, k, 1] = p[:, 1] + p[:, 3] * np.sin(p[:, 2])
        s[:, k, 2] = p[:, 2] + omega + rng.normal(0, math.sqrt(cfg.heading_noise_rad2_s), n)
        s[:, k, 3] = p[:, 3] + rng.normal(0, math.sqrt(cfg.speed_noise_m2_s3), n)
    z = s[:, :, :2] + rng.normal(0, SIGMA, (n, steps, 2))
    nees_pos, nees_th, nees_v = _bank_run(s, z, np.arange(steps, dtype=float), cfg)
    lo2, hi2 = _band(2, n)
    lo1, hi1 = _band(1, n)
    anees_pos = nees_pos[50:].mean()
    assert lo2 < anees_pos < hi2, anees_pos
    assert lo1 < nees_v[50:].mean() < hi1
    assert nees_th[50:].mean() < hi1  # conservative, never over-confident


def test_nees_on_thesis_truth_not_overconfident():
    """Deterministic thesis eq. 3.2 truth (no process noise, constant V and ω = 0.03): the filter
    can only be conservative; position ANEES ≈ 1.4 — below the band, never above it."""
    n, steps = 60, 150
    truth = truth_eq32(steps, 1.0, 1.5, 0.03)
    states = np.broadcast_to(truth[:, 1:5], (n, steps, 4))
    z = states[:, :, :2] + np.random.default_rng(11).normal(0, SIGMA, (n, steps, 2))
    nees_pos, _, _ = _bank_run(states, z, truth[:, 0])
    lo2, hi2 = _band(2, n)
    assert 1.0 < nees_pos[50:].mean() < hi2


# --------------------------------------------------------------------------- robustness
def test_nan_and_outlier_are_rejected_and_logged(caplog):
    truth = truth_eq32(60, 1.0, 1.5, 0.0)
    z = measure(truth, 0)
    trk = IMMTracker()
    for k in range(40):
        assert trk.update(z[k], truth[k, 0])
    before = trk.state
    with caplog.at_level(logging.DEBUG, logger="mjasc.perception.imm"):
        assert not trk.update([np.nan, 1.0], 40.0)
        assert "not finite" in trk.last_rejection_reason
        assert not trk.update([1e6, -1e6], 41.0)
        assert "gate" in trk.last_rejection_reason
    assert sum("rejected" in r.message for r in caplog.records) == 2
    # it coasted 2 s along the track, then keeps tracking
    coast = before[:2] + 2.0 * before[3] * np.array([np.cos(before[2]), np.sin(before[2])])
    np.testing.assert_allclose(trk.position, coast, atol=0.05)  # ω̂ ≠ 0 bends it by ~1 cm
    for k in range(42, 60):
        assert trk.update(z[k], truth[k, 0])
        assert trk.last_rejection_reason == ""
    assert np.hypot(*(trk.position - truth[-1, 1:3])) < 0.6


def test_bad_calls_raise_value_error():
    trk = IMMTracker()
    with pytest.raises(ValueError, match="z"):
        trk.update([1.0, 2.0, 3.0], 0.0)
    with pytest.raises(ValueError, match="first measurement"):
        _ = trk.position
    assert not trk.update([np.nan, 0.0], 0.0) and not trk.initialized
    trk.update([0.0, 0.0], 5.0)
    with pytest.raises(ValueError, match="t_s"):
        trk.update([0.0, 0.0], 4.0)
    with pytest.raises(ValueError, match="t_s"):
        trk.update([0.0, 0.0], float("nan"))


def test_track_restarts_after_consecutive_gated_measurements():
    """The target jumps 100 m (e.g. a mis-association upstream): five measurements are gated,
    the fifth restarts the track there, which then converges again."""
    truth = truth_eq32(80, 1.0, 1.5, 0.0)
    z = measure(truth, 1)
    z[40:] += [100.0, 0.0]
    trk = IMMTracker()
    used = [trk.update(z[k], truth[k, 0]) for k in range(80)]
    assert used[:40] == [True] * 40 and used[40:44] == [False] * 4 and used[44]
    assert np.hypot(*(trk.position - (truth[-1, 1:3] + [100.0, 0.0]))) < 0.6
    assert abs(trk.speed - 1.5) < 0.15


def test_speed_never_negative_and_flip_keeps_velocity():
    """Negative speed after an update is re-parametrized (θ + π, −V): the same velocity vector and
    covariance (up to the V sign) as the plain Kalman update, course re-charted next to the one
    before. One compiled cycle with Ts = 0 (no motion, no mixing) against the closed form."""
    from mjasc.perception.imm.compiled_cycle import imm_cycle

    s = np.array([[[1.0, 2.0, 0.4, 0.05], [0.0, 0.0, 1.0, 0.7]]])
    P = np.tile(np.eye(4) + 0.1, (1, 2, 1, 1))
    z, var = np.array([[-4.0, -3.0]]), 0.1
    out = (np.zeros((1, 2, 4)), np.zeros((1, 2, 4, 4)), np.zeros((1, 2)), np.zeros((1, 4)), np.zeros(1))
    imm_cycle(s, P, np.array([[0.5, 0.5]]), np.eye(2)[None], np.zeros(1), np.zeros((1, 2)), np.zeros((1, 2)),
              z, np.array([var]), np.ones(1, dtype=bool), 1e-3, np.inf, *out)
    su, Pu = out[0][0], out[1][0]
    H = np.eye(2, 4)
    refs = []
    for j in range(2):  # the plain update, then the velocity it gives
        S = H @ P[0, j] @ H.T + var * np.eye(2)
        K = P[0, j] @ H.T @ np.linalg.inv(S)
        x_ref = s[0, j] + K @ (z[0] - s[0, j, :2])
        P_ref = P[0, j] - K @ H @ P[0, j]
        refs.append(x_ref)
        v_ref = x_ref[3] * np.array([np.cos(x_ref[2]), np.sin(x_ref[2])])
        np.testing.assert_allclose(su[j, 3] * np.array([np.cos(su[j, 2]), np.sin(su[j, 2])]), v_ref, atol=1e-14)
        sign = np.diag([1.0, 1.0, 1.0, -1.0 if x_ref[3] < 0 else 1.0])
        np.testing.assert_allclose(Pu[j], sign @ P_ref @ sign, atol=1e-14)
    assert refs[0][3] < 0 < refs[1][3]  # model 0 came out negative, model 1 did not
    assert abs(wrap(su[0, 2] - refs[0][2] - math.pi)) < 1e-12 and abs(su[1, 2] - refs[1][2]) < 1e-14
    assert abs(su[0, 2] - 0.4) <= math.pi + 1e-12  # re-charted next to the course before
    assert np.all(su[:, 3] >= 0)


# --------------------------------------------------------------------------- reference: filterpy
class _FlooredIMM:
    """filterpy's IMMEstimator with the thesis's probability floor applied after each update."""

    def __init__(self, imm, floor):
        self.imm, self.floor = imm, floor

    def step(self, z):
        imm = self.imm
        imm.predict()
        imm.update(z)
        mu = np.maximum(imm.mu, self.floor)
        imm.mu = mu / mu.sum()
        imm._compute_mixing_probabilities()
        imm._compute_state_estimate()


@pytest.mark.parametrize("floor", [0.0, 2e-3])
def test_same_estimates_as_filterpy_imm_estimator(floor):
    """Same 7-model bank in filterpy (KalmanFilter subclasses with the EKF predict of eq. 3.3):
    identical estimates to rounding. The course turns through ±π (filterpy never wraps, so its
    plain mixing sees no discontinuity) and ω switches so all models matter; no gate."""
    cfg = IMMConfig(min_mode_probability=floor, gate_probability=1.0)
    truth = truth_eq32(120, 1.0, 1.5, lambda t: 0.03 if t < 60 else -0.02, heading0=2.9)
    for seed in range(3):
        z = measure(truth, seed)
        trk = IMMTracker(cfg)
        k = 0
        while not trk.velocity_initialized:
            trk.update(z[k], truth[k, 0])
            k += 1
        ref = _FlooredIMM(filterpy_imm(cfg, trk.state, trk.state_covariance, 1.0, trk.mode_probabilities), floor)
        worst = 0.0
        for j in range(k, len(truth)):
            trk.update(z[j], truth[j, 0])
            ref.step(z[j])
            d = ref.imm.x[:, 0] - trk.state
            d[2] = wrap(d[2])
            worst = max(
                worst,
                np.abs(d).max(),
                np.abs(ref.imm.P - trk.state_covariance).max(),
                np.abs(ref.imm.mu - trk.mode_probabilities).max(),
            )
        assert worst < 1e-9, worst


# --------------------------------------------------------------------------- the batched bank
def test_bank_equals_separate_trackers():
    """Tracks started at different times, with per-track times, missed detections (mask), NaN rows
    and an outlier: the bank's results equal those of separate IMMTrackers to rounding."""
    n, steps = 6, 70
    rng = np.random.default_rng(5)
    truths = [truth_eq32(steps, 1.0, 0.5 + 0.4 * i, 0.01 * (i - 2), heading0=0.5 * i) for i in range(n)]
    z = np.stack([measure(tr, 100 + i) for i, tr in enumerate(truths)])
    jitter = rng.uniform(0.0, 0.3, (n, steps))  # per-track measurement times
    times = np.arange(steps)[None, :] + jitter
    start = [0, 0, 3, 5, 5, 9]
    mask = rng.random((n, steps)) > 0.15
    z[2, 30] = np.nan
    z[4, 40] += 50.0
    bank = IMMBank()
    trackers = [IMMTracker() for _ in range(n)]
    rows = {}
    for k in range(steps):
        # start tracks whose first step is k
        for i in range(n):
            if start[i] == k:
                rows[i] = bank.add_track(z[i, k], times[i, k], track_id=10 + i)
                trackers[i].update(z[i, k], times[i, k])
        active = [i for i in range(n) if start[i] < k]
        if not active or len(rows) != len(bank):
            continue
        order = [int(tid) - 10 for tid in bank.track_ids]
        if any(start[i] >= k for i in order):
            continue
        zk = z[order, k]
        used = bank.update(zk, times[order, k], mask[order, k])
        for r_, i in enumerate(order):
            if mask[i, k]:
                assert used[r_] == trackers[i].update(z[i, k], times[i, k])
            else:
                trackers[i].predict(times[i, k])
        np.testing.assert_allclose(bank.states, [trackers[i].state for i in order], atol=1e-10)
        np.testing.assert_allclose(
            bank.state_covariances, [trackers[i].state_covariance for i in order], atol=1e-10
        )
        np.testing.assert_allclose(
            bank.mode_probabilities, [trackers[i].mode_probabilities for i in order], atol=1e-10
        )
    assert bank.rejection_codes.dtype == np.int8


def test_update_rows_cycles_only_those_rows_with_the_configs_variance():
    """update_rows without a measurement variance (the config's σ²): the rows given get the cycle
    a bank of their own gives them, bit for bit; the other rows are untouched."""
    z0 = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 20.0]])
    vel = np.array([[0.5, 0.0], [0.0, 0.5], [0.3, 0.3]])
    bank, alone = IMMBank(), IMMBank()
    bank.add_tracks(z0, 0.0)
    alone.add_tracks(z0[[1, 2]], 0.0)
    for t in (1.0, 2.0, 3.0, 4.0):
        bank.update(z0 + t * vel, t)
        alone.update((z0 + t * vel)[[1, 2]], t)
    before = bank.states.copy()
    z = (z0 + 5.0 * vel)[[1, 2]]
    used = bank.update_rows(np.array([1, 2]), z, 5.0)
    alone.update(z, 5.0)
    assert used.tolist() == [True, True]
    np.testing.assert_array_equal(bank.states[0], before[0])
    np.testing.assert_array_equal(bank.states[1:], alone.states)
    np.testing.assert_array_equal(bank.mode_probabilities[1:], alone.mode_probabilities)


def test_bank_track_list_gating_and_estimates():
    bank = IMMBank()
    truth_a = truth_eq32(30, 1.0, 1.5, 0.0)
    truth_b = truth_eq32(30, 1.0, 1.0, 0.03, heading0=2.0, start=(50.0, 0.0))
    za, zb = measure(truth_a, 1), measure(truth_b, 2)
    a = bank.add_track(za[0], 0.0)
    b = bank.add_track(zb[0], 0.0)
    with pytest.raises(ValueError, match="track_id"):
        bank.add_track(za[0], 0.0, track_id=a)
    for k in range(1, 29):
        assert bank.update(np.stack([za[k], zb[k]]), float(k)).all()
    # association helpers at the next time: each detection is inside its own track's gate only
    dets = np.stack([zb[29], za[29], [1e3, 1e3], [np.nan, 0.0]])
    d2 = bank.mahalanobis_squared(dets, 29.0)
    assert d2.shape == (2, 4) and np.isinf(d2[:, 3]).all()
    np.testing.assert_array_equal(bank.gate(dets, 29.0), [[False, True, False, False], [True, False, False, False]])
    ll = bank.log_likelihoods(dets, 29.0)
    assert ll[0, 1] > ll[0, 0] and ll[1, 0] > ll[1, 1] and ll[0, 3] == -np.inf
    zhat, S = bank.predicted_measurements(29.0)
    assert zhat.shape == (2, 2) and S.shape == (2, 2, 2)
    assert np.all(np.linalg.eigvalsh(S) > 0.1 - 1e-12)  # ≥ R
    assert bank.times_s.tolist() == [28.0, 28.0]  # the helpers do not change the bank
    # coasting grows the position uncertainty
    p0 = bank.position_covariances.copy()
    bank.predict(35.0)
    assert np.all(np.linalg.eigvalsh(bank.position_covariances) > np.linalg.eigvalsh(p0))
    ests = bank.estimates(radius_m={a: 2.5})
    assert isinstance(ests[0], TrackEstimate) and ests[0].radius_m == 2.5 and ests[1].radius_m == 0.0
    assert ests[1].time_s == 35.0 and ests[1].speed_m_s == pytest.approx(bank.speeds[1])
    np.testing.assert_allclose(ests[0].predict_positions(np.array([35.0]))[0], bank.positions[0])
    bank.remove_track(a)
    assert bank.track_ids.tolist() == [b] and len(bank) == 1
    with pytest.raises(ValueError, match="track_id"):
        bank.remove_track(a)


def test_association_helpers_at_a_common_time_with_a_start_up_track():
    """Every track's last cycle at one time and one track still in its start-up filter: the helpers
    at a scalar time predict that track with the common step (benchmarks/bench_perception.py called
    predicted_measurements so and crashed: the common-time path builds no per-track steps)."""
    bank = IMMBank()
    bank.add_track([0.0, 0.0], 0.0)
    assert not bank.velocity_initialized[0]
    zhat, S = bank.predicted_measurements(0.2)
    np.testing.assert_allclose(zhat, [[0.0, 0.0]])
    assert np.all(np.linalg.eigvalsh(S) > 0.1)
    assert bank.mahalanobis_squared([[0.1, 0.0]], 0.2).shape == (1, 1)
    assert np.isfinite(bank.log_likelihoods([[0.1, 0.0]], 0.2)).all()
    zj, Sj, w = bank.predictive_models(0.2)
    assert zj.shape == (1, 7, 2) and Sj.shape == (1, 7, 2, 2) and np.allclose(w, 1 / 7)


def test_filterpy_reference_tracker_matches_imm_tracker():
    """The filterpy-built reference as a tracker (same start-up, then filterpy's IMMEstimator): the
    same estimates as IMMTracker without floor and gate, through the same update/estimate calls."""
    from mjasc.perception.imm.filterpy_reference import FilterpyIMMTracker

    cfg = IMMConfig(min_mode_probability=0.0, gate_probability=1.0)
    truth = truth_eq32(60, 1.0, 1.5, 0.03)
    z = measure(truth, 7)
    mine, ref = IMMTracker(cfg), FilterpyIMMTracker(cfg, dt_s=1.0)
    for k in range(60):
        assert mine.update(z[k], truth[k, 0]) and ref.update(z[k], truth[k, 0])
    assert ref.velocity_initialized and ref.imm is not None
    np.testing.assert_allclose(ref.state, mine.state, atol=1e-9)
    np.testing.assert_allclose(ref.state_covariance, mine.state_covariance, atol=1e-9)
    a, b = ref.estimate(3, 2.0), mine.estimate(3, 2.0)
    assert a.track_id == b.track_id == 3 and a.time_s == b.time_s
    assert abs(a.turn_rate_rad_s - b.turn_rate_rad_s) < 1e-9
    with pytest.raises(ValueError, match="fixed sample time"):
        ref.update(z[0], truth[-1, 0] + 0.5)


def test_predict_then_update_at_same_time_equals_update():
    """Ts = 0 mixes nothing and predicts nothing: predict(t); update(z, t) == update(z, t)."""
    truth = truth_eq32(40, 1.0, 1.5, 0.03)
    z = measure(truth, 3)
    t1, t2 = IMMTracker(), IMMTracker()
    for k in range(40):
        t1.update(z[k], truth[k, 0])
        t2.predict(truth[k, 0])
        t2.update(z[k], truth[k, 0])
    np.testing.assert_allclose(t1.state, t2.state, atol=1e-12)
    np.testing.assert_allclose(t1.state_covariance, t2.state_covariance, atol=1e-12)
    np.testing.assert_allclose(t1.mode_probabilities, t2.mode_probabilities, atol=1e-12)


def test_bank_resized_between_cycles_equals_separate_trackers():
    """Tracks added and removed between cycles (the bank's work buffers are rebuilt for each new
    size) and a predict between updates: every track still equals its own IMMTracker to rounding."""
    steps = 60
    truths = [truth_eq32(steps, 1.0, 1.0 + 0.3 * i, 0.02 * (i - 1), heading0=0.7 * i) for i in range(3)]
    z = np.stack([measure(tr, 40 + i) for i, tr in enumerate(truths)])
    bank = IMMBank()
    trackers = {}
    for k in range(steps):
        t = float(k)
        if k in (0, 15):  # start tracks 0, 1 at 0 s and track 2 at 15 s
            for i in (0, 1) if k == 0 else (2,):
                bank.add_track(z[i, k], t, track_id=i)
                trackers[i] = IMMTracker()
                trackers[i].update(z[i, k], t)
            continue
        if k == 40:
            bank.remove_track(1)
            del trackers[1]
        if k == 30:
            bank.predict(t - 0.5)
            for trk in trackers.values():
                trk.predict(t - 0.5)
        order = bank.track_ids.tolist()
        assert bank.update(z[order, k], t).all()
        for i in order:
            assert trackers[i].update(z[i, k], t)
        np.testing.assert_allclose(bank.states, [trackers[i].state for i in order], atol=1e-10)
        np.testing.assert_allclose(bank.mode_probabilities, [trackers[i].mode_probabilities for i in order], atol=1e-10)
        np.testing.assert_allclose(
            bank.state_covariances, [trackers[i].state_covariance for i in order], atol=1e-10
        )
