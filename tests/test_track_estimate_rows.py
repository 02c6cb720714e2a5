"""track_estimate_rows builds the same TrackEstimate objects as the dataclass constructor."""

import dataclasses

import numpy as np
import pytest

from mjasc.core.estimates import TrackEstimate, track_estimate_rows


def test_rows_equal_constructor():
    rng = np.random.default_rng(0)
    pos, P = rng.normal(size=(3, 2)), rng.normal(size=(3, 2, 2))
    cols = [[0, 1, 7], [1.0, 1.0, 2.5], pos, [0.1, -3.0, 3.14], [0.0, 2.0, 1.0], [0.0, 0.01, -0.02],
            [1.5, 2.0, 0.5], P, [False, True, False], [None, "b", None], [None, np.zeros((4, 2)), None],
            [None, None, "team:x"]]
    got = track_estimate_rows(*cols)
    ref = [TrackEstimate(*row) for row in zip(*cols)]
    assert len(got) == 3
    for g, r in zip(got, ref):
        assert type(g) is TrackEstimate
        assert list(vars(g)) == list(vars(r))  # same fields, same order
        for name, value in vars(r).items():
            if isinstance(value, np.ndarray):  # (a row of an array given: a view, not a copy)
                assert np.array_equal(vars(g)[name], value) and np.shares_memory(vars(g)[name], value)
            else:
                assert vars(g)[name] is value
        with pytest.raises(dataclasses.FrozenInstanceError):
            g.speed_m_s = 1.0
        assert np.array_equal(g.predict_positions(np.array([2.0, 3.0])), r.predict_positions(np.array([2.0, 3.0])))
    assert track_estimate_rows(*[[] for _ in cols]) == []
    with pytest.raises(ValueError, match="columns"):
        track_estimate_rows(*cols[:-1])


def test_estimate_of_equals_the_constructors():
    """estimate_of makes the same TrackEstimate / PlannedTrack as the dataclass constructors."""
    from mjasc.core.estimates import PlannedTrack, estimate_of

    cov = np.eye(2)
    for cls, extra in ((TrackEstimate, ()), (PlannedTrack, ("intention",))):
        values = (7, 1.5, np.array([1.0, 2.0]), 0.3, 1.2, 0.01, 2.5, cov, False, "b", None, None, *extra)
        got, ref = estimate_of(cls, *values), cls(*values)
        assert type(got) is cls and got.__dict__.keys() == ref.__dict__.keys()
        assert all(a is b for a, b in zip(got.__dict__.values(), ref.__dict__.values()))
    with pytest.raises(ValueError):
        estimate_of(TrackEstimate, 1, 2.0)


def test_estimate_replace_equals_dataclasses_replace():
    from mjasc.core.estimates import PlannedTrack, estimate_of, estimate_replace

    proto = estimate_of(PlannedTrack, -1, 1.5, np.array([1.0, 2.0]), 0.3, 1.2, 0.01, 0.0, None, False, "b", None, None,
                        "intention")
    cov = np.eye(2)
    got = estimate_replace(proto, track_id=4, radius_m=2.5, position_covariance=cov)
    ref = dataclasses.replace(proto, track_id=4, radius_m=2.5, position_covariance=cov)
    assert type(got) is PlannedTrack and list(vars(got)) == list(vars(ref))
    assert all(a is b for a, b in zip(vars(got).values(), vars(ref).values()))
    assert proto.track_id == -1 and proto.position_covariance is None  # the prototype is left as it was
    with pytest.raises(dataclasses.FrozenInstanceError):
        got.radius_m = 1.0
