"""Campaign parameter laws: parsing with errors that name the field, the inverse-CDF maps, one
uniform variate per declared parameter (so one law never moves another's draw), grids as a
Cartesian product (the last grid fastest), and laws checked against the parameters' declarations."""

from dataclasses import dataclass

import numpy as np
import pytest
from scipy.stats import norm

from mjasc.campaigns.distributions import (
    Choice,
    Fixed,
    Grid,
    Normal,
    ParameterSpace,
    Uniform,
    family_rng,
    parse_law,
)
from mjasc.core.config_tables import ConfigError, param, read_field


@dataclass(frozen=True)
class P:
    speed_ratio: float = param(1.0, positive=True, maximum=4.0, doc="ratio")
    angle_deg: float = param(0.0, doc="unbounded")
    n: int = param(1, minimum=1, maximum=5, doc="count")
    role: str = param("a", choices=("a", "b"), doc="a string")


def check(name, value, where):
    parent, _, key = where.rpartition(".")
    return read_field(P, name, {key: value}, parent, key=key)


DECLARED = {"speed_ratio": 1.0, "angle_deg": 0.0, "n": 1, "role": "a"}


def space(given, runs_per_point=1):
    return ParameterSpace.build(DECLARED, given, "families[0].parameters", check, runs_per_point)


def test_laws_parse_and_map_a_uniform_variate_by_their_inverse_cdf():
    assert parse_law(2.5, "x") == Fixed(2.5) and parse_law("b", "x") == Fixed("b")
    u = parse_law({"uniform": [2.0, 4.0]}, "x")
    assert u == Uniform(2.0, 4.0) and u.value(0.25) == 2.5
    n = parse_law({"normal": [1.0, 0.5]}, "x")
    assert n.value(0.5) == 1.0 and n.value(0.975) == pytest.approx(1.0 + 0.5 * norm.ppf(0.975), abs=1e-12)
    assert np.isfinite(n.value(0.0))
    c = parse_law({"normal": [1.0, 0.5], "clip": [0.8, 1.1]}, "x")
    assert c == Normal(1.0, 0.5, (0.8, 1.1)) and c.value(0.01) == 0.8 and c.value(0.99) == 1.1
    ch = parse_law({"choice": [1, "b", 3.5]}, "x")
    assert ch == Choice((1, "b", 3.5)) and [ch.value(u) for u in (0.0, 0.34, 0.99)] == [1, "b", 3.5]
    assert parse_law({"grid": [1, 2]}, "x") == Grid((1, 2))


@pytest.mark.parametrize("value, message", [
    ({"uniform": [2.0]}, r"^p\.uniform: must be \[lo, hi\]"),
    ({"uniform": [3.0, 2.0]}, r"^p\.uniform: must have lo ≤ hi"),
    ({"normal": [0.0, -1.0]}, r"^p\.normal\[1\]: must be ≥ 0"),
    ({"normal": [0.0, 1.0], "clip": [1.0, 0.0]}, r"^p\.clip: must have lo ≤ hi"),
    ({"uniform": [0.0, 1.0], "clip": [0.0, 1.0]}, r"^p\.clip: unknown field"),
    ({"uniform": [0.0, 1.0], "grid": [1]}, r"^p: a law is one of"),
    ({"choice": []}, r"^p\.choice: must be a non-empty list"),
    ({"grid": [1.0, float("nan")]}, r"^p\.grid\[1\]: must be a finite number, got nan"),
])
def test_bad_laws_name_the_field(value, message):
    with pytest.raises(ConfigError, match=message):
        parse_law(value, "p")


@pytest.mark.parametrize("given, message", [
    ({"speed_ratio": {"uniform": [0.5, 5.0]}}, r"parameters\.speed_ratio: must be ≤ 4\.0, got 5\.0"),
    ({"speed_ratio": {"normal": [1.0, 0.2]}},
     r"parameters\.speed_ratio: a normal law on a bounded parameter needs clip"),
    ({"n": {"uniform": [1, 3]}}, r"parameters\.n: must be an integer, and a uniform law draws real numbers"),
    ({"n": {"grid": [1, 9]}}, r"parameters\.n: must be ≤ 5, got 9"),
    ({"role": {"choice": ["a", "c"]}}, r"parameters\.role: must be one of a, b, got 'c'"),
    ({"colour": 3}, r"parameters\.colour: unknown parameter"),
])
def test_laws_are_checked_against_the_declarations(given, message):
    with pytest.raises(ConfigError, match=message):
        space(given)


def test_an_unbounded_parameter_takes_a_normal_law_without_clip():
    s = space({"angle_deg": {"normal": [0.0, 10.0]}})
    assert s.laws[1] == ("angle_deg", Normal(0.0, 10.0))


