"""The team's communication link: a broadcast medium with distance-dependent delay and loss.

The thesis's environment block adds "distance-dependent transmission delays and losses" to the
messages the agents exchange (docs/thesis.md §1); the coordination controller (``coordination.py``) sends
its path parameter over this link. Every message a vessel sends is broadcast to every other team
member; each (message, receiver) pair is decided independently:

* **loss** — with d the sender–receiver distance [m], R = ``range_m``, p₀ = ``loss_probability``
  and n = ``loss_exponent``::

      p(d) = p₀ + (1 − p₀) (d / R)^n     for d < R,         p(d) = 1   for d ≥ R

  (a floor p₀ near the sender, rising smoothly to certain loss at the range limit);
* **delay** — ``base_delay_s`` (modem / MAC / processing latency) plus propagation plus jitter::

      τ(d) = base_delay_s + d / propagation_speed_m_s + U(0, jitter_s)

  so the mean delay is ``base_delay_s + d/c + jitter_s/2``.

Presets: ``radio`` (default: a UHF/Wi-Fi class modem between surface craft — range 1000 m, 20 ms
latency, speed of light, 10 ms jitter, no loss floor) and ``acoustic`` (an underwater acoustic
modem — range 2000 m, 0.5 s latency, 1500 m/s, 0.2 s jitter, 5 % loss floor). Any field of the
``[comms]`` table overrides the preset.

When is a message decided? Lazily, at the receiver's first :meth:`CommsNetwork.receive` call at or
after the send time: d is then the distance from the sender's position at sending to the
receiver's position at that call (vessels move ~1 m per comms period; ranges are hundreds of
metres). The random draws (two uniforms per pair, from the generator passed in) happen in the
order of the calls, so a run is a pure function of its seed. Messages are returned in order of
arrival (``received_time_s``), which is non-decreasing over successive calls of one receiver.

**Topology.** Who can hear whom (``topology``): ``all`` (default: every team member hears every
other), ``ring`` (each hears its two neighbours in the team's order, the last closing the ring),
``leader_followers`` (the ``leader`` — default the first vessel — hears every follower, each
follower only the leader) or ``graph`` (the undirected ``links = [["a", "b"], ...]``). A message
is offered only to the members that can hear its sender; the range limit and the loss law still
decide each offered pair. With ``all`` the random draws are those of a plain broadcast.

**Who heard whom.** The link counts, per (sender, receiver), the messages offered, delivered and
lost and the delivered ones' delays (:meth:`CommsNetwork.link_matrix`; the run's summary has it).

**Outcomes.** For the recording, :meth:`CommsNetwork.keep_outcomes` makes the link keep every
decided (message, receiver) pair as a :class:`LinkOutcome` (delivered with its arrival time, or
lost) until :meth:`CommsNetwork.drain_outcomes` hands them over; it draws nothing and changes
nothing else (``mjasc.cooperation.recording`` draws them).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import is_dataclass

import numpy as np

from mjasc.cooperation.link_kernels import DELIVERED, LOST, UNSURE, decide_segments
from mjasc.cooperation.link_records import LinkOutcome, LinkStats, Message, copy_payload
from mjasc.cooperation.network_config import PRESETS, TOPOLOGIES, NetworkConfig, parse_network_options

__all__ = ["NetworkConfig", "Message", "LinkOutcome", "CommsNetwork", "parse_network_options", "PRESETS",
           "TOPOLOGIES"]

_FROZEN_PAYLOADS: set = set()  # frozen dataclass types sent before (checked once per type; shared, not copied)


class CommsNetwork:
    """Broadcast medium shared by a team. ``config`` None = the ``radio`` preset.

    ``send(t, sender, payload, sender_position)`` broadcasts; ``receive(t, receiver,
    receiver_position)`` returns the messages that have arrived for ``receiver`` by time ``t``
    (and not returned before), in arrival order. Send times must be non-decreasing.
    """

    def __init__(self, team_names, config: NetworkConfig | None = None, rng: np.random.Generator | None = None):
        self.team = list(team_names)
        if not self.team or len(set(self.team)) != len(self.team):
            raise ValueError(f"comms: team names must be non-empty and unique, got {self.team!r}")
        self.config = config if config is not None else NetworkConfig()
        if not isinstance(self.config, NetworkConfig):
            raise ValueError(f"comms: config must be a NetworkConfig or None, got {type(self.config).__name__}")
        self.rng = rng if rng is not None else np.random.default_rng(0)
        # the sent messages, as parallel lists (id − self._base is the position in each)
        self._log_time: list[float] = []
        self._log_sender: list[int] = []  # the sender's team index
        self._log_payload: list = []
        # the same messages as columns (x [m], y [m], send time [s], sender) for the compiled decision
        self._log_arr = np.empty((4, 64))
        self._base = 0  # id of the logs' first entry (pruned once every receiver has read past it)
        self._cursor = {n: 0 for n in self.team}  # next message id each receiver has not decided yet
        # per receiver: the pending (arrival, id, sender index, sent time, payload), sorted by (arrival, id)
        self._pending: dict[str, list] = {n: [] for n in self.team}
        # at most the earliest pending arrival of any receiver [s] (inf: none): lowered as messages are
        # decided, made exact again by receive_many (a delivery only raises the earliest)
        self._arrival_s = math.inf
        self._members = frozenset(self.team)
        self._last_send_s = -np.inf
        self._work = None  # the compiled decision's buffers (segments, counts, pairs, outcomes), grown when needed
        self._next_s = math.inf  # send time of the oldest message some receiver has not decided (inf: none)
        self.sent = {n: 0 for n in self.team}
        self.link = {n: LinkStats() for n in self.team}  # per receiver
        #: Changes with every change of a receiver's delivered or lost count (:meth:`counts`): the
        #: recording asks the counts only after it changed.
        self.count_changes = 0
        self.hears = self.config.hears(self.team)  # receiver → the senders it can hear
        self._everyone = all(len(h) == len(self.team) - 1 for h in self.hears.values())
        self._index = {n: k for k, n in enumerate(self.team)}
        n = len(self.team)
        # [receiver, sender] (n, n) bool: who can hear whom
        self._hears_matrix = np.array([[s in self.hears[r] for s in self.team] for r in self.team], dtype=bool)
        # who heard whom: (sender, receiver) counts and the delivered messages' summed delays
        self._pair_offered = np.zeros((n, n), dtype=np.int64)
        self._pair_delivered = np.zeros((n, n), dtype=np.int64)
        self._pair_delay_s = np.zeros((n, n))
        self._outcomes: list[LinkOutcome] | None = None  # kept only when asked (keep_outcomes)

    @property
    def _log(self) -> list[float]:
        """The send times of the messages still logged (not yet pruned)."""
        return self._log_time

    def keep_outcomes(self) -> None:
        """From now on keep each decided (message, receiver) pair for :meth:`drain_outcomes`."""
        if self._outcomes is None:
            self._outcomes = []

    def drain_outcomes(self) -> list[LinkOutcome]:
        """The outcomes decided since the last call (in the order decided); empty unless
        :meth:`keep_outcomes` was called."""
        out, self._outcomes = self._outcomes or [], ([] if self._outcomes is not None else None)
        return out

    def _member(self, name: str, role: str) -> None:
        if name not in self._cursor:
            raise ValueError(f"comms.{role}: {name!r} is not a team member ({', '.join(self.team)})")

    def send(self, t_s: float, sender: str, payload: dict, sender_position) -> int:
        """Broadcast ``payload`` from ``sender`` at time ``t_s`` [s], position (2,) world [m]. Returns its id."""
        if sender not in self._cursor:  # (_member's check without its call)
            self._member(sender, "sender")
        if t_s < self._last_send_s:
            raise ValueError(f"comms.send: time must not go backwards ({t_s} < {self._last_send_s})")
        shared = type(payload) in _FROZEN_PAYLOADS  # a frozen dataclass type seen before: shared as it is
        if not shared:
            if not (isinstance(payload, dict) or (is_dataclass(payload) and payload.__dataclass_params__.frozen)):
                raise ValueError("comms.send: payload must be a dict or a frozen dataclass, "
                                 f"got {type(payload).__name__}")
            if not isinstance(payload, dict):
                _FROZEN_PAYLOADS.add(type(payload))
        self._last_send_s = float(t_s)
        mid = self._base + len(self._log_time)
        if self._next_s == math.inf:  # (everything before was decided for everyone)
            self._next_s = self._last_send_s
        xy = sender_position
        if not (type(xy) is np.ndarray and xy.ndim == 1 and xy.dtype == np.float64):  # (a float vector as it is)
            xy = np.array(sender_position, dtype=float).reshape(-1)[:2]
        k, s = mid - self._base, self._index[sender]
        arr = self._log_arr
        if k == arr.shape[1]:
            arr = self._log_arr = np.concatenate([arr, np.empty_like(arr)], axis=1)
        arr[0, k], arr[1, k], arr[2, k], arr[3, k] = xy[0], xy[1], self._last_send_s, s
        self._log_time.append(self._last_send_s)
        self._log_sender.append(s)
        self._log_payload.append(payload if shared else copy_payload(payload))
        self.sent[sender] += 1
        return mid

    def receive(self, t_s: float, receiver: str, receiver_position) -> list[Message]:
        """Messages that reached ``receiver`` by ``t_s``, ordered by arrival time.

        The messages sent since the receiver's last call are decided together (distances, the
        two uniforms of each pair drawn in message order, loss and delay over arrays); a call
        with nothing new to decide or deliver costs a few dictionary look-ups."""
        return [Message(s, sent, arrived, copy_payload(payload))
                for s, sent, arrived, payload in self.receive_raw(t_s, receiver, receiver_position)]

    def receive_raw(self, t_s: float, receiver: str, receiver_position, decide: bool = True) -> list[tuple]:
        """:meth:`receive` as plain tuples ``(sender, sent time [s], arrival time [s],
        payload)``, the payload the sender's (not the receiver's copy: a dict payload
        must not be changed; a typed message is immutable anyway). The same decisions, draws and
        statistics as :meth:`receive`. ``decide=False``: deliver only what is decided already (by
        :meth:`decide_many`), deciding nothing new."""
        cursor = self._cursor.get(receiver)
        if cursor is None:
            self._member(receiver, "receiver")
        times, pending = self._log_time, self._pending[receiver]
        k0 = cursor - self._base
        if decide and k0 < len(times) and times[k0] <= t_s:
            self.decide_many(t_s, (receiver,), (receiver_position,))
        if not pending or pending[0][0] > t_s:
            return []
        k = bisect_right(pending, (t_s, math.inf))  # those arrived by t_s (sorted by arrival, id)
        arrived = pending[:k]
        del pending[:k]
        stats = self.link[receiver]
        team = self.team
        senders = [item[2] for item in arrived]
        delays = [item[0] - item[3] for item in arrived]
        delay_sum, delay_max = stats.delay_sum_s, stats.delay_max_s
        for delay in delays:  # in arrival order, as the running sums always were
            delay_sum += delay
            delay_max = max(delay_max, delay)
        stats.delivered += k
        self.count_changes += 1
        stats.delay_sum_s, stats.delay_max_s = delay_sum, delay_max
        out = [(team[s], sent, a, payload) for a, _, s, sent, payload in arrived]
        # Per (sender, receiver), in arrival order (np.add.at adds repeated indices one by one; a
        # few arrivals item by item: the same additions in the same order).
        r = self._index[receiver]
        if k <= 8:
            delivered, delay_s = self._pair_delivered, self._pair_delay_s
            for s, delay in zip(senders, delays):
                delivered[s, r] += 1
                delay_s[s, r] += delay
        else:
            np.add.at(self._pair_delivered[:, r], senders, 1)
            np.add.at(self._pair_delay_s[:, r], senders, delays)
        return out

    def receive_many(self, t_s: float, receivers, positions, limits=None) -> list:
        """:meth:`decide_many` for ``receivers`` at their ``positions`` (and ``limits``), then each one's
        :meth:`receive_raw` with ``decide=False``, in their order: a list of arrivals per receiver
        (an empty tuple when nothing is due: most control ticks). The same decisions, draws and
        statistics as those calls."""
        if t_s < self._next_s and t_s < self._arrival_s and self._members.issuperset(receivers):
            return [()] * len(receivers)  # (nothing to decide, nothing due: most control ticks)
        self.decide_many(t_s, receivers, positions, limits)
        pending_all = self._pending
        out = [() if not (pending := pending_all[name]) or pending[0][0] > t_s
               else self.receive_raw(t_s, name, None, False) for name in receivers]
        self._arrival_s = min([p[0][0] for p in pending_all.values() if p], default=math.inf)
        return out

    def decide_many(self, t_s: float, receivers, positions, limits=None) -> None:
        """Decide, for each of ``receivers`` in turn at its position ``positions[k]`` (2,) world [m],
        the messages sent by ``t_s`` it has not decided yet (with ``limits``: only those whose id
        is below ``limits[k]``): loss and delay of every (message, receiver) pair; the survivors
        wait on the receiver's list of pending arrivals for :meth:`receive_raw`.

        The same decisions, random draws and statistics as the receivers' :meth:`receive` calls
        one after the other (the draws in receiver then message order: one draw of all the
        uniforms gives the same numbers), every receiver's pairs in one compiled pass
        (:func:`~mjasc.cooperation.link_kernels.decide_segments`). A call while every message
        sent by ``t_s`` is decided for everyone (most control ticks) returns at once."""
        cursors = self._cursor
        if t_s < self._next_s:  # nothing sent by t_s is undecided for anyone
            for name in receivers:
                if name not in cursors:
                    self._member(name, "receiver")
            return
        base, times = self._base, self._log_time
        n_log = len(times)
        segs = []  # (receiver index, name, k in receivers, first log position, end)
        for k, name in enumerate(receivers):
            cursor = cursors.get(name)
            if cursor is None:
                self._member(name, "receiver")
            k0 = cursor - base
            if k0 >= n_log or times[k0] > t_s:
                continue
            k1 = bisect_right(times, t_s, k0)  # send times are non-decreasing
            if limits is not None:
                k1 = min(k1, limits[k] - base)
            if k1 > k0:
                cursors[name] = base + k1
                segs.append((self._index[name], name, k, k0, k1))
        if segs:
            self._decide(segs, positions)
            self._prune()

    def _decide(self, segs: list, positions) -> None:
        """Loss and delay of the logged messages ``k0 … k1 − 1`` of each receiver's segment (not
        its own, only those it can hear), the receivers in order, in one compiled call
        (:func:`~mjasc.cooperation.link_kernels.decide_segments`; a loss too close to call there is
        left to numpy's :meth:`NetworkConfig.loss_at`); survivors go on their lists of pending
        arrivals (kept sorted by (arrival, id))."""
        log_s = self._log_sender
        m = 0  # the pairs the receivers hear: as many uniform pairs are drawn
        if self._everyone:
            for r, _, _, k0, k1 in segs:
                m += k1 - k0 - log_s[k0:k1].count(r)
        else:
            hm = self._hears_matrix
            for r, _, _, k0, k1 in segs:
                row = hm[r].tolist()
                m += sum(row[s] for s in log_s[k0:k1])
        if not m:
            return
        n_seg = len(segs)
        work = self._work
        if work is None or work[0].shape[0] < n_seg or work[2].shape[1] < m:
            cap = max(m, 2 * work[2].shape[1] if work is not None else 16)
            work = self._work = (np.empty((len(self.team), 5)), np.empty((len(self.team), 3), dtype=np.int64),
                                 np.empty((2, cap), dtype=np.int64), np.empty((3, cap)))
        seg_arr, counts, pairs, out = work
        for j, (r, _, k, k0, k1) in enumerate(segs):
            pos = positions[k]
            if not (type(pos) is np.ndarray and pos.ndim == 1 and pos.dtype == np.float64):
                pos = np.asarray(pos, dtype=float).reshape(-1)
            seg_arr[j] = (r, k0, k1, pos[0], pos[1])
        cfg = self.config
        u = self.rng.random((m, 2))  # (u_loss, u_jitter) per pair, in receiver then message order
        unsure = decide_segments(self._log_arr, seg_arr[:n_seg], self._hears_matrix, u, cfg.range_m,
                                 cfg.loss_probability, cfg.loss_exponent, cfg.base_delay_s, cfg.propagation_speed_m_s,
                                 cfg.jitter_s, self._pair_offered, counts, pairs, out)
        ks, js = pairs[:, :m].tolist()
        arrival_l, outcome_l = out[1:, :m].tolist()
        counts_l = counts[:n_seg].tolist()
        if unsure:
            at = [j for j, o in enumerate(outcome_l) if o == UNSURE]
            for j, gone in zip(at, (u[at, 0] < cfg.loss_at(out[0, :m][at])).tolist()):
                outcome_l[j] = LOST if gone else DELIVERED
                counts_l[js[j]][1] += gone
        link = self.link
        for sg, (n_offered, n_lost, n_far) in zip(segs, counts_l):
            stats = link[sg[1]]
            stats.offered += n_offered
            stats.lost += n_lost
            stats.lost_out_of_range += n_far
        self.count_changes += 1
        team, log_t, log_p = self.team, self._log_time, self._log_payload
        if self._outcomes is not None:
            self._outcomes += [LinkOutcome(team[log_s[k]], segs[j][1], log_t[k],
                                           float("nan") if o != DELIVERED else a, o != DELIVERED)
                               for k, j, a, o in zip(ks, js, arrival_l, outcome_l)]
        new = [[] for _ in segs]
        idb = self._base
        for k, j, a, o in zip(ks, js, arrival_l, outcome_l):
            if o == DELIVERED:
                new[j].append((a, idb + k, log_s[k], log_t[k], log_p[k]))
        pending_all = self._pending
        for sg, items in zip(segs, new):
            if items:
                pending = pending_all[sg[1]]
                # kept sorted by (arrival, id) (unique: the payloads are never compared)
                pending[:] = sorted(pending + items) if pending else sorted(items)
                if pending[0][0] < self._arrival_s:
                    self._arrival_s = pending[0][0]

    def _prune(self) -> None:
        done = min(self._cursor.values()) - self._base
        self._next_s = self._log_time[done] if done < len(self._log_time) else math.inf
        if done > 256:
            for log in (self._log_time, self._log_sender, self._log_payload):
                del log[:done]
            n = len(self._log_time)
            self._log_arr[:, :n] = self._log_arr[:, done:done + n]
            self._base += done

    # ------------------------------------------------------------------ statistics
    def link_matrix(self) -> dict:
        """Who heard whom: ``{"topology", "team", "offered", "delivered", "lost", "mean_delay_s"}``,
        the last four n × n lists indexed [sender][receiver] in team order (offered: the
        message–receiver pairs decided; mean delay of the delivered ones [s], None where none).
        Messages still in flight count as offered, not yet as delivered or lost."""
        off, dlv, dly = self._pair_offered, self._pair_delivered, self._pair_delay_s
        pending = np.zeros_like(off)
        for receiver, waiting in self._pending.items():
            for item in waiting:
                pending[item[2], self._index[receiver]] += 1
        mean = [[round(float(dly[i, j] / dlv[i, j]), 4) if dlv[i, j] else None for j in range(len(self.team))]
                for i in range(len(self.team))]
        return {"topology": self.config.topology, "team": list(self.team), "offered": off.tolist(),
                "delivered": dlv.tolist(), "lost": (off - dlv - pending).tolist(), "mean_delay_s": mean}

    def counts(self, receiver: str) -> tuple[int, int]:
        """(delivered, lost) so far to ``receiver``: :meth:`stats`' two counts, without the dict
        (the recording asks at every record tick)."""
        s = self.link[receiver]
        return s.delivered, s.lost

    def stats(self, receiver: str | None = None) -> dict:
        """Counts and delays, for one receiver or the whole team: ``sent`` (broadcasts),
        ``offered`` (message–receiver pairs decided), ``delivered``, ``lost`` (of which
        ``lost_out_of_range``), ``loss_rate``, ``mean_delay_s``, ``max_delay_s``, ``pending``."""
        if receiver is not None:
            self._member(receiver, "receiver")
            out = self.link[receiver].as_dict()
            out["sent"] = self.sent[receiver]
            out["pending"] = len(self._pending[receiver])
            return out
        total = LinkStats()
        for s in self.link.values():
            total.offered += s.offered
            total.delivered += s.delivered
            total.lost += s.lost
            total.lost_out_of_range += s.lost_out_of_range
            total.delay_sum_s += s.delay_sum_s
            total.delay_max_s = max(total.delay_max_s, s.delay_max_s)
        out = total.as_dict()
        out["sent"] = sum(self.sent.values())
        out["pending"] = sum(len(h) for h in self._pending.values())
        return out
