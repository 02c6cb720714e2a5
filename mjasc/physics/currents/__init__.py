"""Water current fields: the velocity of the water over ground, in the world frame.

The hydrodynamics evaluates the current at every vessel's position at every physics step and
forms the relative velocity ``ν_r = ν − ν_c`` (docs/architecture.md; the thesis's environment
"adds water current", docs/thesis.md §1). Every field maps world-frame points ``(n, 2)`` [m] (ENU: x east,
y north) and a simulation time ``t_s`` [s] to world-frame current velocities ``(n, 2)`` [m/s], and
gives the material derivative seen by a body moving over ground with velocity ``ṗ``::

    a_c = dV/dt along the body's path = ∂V/∂t + (∇V)·ṗ          (n, 2) [m/s²]

which the hydrodynamics needs for the current's added-mass (Froude–Krylov) term.

Contract of every field (``CurrentField``):

* ``velocity(points_m, t_s)`` returns a new ``(n, 2)`` array that the caller owns (it may be
  written in place); ``points_m`` must be shaped ``(n, 2)``.
* ``acceleration(points_m, velocities_m_s, t_s)``: analytic where the field allows, otherwise one
  central finite difference *along the body's path*,
  ``[V(p + h·ṗ, t + h) − V(p − h·ṗ, t − h)] / (2h)`` with ``h = FD_STEP_S = 1e-3 s``
  (spatial step ``h·|ṗ|``, i.e. 5 mm at 5 m/s; truncation error O(h²), round-off ~1e-13 m/s²).
  At a kink of a piecewise field (grid cell edges, a Rankine core edge) it returns the average of
  the two one-sided derivatives.
* ``is_steady`` (no time dependence) and ``is_uniform`` (no space dependence) let callers skip
  work; ``describe()`` returns the parameters as a plain dict that is also a valid config table
  (``current_from_config(f.describe())`` rebuilds the field).
* Fields add: ``f + g`` (and ``sum([f, g, h])``) is a :class:`SumCurrent`.

Direction convention: a current direction is the direction the water flows **toward** ("sets
toward", the oceanographic convention — the opposite of the meteorological "coming from"),
counter-clockwise from east, like headings: in a scenario file in degrees (``direction_deg``, as
every angle there), in code in radians. A current "setting north" has direction 90° (π/2).

Fields (one module each)
------------------------
* ``base`` — :class:`CurrentField`, the interface, and :class:`SumCurrent` (superposition);
* ``analytic`` — :class:`UniformCurrent`, :class:`LinearShear`;
* ``vortex`` — :class:`Vortex` (Lamb–Oseen or Rankine eddy, optionally drifting);
* ``grid`` — :class:`GriddedCurrent` (bilinear on a rectilinear grid, optional time slices);
* ``tidal`` — :class:`TidalCurrent` (sinusoidal reversing tide on top of a base field);
* ``gauss_markov`` — :class:`GaussMarkovCurrent` (seeded, slowly varying uniform current,
  Fossen 2011 §8.3);
* ``config`` — :func:`current_from_config`, the ``[current]`` table → a field;
* ``arrays`` — the readers of the array parameters (vectors, gradients, grids).

Each field declares its parameters once, with bounds, unit and doc, in a frozen dataclass
(``UniformConfig``, ``ShearConfig``, ``VortexConfig``, ``GridConfig``, ``TidalConfig``,
``GaussMarkovConfig``, ``SumConfig``) through :func:`mjasc.core.config_tables.param`: the
constructors and :func:`current_from_config` both read their values through it, so a bad value
is reported the same way (``Vortex.core_radius_m: must be > 0, got -2.0`` from Python,
``current.core_radius_m: ...`` from a scenario). ``Field.from_config(config)`` builds a field
from its read parameters.

TOML schema (``current_from_config``)
-------------------------------------
A scenario's ``[current]`` table; ``type`` selects the field. Numbers may be integers or floats
and must be finite; unknown keys are rejected. Errors are ``ValueError`` (``ConfigError``) naming
the field path, the reason and the value, e.g. ``current.components[1].core_radius_m: must be > 0, got -2.0``.

uniform — constant everywhere; give ``velocity_m_s`` *or* ``speed_m_s`` + ``direction_deg`` (or ``direction_rad``)::

    [current]
    type = "uniform"
    velocity_m_s = [0.3, 0.0]          # east, north [m/s]
    # or: speed_m_s = 0.3  and  direction_deg = 90.0   (flowing toward north)

shear — ``V(p) = V0 + G·(p − p0)``, ``G[i][j] = ∂V_i/∂x_j`` [1/s] (unbounded: keep the domain
small enough that the speeds stay sensible)::

    [current]
    type = "shear"
    base_velocity_m_s = [0.5, 0.0]     # V0 at origin_m
    gradient_per_s = [[0.0, -0.01], [0.0, 0.0]]   # eastward flow slowing by 1 cm/s per m north
    origin_m = [0.0, 0.0]              # optional, default [0, 0]

vortex — an eddy, tangential speed CCW positive (negative ``max_speed_m_s`` turns clockwise)::

    [current]
    type = "vortex"
    centre_m = [50.0, -20.0]
    core_radius_m = 15.0               # Lamb–Oseen r_c (Gaussian width) / Rankine core radius
    max_speed_m_s = 0.4                # peak tangential speed (at 1.1209 r_c for Lamb–Oseen)
    profile = "lamb_oseen"             # optional: "lamb_oseen" (default) | "rankine"
    drift_m_s = [0.05, 0.0]            # optional: the centre moves as centre_m + drift_m_s·t

grid — bilinear interpolation on a rectilinear grid; ``u_m_s[i][j]`` is the east component at
``(x_m[i], y_m[j])`` (``indexing="ij"``, shape ``(nx, ny)``); with ``times_s`` the arrays gain a
leading time axis ``(nt, nx, ny)`` and are interpolated linearly in time. Outside the grid (and
outside ``times_s``) the field is clamped to the edge value::

    [current]
    type = "grid"
    x_m = [0.0, 100.0, 200.0]
    y_m = [0.0, 100.0]
    u_m_s = [[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]]
    v_m_s = [[0.0, 0.0], [0.0, 0.1], [0.0, 0.2]]
    # times_s = [0.0, 600.0]  with u_m_s, v_m_s shaped [2][3][2]

tidal — ``V(p, t) = V_base(p, t) + A·sin(2πt/T + φ)``, a reversing tide along the axis of ``A``.
The base is either a nested field table ``base`` or a uniform ``mean_velocity_m_s``::

    [current]
    type = "tidal"
    amplitude_m_s = [0.0, 0.5]         # flood toward north at peak, ebb toward south
    period_s = 44714.0                 # M2 tide, 12.42 h
    phase_deg = 0.0                    # optional, default 0 (or phase_rad, in radians)
    mean_velocity_m_s = [0.1, 0.0]     # or a nested table:
    # [current.base]
    # type = "shear"  ...

gauss_markov — uniform current ``V(t) = V_mean + x(t)``, each of x's two components an
independent stationary first-order Gauss–Markov process with time constant τ and standard
deviation σ; a deterministic function of (t, seed)::

    [current]
    type = "gauss_markov"
    mean_velocity_m_s = [0.3, 0.1]
    time_constant_s = 300.0            # τ > 0
    sigma_m_s = 0.05                   # σ ≥ 0, per component
    seed = 7                           # int ≥ 0; optional if the scenario has a seed
    step_s = 1.0                       # optional: sample grid Δ, default min(τ/50, 1 s)
    start = "stationary"               # optional: "stationary" (x(0) ~ N(0, σ²)) | "mean" (x(0) = 0)

sum — superposition of components, each a full field table::

    [current]
    type = "sum"
    [[current.components]]
    type = "uniform"
    velocity_m_s = [0.2, 0.0]
    [[current.components]]
    type = "vortex"
    centre_m = [0.0, 0.0]
    core_radius_m = 10.0
    max_speed_m_s = 0.3
"""

from mjasc.physics.currents.analytic import LinearShear, ShearConfig, UniformConfig, UniformCurrent
from mjasc.physics.currents.base import FD_STEP_S, CurrentField, SumConfig, SumCurrent
from mjasc.physics.currents.config import CURRENT_TYPES, current_from_config
from mjasc.physics.currents.gauss_markov import GaussMarkovConfig, GaussMarkovCurrent
from mjasc.physics.currents.grid import GridConfig, GriddedCurrent
from mjasc.physics.currents.tidal import TidalConfig, TidalCurrent
from mjasc.physics.currents.vortex import LAMB_OSEEN_PEAK_RATIO, Vortex, VortexConfig

__all__ = [
    "FD_STEP_S",
    "LAMB_OSEEN_PEAK_RATIO",
    "CurrentField",
    "UniformCurrent",
    "LinearShear",
    "Vortex",
    "GriddedCurrent",
    "TidalCurrent",
    "GaussMarkovCurrent",
    "SumCurrent",
    "current_from_config",
    "CURRENT_TYPES",
    "UniformConfig",
    "ShearConfig",
    "VortexConfig",
    "GridConfig",
    "TidalConfig",
    "GaussMarkovConfig",
    "SumConfig",
]
