"""The compiled streamline tracer (mjasc.avoidance.potential_field.streamline_kernels) against its
numpy form, bit for bit, and the numpy operations whose bits it repeats."""

from __future__ import annotations

import math
from unittest import mock

import numpy as np
import pytest

from mjasc.avoidance.potential_field import PotentialField, streamlines
from mjasc.avoidance.potential_field.streamline_kernels import MAX_PANELS, row_product
from mjasc.core.compiled import pairwise_sum
from mjasc.core.compiled import kernel


def _numpy_form():
    """Run the tracer's numpy form (the reference): no field is small enough for the kernel."""
    return mock.patch.object(streamlines, "MAX_PANELS", -1)


def _same(field, starts, **kw):
    """The compiled and the numpy tracer give the same lines, bit for bit; the lines."""
    fast = field.streamlines(starts, **kw)
    with _numpy_form():
        ref = field.streamlines(starts, **kw)
    assert len(fast) == len(ref)
    for a, b in zip(fast, ref):
        assert a.points.dtype == b.points.dtype and np.array_equal(a.points, b.points)
        assert (a.reason, a.reached_goal, a.obstacle) == (b.reason, b.reached_goal, b.obstacle)
    return fast


def _box(cx, cy, w, h):
    return np.array([[cx - w, cy - h], [cx + w, cy - h], [cx + w, cy + h], [cx - w, cy + h]])


def _regular(n, radius, centre=(0.0, 0.0), phase=0.0):
    th = phase + np.arange(n) * 2 * np.pi / n
    return np.column_stack([centre[0] + radius * np.cos(th), centre[1] + radius * np.sin(th)])


@kernel
def _row_products(X, A, out):
    for i in range(X.shape[0]):
        for c in range(A.shape[1]):
            out[i, c] = row_product(X[i], A, c, X.shape[0])


def test_row_product_has_openblas_order():
    """numpy's (k, m) @ (m, 2): dgemv's order for one row, dgemm's for several (up to MAX_PANELS)."""
    rng = np.random.default_rng(0)
    for m in list(range(1, 40)) + [64, 127, 128, 129, 200, MAX_PANELS]:
        for k in range(1, 6):
            for _ in range(5):
                X = rng.normal(size=(k, m)) * 10.0 ** rng.uniform(-3, 3, size=(k, m))
                A = rng.normal(size=(m, 2)) * 10.0 ** rng.uniform(-3, 3, size=(m, 2))
                out = np.empty((k, 2))
                _row_products(X, A, out)
                assert np.array_equal(out, X @ A), (k, m)


@kernel
def _libm(x, y, out):
    for i in range(x.size):
        out[0, i] = math.log(x[i])
        out[1, i] = math.atan2(y[i], x[i])
        out[2, i] = math.hypot(y[i], x[i])
        out[3, i] = math.sqrt(x[i])


def test_numpy_functions_have_math_bits_and_einsum_is_unfused():
    """What the kernel relies on (docs/architecture.md, compiled kernels): numpy's log, arctan2,
    hypot and sqrt give math's bits here, and einsum's row dot of two columns is unfused."""
    rng = np.random.default_rng(1)
    x = np.abs(rng.normal(size=200_000)) * 10.0 ** rng.uniform(-3, 6, size=200_000)
    y = rng.normal(size=200_000) * 10.0 ** rng.uniform(-3, 6, size=200_000)
    out = np.empty((4, x.size))
    _libm(x, y, out)
    assert np.array_equal(out, np.stack([np.log(x), np.arctan2(y, x), np.hypot(y, x), np.sqrt(x)]))
    a, b = rng.normal(size=(200_000, 2)), rng.normal(size=(200_000, 2))
    for n in (1, 2, 5, 200_000):
        assert np.array_equal(np.einsum("ij,ij->i", a[:n], b[:n]), a[:n, 0] * b[:n, 0] + a[:n, 1] * b[:n, 1])


