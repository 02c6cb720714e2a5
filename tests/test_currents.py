"""Current fields against closed forms: profiles, divergence, circulation, material derivatives,
bilinear exactness, tidal period, Gauss–Markov statistics and determinism, config validation."""

from __future__ import annotations

import math
import re
import tomllib

import numpy as np
import pytest

from mjasc.physics import currents
from mjasc.physics.currents import (
    LAMB_OSEEN_PEAK_RATIO,
    CurrentField,
    GaussMarkovCurrent,
    GriddedCurrent,
    LinearShear,
    SumCurrent,
    TidalCurrent,
    UniformCurrent,
    Vortex,
    current_from_config,
)

RNG = np.random.default_rng(20240611)
POINTS = RNG.uniform(-80.0, 80.0, size=(40, 2))
BODY_VELOCITIES = RNG.uniform(-4.0, 4.0, size=(40, 2))
_RNG_STATE = RNG.bit_generator.state


@pytest.fixture(autouse=True)
def _same_draws_whatever_the_test_order():
    """Each test sees the same RNG stream, however pytest (or xdist) orders the tests."""
    RNG.bit_generator.state = _RNG_STATE


def fd_acceleration(field: CurrentField, points, velocities, t_s):
    """The base class's finite-difference material derivative, whatever the subclass overrides."""
    return CurrentField.acceleration(field, points, velocities, t_s)


def numerical_divergence(field: CurrentField, points, t_s=0.0, h=1e-4):
    ex, ey = np.array([h, 0.0]), np.array([0.0, h])
    dudx = (field.velocity(points + ex, t_s)[:, 0] - field.velocity(points - ex, t_s)[:, 0]) / (2 * h)
    dvdy = (field.velocity(points + ey, t_s)[:, 1] - field.velocity(points - ey, t_s)[:, 1]) / (2 * h)
    return dudx + dvdy


def circulation_numerical(field: CurrentField, centre, radius, n=4000):
    """∮ V·dl around a CCW circle (midpoint rule: spectrally accurate for a smooth periodic integrand)."""
    theta = (np.arange(n) + 0.5) * 2 * np.pi / n
    points = centre + radius * np.stack([np.cos(theta), np.sin(theta)], axis=-1)
    tangent = np.stack([-np.sin(theta), np.cos(theta)], axis=-1)
    v = field.velocity(points, 0.0)
    return float(np.sum(np.einsum("ij,ij->i", v, tangent)) * radius * 2 * np.pi / n)


# --------------------------------------------------------------------------------- uniform


def test_uniform_is_constant_everywhere_and_always():
    field = UniformCurrent((0.3, -0.1))
    for t in (0.0, 17.5, 1e5):
        v = field.velocity(POINTS, t)
        assert v.shape == POINTS.shape
        np.testing.assert_array_equal(v, np.tile([0.3, -0.1], (len(POINTS), 1)))
    assert field.is_steady and field.is_uniform
    np.testing.assert_array_equal(field.acceleration(POINTS, BODY_VELOCITIES, 3.0), 0.0)


def test_uniform_returns_a_fresh_writable_array():
    field = UniformCurrent((0.3, 0.0))
    v = field.velocity(POINTS[:3], 0.0)
    v += 1.0
    np.testing.assert_array_equal(field.velocity(POINTS[:3], 0.0)[:, 0], 0.3)


def test_uniform_direction_is_where_the_water_flows_toward_ccw_from_east():
    north = UniformCurrent(speed_m_s=0.5, direction_rad=math.pi / 2)
    np.testing.assert_allclose(north.velocity(POINTS[:1], 0.0), [[0.0, 0.5]], atol=1e-15)
    southwest = UniformCurrent(speed_m_s=2.0, direction_rad=-3 * math.pi / 4)
    np.testing.assert_allclose(southwest.velocity_m_s, [-math.sqrt(2), -math.sqrt(2)])
    assert southwest.speed_m_s == pytest.approx(2.0)
    assert southwest.direction_rad == pytest.approx(-3 * math.pi / 4)
    # in degrees, as every other angle of a scenario: the same field
    assert np.array_equal(UniformCurrent(speed_m_s=2.0, direction_deg=-135.0).velocity_m_s,
                          UniformCurrent(speed_m_s=2.0, direction_rad=math.radians(-135.0)).velocity_m_s)
    np.testing.assert_allclose(current_from_config({"type": "uniform", "speed_m_s": 0.5, "direction_deg": 90.0})
                               .velocity(POINTS[:1], 0.0), [[0.0, 0.5]], atol=1e-15)


@pytest.mark.parametrize("points", [np.zeros(2), np.zeros((3, 3)), np.zeros((2, 2, 2))])
def test_points_must_be_n_by_2(points):
    with pytest.raises(ValueError, match=r"points_m: must have shape \(n, 2\)"):
        UniformCurrent((0.1, 0.0)).velocity(points, 0.0)


def test_empty_point_sets_are_fine():
    for field in (UniformCurrent((0.1, 0.0)), Vortex((0, 0), 5.0, 0.2)):
        assert field.velocity(np.zeros((0, 2)), 0.0).shape == (0, 2)


