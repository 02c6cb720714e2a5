"""The same floating-point bits on every x86-64 machine with AVX2 (mjasc.core.portable_math's claim),
checked against a reference taken on another kind of CPU (mjasc.core.math_fingerprint).

The reference below was taken with the locked packages on an Intel Xeon with AVX-512 (numpy and
OpenBLAS pinned to their AVX2 loops by importing mjasc). The project's other hosts are AMD EPYC
(Zen 3, AVX2 only), so a test session on either kind compares its bits with the other's. A mismatch
means runs here give other bits than runs there — a campaign spread over both would depend on where
each run ran — unless a locked package changed (then take a new reference: the test skips where
the package versions differ from the reference's)."""

import os
import platform
import subprocess
import sys

import pytest

from mjasc.core.math_fingerprint import digest, environment, fingerprint
from mjasc.core.portable_math import cpu_flags

#: Taken on 2026-12-06 (Intel Xeon, AVX-512, pinned: numpy at x86-64-v3, OpenBLAS Haswell on one thread),
#: `python -m mjasc.core.math_fingerprint`.
REFERENCE = {
    "random": "9405791455e6a27d", "numpy_sin": "80cd46b7334ccfe5", "numpy_cos": "127feefbfc744500",
    "numpy_tanh": "bea766b00204bfdb", "numpy_tanh_small": "354ca2ec60f367bf", "numpy_exp": "b0aa632691a4cc76",
    "numpy_expm1": "bc34571b4e89635a", "numpy_log": "7d830f1199f5f8eb", "numpy_arctan2": "3cc7f9ce3ec6d8f3",
    "numpy_arctan": "b1d4d3a1f62ec8d3", "numpy_hypot": "13d654075699f977", "numpy_sqrt": "ba6a9ae13f0540fd",
    "numpy_arcsin": "c6abc0805476a4cb", "numpy_power": "30ccde643f8d10ee", "numpy_products": "72f9032d18b55c28",
    "numpy_linalg": "97675af6bda5c89e", "scipy_lu": "ff98b39453488e46", "numba_math": "f2338df30b3f7259",
    "mujoco": "6b02ef2fdf598a10",
}
REFERENCE_ENVIRONMENT = {"numpy": "2.4.6", "scipy": "1.17.1", "numba": "0.68.1", "mujoco": "3.17.0",
                         "libc": "glibc 2.36", "machine": "x86_64", "avx512_loops": "False",
                         "openblas_coretype": "Haswell", "openblas_threads": "1"}

AVX512 = {"avx512f", "avx512dq", "avx512cd", "avx512bw", "avx512vl"} <= cpu_flags()


def test_this_machine_computes_the_reference_bits():
    env = environment()
    other = {k: (env[k], v) for k, v in REFERENCE_ENVIRONMENT.items() if env.get(k) != v}
    if other:
        pytest.skip(f"the reference was taken with other packages or another machine kind: {other}")
    if not {"avx2", "fma"} <= cpu_flags():
        pytest.skip("the pin's claim covers x86-64 CPUs with AVX2 and FMA")
    parts = fingerprint()
    differ = sorted(k for k, v in REFERENCE.items() if parts.get(k) != v)
    assert not differ, (f"this {platform.processor() or platform.machine()} computes other bits than the "
                        f"reference machine in {differ}: runs here and there are not the same bit for bit")
    assert digest(parts) == digest(REFERENCE)


def test_the_fingerprint_is_the_same_in_a_fresh_process():
    """A fresh ``python -m mjasc.core.math_fingerprint`` (the pin from importing mjasc, numba's
    cached kernel) prints this process's digest."""
    env = {k: v for k, v in os.environ.items() if k not in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")}
    out = subprocess.run([sys.executable, "-m", "mjasc.core.math_fingerprint"], env=env, capture_output=True,
                         text=True, check=True).stdout
    assert out.splitlines()[0] == f"digest {digest()}"


@pytest.mark.skipif(not AVX512, reason="numpy's AVX-512 loops exist on AVX-512 CPUs only")
def test_the_fingerprint_sees_numpys_avx512_loops():
    """Unpinned (MJASC_NATIVE_MATH=1) on an AVX-512 CPU numpy's own loops and OpenBLAS's AVX-512
    kernels give other bits: the fingerprint tells them apart, and names where."""
    env = {k: v for k, v in os.environ.items() if k not in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")}
    out = subprocess.run([sys.executable, "-m", "mjasc.core.math_fingerprint"], env={**env, "MJASC_NATIVE_MATH": "1"},
                         capture_output=True, text=True, check=True).stdout
    native = dict(line.split() for line in out.splitlines() if line and not line.startswith("#"))
    pinned = fingerprint()
    assert native.pop("digest") != digest(pinned)
    differ = {k for k, v in native.items() if pinned[k] != v}
    assert {"numpy_arctan2", "numpy_power", "numpy_products"} <= differ
    assert {"random", "numpy_cos", "mujoco"}.isdisjoint(differ)  # (loops that have no AVX-512 version)
