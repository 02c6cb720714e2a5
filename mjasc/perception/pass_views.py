"""Each vessel's :class:`~mjasc.perception.range_sensor.Scan` and
:class:`~mjasc.perception.detection.Detections` of a sensing pass, made on first read (world ENU,
body FLU, SI).

A fleet's sensing pass (:meth:`mjasc.perception.fleet.PerceptionFleet._sense`) has every vessel's
scan and detections in stacked arrays (:class:`~mjasc.perception.scan_batch.ScanStack`,
:class:`~mjasc.perception.detection.DetectionBatch`). Handing each vessel its own objects cost a
dozen array views per object and vessel at every pass, while in a run without a recording or an
observer only the tracker reads a few of their fields, which it gets from the stacked arrays. So
the pass hands on :class:`PassScan` and :class:`~mjasc.perception.detection.PassDetections`
(:class:`FilledOnRead` both): instances of the same frozen
dataclasses (``isinstance`` holds, ``dataclasses.replace`` and equality work) that hold only the
pass's arrays and their index, and fill in every field — the same views as before, the same
values — the first time any field is read. Like :class:`mjasc.core.estimates.Pending`, what is
made depends only on values that do not change afterwards (the pass's arrays are new each pass).
"""

from __future__ import annotations

from mjasc.perception.range_sensor import Scan

__all__ = ["FilledOnRead", "PassScan", "filled_on_read"]


class FilledOnRead:
    """Mixin of a frozen dataclass whose instance ``__dict__`` holds only ``_src`` = (make, args)
    until a field is read: then ``make(fields, *args)`` writes every field into it."""

    __slots__ = ()

    def __getattr__(self, name: str):  # (only for names not found: the fields not made yet)
        d = self.__dict__
        src = d.pop("_src", None)
        if src is None or name.startswith("__"):
            if src is not None:
                d["_src"] = src
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        make, args = src
        make(d, *args)
        try:
            return d[name]
        except KeyError:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}") from None


class PassScan(FilledOnRead, Scan):
    """A :class:`~mjasc.perception.range_sensor.Scan` whose fields are made on first read."""


def filled_on_read(cls: type, make, args):
    """An instance of ``cls`` (a :class:`FilledOnRead` dataclass) that ``make(fields_dict, *args)``
    fills on first read."""
    obj = object.__new__(cls)
    obj.__dict__["_src"] = (make, args)
    return obj
