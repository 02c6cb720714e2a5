"""Bring your own algorithm: the interfaces of the pluggable onboard stages, the build context and
the registry of methods by name (built-in, registered in code, or from installed packages' entry
points). See docs/plugins.md."""

from mjasc.plugins.context import StageContext
from mjasc.plugins.registry import MethodChoice, available, method_class, parse_method_table, register, unregister
from mjasc.plugins.stages import AvoidanceMethod, ControlMethod, CoordinationMethod, StageMethod, TrackingMethod

__all__ = ["StageContext", "StageMethod", "AvoidanceMethod", "TrackingMethod", "CoordinationMethod", "ControlMethod", "MethodChoice", "available",
           "method_class", "parse_method_table", "register", "unregister"]
