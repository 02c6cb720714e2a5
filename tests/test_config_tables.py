"""config_tables: each reader accepts exactly its kind of value and names the path and the reason
otherwise; dataclass_from_table reads a table by its dataclass's field types."""

from dataclasses import dataclass, field

import numpy as np
import pytest

from mjasc.core.config_tables import (
    ConfigError,
    boolean,
    check_keys,
    dataclass_from_table,
    errors_as,
    integer,
    load_toml,
    number,
    point,
    points,
    show,
    string,
    table,
)


def test_show_formats_values_plainly():
    assert show(1.5) == "1.5" and show(np.float32(2.0)) == "2.0" and show(np.int64(3)) == "3"
    assert show(True) == "True" and show("x") == "'x'" and show(np.zeros((2, 3))) == "an array of shape [2, 3]"
    assert show("a" * 200).endswith("...") and len(show("a" * 200)) == 80


def test_table_and_keys():
    t = {"a": 1}
    assert table(t, "x") is t
    with pytest.raises(ConfigError, match=r"^x\.y: must be a table, got \[1\]$"):
        table([1], "x.y")
    check_keys({"a": 1, "b": 2}, {"a", "b", "c"}, "x")
    with pytest.raises(ConfigError, match=r"^x\.b: unknown field \(allowed: a, c, z\)$"):
        check_keys({"z": 0, "b": 2, "a": 1}, ["c", "a", "z"], "x")


@pytest.mark.parametrize(("value", "kwargs", "message"), [
    (True, {}, "must be a number, got True"),
    ("1", {}, "must be a number, got '1'"),
    (np.ones(1), {}, "must be a number, got an array of shape [1]"),
    (float("nan"), {}, "must be finite, got nan"),
    (float("-inf"), {}, "must be finite, got -inf"),
    (0, {"positive": True}, "must be > 0, got 0"),
    (-0.5, {"nonneg": True}, "must be ≥ 0, got -0.5"),
    (0.9, {"minimum": 1}, "must be ≥ 1, got 0.9"),
    (2.5, {"maximum": 2.0}, "must be ≤ 2.0, got 2.5"),
])
def test_number_rejects(value, kwargs, message):
    with pytest.raises(ConfigError) as err:
        number(value, "t.k", **kwargs)
    assert str(err.value) == f"t.k: {message}"


def test_number_accepts_reals_and_returns_floats():
    for v in (3, 3.0, np.int32(3), np.float32(3.0)):
        out = number(v, "k", positive=True, nonneg=True, minimum=3, maximum=3)
        assert out == 3.0 and type(out) is float
    assert number(0, "k", nonneg=True) == 0.0 and number(-7.25, "k") == -7.25


def test_integer_boolean_string():
    assert integer(5, "k", minimum=5, maximum=5) == 5 and type(integer(np.int64(2), "k")) is int
    for bad, reason in [(3.0, "must be an integer, got 3.0"), (True, "must be an integer, got True"),
                        ("3", "must be an integer, got '3'")]:
        with pytest.raises(ConfigError, match=rf"^k: {reason}$"):
            integer(bad, "k")
    with pytest.raises(ConfigError, match="^k: must be ≥ 1, got 0$"):
        integer(0, "k", minimum=1)
    with pytest.raises(ConfigError, match="^k: must be ≤ 9, got 10$"):
        integer(10, "k", maximum=9)
    assert boolean(False, "k") is False and boolean(np.bool_(True), "k") is True
    for bad in (0, 1, "true", None):
        with pytest.raises(ConfigError, match="^k: must be true or false"):
            boolean(bad, "k")
    assert string("b", "k", choices=("b", "a")) == "b"
    with pytest.raises(ConfigError, match="^k: must be one of a, b, got 'c'$"):
        string("c", "k", choices=["b", "a"])
    for bad in ("", None, 3):
        with pytest.raises(ConfigError, match="^k: must be a non-empty string"):
            string(bad, "k", choices=["a"])


def test_points():
    np.testing.assert_array_equal(point([1, 2.5], "p"), [1.0, 2.5])
    with pytest.raises(ConfigError, match=r"^p: must be a point \[x, y\] in metres, got \[1, 2, 3\]$"):
        point([1, 2, 3], "p")
    with pytest.raises(ConfigError, match=r"^p\[1\]: must be a number, got 'y'$"):
        point([0, "y"], "p")
    pts = points([[0, 0], [1, 0], [1, 1]], "poly", 3)
    assert pts.shape == (3, 2) and pts.dtype == float
    assert points([], "none", 0).shape == (0, 2)
    with pytest.raises(ConfigError, match=r"^poly: must be a list of at least 3 points"):
        points([[0, 0], [1, 1]], "poly", 3)
    with pytest.raises(ConfigError, match=r"^poly\[1\]\[0\]: must be finite"):
        points([[0, 0], [float("inf"), 1]], "poly", 1)


