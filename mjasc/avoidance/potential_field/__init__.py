"""Path re-planning on a harmonic potential field built with source panels (thesis §4.1, App. A;
docs/thesis.md §4).

A vessel re-plans by following a streamline of a flow made of a uniform flow, a sink at its goal
and source panels on the (inflated) obstacle polygons; the robust rule V_j = r·a_max·L_j keeps
the obstacles' net strength below the sink's, so the streamline reaches the goal. World frame ENU,
metres.

- :mod:`~mjasc.avoidance.potential_field.panels` — source panels on polygon edges and their
  induced velocity in closed form (thesis eqs. 4.3–4.4);
- :mod:`~mjasc.avoidance.potential_field.field` — :class:`PotentialField`: uniform flow + goal sink
  + panels, the boundary condition (eqs. 4.10–4.19) and the robust field (eqs. 4.26–4.33);
- :mod:`~mjasc.avoidance.potential_field.streamlines` — tracing the path ṗ = u/‖u‖ (RK4) and why
  a streamline stops (:class:`Streamline`); its loop compiled in
  :mod:`~mjasc.avoidance.potential_field.streamline_kernels`.

Polygon cleaning and inflation are general planar geometry: :mod:`mjasc.core.geometry`.
"""

from mjasc.avoidance.potential_field.field import DEFAULT_SINK_STRENGTH, PotentialField
from mjasc.avoidance.potential_field.panels import TWO_PI, Panels, make_panels, panel_influence
from mjasc.avoidance.potential_field.streamlines import (
    REASONS,
    VERTEX_STEP_FRACTION,
    Streamline,
    trace_streamlines,
)

__all__ = ["PotentialField", "DEFAULT_SINK_STRENGTH", "Panels", "make_panels", "panel_influence", "TWO_PI",
           "Streamline", "trace_streamlines", "REASONS", "VERTEX_STEP_FRACTION"]
