"""Tests for mjasc.cooperation.comms: the broadcast link's loss and delay statistics against its stated model,
arrival order, determinism per seed, the range cut-off and input validation."""

import numpy as np
import pytest

from mjasc.cooperation.comms import PRESETS, CommsNetwork, NetworkConfig, parse_network_options
from mjasc.runs.scenario import ScenarioError, parse_scenario


def _pump(cfg, distances, n, seed=0, period_s=0.1):
    """Sender at the origin broadcasts n messages; receivers r0, r1, … sit at the given distances
    on the x axis and poll right after each send and once at the end. Returns the network and the
    messages each receiver got."""
    names = ["tx"] + [f"r{k}" for k in range(len(distances))]
    net = CommsNetwork(names, cfg, np.random.default_rng(seed))
    got = {r: [] for r in names[1:]}
    for i in range(n):
        t = i * period_s
        net.send(t, "tx", {"i": i}, [0.0, 0.0])
        for r, d in zip(names[1:], distances):
            got[r].extend(net.receive(t, r, [d, 0.0]))
    t_end = n * period_s + 1e3
    for r, d in zip(names[1:], distances):
        got[r].extend(net.receive(t_end, r, [d, 0.0]))
    return net, got


def test_loss_model_closed_form():
    cfg = NetworkConfig(range_m=400.0, loss_probability=0.1, loss_exponent=2.0)
    # p(d) = p0 + (1 − p0)(d/R)^n, 1 at and beyond R
    np.testing.assert_allclose(cfg.loss_at([0.0, 200.0, 399.999, 400.0, 1e4]),
                               [0.1, 0.1 + 0.9 * 0.25, 0.1 + 0.9 * (399.999 / 400) ** 2, 1.0, 1.0])
    assert cfg.mean_delay_at(0.0) == pytest.approx(0.02 + 0.005)


def test_loss_rate_matches_model_over_many_messages():
    cfg = NetworkConfig(range_m=400.0, loss_probability=0.1, loss_exponent=2.0)
    distances = [10.0, 200.0, 350.0]
    n = 10_000
    net, got = _pump(cfg, distances, n, seed=3)
    for k, d in enumerate(distances):
        p = float(cfg.loss_at(d))
        s = net.stats(f"r{k}")
        assert s["offered"] == n
        assert s["delivered"] + s["lost"] == n == len(got[f"r{k}"]) + s["lost"]
        se = np.sqrt(p * (1 - p) / n)
        assert abs(s["loss_rate"] - p) < 4 * se, (d, s["loss_rate"], p)


def test_delay_statistics_match_model():
    # Acoustic preset: the propagation term is visible (750 m at 1500 m/s = 0.5 s).
    cfg = PRESETS["acoustic"]
    d = 750.0
    net, got = _pump(cfg, [d], 8000, seed=5)
    delays = np.array([m.delay_s for m in got["r0"]])
    lo = cfg.base_delay_s + d / cfg.propagation_speed_m_s
    assert delays.min() >= lo - 1e-12 and delays.max() <= lo + cfg.jitter_s + 1e-12
    # jitter ~ U(0, J): mean lo + J/2, std J/√12
    se = cfg.jitter_s / np.sqrt(12 * len(delays))
    assert delays.mean() == pytest.approx(float(cfg.mean_delay_at(d)), abs=4 * se)
    assert delays.std() == pytest.approx(cfg.jitter_s / np.sqrt(12), rel=0.05)
    assert net.stats("r0")["mean_delay_s"] == pytest.approx(delays.mean())
    # radio: the speed of light adds nothing measurable
    assert float(PRESETS["radio"].mean_delay_at(500.0)) == pytest.approx(0.025, abs=1e-5)


def test_messages_arrive_in_time_order_and_never_early():
    # Jitter (2 s) much larger than the send interval (0.1 s): messages overtake each other.
    cfg = NetworkConfig(base_delay_s=0.5, jitter_s=2.0)
    net = CommsNetwork(["a", "b"], cfg, np.random.default_rng(1))
    got, polls = [], []
    for i in range(500):
        t = 0.1 * i
        net.send(t, "a", {"i": i}, [0, 0])
        if i % 3 == 0:  # the receiver polls less often than the sender sends
            msgs = net.receive(t, "b", [5, 0])
            polls.extend([t] * len(msgs))
            got.extend(msgs)
    arrivals = np.array([m.received_time_s for m in got])
    assert np.all(np.diff(arrivals) >= 0)  # time order across successive polls
    assert np.all(arrivals <= np.array(polls) + 1e-12)  # nothing delivered before it arrived
    sent_order = np.array([m.payload["i"] for m in got])
    assert np.any(np.diff(sent_order) < 0)  # ... and the jitter did reorder them
    assert all(m.received_time_s - m.sent_time_s >= 0.5 for m in got)


