"""A campaign parameter's sampling law, as a campaign file declares it, and the seeded draws.

In a family's ``[families.parameters]`` table every parameter is either a plain value or a law::

    tcpa_s = 40.0                                        # fixed
    dcpa_m = { uniform = [-15.0, 15.0] }                 # uniform on [lo, hi]
    speed_ratio = { normal = [1.0, 0.2], clip = [0.5, 1.5] }   # Gaussian (mean, sd), clipped to [lo, hi]
    target_radius_m = { choice = [1.2, 2.5, 4.0] }      # one of the values, equally likely
    relative_course_deg = { grid = [150.0, 165.0, 180.0] }     # every value, in turn

**The run set.** A family's runs are the Cartesian product of its grids (parameters in the family's
declared order, the last one varying fastest) times ``runs_per_point`` draws of the random laws
(uniform, normal, choice): run ``k`` of the family sits at grid point ``k // runs_per_point``.
A family without grids is one point: ``runs_per_point`` runs.

**The draws.** Run ``k`` of the family with index ``f`` (its position in the file, from 0) draws
from ``numpy.random.default_rng([base_seed, f, k, 0xC0FFEE])`` — a stream apart from the run's own
streams (which derive from the scenario seed). Each draw takes **exactly one uniform variate
u ∈ [0, 1) per declared parameter, in the family's declared order, whatever its law** (a fixed or
grid parameter takes one too and ignores it), and maps it by the law's inverse CDF:

    uniform [lo, hi]      lo + u (hi − lo)
    normal [μ, σ]         μ + σ Φ⁻¹(u), then clipped to [lo, hi] when ``clip`` is given
    choice [v₀ … v₋₁]     v_⌊u·n⌋

So changing one parameter's law never changes another parameter's draw, and the same file gives the
same runs on any machine. A family that rejects a draw (an encounter whose geometry does not have
the family's COLREG role) draws again from the same generator: the next ``n`` variates.

A law is checked when the file is read against the parameter's declaration
(:func:`mjasc.core.config_tables.param`: type and bounds): every value a law can produce must be
allowed — a fixed value, both ends of a uniform or of a normal's ``clip``, every choice and grid
value. A normal law on a bounded parameter needs a ``clip`` inside the bounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np
from scipy.special import ndtri

from mjasc.core.config_tables import ConfigError, show

__all__ = ["DRAW_STREAM", "Law", "Fixed", "Uniform", "Normal", "Choice", "Grid", "parse_law", "ParameterSpace",
           "family_rng"]

#: Last entry of the per-run seed sequence ``[base_seed, family_index, k, DRAW_STREAM]``.
DRAW_STREAM = 0xC0FFEE

Value = float | int | str | bool


# ---------------------------------------------------------------------- laws
class Law:
    """A parameter's law: ``value(u)`` maps one uniform variate to a value; ``support()`` lists the
    values that bound what it can produce (checked against the parameter's declaration)."""

    random = False
    grid = False

    def value(self, u: float) -> Value:
        raise NotImplementedError

    def support(self) -> list[Value]:
        raise NotImplementedError

    def describe(self) -> Any:
        """The law as the campaign file writes it."""
        raise NotImplementedError


@dataclass(frozen=True)
class Fixed(Law):
    fixed: Value

    def value(self, u: float) -> Value:
        return self.fixed

    def support(self) -> list[Value]:
        return [self.fixed]

    def describe(self) -> Any:
        return self.fixed


@dataclass(frozen=True)
class Uniform(Law):
    lo: float
    hi: float
    random = True

    def value(self, u: float) -> float:
        return self.lo + u * (self.hi - self.lo)

    def support(self) -> list[Value]:
        return [self.lo, self.hi]

    def describe(self) -> Any:
        return {"uniform": [self.lo, self.hi]}


@dataclass(frozen=True)
class Normal(Law):
    mean: float
    sd: float
    clip: tuple[float, float] | None = None
    random = True

    def value(self, u: float) -> float:
        x = self.mean + self.sd * float(ndtri(max(u, 2.0**-53)))  # u = 0 would give −∞
        if self.clip is not None:
            x = min(max(x, self.clip[0]), self.clip[1])
        return x

    def support(self) -> list[Value]:
        return [self.mean] if self.clip is None else [self.clip[0], self.clip[1]]

    def describe(self) -> Any:
        d: dict[str, Any] = {"normal": [self.mean, self.sd]}
        if self.clip is not None:
            d["clip"] = list(self.clip)
        return d


@dataclass(frozen=True)
class Choice(Law):
    values: tuple[Value, ...]
    random = True

    def value(self, u: float) -> Value:
        return self.values[min(int(u * len(self.values)), len(self.values) - 1)]

    def support(self) -> list[Value]:
        return list(self.values)

    def describe(self) -> Any:
        return {"choice": list(self.values)}


@dataclass(frozen=True)
class Grid(Law):
    values: tuple[Value, ...]
    grid = True

    def value(self, u: float) -> Value:  # a grid's value is set by the grid point, not by u
        raise TypeError("a grid parameter takes its value from the grid point")

    def support(self) -> list[Value]:
        return list(self.values)

    def describe(self) -> Any:
        return {"grid": list(self.values)}


def _scalar(value: Any, where: str) -> Value:
    if isinstance(value, bool) or isinstance(value, str):
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float) and math.isfinite(value):
        return value
    if isinstance(value, float):
        raise ConfigError(f"{where}: must be a finite number, got {show(value)}")
    raise ConfigError(f"{where}: must be a number, a string or true/false, got {show(value)}")


