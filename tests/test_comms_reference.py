"""The link's plain-list log and tuple heaps against the per-message form it replaced (the
reference below: a log of message objects, a heap of Message objects per receiver), bit for bit:
the same deliveries in the same order, the same random draws, statistics, link matrix and outcomes."""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np
import pytest

from mjasc.cooperation.comms import CommsNetwork, LinkOutcome, Message, NetworkConfig
from mjasc.cooperation.link_records import LinkStats, copy_payload
from mjasc.cooperation.messages import TeamMessage


@dataclass
class _Sent:
    id: int
    time_s: float
    sender: str
    payload: dict
    position_m: np.ndarray


class _ReferenceNetwork:
    """The link as it was: one object per logged message and per pending delivery."""

    def __init__(self, team_names, config, rng):
        self.team = list(team_names)
        self.config, self.rng = config, rng
        self._log, self._base = [], 0
        self._cursor = {n: 0 for n in self.team}
        self._pending = {n: [] for n in self.team}
        self.sent = {n: 0 for n in self.team}
        self.link = {n: LinkStats() for n in self.team}
        self.hears = self.config.hears(self.team)
        self._everyone = all(len(h) == len(self.team) - 1 for h in self.hears.values())
        self._index = {n: k for k, n in enumerate(self.team)}
        n = len(self.team)
        self._pair_offered = np.zeros((n, n), dtype=np.int64)
        self._pair_delivered = np.zeros((n, n), dtype=np.int64)
        self._pair_delay_s = np.zeros((n, n))
        self._outcomes = []

    def send(self, t_s, sender, payload, sender_position):
        mid = self._base + len(self._log)
        self._log.append(_Sent(mid, float(t_s), sender, copy_payload(payload),
                               np.array(sender_position, dtype=float).reshape(-1)[:2]))
        self.sent[sender] += 1
        return mid

    def receive(self, t_s, receiver, receiver_position):
        log, heap = self._log, self._pending[receiver]
        k0 = self._cursor[receiver] - self._base
        k = k0
        while k < len(log) and log[k].time_s <= t_s:
            k += 1
        if k > k0:
            self._decide(receiver, log[k0:k], receiver_position)
            self._cursor[receiver] = self._base + k
            done = min(self._cursor.values()) - self._base
            if done > 256:
                del self._log[:done]
                self._base += done
        stats = self.link[receiver]
        out, senders, delays = [], [], []
        while heap and heap[0][0] <= t_s:
            msg = heapq.heappop(heap)[2]
            stats.delay_sum_s += msg.delay_s
            stats.delay_max_s = max(stats.delay_max_s, msg.delay_s)
            senders.append(self._index[msg.sender])
            delays.append(msg.delay_s)
            out.append(msg)
        stats.delivered += len(out)
        r = self._index[receiver]
        np.add.at(self._pair_delivered[:, r], senders, 1)
        np.add.at(self._pair_delay_s[:, r], senders, delays)
        return out

    def _decide(self, receiver, sent, receiver_position):
        if self._everyone:
            sent = [m for m in sent if m.sender != receiver]
        else:
            sent = [m for m in sent if m.sender in self.hears[receiver]]
        if not sent:
            return
        cfg, stats = self.config, self.link[receiver]
        pos = np.asarray(receiver_position, dtype=float).reshape(-1)
        from_xy = np.array([m.position_m for m in sent])
        d = np.hypot(from_xy[:, 0] - pos[0], from_xy[:, 1] - pos[1])
        u = self.rng.random((len(sent), 2))
        out_of_range = d >= cfg.range_m
        lost = out_of_range | (u[:, 0] < cfg.loss_at(d))
        times = np.array([m.time_s for m in sent])
        arrival = times + cfg.base_delay_s + d / cfg.propagation_speed_m_s + u[:, 1] * cfg.jitter_s
        stats.offered += len(sent)
        np.add.at(self._pair_offered[:, self._index[receiver]], [self._index[m.sender] for m in sent], 1)
        stats.lost += int(np.count_nonzero(lost))
        stats.lost_out_of_range += int(np.count_nonzero(out_of_range))
        self._outcomes += [LinkOutcome(m.sender, receiver, m.time_s, float("nan") if gone else a, gone)
                           for m, a, gone in zip(sent, arrival.tolist(), lost.tolist())]
        for m, a, gone in zip(sent, arrival.tolist(), lost.tolist()):
            if not gone:
                heapq.heappush(self._pending[receiver], (a, m.id, Message(m.sender, m.time_s, a, copy_payload(m.payload))))


