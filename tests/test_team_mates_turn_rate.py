"""The team mates' heading rate in plain floats (:func:`mjasc.avoidance.team_mates._turn_rate`)
gives numpy's ``np.angle(np.exp(1j Δψ)) / Δt`` bit for bit (the form it replaces), also at ±0,
±π, multiples of 2π and for a Δψ that is not finite."""

import math

import numpy as np

from mjasc.avoidance.team_mates import _turn_rate


def _numpy_rate(dh: float, dt: float) -> float:
    z = np.exp(1j * np.array([dh]))
    return (np.arctan2(z.imag, z.real) / np.array([dt])).tolist()[0]


def test_turn_rate_is_numpys_bits():
    rng = np.random.default_rng(3)
    for scale in (1e-12, 1e-4, 0.1, 1.0, 3.0, 10.0, 1e3):
        dh = (rng.normal(size=3000) * scale).tolist()
        dt = rng.uniform(0.05, 3.0, size=3000).tolist()
        for a, b in zip(dh, dt):
            assert _turn_rate(a, b).hex() == _numpy_rate(a, b).hex()
    for a in (0.0, -0.0, math.pi, -math.pi, 2 * math.pi, -2 * math.pi, 5e-324, -5e-324):
        assert _turn_rate(a, 0.5).hex() == _numpy_rate(a, 0.5).hex()


def test_turn_rate_not_finite():
    with np.errstate(invalid="ignore"):
        for a in (math.inf, -math.inf, math.nan):
            assert math.isnan(_turn_rate(a, 1.0)) and math.isnan(_numpy_rate(a, 1.0))