def _real(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{where}: must be a finite number, got {show(value)}")
    return float(value)


def _pair(value: Any, where: str, what: str) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise ConfigError(f"{where}: must be [{what}], got {show(value)}")
    return _real(value[0], f"{where}[0]"), _real(value[1], f"{where}[1]")


def _values(value: Any, where: str) -> tuple[Value, ...]:
    if not isinstance(value, list) or not value:
        raise ConfigError(f"{where}: must be a non-empty list of values, got {show(value)}")
    return tuple(_scalar(v, f"{where}[{i}]") for i, v in enumerate(value))


def parse_law(value: Any, where: str) -> Law:
    """A campaign file's value for one parameter → its :class:`Law` (module docstring).
    Raises ConfigError naming ``where`` (``families[0].parameters.dcpa_m.uniform``)."""
    if not isinstance(value, Mapping):
        return Fixed(_scalar(value, where))
    kinds = [k for k in ("uniform", "normal", "choice", "grid") if k in value]
    if len(kinds) != 1:
        raise ConfigError(f"{where}: a law is one of {{ uniform = [lo, hi] }}, {{ normal = [mean, sd] }} "
                          f"(optional clip = [lo, hi]), {{ choice = [...] }}, {{ grid = [...] }}, "
                          f"got {show(dict(value))}")
    kind = kinds[0]
    allowed = {kind, "clip"} if kind == "normal" else {kind}
    extra = sorted(set(value) - allowed)
    if extra:
        raise ConfigError(f"{where}.{extra[0]}: unknown field (allowed: {', '.join(sorted(allowed))})")
    w = f"{where}.{kind}"
    if kind == "uniform":
        lo, hi = _pair(value[kind], w, "lo, hi")
        if not lo <= hi:
            raise ConfigError(f"{w}: must have lo ≤ hi, got {show(value[kind])}")
        return Uniform(lo, hi)
    if kind == "normal":
        mean, sd = _pair(value[kind], w, "mean, sd")
        if sd < 0:
            raise ConfigError(f"{w}[1]: must be ≥ 0 (a standard deviation), got {sd}")
        clip = None
        if "clip" in value:
            clip = _pair(value["clip"], f"{where}.clip", "lo, hi")
            if not clip[0] <= clip[1]:
                raise ConfigError(f"{where}.clip: must have lo ≤ hi, got {show(value['clip'])}")
        return Normal(mean, sd, clip)
    if kind == "choice":
        return Choice(_values(value[kind], w))
    return Grid(_values(value[kind], w))


# ---------------------------------------------------------------------- a family's parameter space
Checker = Callable[[str, Value, str], Any]
"""``check(name, value, where)``: the value as the parameter's declaration reads it (raises ConfigError)."""


@dataclass(frozen=True)
class ParameterSpace:
    """The laws of one family's parameters, in the family's declared order (every declared
    parameter is present: those the file does not give are :class:`Fixed` at their defaults)."""

    laws: tuple[tuple[str, Law], ...]
    runs_per_point: int = 1

    @classmethod
    def build(cls, declared: Mapping[str, Value], given: Mapping[str, Any], where: str, check: Checker,
              runs_per_point: int = 1) -> "ParameterSpace":
        """``declared``: name → default, in the family's order; ``given``: the file's parameters
        table (unknown names are errors); ``check`` validates every value a law can produce."""
        unknown = sorted(set(given) - set(declared))
        if unknown:
            raise ConfigError(f"{where}.{unknown[0]}: unknown parameter (allowed: {', '.join(declared)})")
        laws = []
        for name, default in declared.items():
            law = parse_law(given[name], f"{where}.{name}") if name in given else Fixed(default)
            for v in law.support():
                try:
                    check(name, v, f"{where}.{name}")
                except ConfigError as exc:
                    if isinstance(law, (Uniform, Normal)) and "must be an integer" in str(exc):
                        kind = "uniform" if isinstance(law, Uniform) else "normal"
                        raise ConfigError(f"{where}.{name}: must be an integer, and a {kind} law draws real numbers: "
                                          f"write {{ choice = [...] }} or {{ grid = [...] }} of integers") from None
                    raise
            if isinstance(law, Normal) and law.clip is None:
                try:
                    check(name, -1e300, f"{where}.{name}")
                    check(name, 1e300, f"{where}.{name}")
                except ConfigError:
                    raise ConfigError(f"{where}.{name}: a normal law on a bounded parameter needs clip = [lo, hi] "
                                      f"inside its bounds, got {show(dict(given[name]))}") from None
            laws.append((name, law))
        return cls(tuple(laws), runs_per_point)

    @property
    def grids(self) -> list[tuple[str, Grid]]:
        return [(n, law) for n, law in self.laws if law.grid]

    @property
    def points(self) -> int:
        """Number of grid points (1 without grids)."""
        return math.prod(len(g.values) for _, g in self.grids)

    @property
    def runs(self) -> int:
        return self.points * self.runs_per_point

    def grid_point(self, g: int) -> dict[str, Value]:
        """The grid values of point g (itertools.product order: the last grid varies fastest)."""
        out = {}
        for name, law in reversed(self.grids):  # mixed-radix digits, the last grid the fastest
            g, i = divmod(g, len(law.values))
            out[name] = law.values[i]
        return {name: out[name] for name, _ in self.grids}

    def draw(self, k: int, rng: np.random.Generator) -> dict[str, Value]:
        """All parameter values of run k: its grid point's values and one fresh draw of the others,
        taking one uniform variate per declared parameter from ``rng`` (module docstring)."""
        if not 0 <= k < self.runs:
            raise IndexError(f"run {k}: the family has {self.runs} run(s)")
        fixed = self.grid_point(k // self.runs_per_point)
        u = rng.random(len(self.laws))
        return {name: fixed[name] if law.grid else law.value(float(ui)) for (name, law), ui in zip(self.laws, u)}

    def describe(self) -> dict[str, Any]:
        return {name: law.describe() for name, law in self.laws}


def family_rng(base_seed: int, family_index: int, k: int) -> np.random.Generator:
    """The draw generator of run k of family ``family_index``: ``default_rng([base_seed, f, k, 0xC0FFEE])``."""
    return np.random.default_rng([int(base_seed), int(family_index), int(k), DRAW_STREAM])