def _check(got, want, shared=False):
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert (g.sender, g.sent_time_s, g.received_time_s) == (w.sender, w.sent_time_s, w.received_time_s)
        if isinstance(w.payload, dict):
            assert g.payload["k"] == w.payload["k"] and (shared or g.payload is not w.payload)
        else:
            assert g.payload is w.payload


def _same(a, b):
    return a == b or (a != a and b != b)


@pytest.mark.parametrize("cfg", [
    NetworkConfig(),
    NetworkConfig(range_m=120.0, loss_probability=0.2, loss_exponent=2.0, base_delay_s=0.3,
                  propagation_speed_m_s=1500.0, jitter_s=0.9),
    NetworkConfig(topology="ring", range_m=150.0, loss_probability=0.1, jitter_s=1.5),
    NetworkConfig(topology="leader_followers", leader="c", jitter_s=0.7, base_delay_s=0.2),
])
def test_link_matches_the_per_message_reference(cfg):
    team = ["a", "b", "c", "d", "e"]
    new = CommsNetwork(team, cfg, np.random.default_rng(7))
    new.keep_outcomes()
    ref = _ReferenceNetwork(team, cfg, np.random.default_rng(7))
    drive = np.random.default_rng(11)
    xy = drive.uniform(-80, 80, (len(team), 2))
    t, outcomes = 0.0, []
    for step in range(1500):
        t += float(drive.choice([0.0, 0.1, 0.1, 0.3]))
        xy += drive.normal(0, 1.0, xy.shape)
        i = int(drive.integers(len(team)))
        if drive.random() < 0.35:
            payload = (TeamMessage(team[i], xy[i].copy(), 0.0, np.zeros(2), 1.0) if drive.random() < 0.5
                       else {"k": step, "a": np.arange(3.0)})
            assert new.send(t, team[i], payload, xy[i]) == ref.send(t, team[i], payload, xy[i])
        elif drive.random() < 0.8:
            _check(new.receive(t, team[i], xy[i]), ref.receive(t, team[i], xy[i]))
        elif drive.random() < 0.5:  # a fleet's tick: everyone decided in one pass, then each delivered
            who = [team[j] for j in np.sort(drive.choice(len(team), int(drive.integers(1, len(team) + 1)), False))]
            where = [xy[team.index(n)] for n in who]
            new.decide_many(t, who, where)
            for n, p in zip(who, where):
                got = [Message(s, a, b, c) for s, a, b, c in new.receive_raw(t, n, p, decide=False)]
                _check(got, ref.receive(t, n, p), shared=True)
        else:  # a comms slot: each member sends, then polls; batched: all send, then one pass with limits
            limits = [new.send(t, n, {"k": -j}, xy[j]) + 1 for j, n in enumerate(team)]
            new.decide_many(t, team, list(xy), limits)
            for j, n in enumerate(team):
                ref.send(t, n, {"k": -j}, xy[j])
                got = [Message(s, a, b, c) for s, a, b, c in new.receive_raw(t, n, xy[j], decide=False)]
                _check(got, ref.receive(t, n, xy[j]), shared=True)
        outcomes += new.drain_outcomes()
    assert len(outcomes) == len(ref._outcomes)
    for g, w in zip(outcomes, ref._outcomes):
        assert (g.sender, g.receiver, g.sent_time_s, g.lost) == (w.sender, w.receiver, w.sent_time_s, w.lost)
        assert _same(g.arrival_time_s, w.arrival_time_s)
    for n in team:
        assert new.link[n].as_dict().keys() == ref.link[n].as_dict().keys()
        for key, value in ref.link[n].as_dict().items():
            assert _same(new.link[n].as_dict()[key], value), (n, key)
    assert np.array_equal(new._pair_offered, ref._pair_offered)
    assert np.array_equal(new._pair_delivered, ref._pair_delivered)
    assert np.array_equal(new._pair_delay_s, ref._pair_delay_s)
    assert new.rng.random() == ref.rng.random()
    assert new.stats()["offered"] > 100 and new.stats()["delivered"] > 50