def test_broadcast_reaches_every_other_member_not_the_sender():
    net = CommsNetwork(["a", "b", "c"], NetworkConfig(jitter_s=0.0), np.random.default_rng(0))
    payload = {"x": np.array([1.0, 2.0])}
    net.send(0.0, "a", payload, [0, 0])
    payload["x"][0] = 99.0  # the sender's later changes do not reach the receivers
    assert net.receive(0.01, "b", [1, 0]) == []  # 20 ms latency: not there yet
    mb = net.receive(1.0, "b", [1, 0])
    mc = net.receive(1.0, "c", [0, 1])
    assert net.receive(1.0, "a", [0, 0]) == []
    assert [m.sender for m in mb] == ["a"] and [m.sender for m in mc] == ["a"]
    assert mb[0].payload["x"][0] == 1.0
    mb[0].payload["x"][1] = -5.0  # each receiver has its own copy
    assert mc[0].payload["x"][1] == 2.0
    assert mb[0].received_time_s == pytest.approx(0.02 + 1 / 3e8)
    assert net.receive(2.0, "b", [1, 0]) == []  # delivered once
    s = net.stats()
    assert (s["sent"], s["offered"], s["delivered"], s["lost"]) == (1, 2, 2, 0)


def test_deterministic_per_seed():
    cfg = NetworkConfig(loss_probability=0.3, jitter_s=0.5)

    def run(seed):
        _, got = _pump(cfg, [50.0, 120.0], 300, seed=seed)
        return [(r, m.payload["i"], m.received_time_s) for r in got for m in got[r]]

    assert run(4) == run(4)
    assert run(4) != run(5)


def test_range_cut_off():
    cfg = NetworkConfig(range_m=100.0, loss_probability=0.0, loss_exponent=8.0)
    net, got = _pump(cfg, [99.0, 100.0, 150.0], 2000, seed=2)
    assert len(got["r1"]) == 0 and len(got["r2"]) == 0
    assert net.stats("r1")["lost_out_of_range"] == 2000 == net.stats("r2")["lost_out_of_range"]
    p = float(cfg.loss_at(99.0))  # 0.99^8 ≈ 0.92 lost just inside
    assert net.stats("r0")["loss_rate"] == pytest.approx(p, abs=0.03)
    assert net.stats("r0")["lost_out_of_range"] == 0


def test_parse_network_options_and_presets():
    assert parse_network_options({}, "comms") == PRESETS["radio"] == NetworkConfig()
    cfg = parse_network_options({"preset": "acoustic", "range_m": 800}, "comms")
    assert cfg.range_m == 800.0 and cfg.propagation_speed_m_s == 1500.0
    for table, msg in [({"range_m": 0}, "comms.range_m: must be > 0"),
                       ({"loss_probability": 1.5}, "comms.loss_probability: must be ≤ 1"),
                       ({"jitter_s": -1}, "comms.jitter_s: must be ≥ 0"),
                       ({"base_delay_s": "fast"}, "comms.base_delay_s: must be a number"),
                       ({"preset": "laser"}, "comms.preset: must be one of"),
                       ({"rang_m": 3}, "comms.rang_m: unknown field")]:
        with pytest.raises(ValueError, match=msg.replace("(", r"\(")):
            parse_network_options(table, "comms")


def test_scenario_comms_table():
    base = {"duration_s": 1.0, "vessels": [{"name": "a", "type": "delfim", "comms": {}}]}
    sc = parse_scenario({**base, "comms": {"loss_probability": 0.2}})
    assert isinstance(sc.comms, NetworkConfig) and sc.comms.loss_probability == 0.2
    with pytest.raises(ScenarioError, match=r"comms\.range_m: must be > 0"):
        parse_scenario({**base, "comms": {"range_m": -5.0}})


def test_bad_use_raises():
    net = CommsNetwork(["a", "b"], None, np.random.default_rng(0))
    with pytest.raises(ValueError, match="comms.sender: 'z' is not a team member"):
        net.send(0.0, "z", {}, [0, 0])
    with pytest.raises(ValueError, match="comms.receiver"):
        net.receive(0.0, "z", [0, 0])
    net.send(1.0, "a", {}, [0, 0])
    with pytest.raises(ValueError, match="time must not go backwards"):
        net.send(0.5, "b", {}, [0, 0])
    with pytest.raises(ValueError, match="unique"):
        CommsNetwork(["a", "a"], None)


def test_long_runs_prune_the_log():
    net = CommsNetwork(["a", "b"], NetworkConfig(), np.random.default_rng(0))
    for i in range(3000):
        net.send(float(i), "a", {"i": i}, [0, 0])
        net.receive(float(i), "a", [0, 0])
        net.receive(float(i), "b", [1, 0])
    assert len(net._log) < 300
    assert net.stats("b")["delivered"] == 2999


