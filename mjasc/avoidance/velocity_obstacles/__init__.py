"""Velocity obstacles (Fiorini & Shiller 1998) with COLREG constraints (Kuwata et al. 2014): the
second collision-avoidance method, registered as ``"velocity_obstacle"``. One concept per module:
``cones`` (VO membership and time to collision over candidates × obstacles), ``colreg_constraints``
(roles, forbidden half-planes, stand-on, role persistence), ``candidates`` (preferred velocity,
candidate grid, cost and choice), ``options`` (the ``[vessels.avoidance]`` table), ``method`` (the
:class:`~mjasc.plugins.AvoidanceMethod`). See docs/avoidance.md, "Velocity obstacles"."""
