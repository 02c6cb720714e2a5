"""Perception: one vessel's view of the world from its own range sensor (thesis §3.2.1, docs/thesis.md §2;
docs/perception.md).

* :mod:`~mjasc.perception.range_sensor` — MuJoCo ray-cast fan (``mj_multiRay``), noise, dropout,
  clutter; :mod:`~mjasc.perception.beam_culling` — the beams of a fan that can meet a geom (only
  those are cast);
* :mod:`~mjasc.perception.detection` — clustering the returns into objects (centre, radius, σ²);
* :mod:`~mjasc.perception.static_map` — grid of static returns → convex polygons for the planner;
* :mod:`~mjasc.perception.imm` — the IMM bank of constant-turn EKFs over [x, y, course, speed];
* :mod:`~mjasc.perception.tracking` — multi-target tracking: association, track management,
  manoeuvres, outlines, team mates;
* :mod:`~mjasc.perception.pipeline` — :class:`~mjasc.perception.pipeline.Perception`, the component
  a vessel's agent runs: sensor → detections → static map and tracks.
"""
