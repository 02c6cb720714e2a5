"""Harmonic potential field (thesis §4.1, App. A; docs/thesis.md §4): closed forms against quadrature,
the classical source-panel limit against potential-flow theory, the robust bound against the
thesis's claims, and degenerate input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from mjasc.avoidance.potential_field import PotentialField, Streamline, panel_influence
from mjasc.core.geometry import (
    clean_polygon,
    inflate_polygon,
    point_in_polygon,
    polygon_signed_area,
    signed_distance_to_polygon,
)


def regular_polygon(n, radius=1.0, centre=(0.0, 0.0), phase=0.0):
    th = phase + np.arange(n) * 2 * np.pi / n
    return np.column_stack([centre[0] + radius * np.cos(th), centre[1] + radius * np.sin(th)])


def square(cx, cy, half):
    return np.array([[-half, -half], [half, -half], [half, half], [-half, half]]) + [cx, cy]


def quadrature_influence(p, a, b):
    """1/(2π) ∫_panel (p − q)/‖p − q‖² dl_q by adaptive quadrature."""
    L = np.linalg.norm(b - a)

    def comp(s, k):
        q = a + s * (b - a)
        d = p - q
        return d[k] / (d @ d)

    return np.array([quad(comp, 0.0, 1.0, args=(k,), epsabs=1e-13, epsrel=1e-12)[0] for k in (0, 1)]) * L / (2 * np.pi)


# ---------------------------------------------------------------------------- one panel


def test_panel_closed_form_matches_quadrature():
    rng = np.random.default_rng(0)
    for _ in range(20):
        a, b = rng.uniform(-5, 5, 2), rng.uniform(-5, 5, 2)
        # points at least 0.3 panel lengths away from the segment
        while True:
            p = rng.uniform(-8, 8, 2)
            if signed_distance_to_polygon(p[None], np.array([a, b, b + 1e-9]))[0] > 0.3 * np.linalg.norm(b - a):
                break
        w = panel_influence(p[None], a[None], b[None])[0, 0]
        np.testing.assert_allclose(w, quadrature_influence(p, a, b), atol=1e-10)


def test_panel_normal_velocity_jumps_by_strength():
    # thesis eq. 4.3: u_n → +λ/2 just outside (normal side), −λ/2 just inside; tangential continuous
    a, b = np.array([1.0, 2.0]), np.array([4.0, -1.0])
    t = (b - a) / np.linalg.norm(b - a)
    n = np.array([t[1], -t[0]])
    for s in (0.2, 0.5, 0.9):
        c = a + s * (b - a)
        eps = 1e-7
        w_out = panel_influence((c + eps * n)[None], a[None], b[None])[0, 0]
        w_in = panel_influence((c - eps * n)[None], a[None], b[None])[0, 0]
        assert w_out @ n == pytest.approx(0.5, abs=1e-6)
        assert w_in @ n == pytest.approx(-0.5, abs=1e-6)
        assert (w_out - w_in) @ n == pytest.approx(1.0, abs=1e-6)
        assert (w_out - w_in) @ t == pytest.approx(0.0, abs=1e-5)
    # tangential velocity is zero at the panel centre (thesis: "starts from zero at the center")
    w_c = panel_influence((0.5 * (a + b) + 1e-9 * n)[None], a[None], b[None])[0, 0]
    assert w_c @ t == pytest.approx(0.0, abs=1e-8)


def test_influence_matrix_is_digest_integral():
    # P_ij = I_ij / 2π with I_ij = ∫_j ∂/∂n_i ln‖c_i − q‖ dl_q (docs/thesis.md §4); P_ii = 1/2
    f = PotentialField([square(0, 0, 1.0), regular_polygon(5, 1.0, (4.0, 1.0))], uniform_direction=0.3)
    pan = f.panels
    P = f.influence_matrix
    np.testing.assert_allclose(np.diag(P), 0.5)
    for i, j in [(0, 1), (1, 3), (2, 6), (7, 0), (8, 4)]:
        ci, ni, a, b = pan.centre[i], pan.normal[i], pan.start[j], pan.end[j]
        L = np.linalg.norm(b - a)

        def dn_log(s):
            d = ci - (a + s * (b - a))
            return (d @ ni) / (d @ d)

        I_ij = quad(dn_log, 0, 1, epsabs=1e-13, limit=200)[0] * L
        assert P[i, j] == pytest.approx(I_ij / (2 * np.pi), abs=1e-10)


# ---------------------------------------------------------------------------- classical panel method


def test_circle_classical_source_panel_method():
    """V_i = 0, no sink, uniform flow only: the aerodynamic source-panel method."""
    U, R, m = 1.3, 2.0, 64
    f = PotentialField([regular_polygon(m, R)], uniform_speed=U, uniform_direction=0.0)
    pan = f.panels
    cv = f.control_point_velocity()
    # flow tangent to the body at the control points
    np.testing.assert_allclose(np.einsum("ij,ij->i", cv, pan.normal), 0.0, atol=1e-12)
    # closed body: net source strength ≈ 0
    assert abs(f.net_obstacle_strength) < 1e-9 * np.sum(np.abs(f.strengths) * pan.length)
    # surface speed → potential-flow value 2U|sin θ|
    theta = np.arctan2(pan.centre[:, 1], pan.centre[:, 0])
    np.testing.assert_allclose(np.linalg.norm(cv, axis=1), 2 * U * np.abs(np.sin(theta)), atol=1e-9)
    # and just off the surface the field of velocity() agrees with the exterior limit
    off = f.velocity(pan.centre + 1e-7 * pan.normal)
    np.testing.assert_allclose(off, cv, atol=1e-5)
    # far away → U; at 2R, exact potential flow u_x = U(1 − R²/r² cos 2θ) on the axis
    np.testing.assert_allclose(f.velocity(np.array([[3e4, -2e4]])), [[U, 0.0]], atol=1e-4)
    # off the body the panel solution converges to the cylinder's exact potential flow
    # u = U(1 − R²/r² cos 2θ, −R²/r² sin 2θ), error ∝ 1/m
    r_probe = np.array([[0.0, 2 * R], [-2 * R, 0.0], [3 * R, 0.0], [2 * R, 2 * R]])
    rr2 = np.sum(r_probe**2, axis=1)
    th = np.arctan2(r_probe[:, 1], r_probe[:, 0])
    exact = U * np.column_stack([1 - R**2 / rr2 * np.cos(2 * th), -R**2 / rr2 * np.sin(2 * th)])
    err_64 = np.abs(f.velocity(r_probe) - exact).max()
    fine = PotentialField([regular_polygon(4 * m, R)], uniform_speed=U, uniform_direction=0.0)
    err_256 = np.abs(fine.velocity(r_probe) - exact).max()
    assert err_256 < 2e-3 * U
    assert 3.0 < err_64 / err_256 < 5.0


def test_fast_velocity_matches_reference_sum():
    obs = [square(0, 0, 1.5), regular_polygon(7, 1.2, (6, 2)), np.array([[10, -3], [14, -3], [12, 0.5]])]
    f = PotentialField(obs, goal=[20, 1], start=[-8, 0], safety_ratio=0.5, inflation=0.3, panels_per_edge=2)
    pts = np.random.default_rng(1).uniform([-10, -6], [22, 6], (400, 2))
    pan = f.panels
    d = pts - f.goal
    ref = (
        f.uniform_speed * np.array([np.cos(f.uniform_direction), np.sin(f.uniform_direction)])
        - f.sink_strength / (2 * np.pi) * d / np.sum(d * d, axis=1)[:, None]
        + np.einsum("nmk,m->nk", panel_influence(pts, pan.start, pan.end), f.strengths)
    )
    np.testing.assert_allclose(f.velocity(pts), ref, atol=1e-10)
    np.testing.assert_allclose(f.velocity(pts, chunk=7), ref, atol=1e-10)
    np.testing.assert_allclose(f.velocity(pts[3]), ref[3], atol=1e-10)


def test_boundary_condition_holds_with_sink_and_normal_velocity():
    obs = [square(10, 1, 2.0)]
    V = np.linspace(0.1, 0.9, 8)
    f = PotentialField(obs, goal=[25, 0], start=[0, 0], normal_velocity=V, panels_per_edge=2)
    vn = np.einsum("ij,ij->i", f.control_point_velocity(), f.panels.normal)
    np.testing.assert_allclose(vn, V, atol=1e-12)
    # default α points from the start to the goal
    assert f.uniform_direction == pytest.approx(0.0)


# ---------------------------------------------------------------------------- robust field


def _square_field(r):
    return PotentialField([square(20, 2, 3)], goal=[40, 0], start=[0, 0], safety_ratio=r,
                          inflation=1.0, panels_per_edge=3, sink_strength=30.0)


def test_robust_rule_algebra():
    f1, f05 = _square_field(1.0), _square_field(0.5)
    L = f1.panels.length
    # V_j = a·L_j with a = r·a_max; at r = 1 the net obstacle strength equals the sink (eq. 4.29)
    np.testing.assert_allclose(f1.normal_velocities, f1.alpha_max * L)
    np.testing.assert_allclose(f05.normal_velocities, 0.5 * f05.alpha_max * L)
    assert f1.net_obstacle_strength == pytest.approx(30.0, rel=1e-10)
    # λ_ob is affine in r: λ_ob(r) = r(λ_g − LᵀJb) + LᵀJb
    f0 = _square_field(0.0)
    assert f05.net_obstacle_strength == pytest.approx(0.5 * (f0.net_obstacle_strength + 30.0), rel=1e-10)
    # a_max = (λ_g − LᵀJb)/(LᵀJL), J = P⁻¹ (docs/thesis.md §4)
    J = np.linalg.inv(f1.influence_matrix)
    assert f1.alpha_max == pytest.approx((30.0 - L @ J @ f1.rhs_free_stream) / (L @ J @ L), rel=1e-10)


def test_safety_ratio_sweep_reaches_goal_with_growing_clearance():
    ratios = [0.1, 0.2, 0.4, 0.6, 0.8, 1.0]
    clearance = []
    for r in ratios:
        f = _square_field(r)
        s = f.streamline(step=1.0)
        assert s.reached_goal, (r, s.reason)
        assert np.allclose(s.points[-1], f.goal)
        clearance.append(f.distance_to_obstacles(s.points).min())
    assert min(clearance) > 0
    assert np.all(np.diff(clearance) > 0), clearance


@pytest.mark.parametrize("r", [1.2, 2.0])
def test_beyond_the_bound_the_goal_is_missed(r):
    f = _square_field(r)
    assert f.net_obstacle_strength > f.sink_strength
    s = f.streamline(step=1.0)
    assert not s.reached_goal and s.reason == "runaway"


def test_dock_scenario_sweep_like_thesis():
    from mjasc.figures.potential_field import dock_scenario, safety_ratio_sweep

    sc = dock_scenario()
    runs = safety_ratio_sweep((0.2, 0.3, 0.7, 1.0), scenario=sc, step=1.0)
    assert all(len(run.field.panels) == 24 for run in runs)  # as thesis Table 6.2 (b)
    clear = []
    for run in runs:
        assert run.path.reached_goal, (run.safety_ratio, run.path.reason)
        clear.append(run.field.distance_to_obstacles(run.path.points).min())
        # the quay (not paneled: upstream of the start) is never approached
        assert signed_distance_to_polygon(run.path.points, sc.quay).min() > sc.inflation_m
        assert run.field.net_obstacle_strength <= 30.0 + 1e-9
    assert min(clear) > 0 and clear[-1] > clear[0]
    # r = 1 leaves the bottleneck between vessels 1 and 3 alone: passes south of vessel 3
    r1 = runs[-1].path.points
    near = np.abs(r1[:, 0] - sc.starts[2, 0]) < 2.0
    assert np.all(r1[near, 1] < sc.starts[2, 1] - sc.inflation_m)
    # beyond the bound the path misses the goal, as the thesis says
    (over,) = safety_ratio_sweep((1.3,), scenario=sc, step=1.0)
    assert not over.path.reached_goal
    # (c): λ_g = 70, U = 1.85, r = 0.2 with 32 panels
    (c,) = safety_ratio_sweep((0.2,), 70.0, 1.85, with_pontoon=True, scenario=sc, step=1.0)
    assert len(c.field.panels) == 32 and c.path.reached_goal
    assert c.field.distance_to_obstacles(c.path.points).min() > 0


def test_no_local_minima_from_random_starts():
    obs = [square(8, 3, 2.0), regular_polygon(6, 2.5, (18, -4)), np.array([[26, 2], [31, 2], [28, 7]])]
    f = PotentialField(obs, goal=[40, 0], uniform_direction=0.0, uniform_speed=1.0, sink_strength=120.0,
                       safety_ratio=0.5, inflation=1.0, panels_per_edge=2)
    rng = np.random.default_rng(42)
    starts = rng.uniform([-15, -15], [35, 15], (200, 2))
    starts = starts[f.distance_to_obstacles(starts) > 0.2][:60]
    lines = f.streamlines(starts, step=1.0)
    reasons = [s.reason for s in lines]
    assert all(s.reached_goal for s in lines), reasons
    assert all(f.distance_to_obstacles(s.points[:-1]).min() > 0 for s in lines)


# ---------------------------------------------------------------------------- streamline statuses


def test_streamline_stagnation_on_a_saddle():
    # Sink at the origin, emitting obstacle on the +x axis, no uniform flow: on the axis behind
    # the obstacle the flow goes out near it and in far away → a saddle; a start on the axis
    # beyond it runs into it (by symmetry) and stalls.
    f = PotentialField([square(10, 0, 3)], goal=[0, 0], uniform_speed=0.0, uniform_direction=0.0,
                       normal_velocity=1.0, sink_strength=30.0)
    s = f.streamline([100.0, 0.0], step=1.0)
    assert s.reason == "stagnation" and not s.reached_goal
    end = s.points[-1]
    assert np.linalg.norm(f.velocity(end)) < 1e-3 * np.linalg.norm(f.velocity([60.0, 0.0]))


def test_streamline_runaway_and_goal_statuses():
    f = PotentialField([], goal=[0, 0], uniform_direction=0.0, uniform_speed=1.0, sink_strength=30.0)
    x_stag = 30.0 / (2 * np.pi)  # sink + uniform flow: stagnation point downstream of the sink
    s = f.streamline([x_stag + 5.0, 0.0], step=0.5)
    assert s.reason == "runaway" and not s.reaches_goal
    s = f.streamline([x_stag - 1.0, 0.0], step=0.5, goal_tolerance=0.05)
    assert isinstance(s, Streamline) and s.reached_goal and s.reaches_goal and s.reason == "goal"
    steps = np.linalg.norm(np.diff(s.points, axis=0), axis=1)
    assert steps.max() <= 0.5 + 1e-12  # arc-length steps bounded by `step`
    assert s.length == pytest.approx(x_stag - 1.0, rel=1e-9)  # straight into the sink


def test_streamline_into_front_stagnation_of_a_body_is_reported():
    # classical V = 0 body: the axis streamline ends on the body at its stagnation point
    f = PotentialField([regular_polygon(32, 2.0, phase=np.pi / 32)], uniform_direction=0.0)
    s = f.streamline([-10.0, 0.0], step=0.5)
    assert s.reason == "entered_obstacle" and s.obstacle == 0
    assert s.points[-1, 0] == pytest.approx(-2.0, abs=0.1)


# ---------------------------------------------------------------------------- polygons and degenerate input


def test_polygon_cleaning():
    sq = square(0, 0, 1)
    # clockwise → reversed (counter-clockwise); explicit closing vertex and duplicates dropped
    cw = np.vstack([sq[::-1], sq[::-1][:1]])
    c = clean_polygon(np.insert(cw, 2, cw[2], axis=0))
    assert len(c) == 4 and polygon_signed_area(c) == pytest.approx(4.0)
    # collinear vertices merged
    col = np.array([[-1, -1], [0, -1], [1, -1], [1, 0], [1, 1], [-1, 1]], float)
    assert len(clean_polygon(col)) == 4
    f = PotentialField([sq[::-1]], uniform_direction=0.0)
    assert polygon_signed_area(f.polygons[0]) > 0
    # outward normals: from the centre towards the control points
    assert np.all(np.einsum("ij,ij->i", f.panels.normal, f.panels.centre) > 0)


@pytest.mark.parametrize(
    "poly, match",
    [
        (np.array([[0, 0], [1, 0], [0, 0]], float), "3 distinct vertices"),
        (np.array([[0, 0], [1, 0], [2, 0]], float), "no area|zero area|folds back"),
        (np.array([[0, 0], [2, 2], [2, 0], [0, 2]], float), "self-intersecting"),
        (np.array([[0, 0], [2, 0], [1, 0], [1, 1]], float), "folds back"),
        (np.array([[0, 0], [1, 0], [np.nan, 1]]), "finite"),
        (np.zeros((3, 3)), r"shape \(k, 2\)"),
    ],
)
def test_degenerate_polygons_raise(poly, match):
    with pytest.raises(ValueError, match=match):
        PotentialField([square(10, 10, 1), poly], uniform_direction=0.0)


def test_inflation_offset():
    # square: 90° corners keep a miter; every original point ends ≥ margin inside
    d = 0.7
    inf = inflate_polygon(square(0, 0, 1), d)
    np.testing.assert_allclose(np.sort(np.abs(inf), axis=0), np.full((4, 2), 1 + d))
    # sharp triangle: tangent bevels, still ≥ d everywhere, never more than d/cos(45°)... at corners
    tri = clean_polygon(np.array([[0, 0], [6, 0], [3, 1]], float))
    inf = inflate_polygon(tri, d)
    assert len(inf) > 3
    s = np.linspace(0, 1, 50)[:, None]
    edge_pts = np.concatenate([tri[i] + s * (tri[(i + 1) % 3] - tri[i]) for i in range(3)])
    assert signed_distance_to_polygon(edge_pts, inf).max() <= -d * (1 - 1e-9)
    corner_depth = -signed_distance_to_polygon(tri, inf)
    assert corner_depth.max() < d * 1.0001  # bevel tangent to the clearance circle
    # concave L: miter at the reflex corner
    L = np.array([[0, 0], [4, 0], [4, 1], [1, 1], [1, 4], [0, 4]], float)
    infL = inflate_polygon(L, 0.25)
    assert point_in_polygon(np.array([[1.2, 1.2]]), infL)[0]
    assert not point_in_polygon(np.array([[1.3, 1.3]]), infL)[0]
    # a notch narrower than twice the margin is swallowed → error
    U = np.array([[0, 0], [5, 0], [5, 5], [3, 5], [3, 1], [2, 1], [2, 5], [0, 5]], float)
    with pytest.raises(ValueError, match="inflation"):
        PotentialField([U], uniform_direction=0.0, inflation=0.8)
    with pytest.raises(ValueError, match="inflation"):
        PotentialField([square(0, 0, 1)], uniform_direction=0.0, inflation=-1.0)


def test_bad_field_arguments_raise():
    obs = [square(10, 0, 2)]
    with pytest.raises(ValueError, match=r"goal .* inside obstacle 1"):
        PotentialField([square(-20, 0, 1), square(10, 0, 2)], goal=[10.5, 0.5], uniform_direction=0.0)
    with pytest.raises(ValueError, match=r"goal .* inside obstacle 0 \(inflated by 1.0 m\)"):
        PotentialField(obs, goal=[12.5, 0], uniform_direction=0.0, inflation=1.0)  # in the margin only
    with pytest.raises(ValueError, match=r"start .* inside obstacle 0"):
        PotentialField(obs, goal=[30, 0], start=[12.5, 0], inflation=1.0)
    f = PotentialField(obs, goal=[30, 0], uniform_direction=0.0, inflation=1.0)
    with pytest.raises(ValueError, match=r"start .* inside obstacle 0"):
        f.streamline([12.5, 0.0])
    with pytest.raises(ValueError, match="overlap"):
        PotentialField([square(0, 0, 1), square(2.5, 0, 1)], uniform_direction=0.0, inflation=0.5)
    with pytest.raises(ValueError, match="uniform_direction is required"):
        PotentialField(obs, goal=[30, 0])
    with pytest.raises(ValueError, match=r"normal_velocity .*one value per panel \(4 panels\)"):
        PotentialField(obs, goal=[30, 0], uniform_direction=0.0, normal_velocity=[1.0, 2.0])
    with pytest.raises(ValueError, match="either normal_velocity or safety_ratio"):
        PotentialField(obs, goal=[30, 0], uniform_direction=0.0, normal_velocity=1.0, safety_ratio=0.5)
    with pytest.raises(ValueError, match="needs a goal"):
        PotentialField(obs, uniform_direction=0.0, safety_ratio=0.5)
    with pytest.raises(ValueError, match="safety_ratio"):
        PotentialField(obs, goal=[30, 0], uniform_direction=0.0, safety_ratio=-0.1)
    with pytest.raises(ValueError, match="sink_strength"):
        PotentialField(obs, goal=[30, 0], uniform_direction=0.0, sink_strength=0.0)
    with pytest.raises(ValueError, match="panels_per_edge"):
        PotentialField(obs, uniform_direction=0.0, panels_per_edge=0)


def test_panel_subdivision():
    f = PotentialField([square(0, 0, 2)], uniform_direction=0.0, panels_per_edge=6)
    assert len(f.panels) == 24 and np.allclose(f.panels.length, 4 / 6)
    g = PotentialField([np.array([[0, 0], [10, 0], [10, 1], [0, 1]], float)], uniform_direction=0.0,
                       max_panel_length=1.0)
    assert len(g.panels) == 22 and g.panels.length.max() <= 1.0 + 1e-12
    # consecutive panels join up, per obstacle
    np.testing.assert_allclose(g.panels.end, g.panels.start[g.panels.next_index])


def test_make_figures_writes_pngs(tmp_path):
    from mjasc.figures.potential_field import dock_scenario, make_figures

    paths = make_figures(tmp_path)
    assert len(paths) == 2
    for p in paths:
        assert p.exists() and p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    d = dock_scenario().as_dict()
    assert len(d["starts"]) == 3 and len(d["goals"]) == 3


def test_dock_figure_labels_each_hull_nearest_its_own_hull():
    """Every vessel's name label in the dock figure sits closer to its own hull than to any other
    and covers no other hull (on paper, as drawn): with labels 9 pt above each hull, "vessel 3"
    sat on vessel 1's hull."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mjasc.figures.potential_field import HULL_LABEL_GID, _draw_scene, dock_scenario

    sc = dock_scenario()
    fig, ax = plt.subplots(figsize=(6, 4.2))  # a panel of the committed figure
    try:
        _draw_scene(ax, sc)
        ax.set_xlim(-20, 80)
        ax.set_ylim(-35, 35)
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        labels = [t for t in ax.texts if t.get_gid() == HULL_LABEL_GID]
        assert [t.get_text() for t in labels] == list(sc.names)
        hulls_px = [ax.transData.transform(h) for h in sc.hulls]
        for k, t in enumerate(labels):
            box = t.get_window_extent(renderer)
            centre = np.array([0.5 * (box.x0 + box.x1), 0.5 * (box.y0 + box.y1)])
            dist = [np.min(np.hypot(*(h - centre).T)) for h in hulls_px]
            assert int(np.argmin(dist)) == k, (t.get_text(), dist)
            for j, h in enumerate(hulls_px):
                if j != k:
                    inside = (h[:, 0] >= box.x0) & (h[:, 0] <= box.x1) & (h[:, 1] >= box.y0) & (h[:, 1] <= box.y1)
                    assert not inside.any(), (t.get_text(), sc.names[j])
            # nor on the quay (vessel 2's label, left of its hull, lay on it)
            quay = ax.transData.transform(sc.quay)
            assert box.x0 > quay[:, 0].max() or box.x1 < quay[:, 0].min() or box.y0 > quay[:, 1].max() or \
                box.y1 < quay[:, 1].min(), (t.get_text(), "quay")
    finally:
        plt.close(fig)
