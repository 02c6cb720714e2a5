"""A campaign on a scheduler compares each worker's math digest with this machine's
(mjasc.campaigns.cluster.workers_math_problem): the verdicts, and a digest that could not be
computed said as such — never taken for a match, never kept for the next campaign."""

import subprocess

import pytest

from mjasc.campaigns import cluster
from mjasc.campaigns.cluster import MathDigestError, math_digest, worker_math, workers_math_problem


def test_the_same_digest_everywhere_is_no_problem():
    assert workers_math_problem({"tcp://a": {"digest": "abc"}, "tcp://b": {"digest": "abc"}}, "abc") == ""


def test_another_digest_names_the_worker_and_both_digests():
    problem = workers_math_problem({"tcp://a": {"digest": "abc"}, "tcp://b": {"digest": "xyz"}}, "abc")
    assert problem.startswith("1 of 2 Dask worker(s) compute other floating-point bits than this machine")
    assert "worker tcp://b: math digest xyz, here abc" in problem and "OPENBLAS_NUM_THREADS" in problem


def test_a_digest_that_failed_is_said_as_such_on_either_side():
    """Two failures are not a match: a worker whose fingerprint failed, or this machine's."""
    failed = {"tcp://a": {"error": "python -m mjasc.core.math_fingerprint: TimeoutExpired"}}
    assert workers_math_problem(failed, "abc").startswith(
        "could not compute the math digest on 1 Dask worker(s) (worker tcp://a: python -m")
    own = MathDigestError("python -m mjasc.core.math_fingerprint exited with status 1: ImportError: x")
    assert workers_math_problem({"tcp://a": {"digest": "abc"}}, own).startswith(
        "could not compute this machine's math digest (python -m mjasc.core.math_fingerprint exited")


def test_a_failure_is_not_kept_for_the_next_campaign(monkeypatch):
    """A slow start once (the fingerprint's process timed out) must not leave a long-lived process
    reporting a failure for ever: only digests are kept."""
    monkeypatch.setattr(cluster, "_MATH_DIGESTS", {})
    real = subprocess.run

    def timed_out(*args, **kwargs):
        raise subprocess.TimeoutExpired(args[0], 1.0)

    monkeypatch.setattr(subprocess, "run", timed_out)
    with pytest.raises(MathDigestError, match="TimeoutExpired"):
        math_digest(True)
    assert worker_math(True) == {"error": worker_math(True)["error"]} and "TimeoutExpired" in worker_math(True)["error"]
    monkeypatch.setattr(subprocess, "run", real)
    assert math_digest(True) == math_digest(False)  # (this test process is pinned as a run child is)