def test_grids_are_a_cartesian_product_times_runs_per_point():
    s = space({"n": {"grid": [1, 2, 3]}, "role": {"grid": ["a", "b"]}, "speed_ratio": {"uniform": [0.5, 1.5]}}, 4)
    assert (s.points, s.runs) == (6, 24)
    points = [s.grid_point(g) for g in range(6)]
    assert points == [{"n": n, "role": r} for n in (1, 2, 3) for r in ("a", "b")]  # the last grid fastest
    for k in range(s.runs):
        v = s.draw(k, family_rng(0, 0, k))
        assert {key: v[key] for key in ("n", "role")} == points[k // 4] and 0.5 <= v["speed_ratio"] <= 1.5
    with pytest.raises(IndexError):
        s.draw(24, family_rng(0, 0, 24))


def test_one_uniform_per_declared_parameter_in_declared_order():
    """The stream is default_rng([base_seed, family, k, 0xC0FFEE]); parameter i takes variate i."""
    s = space({"angle_deg": {"uniform": [-90.0, 90.0]}, "speed_ratio": {"uniform": [0.5, 4.0]}}, 10)
    u = np.random.default_rng([3, 1, 7, 0xC0FFEE]).random(4)
    v = s.draw(7, family_rng(3, 1, 7))
    assert v == {"speed_ratio": 0.5 + 3.5 * u[0], "angle_deg": -90.0 + 180.0 * u[1], "n": 1, "role": "a"}


def test_changing_one_law_never_changes_another_draw():
    a = space({"angle_deg": {"uniform": [-90.0, 90.0]}}, 20)
    b = space({"angle_deg": {"uniform": [-90.0, 90.0]}, "speed_ratio": {"normal": [1.0, 0.3], "clip": [0.1, 4.0]},
               "n": {"choice": [1, 2, 3]}}, 20)
    for k in range(20):
        assert a.draw(k, family_rng(0, 2, k))["angle_deg"] == b.draw(k, family_rng(0, 2, k))["angle_deg"]


def test_draws_are_deterministic_and_differ_between_runs_families_and_base_seeds():
    s = space({"angle_deg": {"uniform": [-90.0, 90.0]}}, 3)
    first = [s.draw(k, family_rng(5, 0, k))["angle_deg"] for k in range(3)]
    assert first == [s.draw(k, family_rng(5, 0, k))["angle_deg"] for k in range(3)]
    assert len(set(first)) == 3
    assert s.draw(0, family_rng(5, 1, 0)) != s.draw(0, family_rng(5, 0, 0))
    assert s.draw(0, family_rng(6, 0, 0)) != s.draw(0, family_rng(5, 0, 0))


def test_sample_moments_match_the_laws():
    s = space({"angle_deg": {"normal": [3.0, 2.0]}, "speed_ratio": {"uniform": [0.5, 1.5]}}, 4000)
    draws = [s.draw(k, family_rng(0, 0, k)) for k in range(4000)]
    a = np.array([d["angle_deg"] for d in draws])
    r = np.array([d["speed_ratio"] for d in draws])
    assert abs(a.mean() - 3.0) < 4 * 2.0 / np.sqrt(4000) and abs(a.std() - 2.0) < 0.1
    assert abs(r.mean() - 1.0) < 4 * (1 / np.sqrt(12)) / np.sqrt(4000) and r.min() >= 0.5 and r.max() <= 1.5


@pytest.mark.parametrize("given, message", [
    ({"angle_deg": float("inf")}, r"^families\[0\]\.parameters\.angle_deg: must be a finite number, got inf$"),
    ({"angle_deg": float("nan")}, r"^families\[0\]\.parameters\.angle_deg: must be a finite number, got nan$"),
    ({"n": {"uniform": [1, 4]}}, r"^families\[0\]\.parameters\.n: must be an integer, and a uniform law draws real "
                                 r"numbers: write \{ choice = \[\.\.\.\] \} or \{ grid = \[\.\.\.\] \} of integers$"),
    ({"n": {"normal": [2, 1], "clip": [1, 4]}}, r"n: must be an integer, and a normal law draws real numbers"),
])
def test_errors_say_what_was_wrong_in_the_user_s_terms(given, message):
    """inf was "not a number" and an integer parameter's uniform law named a value the user never
    wrote ("must be an integer, got 0.0", its lower end as drawn)."""
    with pytest.raises(ConfigError, match=message):
        space(given)
    assert space({"n": {"choice": [1, 4]}}).draw(0, family_rng(0, 0, 0))["n"] in (1, 4)