# --------------------------------------------------------------------------------- shear


def test_shear_reproduces_a_river_profile():
    # an eastward river flowing 1 m/s along its south bank y = 0, 0.02 (m/s)/m slower northward
    field = LinearShear((1.0, 0.0), [[0.0, -0.02], [0.0, 0.0]], origin_m=(10.0, 0.0))
    y = np.linspace(0.0, 50.0, 11)
    points = np.stack([RNG.uniform(-100, 100, y.size), y], axis=-1)
    v = field.velocity(points, 0.0)
    np.testing.assert_allclose(v[:, 0], 1.0 - 0.02 * y, atol=1e-15)
    np.testing.assert_array_equal(v[:, 1], 0.0)
    assert field.is_steady and not field.is_uniform


def test_shear_general_gradient_and_analytic_acceleration_match_finite_differences():
    gradient = np.array([[0.01, -0.03], [0.02, 0.005]])
    field = LinearShear((0.2, -0.4), gradient, origin_m=(3.0, -7.0))
    expected = np.array([0.2, -0.4]) + (POINTS - [3.0, -7.0]) @ gradient.T
    np.testing.assert_allclose(field.velocity(POINTS, 0.0), expected, rtol=1e-14, atol=1e-14)
    analytic = field.acceleration(POINTS, BODY_VELOCITIES, 5.0)
    np.testing.assert_allclose(analytic, BODY_VELOCITIES @ gradient.T, rtol=1e-14)
    np.testing.assert_allclose(fd_acceleration(field, POINTS, BODY_VELOCITIES, 5.0), analytic, atol=1e-10)


# --------------------------------------------------------------------------------- vortex


def test_lamb_oseen_peak_ratio_solves_its_equation():
    alpha = LAMB_OSEEN_PEAK_RATIO**2
    assert math.exp(alpha) == pytest.approx(1 + 2 * alpha, rel=1e-15)
    assert LAMB_OSEEN_PEAK_RATIO == pytest.approx(1.12091, abs=1e-5)


@pytest.mark.parametrize(
    ("profile", "peak_ratio"), [("lamb_oseen", LAMB_OSEEN_PEAK_RATIO), ("rankine", 1.0)]
)
def test_vortex_tangential_speed_peaks_at_the_right_radius(profile, peak_ratio):
    core, vmax = 12.0, 0.4
    field = Vortex((5.0, -3.0), core, vmax, profile=profile)
    r = np.linspace(0.0, 6 * core, 60001)
    speeds = field.tangential_speed_m_s(r)
    assert r[np.argmax(speeds)] == pytest.approx(peak_ratio * core, abs=2e-3)
    assert speeds.max() == pytest.approx(vmax, rel=1e-9)
    # and the vector field has that speed, tangential and CCW
    radial = np.array([[math.cos(0.7), math.sin(0.7)]])
    v = field.velocity(np.array([5.0, -3.0]) + peak_ratio * core * radial, 0.0)
    assert np.linalg.norm(v) == pytest.approx(vmax, rel=1e-9)
    assert float(v[0] @ radial[0]) == pytest.approx(0.0, abs=1e-15)
    assert radial[0, 0] * v[0, 1] - radial[0, 1] * v[0, 0] > 0.0  # CCW


def test_rankine_profile_is_solid_body_inside_and_irrotational_outside():
    field = Vortex((0.0, 0.0), 10.0, 0.5, profile="rankine")
    r_in = np.linspace(0.0, 10.0, 11)
    np.testing.assert_allclose(field.tangential_speed_m_s(r_in), 0.05 * r_in, rtol=1e-14)
    r_out = np.linspace(10.0, 100.0, 10)
    np.testing.assert_allclose(field.tangential_speed_m_s(r_out), 5.0 / r_out, rtol=1e-14)


def test_lamb_oseen_profile_closed_form():
    core, vmax = 8.0, -0.3  # clockwise
    field = Vortex((0.0, 0.0), core, vmax)
    gamma = 2 * math.pi * LAMB_OSEEN_PEAK_RATIO * core * vmax / (1 - math.exp(-LAMB_OSEEN_PEAK_RATIO**2))
    assert field.circulation_m2_s == pytest.approx(gamma)
    r = np.array([0.5, 3.0, 8.0, 20.0, 200.0])
    expected = gamma / (2 * math.pi * r) * (1 - np.exp(-(r**2) / core**2))
    np.testing.assert_allclose(field.tangential_speed_m_s(r), expected, rtol=1e-13)
    # finite at the centre, zero there
    assert field.velocity(np.zeros((1, 2)), 0.0) == pytest.approx(np.zeros((1, 2)))


@pytest.mark.parametrize("profile", ["lamb_oseen", "rankine"])
def test_vortex_is_divergence_free(profile):
    field = Vortex((4.0, 2.0), 15.0, 0.6, profile=profile, drift_m_s=(0.1, -0.2))
    points = RNG.uniform(-60, 60, size=(200, 2))
    div = numerical_divergence(field, points, t_s=12.0)
    assert np.max(np.abs(div)) < 1e-9  # the velocities' own gradients are ~1e-2 1/s