def _round(cfg, names, rounds=200, seed=3):
    """Every member broadcasts once per round from 10 m apart; everyone polls after each round.
    Returns the network and {receiver: senders heard}."""
    net = CommsNetwork(names, cfg, np.random.default_rng(seed))
    heard = {r: set() for r in names}
    for i in range(rounds):
        t = float(i)
        for k, n in enumerate(names):
            net.send(t, n, {"i": i}, [10.0 * k, 0.0])
        for k, r in enumerate(names):
            heard[r] |= {m.sender for m in net.receive(t + 0.5, r, [10.0 * k, 0.0])}
    return net, heard


def test_topologies_decide_who_hears_whom():
    names = ["a", "b", "c", "d", "e"]
    _, ring = _round(NetworkConfig(topology="ring"), names)
    assert ring == {"a": {"b", "e"}, "b": {"a", "c"}, "c": {"b", "d"}, "d": {"c", "e"}, "e": {"d", "a"}}
    _, star = _round(NetworkConfig(topology="leader_followers", leader="c"), names)
    assert star["c"] == {"a", "b", "d", "e"} and all(star[r] == {"c"} for r in "abde")
    _, graph = _round(NetworkConfig(topology="graph", links=(("a", "b"), ("b", "e"))), names)
    assert graph == {"a": {"b"}, "b": {"a", "e"}, "c": set(), "d": set(), "e": {"b"}}
    _, everyone = _round(NetworkConfig(), names)
    assert all(everyone[r] == set(names) - {r} for r in names)


def test_link_matrix_counts_each_pair_and_adds_up_to_the_receivers_statistics():
    """Who heard whom: per (sender, receiver) offered = delivered + lost (nothing in flight after
    the last poll), the loss rate of each pair near its model's p(d), and the per-receiver totals."""
    cfg = NetworkConfig(range_m=100.0, loss_probability=0.2, loss_exponent=2.0)
    names = ["a", "b", "c"]
    net, _ = _round(cfg, names, rounds=2000)
    m = net.link_matrix()
    off, dlv, lost = (np.array(m[k]) for k in ("offered", "delivered", "lost"))
    assert m["team"] == names and m["topology"] == "all"
    np.testing.assert_array_equal(np.diag(off), 0)
    np.testing.assert_array_equal(off, dlv + lost)
    for j, r in enumerate(names):
        st = net.stats(r)
        assert off[:, j].sum() == st["offered"] and dlv[:, j].sum() == st["delivered"]
    # a–c are 20 m apart: p = 0.2 + 0.8 · 0.2² = 0.232 (3σ of a binomial over 2000 draws ≈ 0.028)
    assert lost[0, 2] / off[0, 2] == pytest.approx(0.232, abs=0.03)
    assert m["mean_delay_s"][0][1] == pytest.approx(cfg.mean_delay_at(10.0), abs=0.002)


def test_topology_errors_name_the_field():
    base = {"name": "t", "duration_s": 1.0, "vessels": [
        {"name": n, "type": "otter", "position_m": [10.0 * k, 0.0], "comms": {}} for k, n in enumerate("ab")]}
    for comms, match in [({"topology": "star"}, r"comms\.topology: must be one of"),
                         ({"topology": "graph"}, r"comms\.links: a graph topology needs links"),
                         ({"topology": "graph", "links": [["a", "z"]]}, r"comms\.links\[0\]: 'z' is not a team member"),
                         ({"topology": "graph", "links": [["a"]]}, r"comms\.links\[0\]: must be a pair"),
                         ({"topology": "leader_followers", "leader": "q"}, r"comms\.leader: 'q' is not a team member"),
                         # a key the topology would ignore (it was accepted and ignored silently)
                         ({"topology": "ring", "links": [["a", "b"]]}, r"comms\.links: only with topology = \"graph\""),
                         ({"links": [["a", "b"]]}, r"comms\.links: only with topology = \"graph\" \(the topology is 'all'"),
                         ({"leader": "b"}, r"comms\.leader: only with topology = \"leader_followers\"")]:
        with pytest.raises(ScenarioError, match=match):
            parse_scenario({**base, "comms": comms})


def test_a_comms_table_that_no_vessel_takes_part_in_is_refused():
    """A [comms] table configures the link the vessels' coordination talks over; without any vessel
    with a [vessels.comms] table nothing would ever be sent, so the table (a forgotten vessel table,
    most likely) is refused instead of accepted unused; with one vessel in the link it is fine."""
    vessels = [{"name": n, "type": "otter", "position_m": [10.0 * k, 0.0]} for k, n in enumerate("ab")]
    with pytest.raises(ScenarioError, match=r"^comms: no vessel takes part in the link"):
        parse_scenario({"name": "t", "duration_s": 1.0, "vessels": vessels, "comms": {"loss_probability": 0.1}})
    vessels[0]["comms"] = {}
    assert parse_scenario({"name": "t", "duration_s": 1.0, "vessels": vessels, "comms": {}}).comms is not None