def test_pairwise_sum_is_reduceats():
    rng = np.random.default_rng(2)
    for m in (1, 2, 5, 8, 9, 16, 17, 130, 300):
        b = rng.normal(size=(3, m)) * 1e3
        cuts = sorted(rng.choice(np.arange(1, m), size=min(2, m - 1), replace=False).tolist()) if m > 1 else []
        offsets = np.array([0] + cuts)
        ref = np.add.reduceat(b, offsets, axis=1)
        for i in range(3):
            for k, lo in enumerate(offsets):
                hi = offsets[k + 1] if k + 1 < len(offsets) else m
                assert b[i, lo] + pairwise_sum(b[i], lo + 1, hi - lo - 1) == ref[i, k]


def test_dock_fields_as_the_numpy_form():
    """The thesis's dock fields (§6.2, the re-planning's geometry) from every start offset."""
    from mjasc.figures.potential_field import safety_ratio_sweep

    for ratios, lam, u, pontoon in (((0.2, 0.7, 1.0, 1.3), 30.0, 1.0, False), ((0.2,), 70.0, 1.85, True)):
        for run in safety_ratio_sweep(ratios, lam, u, with_pontoon=pontoon, step=1.0):
            f = run.field
            starts = np.array([f.start + [0.0, o] for o in (0.0, 0.3, -0.3, 1.0, -1.0)])
            for step in (0.5, 1.0):
                _same(f, starts, step=step)
                _same(f, starts[:1], step=step)


def test_statuses_as_the_numpy_form():
    """Stagnation, runaway, goal and entered obstacle, and a field without panels or goal."""
    f = PotentialField([_box(10, 0, 3, 3)], goal=[0, 0], uniform_speed=0.0, uniform_direction=0.0,
                       normal_velocity=1.0, sink_strength=30.0)
    assert _same(f, np.array([[100.0, 0.0]]), step=1.0)[0].reason == "stagnation"
    f = PotentialField([], goal=[0, 0], uniform_direction=0.0, uniform_speed=1.0, sink_strength=30.0)
    x_stag = 30.0 / (2 * np.pi)
    lines = _same(f, np.array([[x_stag + 5.0, 0.0], [x_stag - 1.0, 0.0]]), step=0.5, goal_tolerance=0.05)
    assert [s.reason for s in lines] == ["runaway", "goal"]
    f = PotentialField([_regular(32, 2.0, phase=np.pi / 32)], uniform_direction=0.0)
    line = _same(f, np.array([[-10.0, 0.0], [-10.0, 0.5]]), step=0.5)[0]
    assert line.reason == "entered_obstacle" and line.obstacle == 0
    f = PotentialField([], uniform_direction=0.3)
    assert _same(f, np.array([[0.0, 0.0], [1.0, 1.0]]), step=1.0, max_length=2.0)[0].reason == "max_length"


@pytest.mark.parametrize("seed", range(4))
def test_random_fields_as_the_numpy_form(seed):
    rng = np.random.default_rng(seed)
    done = 0
    while done < 12:
        obstacles = [_box(rng.uniform(10, 50), rng.uniform(-15, 15), rng.uniform(1, 5), rng.uniform(1, 5))
                     for _ in range(rng.integers(0, 4))]
        try:
            f = PotentialField(obstacles, goal=[60.0, rng.uniform(-5, 5)], start=[0.0, 0.0],
                               sink_strength=rng.uniform(20, 80),
                               safety_ratio=rng.uniform(0, 1.3) if obstacles else None, inflation=1.5,
                               max_panel_length=float(rng.choice([1.0, 2.0, 5.0])))
        except ValueError:
            continue
        starts = np.array([[0.0, o] for o in (0.0, 0.3, -0.3, 1.0, -1.0)][: rng.integers(1, 6)])
        starts = np.array([s for s in starts if f.obstacle_containing(s) is None])
        _same(f, starts, step=float(rng.choice([0.5, 1.0, 2.0])), max_length=300.0)
        done += 1


def test_more_panels_than_the_kernel_sums_run_the_numpy_form():
    f = PotentialField([_regular(8, 10.0, (30.0, 0.0))], goal=[60.0, 0.0], start=[0.0, 0.0], safety_ratio=0.5,
                       max_panel_length=0.2)
    assert len(f.panels) > MAX_PANELS
    with mock.patch.object(streamlines, "trace_compiled", side_effect=AssertionError("not for this field")):
        assert len(f.streamline(step=1.0).points) > 1
