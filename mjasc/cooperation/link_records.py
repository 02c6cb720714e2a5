"""What the team's link hands out and counts: a delivered :class:`Message`, the :class:`LinkOutcome`
of one (message, receiver) pair kept for the recording, and the :class:`LinkStats` of one (sender,
receiver) pair (offered, delivered, lost, delays [s]). The link itself is
:class:`mjasc.cooperation.comms.CommsNetwork`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Message", "LinkOutcome", "LinkStats", "copy_payload"]


@dataclass(frozen=True)
class Message:
    """One delivered message. ``payload`` is the receiver's own copy of a dict payload, or the
    sender's immutable typed message (:class:`~mjasc.cooperation.messages.TeamMessage`)."""

    sender: str
    sent_time_s: float
    received_time_s: float
    payload: object

    @property
    def delay_s(self) -> float:
        return self.received_time_s - self.sent_time_s


@dataclass(frozen=True)
class LinkOutcome:
    """What became of one message for one receiver: sent by ``sender`` at ``sent_time_s`` [s];
    ``lost`` (then ``arrival_time_s`` is NaN) or delivered at ``arrival_time_s`` [s]."""

    sender: str
    receiver: str
    sent_time_s: float
    arrival_time_s: float
    lost: bool


@dataclass
class LinkStats:
    """The counts of one (sender, receiver) pair of the link
    (:meth:`~mjasc.cooperation.comms.CommsNetwork.link_matrix`)."""

    offered: int = 0  # (message, receiver) pairs decided
    delivered: int = 0
    lost: int = 0
    lost_out_of_range: int = 0
    delay_sum_s: float = 0.0
    delay_max_s: float = 0.0

    def as_dict(self) -> dict:
        return {"offered": self.offered, "delivered": self.delivered, "lost": self.lost,
                "lost_out_of_range": self.lost_out_of_range,
                "loss_rate": self.lost / self.offered if self.offered else 0.0,
                "mean_delay_s": self.delay_sum_s / self.delivered if self.delivered else float("nan"),
                "max_delay_s": self.delay_max_s}


def copy_payload(payload):
    """A receiver's own copy of a dict payload (arrays copied); a typed message (a frozen
    dataclass such as :class:`~mjasc.cooperation.messages.TeamMessage`) is shared: nobody mutates it."""
    if isinstance(payload, dict):
        return {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in payload.items()}
    return payload