@pytest.mark.parametrize("profile", ["lamb_oseen", "rankine"])
@pytest.mark.parametrize("radius", [2.0, 10.0, 11.2, 35.0, 400.0])
def test_vortex_circulation_matches_closed_form(profile, radius):
    core, vmax = 10.0, 0.5
    field = Vortex((-7.0, 3.0), core, vmax, profile=profile)
    if profile == "lamb_oseen":
        gamma = 2 * math.pi * LAMB_OSEEN_PEAK_RATIO * core * vmax / (1 - math.exp(-LAMB_OSEEN_PEAK_RATIO**2))
        expected = gamma * (1 - math.exp(-(radius**2) / core**2))
    else:
        expected = 2 * math.pi * vmax * (radius**2 / core if radius <= core else core)
    assert circulation_numerical(field, np.array([-7.0, 3.0]), radius) == pytest.approx(expected, rel=1e-9)
    assert float(field.circulation_within_m2_s(radius)) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("profile", ["lamb_oseen", "rankine"])
def test_vortex_analytic_acceleration_matches_finite_differences(profile):
    field = Vortex((1.0, -2.0), 9.0, 0.45, profile=profile, drift_m_s=(0.3, 0.1))
    t = 20.0
    centre = field.centre_at(t)
    np.testing.assert_allclose(centre, [7.0, 0.0])
    # points over all regimes: at the centre, tiny radii (series branch), the core, far away;
    # avoid a Rankine core edge where the derivative jumps
    radii = np.array([0.0, 1e-4, 0.05, 0.9, 3.0, 7.0, 12.0, 30.0, 90.0])
    rng = np.random.default_rng(187)  # local: inputs must not depend on which tests ran before
    angles = rng.uniform(-np.pi, np.pi, radii.size)
    points = centre + radii[:, None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    points = np.vstack([points, POINTS])
    velocities = np.vstack([rng.uniform(-3, 3, size=(radii.size, 2)), BODY_VELOCITIES])
    analytic = field.acceleration(points, velocities, t)
    fd = fd_acceleration(field, points, velocities, t)
    # central differences carry an O(h²) truncation error of a few 1e-9 m/s² near the core
    np.testing.assert_allclose(analytic, fd, rtol=1e-6, atol=1e-8)


def test_drifting_vortex_is_the_steady_vortex_translated():
    still = Vortex((0.0, 0.0), 5.0, 0.3)
    moving = Vortex((0.0, 0.0), 5.0, 0.3, drift_m_s=(1.0, -0.5))
    assert still.is_steady and not moving.is_steady
    t = 8.0
    np.testing.assert_allclose(
        moving.velocity(POINTS + [8.0, -4.0], t), still.velocity(POINTS, 0.0), atol=1e-15
    )
    # a body riding along with the centre sees a steady flow: zero acceleration at the centre
    # and, for any point, the same acceleration as the still vortex for the relative velocity
    np.testing.assert_allclose(
        moving.acceleration(POINTS + [8.0, -4.0], BODY_VELOCITIES + [1.0, -0.5], t),
        still.acceleration(POINTS, BODY_VELOCITIES, 0.0),
        atol=1e-15,
    )


# --------------------------------------------------------------------------------- grid


def _bilinear_function(x, y):
    u = 0.3 + 0.01 * x - 0.02 * y + 0.001 * x * y
    v = -0.1 + 0.005 * x + 0.003 * y - 0.0004 * x * y
    return u, v


X_GRID = np.array([-50.0, -20.0, 0.0, 5.0, 40.0, 90.0])
Y_GRID = np.array([-30.0, 0.0, 25.0, 60.0])


def _grid_field(function=_bilinear_function):
    xx, yy = np.meshgrid(X_GRID, Y_GRID, indexing="ij")
    u, v = function(xx, yy)
    return GriddedCurrent(X_GRID, Y_GRID, u, v)


def test_grid_is_exact_at_the_nodes():
    u = RNG.normal(size=(X_GRID.size, Y_GRID.size))
    v = RNG.normal(size=(X_GRID.size, Y_GRID.size))
    field = GriddedCurrent(X_GRID, Y_GRID, u, v)
    xx, yy = np.meshgrid(X_GRID, Y_GRID, indexing="ij")
    nodes = np.stack([xx.ravel(), yy.ravel()], axis=-1)
    np.testing.assert_array_equal(field.velocity(nodes, 0.0), np.stack([u.ravel(), v.ravel()], -1))


def test_grid_is_bilinear_inside_a_cell():
    u = RNG.normal(size=(X_GRID.size, Y_GRID.size))
    v = RNG.normal(size=(X_GRID.size, Y_GRID.size))
    field = GriddedCurrent(X_GRID, Y_GRID, u, v)
    # cell (1, 2): x ∈ [-20, 0], y ∈ [25, 60]; at fractions (0.25, 0.6)
    point = np.array([[-20.0 + 0.25 * 20.0, 25.0 + 0.6 * 35.0]])
    for comp, values in enumerate((u, v)):
        expected = (
            0.75 * 0.4 * values[1, 2] + 0.25 * 0.4 * values[2, 2]
            + 0.75 * 0.6 * values[1, 3] + 0.25 * 0.6 * values[2, 3]
        )
        assert field.velocity(point, 0.0)[0, comp] == pytest.approx(expected, rel=1e-13)
    # the centre of a cell is the mean of its four corners
    centre = np.array([[(-20.0 + 0.0) / 2, (25.0 + 60.0) / 2]])
    np.testing.assert_allclose(
        field.velocity(centre, 0.0)[0, 0], u[1:3, 2:4].mean(), rtol=1e-13
    )


def test_grid_reproduces_a_bilinear_analytic_field_exactly():
    field = _grid_field()
    points = np.stack([RNG.uniform(-50, 90, 500), RNG.uniform(-30, 60, 500)], axis=-1)
    u, v = _bilinear_function(points[:, 0], points[:, 1])
    np.testing.assert_allclose(field.velocity(points, 0.0), np.stack([u, v], -1), rtol=0, atol=1e-13)
    # and its finite-difference acceleration is the analytic gradient times the body velocity
    linear = _grid_field(lambda x, y: (0.3 + 0.01 * x - 0.02 * y, -0.1 + 0.005 * x + 0.003 * y))
    inner = np.stack([RNG.uniform(-45, 85, 50), RNG.uniform(-25, 55, 50)], axis=-1)
    vel = RNG.uniform(-3, 3, (50, 2))
    expected = vel @ np.array([[0.01, -0.02], [0.005, 0.003]]).T
    np.testing.assert_allclose(linear.acceleration(inner, vel, 0.0), expected, atol=1e-10)


def test_grid_clamps_outside_to_the_edge_value():
    field = _grid_field()
    outside = np.array([[-500.0, 10.0], [300.0, 10.0], [0.0, -1e4], [1e3, 1e3], [-1e3, -1e3]])
    edge = np.array([[-50.0, 10.0], [90.0, 10.0], [0.0, -30.0], [90.0, 60.0], [-50.0, -30.0]])
    np.testing.assert_array_equal(field.velocity(outside, 0.0), field.velocity(edge, 0.0))


def test_grid_time_slices_interpolate_linearly_and_clamp():
    u0 = RNG.normal(size=(X_GRID.size, Y_GRID.size))
    v0 = RNG.normal(size=(X_GRID.size, Y_GRID.size))
    u = np.stack([u0, 2 * u0 + 1, -u0])
    v = np.stack([v0, v0 - 1, 3 * v0])
    times = np.array([0.0, 100.0, 400.0])
    field = GriddedCurrent(X_GRID, Y_GRID, u, v, times_s=times)
    assert not field.is_steady and not field.is_uniform
    slices = [GriddedCurrent(X_GRID, Y_GRID, u[k], v[k]) for k in range(3)]
    vs = [s.velocity(POINTS, 0.0) for s in slices]
    np.testing.assert_allclose(field.velocity(POINTS, 100.0), vs[1], atol=1e-14)
    np.testing.assert_allclose(field.velocity(POINTS, 250.0), 0.5 * (vs[1] + vs[2]), atol=1e-14)
    np.testing.assert_allclose(field.velocity(POINTS, 25.0), 0.75 * vs[0] + 0.25 * vs[1], atol=1e-14)
    np.testing.assert_array_equal(field.velocity(POINTS, -5.0), vs[0])
    np.testing.assert_array_equal(field.velocity(POINTS, 1e6), vs[2])
    # ∂V/∂t inside a slice interval, for a body at rest
    rest = np.zeros_like(POINTS)
    np.testing.assert_allclose(
        field.acceleration(POINTS, rest, 250.0), (vs[2] - vs[1]) / 300.0, atol=1e-10
    )


def test_grid_rejects_bad_shapes():
    good = np.zeros((X_GRID.size, Y_GRID.size))
    with pytest.raises(ValueError, match=r"u_m_s: must have shape \[6, 4\]"):
        GriddedCurrent(X_GRID, Y_GRID, good.T, good)
    with pytest.raises(ValueError, match=r"v_m_s: must be an array of shape \[2, 6, 4\], got an array of shape \[6, 4\]"):
        GriddedCurrent(X_GRID, Y_GRID, np.stack([good, good]), good, times_s=[0.0, 1.0])
    with pytest.raises(ValueError, match="x_m: must be at least 2 strictly increasing"):
        GriddedCurrent([0.0, 0.0, 1.0], Y_GRID, good[:3], good[:3])


# --------------------------------------------------------------------------------- tidal


def test_tidal_period_amplitude_and_analytic_acceleration():
    period, amplitude, phase = 44712.0, np.array([0.0, 0.5]), 0.4
    field = TidalCurrent((0.1, 0.0), amplitude, period, phase)
    assert field.is_uniform and not field.is_steady
    t = np.linspace(0.0, period, 20001)
    north = np.array([field.velocity(POINTS[:1], ti)[0, 1] for ti in t])
    east = np.array([field.velocity(POINTS[:1], ti)[0, 0] for ti in t])
    np.testing.assert_allclose(east, 0.1)
    assert north.max() == pytest.approx(0.5, rel=1e-6)
    assert north.min() == pytest.approx(-0.5, rel=1e-6)
    # periodic
    for ti in (0.0, 1234.5, 30000.0):
        np.testing.assert_allclose(
            field.velocity(POINTS, ti + period), field.velocity(POINTS, ti), atol=1e-13
        )
    # the flood peak comes where 2πt/T + φ = π/2
    t_peak = (math.pi / 2 - phase) * period / (2 * math.pi)
    np.testing.assert_allclose(field.velocity(POINTS[:1], t_peak), [[0.1, 0.5]], atol=1e-12)
    # acceleration is the analytic time derivative (uniform: no advective term)
    for ti in (0.0, 5000.0, 22000.0):
        expected = amplitude * 2 * math.pi / period * math.cos(2 * math.pi * ti / period + phase)
        acc = field.acceleration(POINTS[:3], BODY_VELOCITIES[:3], ti)
        np.testing.assert_allclose(acc, np.tile(expected, (3, 1)), rtol=1e-14, atol=1e-20)
        np.testing.assert_allclose(
            fd_acceleration(field, POINTS[:3], BODY_VELOCITIES[:3], ti), acc, rtol=1e-6, atol=1e-12
        )


def test_tidal_phase_may_be_given_in_degrees_as_every_angle_of_a_scenario():
    """A scenario writes its angles in degrees (heading_deg, a current's direction_deg): the tide's
    phase too (phase_deg; phase_rad still works, not both); the default phase is 0."""
    base = {"type": "tidal", "amplitude_m_s": [0.0, 0.5], "period_s": 44712.0, "mean_velocity_m_s": [0.1, 0.0]}
    in_degrees = current_from_config({**base, "phase_deg": 30.0})
    in_radians = current_from_config({**base, "phase_rad": math.radians(30.0)})
    for ti in (0.0, 1234.5, 30000.0):
        np.testing.assert_array_equal(in_degrees.velocity(POINTS, ti), in_radians.velocity(POINTS, ti))
    assert in_degrees.describe()["phase_rad"] == math.radians(30.0)  # (describe() rebuilds the same field)
    np.testing.assert_array_equal(current_from_config(in_degrees.describe()).velocity(POINTS, 99.0),
                                  in_degrees.velocity(POINTS, 99.0))
    np.testing.assert_allclose(current_from_config(base).velocity(POINTS[:1], 0.0), [[0.1, 0.0]], atol=0)
    with pytest.raises(ValueError, match=r"current\.phase_deg: give phase_deg or phase_rad, not both"):
        current_from_config({**base, "phase_deg": 30.0, "phase_rad": 0.5})
    np.testing.assert_array_equal(TidalCurrent((0.1, 0.0), [0.0, 0.5], 44712.0, phase_deg=30.0).velocity(POINTS, 7.0),
                                  in_radians.velocity(POINTS, 7.0))


def test_tidal_over_a_shear_base_adds_the_advective_term():
    base = LinearShear((0.2, 0.0), [[0.0, 0.01], [-0.02, 0.0]])
    field = TidalCurrent(base, (0.3, 0.3), period_s=600.0)
    assert not field.is_uniform
    t = 77.0
    np.testing.assert_allclose(
        field.velocity(POINTS, t), base.velocity(POINTS, t) + field.tide_m_s(t), atol=1e-15
    )
    np.testing.assert_allclose(
        field.acceleration(POINTS, BODY_VELOCITIES, t),
        fd_acceleration(field, POINTS, BODY_VELOCITIES, t),
        rtol=1e-6,
        atol=1e-10,
    )


# --------------------------------------------------------------------------------- Gauss–Markov


def _gm(seed=11, **kw):
    params = dict(mean_velocity_m_s=(0.3, -0.1), time_constant_s=20.0, sigma_m_s=0.05)
    params.update(kw)
    return GaussMarkovCurrent(seed=seed, **params)


def test_gauss_markov_same_seed_same_values_whatever_the_query_history():
    times = np.sort(np.concatenate([RNG.uniform(0, 3000, 300), [0.0, 0.4, 0.4, 2999.99]]))
    point = np.zeros((1, 2))
    a = _gm()
    forward = np.array([a.velocity(point, t)[0] for t in times])
    b = _gm()
    b.velocity(point, 5000.0)  # jump far ahead first
    for t in RNG.uniform(0, 6000, 50):  # random queries in between
        b.velocity(point, t)
    backward = np.array([b.velocity(point, t)[0] for t in times[::-1]])[::-1]
    np.testing.assert_array_equal(forward, backward)
    # the vectorized query agrees with the per-step one
    np.testing.assert_allclose(_gm().velocity_at_times(times), forward, rtol=0, atol=1e-15)


def test_gauss_markov_different_seeds_differ_and_mean_start():
    t = np.linspace(0.0, 500.0, 101)
    a, b = _gm(seed=1).velocity_at_times(t), _gm(seed=2).velocity_at_times(t)
    assert np.max(np.abs(a - b)) > 0.01
    start = _gm(start="mean")
    np.testing.assert_array_equal(start.velocity(np.zeros((2, 2)), 0.0), [[0.3, -0.1]] * 2)
    flat = _gm(sigma_m_s=0.0)
    np.testing.assert_array_equal(flat.velocity_at_times(t), np.tile([0.3, -0.1], (t.size, 1)))


def test_gauss_markov_variance_and_autocorrelation():
    tau, sigma = 1.0, 0.07
    field = _gm(seed=5, time_constant_s=tau, sigma_m_s=sigma)
    step = field.describe()["step_s"]
    assert step == pytest.approx(tau / 50)
    times = np.arange(0.0, 10000.0 * tau, step)  # knots: exact samples of the process
    x = field.velocity_at_times(times) - [0.3, -0.1]
    # std of the estimates ≈ √(2τ/T) ≈ 1.4 % (variance) per component: 5 % tolerance
    np.testing.assert_allclose(x.mean(axis=0), 0.0, atol=0.05 * sigma)
    np.testing.assert_allclose(x.var(axis=0), sigma**2, rtol=0.05)
    lag = round(tau / step)
    rho = np.mean(x[:-lag] * x[lag:], axis=0) / x.var(axis=0)
    np.testing.assert_allclose(rho, math.exp(-1.0), atol=0.03)
    # the components are independent
    assert abs(np.corrcoef(x[:, 0], x[:, 1])[0, 1]) < 0.05


def test_gauss_markov_acceleration_is_the_slope_of_its_interpolant():
    field = _gm(step_s=0.5)
    point, rest = np.zeros((1, 2)), np.zeros((1, 2))
    h = 1e-3  # the queried times are all > h before the next knot: one linear segment
    for t in (0.0, 0.1, 3.3, 77.7, 1000.2):
        expected = (field.velocity(point, t + h) - field.velocity(point, t)) / h
        np.testing.assert_allclose(field.acceleration(point, rest, t), expected, rtol=1e-6)
        assert np.all(expected != 0.0)
    np.testing.assert_array_equal(field.acceleration(point, rest, -1.0), 0.0)
    np.testing.assert_array_equal(field.velocity(point, -3.0), field.velocity(point, 0.0))


# --------------------------------------------------------------------------------- sum


def test_sum_superposes_and_flattens():
    u = UniformCurrent((0.2, 0.0))
    s = LinearShear((0.0, 0.1), [[0.0, 0.01], [0.0, 0.0]])
    w = Vortex((10.0, 0.0), 5.0, 0.3, drift_m_s=(0.0, 0.1))
    total = u + s + w
    assert isinstance(total, SumCurrent) and len(total.fields) == 3
    assert sum([u, s, w]).describe() == total.describe()
    assert not total.is_steady and not total.is_uniform
    assert (u + u).is_steady and (u + u).is_uniform
    t = 4.0
    np.testing.assert_allclose(
        total.velocity(POINTS, t),
        u.velocity(POINTS, t) + s.velocity(POINTS, t) + w.velocity(POINTS, t),
        atol=1e-15,
    )
    np.testing.assert_allclose(
        total.acceleration(POINTS, BODY_VELOCITIES, t),
        fd_acceleration(total, POINTS, BODY_VELOCITIES, t),
        rtol=1e-6,
        atol=1e-9,
    )


# --------------------------------------------------------------------------------- config


ALL_TYPES_TOML = """
[current]
type = "sum"

[[current.components]]
type = "uniform"
speed_m_s = 0.3
direction_rad = 1.0

[[current.components]]
type = "shear"
base_velocity_m_s = [0.5, 0]
gradient_per_s = [[0.0, -0.01], [0, 0]]

[[current.components]]
type = "vortex"
centre_m = [50.0, -20.0]
core_radius_m = 15
max_speed_m_s = -0.4
profile = "rankine"
drift_m_s = [0.05, 0.0]

[[current.components]]
type = "grid"
x_m = [0.0, 100.0, 200.0]
y_m = [0.0, 100.0]
times_s = [0, 600]
u_m_s = [[[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]], [[0.0, 0.0], [0.1, 0.1], [0.2, 0.2]]]
v_m_s = [[[0.0, 0.0], [0.0, 0.1], [0.0, 0.2]], [[0.0, 0.0], [0.0, 0.1], [0.0, 0.2]]]

[[current.components]]
type = "tidal"
amplitude_m_s = [0.0, 0.5]
period_s = 44712.0
phase_rad = 0.3
[current.components.base]
type = "gauss_markov"
mean_velocity_m_s = [0.3, 0.1]
time_constant_s = 300.0
sigma_m_s = 0.05
seed = 7
"""


def _docstring_examples() -> list[str]:
    """The TOML examples of the module docstring (indented blocks after '::')."""
    blocks = re.findall(r"::\n\n((?:    .*\n|\n)+)", currents.__doc__)
    return [re.sub(r"^    ", "", b, flags=re.M) for b in blocks if "[current]" in b]


def test_every_docstring_example_builds():
    examples = _docstring_examples()
    assert len(examples) == 7
    kinds = set()
    for text in examples:
        table = tomllib.loads(text)["current"]
        field = current_from_config(table)
        kinds.add(table["type"])
        assert field.velocity(POINTS, 10.0).shape == POINTS.shape
    assert kinds == {"uniform", "shear", "vortex", "grid", "tidal", "gauss_markov", "sum"}


def test_config_builds_every_type_and_round_trips_through_describe():
    table = tomllib.loads(ALL_TYPES_TOML)["current"]
    field = current_from_config(table)
    assert isinstance(field, SumCurrent) and len(field.fields) == 5
    uniform, shear, vortex, grid, tidal = field.fields
    np.testing.assert_allclose(uniform.velocity_m_s, [0.3 * math.cos(1.0), 0.3 * math.sin(1.0)])
    assert isinstance(shear, LinearShear) and isinstance(vortex, Vortex)
    assert isinstance(grid, GriddedCurrent) and isinstance(tidal, TidalCurrent)
    assert isinstance(tidal.base, GaussMarkovCurrent)
    description = field.describe()
    rebuilt = current_from_config(description)
    assert rebuilt.describe() == description
    # the description is plain TOML-able data: only lists, floats, ints, strings and dicts
    def plain(value):
        if isinstance(value, dict):
            return all(isinstance(k, str) and plain(v) for k, v in value.items())
        if isinstance(value, list):
            return all(plain(v) for v in value)
        return type(value) in (float, int, str)

    assert plain(description)
    for t in (0.0, 123.4, 900.0):
        np.testing.assert_array_equal(rebuilt.velocity(POINTS, t), field.velocity(POINTS, t))
        np.testing.assert_array_equal(
            rebuilt.acceleration(POINTS, BODY_VELOCITIES, t),
            field.acceleration(POINTS, BODY_VELOCITIES, t),
        )


def test_gauss_markov_seed_can_come_from_the_scenario():
    table = {"type": "gauss_markov", "mean_velocity_m_s": [0, 0], "time_constant_s": 5, "sigma_m_s": 0.1}
    with pytest.raises(ValueError, match=r"^current\.seed: missing$"):
        current_from_config(table)
    derived = current_from_config(table, seed=3).describe()["seed"]
    assert derived == current_from_config(table, seed=3).describe()["seed"]  # reproducible
    assert derived != current_from_config(table, seed=4).describe()["seed"]
    # two unseeded components of one scenario get different noise
    both = current_from_config({"type": "sum", "components": [table, table]}, seed=3)
    first, second = (f.describe()["seed"] for f in both.fields)
    assert first != second
    t = np.linspace(0, 100, 11)
    assert not np.array_equal(both.fields[0].velocity_at_times(t), both.fields[1].velocity_at_times(t))
    # an explicit seed wins, and the description rebuilds the same field without the scenario
    assert current_from_config({**table, "seed": 9}, seed=3).describe()["seed"] == 9
    rebuilt = current_from_config(both.describe())
    np.testing.assert_array_equal(rebuilt.velocity(POINTS, 42.0), both.velocity(POINTS, 42.0))


def _sum_with(second: dict) -> dict:
    return {"type": "sum", "components": [{"type": "uniform", "velocity_m_s": [0.1, 0]}, second]}


VORTEX = {"type": "vortex", "centre_m": [0, 0], "core_radius_m": 5, "max_speed_m_s": 0.3}
GM = {"type": "gauss_markov", "mean_velocity_m_s": [0, 0], "time_constant_s": 5, "sigma_m_s": 0.1, "seed": 1}
GRID = {"type": "grid", "x_m": [0, 1], "y_m": [0, 1, 2], "u_m_s": [[0, 0, 0], [1, 1, 1]], "v_m_s": [[0, 0, 0], [0, 0, 0]]}


@pytest.mark.parametrize(
    ("table", "message"),
    [
        (_sum_with({**VORTEX, "core_radius_m": -2}), "current.components[1].core_radius_m: must be ≥ 0.01, got -2"),
        ({"type": "whirlpool"}, "current.type: unknown current type 'whirlpool'"),
        ({"velocity_m_s": [0, 0]}, "current.type: missing"),
        ("uniform", "current: must be a table, got 'uniform'"),
        ({"type": "uniform"}, "current.velocity_m_s: missing"),
        ({"type": "uniform", "velocity_m_s": [0.1]}, "current.velocity_m_s: must be 2 numbers [x, y], got [0.1]"),
        ({"type": "uniform", "velocity_m_s": "east"}, "current.velocity_m_s: must be 2 numbers"),
        ({"type": "uniform", "velocity_m_s": [0.1, float("nan")]}, "current.velocity_m_s: must be finite"),
        ({"type": "uniform", "velocity_m_s": [True, 0]}, "current.velocity_m_s: must be 2 numbers"),
        ({"type": "uniform", "speed_m_s": -0.3, "direction_rad": 0}, "current.speed_m_s: must be >= 0, got -0.3"),
        ({"type": "uniform", "speed_m_s": 0.3, "direction_rad": float("inf")}, "current.direction_rad: must be finite, got inf"),
        ({"type": "uniform", "velocity_m_s": [0, 0], "speed_m_s": 1}, "current.speed_m_s: give either"),
        ({"type": "uniform", "speed_m_s": 1},
         "current.direction_deg: missing (required with speed_m_s; or direction_rad)"),
        ({"type": "uniform", "speed_m_s": 1, "direction_deg": 90, "direction_rad": 1.5},
         "current.direction_rad: give direction_deg or direction_rad, not both"),
        ({"type": "uniform", "velocity_m_s": [0, 0], "direction_deg": 90}, "current.direction_deg: give either"),
        ({"type": "uniform", "velocity": [0, 0]}, "current.velocity: unknown key for type 'uniform'"),
        ({"type": "shear", "base_velocity_m_s": [0, 0], "gradient_per_s": [0, 0, 0, 0]}, "current.gradient_per_s: must be a 2x2 matrix"),
        ({"type": "shear", "gradient_per_s": [[0, 0], [0, 0]]}, "current.base_velocity_m_s: missing"),
        ({**VORTEX, "profile": "burgers"}, "current.profile: must be one of 'lamb_oseen', 'rankine', got 'burgers'"),
        ({**VORTEX, "max_speed_m_s": "fast"}, "current.max_speed_m_s: must be a number, got 'fast'"),
        ({**VORTEX, "core_radius_m": 0}, "current.core_radius_m: must be ≥ 0.01, got 0"),
        ({**VORTEX, "drift_m_s": [0, 0, 0]}, "current.drift_m_s: must be 2 numbers"),
        ({**GRID, "x_m": [1, 0]}, "current.x_m: must be at least 2 strictly increasing numbers"),
        ({**GRID, "u_m_s": [[0, 0], [1, 1]]}, "current.u_m_s: must have shape [2, 3], got [2, 2]"),
        ({**GRID, "v_m_s": [[0, 0, 0], [0, 0]]}, "current.v_m_s: must be an array of shape [2, 3], got a ragged array"),
        ({**GRID, "times_s": [0.0, 10.0]}, "current.u_m_s: must be an array of shape [2, 2, 3]"),
        ({"type": "tidal", "amplitude_m_s": [0, 1], "period_s": -5}, "current.period_s: must be ≥ 60.0, got -5.0"),
        ({"type": "tidal", "amplitude_m_s": [0, 1], "period_s": 12.42}, "current.period_s: must be ≥ 60.0, got 12.42"),
        ({"type": "tidal", "amplitude_m_s": [0, 1], "period_s": 600, "base": {**VORTEX, "core_radius_m": -1}}, "current.base.core_radius_m: must be ≥ 0.01, got -1"),
        ({"type": "tidal", "amplitude_m_s": [0, 1], "period_s": 600, "base": {"type": "uniform", "velocity_m_s": [0, 0]}, "mean_velocity_m_s": [0, 0]}, "current.mean_velocity_m_s: give either base or mean_velocity_m_s"),
        ({"type": "tidal", "period_s": 600}, "current.amplitude_m_s: missing"),
        ({**GM, "time_constant_s": -1.5}, "current.time_constant_s: must be ≥ 1.0, got -1.5"),
        ({**GM, "sigma_m_s": -0.1}, "current.sigma_m_s: must be >= 0, got -0.1"),
        ({**GM, "seed": 1.5}, "current.seed: must be an integer >= 0, got 1.5"),
        ({**GM, "seed": -1}, "current.seed: must be an integer >= 0, got -1"),
        ({**GM, "step_s": 0}, "current.step_s: must be ≥ 0.01, got 0"),
        ({**GM, "start": "zero"}, "current.start: must be one of 'stationary', 'mean', got 'zero'"),
        ({"type": "sum", "components": []}, "current.components: must contain at least one component"),
        ({"type": "sum", "components": {"type": "uniform"}}, "current.components: must be a list of tables"),
        ({"type": "sum"}, "current.components: missing"),
        (_sum_with({"type": "sum", "components": [GM, {**GM, "sigma_m_s": float("nan")}]}), "current.components[1].components[1].sigma_m_s: must be finite, got nan"),
        (_sum_with({"type": "gauss_markov"}), "current.components[1].mean_velocity_m_s: missing"),
        (_sum_with(5), "current.components[1]: must be a table, got 5"),
    ],
)
def test_config_errors_name_the_field_path(table, message):
    with pytest.raises(ValueError) as error:
        current_from_config(table)
    assert str(error.value).startswith(message), str(error.value)


def test_constructor_errors_name_the_parameter():
    with pytest.raises(ValueError, match="core_radius_m: must be ≥ 0.01, got -2"):
        Vortex((0, 0), -2, 0.3)
    with pytest.raises(ValueError, match="time_constant_s: must be ≥ 1.0"):
        GaussMarkovCurrent((0, 0), 0.0, 0.1, seed=1)
    with pytest.raises(ValueError, match="give either velocity_m_s or speed_m_s"):
        UniformCurrent((0.1, 0.0), speed_m_s=0.1, direction_rad=0.0)
    with pytest.raises(ValueError, match="velocities_m_s: must match"):
        Vortex((0, 0), 2, 0.3).acceleration(POINTS, BODY_VELOCITIES[:3], 0.0)
    with pytest.raises(ValueError, match=r"fields\[1\]: must be a CurrentField"):
        SumCurrent([UniformCurrent((0, 0)), (0.1, 0.2)])