# ---------------------------------------------------------------------------------------------- dataclasses
@dataclass(frozen=True)
class Example:
    gain: float = 1.0
    count: int = 3
    enabled: bool = True
    mode: str = "fast"
    limit_m: float | None = None
    commands: tuple[float, float] = (0.0, 0.0)
    knots: tuple[int, ...] = ()
    tags: dict = field(default_factory=dict)

    def __post_init__(self):
        _check_example(self, "example")


def _check_example(c: Example, where: str) -> None:
    number(c.gain, f"{where}.gain", positive=True)
    if c.limit_m is not None and c.limit_m < c.gain:
        raise ConfigError(f"{where}.limit_m: must be ≥ gain ({c.gain}), got {c.limit_m}")


def test_dataclass_from_table_reads_by_field_type():
    assert dataclass_from_table(Example, {}, "ex") == Example()
    cfg = dataclass_from_table(Example, {"gain": 2, "count": 4, "enabled": False, "mode": "slow", "limit_m": 5,
                                         "commands": [0.5, -1], "knots": [1, 2, 3]}, "ex")
    assert cfg == Example(2.0, 4, False, "slow", 5.0, (0.5, -1.0), (1, 2, 3))
    assert type(cfg.gain) is float and type(cfg.limit_m) is float and type(cfg.commands[1]) is float
    preset = Example(gain=7.0, mode="slow")
    assert dataclass_from_table(Example, {"count": 1}, "ex", defaults=preset) == Example(gain=7.0, count=1, mode="slow")


@pytest.mark.parametrize(("tbl", "message"), [
    ("gain", "ex: must be a table, got 'gain'"),
    ({"gian": 1.0}, "ex.gian: unknown field (allowed: commands, count, enabled, gain, knots, limit_m, mode, tags)"),
    ({"gain": "1"}, "ex.gain: must be a number, got '1'"),
    ({"gain": True}, "ex.gain: must be a number, got True"),
    ({"count": 2.0}, "ex.count: must be an integer, got 2.0"),
    ({"enabled": 1}, "ex.enabled: must be true or false, got 1"),
    ({"mode": ""}, "ex.mode: must be a non-empty string, got ''"),
    ({"limit_m": float("inf")}, "ex.limit_m: must be finite, got inf"),
    ({"commands": [1.0]}, "ex.commands: must be a list of 2 values, got [1.0]"),
    ({"commands": [1.0, "x"]}, "ex.commands[1]: must be a number, got 'x'"),
    ({"knots": 3}, "ex.knots: must be a list, got 3"),
    ({"knots": [1, 2.5]}, "ex.knots[1]: must be an integer, got 2.5"),
    # the class's own check, addressed to the table (not to its default name "example"):
    ({"gain": -1}, "ex.gain: must be > 0, got -1.0"),
    ({"gain": 2, "limit_m": 1}, "ex.limit_m: must be ≥ gain (2.0), got 1.0"),
])
def test_dataclass_from_table_rejects_naming_the_key(tbl, message):
    with pytest.raises(ConfigError) as err:
        dataclass_from_table(Example, tbl, "ex", check=_check_example)
    assert str(err.value) == message


def test_dataclass_from_table_converters_and_missing_fields():
    cfg = dataclass_from_table(Example, {"mode": "slow", "tags": {"a": 1}}, "ex",
                               {"mode": lambda v, w: string(v, w, choices={"slow", "fast"}),
                                "tags": lambda v, w: dict(table(v, w))})
    assert cfg.mode == "slow" and cfg.tags == {"a": 1}
    with pytest.raises(ConfigError, match=r"^ex\.mode: must be one of fast, slow"):
        dataclass_from_table(Example, {"mode": "medium"}, "ex", {"mode": lambda v, w: string(v, w, choices={"slow", "fast"})})
    with pytest.raises(TypeError, match="tags"):  # no reader for a dict field: the caller's mistake
        dataclass_from_table(Example, {"tags": {}}, "ex")
    # without check=, the class's __post_init__ speaks with its own name
    with pytest.raises(ConfigError, match=r"^example\.gain: must be > 0"):
        dataclass_from_table(Example, {"gain": 0}, "ex")

    @dataclass(frozen=True)
    class Required:
        name: str
        size: int = 1

    assert dataclass_from_table(Required, {"name": "a"}, "r") == Required("a")
    with pytest.raises(ConfigError, match=r"^r\.name: missing$"):
        dataclass_from_table(Required, {"size": 2}, "r")


