"""A gridded current: bilinear interpolation on a rectilinear grid, with optional time slices.

``u_m_s[i][j]`` / ``v_m_s[i][j]`` are the east / north components [m/s] at ``(x_m[i], y_m[j])``
(``indexing="ij"``, shape ``(nx, ny)``); with ``times_s`` the arrays gain a leading time axis
``(nt, nx, ny)`` and are interpolated linearly in time. Outside the grid (and outside ``times_s``)
the field is clamped to the edge value. World frame ENU, SI units.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from mjasc.core.config_tables import check_params, param
from mjasc.physics.currents.arrays import grid_values, increasing
from mjasc.physics.currents.base import CurrentField, as_points, read_parameters

__all__ = ["GridConfig", "GriddedCurrent"]


def _as_given(value: Any, where: str) -> Any:
    """Reader of the grid values: kept as given, read by :meth:`GridConfig.check` once the axes
    (and so the shape) are known."""
    return value


@dataclass(frozen=True)
class GridConfig:
    """The parameters of a :class:`GriddedCurrent` (``[current]`` of ``type = "grid"``)."""

    x_m: np.ndarray = param(reader=increasing(2), unit="m", doc="grid lines along x (east), strictly increasing")
    y_m: np.ndarray = param(reader=increasing(2), unit="m", doc="grid lines along y (north), strictly increasing")
    u_m_s: Any = param(reader=_as_given, unit="m/s",
                       doc="east component at (x_m[i], y_m[j]), shape (nx, ny), or (nt, nx, ny) with times_s")
    v_m_s: Any = param(reader=_as_given, unit="m/s", doc="north component, shaped as u_m_s")
    times_s: np.ndarray | None = param(None, reader=increasing(1), unit="s",
                                       doc="times of the slices, strictly increasing (none: steady)")

    def __post_init__(self):
        check_params(self, "GriddedCurrent")
        self.check(self, "GriddedCurrent")

    @property
    def shape(self) -> tuple[int, ...]:
        """The shape of ``u_m_s`` and ``v_m_s``: (nx, ny), or (nt, nx, ny) with time slices."""
        grid = (len(self.x_m), len(self.y_m))
        return grid if self.times_s is None else (len(self.times_s), *grid)

    @staticmethod
    def check(config: GridConfig, where: str) -> None:
        """The components have the grid's shape."""
        for name in ("u_m_s", "v_m_s"):
            grid_values(getattr(config, name), f"{where}.{name}", config.shape)


def _locate(axis: np.ndarray, coords: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cell index i (so that axis[i] ≤ c ≤ axis[i+1]) and weight w ∈ [0, 1], clamped at the ends."""
    clamped = np.clip(coords, axis[0], axis[-1])
    index = np.searchsorted(axis, clamped, side="right") - 1
    np.clip(index, 0, axis.size - 2, out=index)
    left = axis[index]
    weight = (clamped - left) / (axis[index + 1] - left)
    return index, weight


class GriddedCurrent(CurrentField):
    """Bilinear interpolation of a current sampled on a rectilinear grid, optional time slices.

    x_m (nx,), y_m (ny,): strictly increasing grid lines [m], nx, ny ≥ 2.
    u_m_s, v_m_s: east and north components [m/s], ``u_m_s[i, j]`` at ``(x_m[i], y_m[j])``
    (shape (nx, ny), ``np.meshgrid(x, y, indexing="ij")`` order), or (nt, nx, ny) with
    ``times_s`` (nt,) strictly increasing [s]: linear in time between slices.
    Outside the grid the point is clamped onto it (the edge value continues outward, zero normal
    gradient); before the first / after the last time slice the field holds that slice.
    Exact at the nodes; reproduces any field of the form a + b·x + c·y + d·x·y exactly.
    Acceleration by the default finite difference."""

    is_uniform = False

    def __init__(self, x_m: Any, y_m: Any, u_m_s: Any, v_m_s: Any, times_s: Any = None):
        self._setup(read_parameters(GridConfig, "GriddedCurrent", x_m=x_m, y_m=y_m, u_m_s=u_m_s, v_m_s=v_m_s,
                                    times_s=times_s))

    def _setup(self, config: GridConfig) -> None:
        self._x = np.array(config.x_m, dtype=float)
        self._y = np.array(config.y_m, dtype=float)
        self._times = None if config.times_s is None else np.array(config.times_s, dtype=float)
        shape = config.shape
        components = []
        for name in ("u_m_s", "v_m_s"):
            array = grid_values(getattr(config, name), name, shape)
            components.append(array if self._times is not None else array[None])
        self._field = np.stack(components, axis=-1)  # (nt, nx, ny, 2)
        self.is_steady = self._field.shape[0] == 1

    def _bilinear(self, slice_index: int, ix, iy, wx, wy) -> np.ndarray:
        # (1 − w)·a + w·b form: exact at w = 0 and w = 1, hence exact at every node
        grid = self._field[slice_index]
        wx = wx[:, None]
        wy = wy[:, None]
        low = (1.0 - wx) * grid[ix, iy] + wx * grid[ix + 1, iy]
        high = (1.0 - wx) * grid[ix, iy + 1] + wx * grid[ix + 1, iy + 1]
        return (1.0 - wy) * low + wy * high

    def velocity(self, points_m: np.ndarray, t_s: float) -> np.ndarray:
        points = as_points(points_m, "points_m")
        ix, wx = _locate(self._x, points[:, 0])
        iy, wy = _locate(self._y, points[:, 1])
        if self._field.shape[0] == 1:
            return self._bilinear(0, ix, iy, wx, wy)
        (k,), (wt,) = _locate(self._times, np.array([float(t_s)]))
        out = self._bilinear(k, ix, iy, wx, wy)
        if wt > 0.0:
            out *= 1.0 - wt
            out += wt * self._bilinear(k + 1, ix, iy, wx, wy)
        return out

    def describe(self) -> dict[str, Any]:
        table: dict[str, Any] = {
            "type": "grid",
            "x_m": self._x.tolist(),
            "y_m": self._y.tolist(),
        }
        field = self._field if self._times is not None else self._field[0]
        table["u_m_s"] = field[..., 0].tolist()
        table["v_m_s"] = field[..., 1].tolist()
        if self._times is not None:
            table["times_s"] = self._times.tolist()
        return table