def _receive_many_reference(net, t, receivers, positions, limits=None):
    """``CommsNetwork.receive_many`` as it was before its quiet-tick return: decide_many, then each
    receiver's due arrivals."""
    net.decide_many(t, receivers, positions, limits)
    return [() if not (p := net._pending[n]) or p[0][0] > t else net.receive_raw(t, n, None, False)
            for n in receivers]


@pytest.mark.parametrize("cfg", [
    NetworkConfig(),
    NetworkConfig(range_m=120.0, loss_probability=0.2, base_delay_s=0.3, jitter_s=0.9),
    NetworkConfig(topology="ring", range_m=150.0, loss_probability=0.1, jitter_s=1.5),
])
def test_receive_many_equals_deciding_and_delivering_on_quiet_and_busy_ticks(cfg):
    """A fleet's control ticks (most of them with nothing to decide or deliver: the early return)
    and comms slots (limits) through ``receive_many`` give what decide_many and the receivers'
    deliveries gave: the same arrivals, statistics, pair counts and random draws."""
    team = ["a", "b", "c", "d"]
    new, ref = (CommsNetwork(team, cfg, np.random.default_rng(3)) for _ in range(2))
    drive = np.random.default_rng(5)
    xy = drive.uniform(-80, 80, (len(team), 2))
    t, quiet, busy = 0.0, 0, 0
    for step in range(3000):
        t += 0.05
        xy += drive.normal(0, 0.5, xy.shape)
        if step % 20 == 0:  # a comms slot: everyone sends, then one pass with limits
            limits = [new.send(t, n, {"k": step}, xy[j]) + 1 for j, n in enumerate(team)]
            assert [ref.send(t, n, {"k": step}, xy[j]) + 1 for j, n in enumerate(team)] == limits
            got, want = new.receive_many(t, team, list(xy), limits), _receive_many_reference(ref, t, team, list(xy),
                                                                                            limits)
        elif drive.random() < 0.1:  # one receiver on its own (decides and delivers outside receive_many)
            j = int(drive.integers(len(team)))
            got, want = [new.receive_raw(t, team[j], xy[j])], [ref.receive_raw(t, team[j], xy[j])]
        else:  # a control tick: some receivers, every message sent by now
            who = [team[j] for j in np.sort(drive.choice(len(team), int(drive.integers(1, len(team) + 1)), False))]
            where = [xy[team.index(n)] for n in who]
            got, want = new.receive_many(t, who, where), _receive_many_reference(ref, t, who, where)
        assert len(got) == len(want)
        for g, w in zip(got, want):
            assert list(g) == list(w)
        if any(got):
            busy += 1
        else:
            quiet += 1
    assert quiet > 1000 and busy > 100
    for n in team:
        assert new.link[n].as_dict() == ref.link[n].as_dict()
    assert np.array_equal(new._pair_offered, ref._pair_offered)
    assert np.array_equal(new._pair_delivered, ref._pair_delivered)
    assert np.array_equal(new._pair_delay_s, ref._pair_delay_s)
    assert new.rng.random() == ref.rng.random()
    with pytest.raises(ValueError, match="not a team member"):
        new.receive_many(t + 100.0, ["a", "x"], [xy[0], xy[1]])