def test_errors_as_converts_config_errors_only():
    class MyError(ValueError):
        pass

    with pytest.raises(MyError, match="^k: must be a number"):
        with errors_as(MyError):
            number("x", "k")
    with pytest.raises(ValueError) as err:  # other errors pass unchanged
        with errors_as(MyError):
            raise ValueError("plain")
    assert type(err.value) is ValueError


def test_load_toml_names_the_file(tmp_path):
    good = tmp_path / "a.toml"
    good.write_text('name = "x"\n[rates]\nphysics_hz = 50\n')
    assert load_toml(good) == {"name": "x", "rates": {"physics_hz": 50}}

    class MyError(ValueError):
        pass

    with pytest.raises(MyError, match=r"missing\.toml: no such scenario file$"):
        load_toml(tmp_path / "missing.toml", MyError, "scenario")
    bad = tmp_path / "bad.toml"
    bad.write_text("name = \n")
    with pytest.raises(ConfigError, match=r"bad\.toml: not valid TOML: "):
        load_toml(bad)


# ------------------------------------------------------------------ parameters declared once
from dataclasses import dataclass as _dc  # noqa: E402

from mjasc.core.config_tables import check_params, describe_params, param  # noqa: E402


@_dc(frozen=True)
class _Inner:
    window_s: float | None = param(30.0, positive=True, unit="s", doc="window", phrase="must be finite and > 0")
    steps: int = param(8, minimum=8, doc="vertex count")

    def __post_init__(self):
        check_params(self, "inner")


@_dc(frozen=True)
class _Outer:
    gain: float = param(0.3, positive=True, unit="1/s", doc="gain k")
    ratio: float = param(0.5, nonneg=True, maximum=1.0, doc="safety ratio")
    mode: str = param("fast", choices=("fast", "slow"), doc="mode")
    inner: _Inner = param(default_factory=_Inner, flatten=True, doc="prediction")

    def __post_init__(self):
        check_params(self, "outer")


def test_param_bounds_checked_on_construction_and_from_tables():
    with pytest.raises(ConfigError, match=r"^outer\.gain: must be > 0, got -1$"):
        _Outer(gain=-1)
    with pytest.raises(ConfigError, match=r"^outer\.ratio: must be ≤ 1.0, got 2$"):
        _Outer(ratio=2)
    with pytest.raises(ConfigError, match=r"^v\[0\]\.av\.mode: must be one of fast, slow, got 'medium'$"):
        dataclass_from_table(_Outer, {"mode": "medium"}, "v[0].av")
    # a flattened nested config reads its fields from the parent table, errors name that table
    with pytest.raises(ConfigError, match=r"^av\.window_s: must be finite and > 0, got 0.0$"):
        dataclass_from_table(_Outer, {"window_s": 0}, "av")
    with pytest.raises(ConfigError, match=r"^av\.steps: must be ≥ 8, got 3$"):
        dataclass_from_table(_Outer, {"steps": 3}, "av")
    with pytest.raises(ConfigError, match=r"^av\.nope: unknown field"):
        dataclass_from_table(_Outer, {"nope": 3}, "av")
    c = dataclass_from_table(_Outer, {"window_s": 12.0, "gain": 2}, "av")
    assert c.inner.window_s == 12.0 and c.gain == 2.0 and c.inner.steps == 8
    assert _Outer(inner=_Inner(window_s=None)).inner.window_s is None  # X | None accepts None


def test_describe_params_lists_every_declared_parameter_once():
    rows = {r["name"]: r for r in describe_params(_Outer)}
    assert list(rows) == ["gain", "ratio", "mode", "window_s", "steps"]
    assert rows["gain"]["unit"] == "1/s" and rows["gain"]["bounds"] == "> 0" and rows["gain"]["default"] == 0.3
    assert rows["ratio"]["bounds"] == "≥ 0, ≤ 1.0"


def test_read_field_reads_one_key_as_its_declared_field():
    from mjasc.core.config_tables import read_field

    assert read_field(_Outer, "gain", {"k_gain": 2}, "t", key="k_gain") == 2.0
    assert read_field(_Outer, "gain", {}, "t") == 0.3  # the field's default
    assert read_field(_Outer, "gain", {}, "t", default=9.0) == 9.0
    with pytest.raises(ConfigError, match=r"^t\.k_gain: must be > 0, got -1.0$"):
        read_field(_Outer, "gain", {"k_gain": -1}, "t", key="k_gain")
    with pytest.raises(ConfigError, match=r"^t\.mode: must be a non-empty string, got 3$"):
        read_field(_Outer, "mode", {"mode": 3}, "t")
    with pytest.raises(ConfigError, match=r"^t\.window_s: must be finite and > 0, got 0.0$"):
        read_field(_Inner, "window_s", {"window_s": 0}, "t")
