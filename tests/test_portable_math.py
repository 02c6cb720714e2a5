"""mjasc pins numpy's and OpenBLAS's loops below AVX-512, and OpenBLAS to one thread, before numpy
loads (mjasc.core.portable_math):
what it sets where, that it never overrides a user's choice or acts after numpy, and that the test
session and a fresh ``import mjasc`` really run with the pin."""

import json
import os
import platform
import subprocess
import sys

import pytest

from mjasc.core.portable_math import BLAS_CORE, BLAS_THREADS, NUMPY_FEATURES_OFF, pin, status

X86 = platform.machine().lower() in ("x86_64", "amd64")


def test_pins_numpy_and_openblas_on_an_avx2_x86_cpu():
    env = {}
    assert pin(env, {}, "x86_64", {"avx2", "fma", "sse2"}) == env == {
        "NPY_DISABLE_CPU_FEATURES": NUMPY_FEATURES_OFF, "OPENBLAS_CORETYPE": BLAS_CORE,
        "OPENBLAS_NUM_THREADS": BLAS_THREADS}


def test_no_blas_core_without_avx2_and_nothing_off_x86():
    env = {}
    pin(env, {}, "AMD64", {"sse2", "avx"})  # Haswell kernels would not run there
    assert env == {"NPY_DISABLE_CPU_FEATURES": NUMPY_FEATURES_OFF, "OPENBLAS_NUM_THREADS": BLAS_THREADS}
    env = {}  # (elsewhere only the thread count: OpenBLAS's LU splits its work by it on every CPU)
    assert pin(env, {}, "aarch64", {"asimd"}) == {"OPENBLAS_NUM_THREADS": BLAS_THREADS} == env


@pytest.mark.parametrize("env, modules", [
    ({"MJASC_NATIVE_MATH": "1"}, {}),  # opted out
    ({}, {"numpy": object()}),  # too late: numpy chose its loops already
])
def test_does_nothing_when_opted_out_or_after_numpy(env, modules):
    before = dict(env)
    assert pin(env, modules, "x86_64", {"avx2", "fma"}) == {} and env == before


def test_a_users_own_settings_are_kept():
    env = {"NPY_DISABLE_CPU_FEATURES": "X86_V3", "OPENBLAS_CORETYPE": "Zen", "OPENBLAS_NUM_THREADS": "4"}
    assert pin(env, {}, "x86_64", {"avx2", "fma"}) == {}
    assert env == {"NPY_DISABLE_CPU_FEATURES": "X86_V3", "OPENBLAS_CORETYPE": "Zen", "OPENBLAS_NUM_THREADS": "4"}


@pytest.mark.skipif(not X86, reason="the pin applies to x86-64 only")
def test_this_test_session_runs_pinned():
    """conftest imports mjasc before any test module imports numpy."""
    if "NPY_DISABLE_CPU_FEATURES" in os.environ and os.environ["NPY_DISABLE_CPU_FEATURES"] != NUMPY_FEATURES_OFF:
        pytest.skip("NPY_DISABLE_CPU_FEATURES set by the environment")
    assert os.environ.get("NPY_DISABLE_CPU_FEATURES") == NUMPY_FEATURES_OFF
    assert status()["avx512_loops"] is False


@pytest.mark.skipif(not X86, reason="the pin applies to x86-64 only")
def test_importing_mjasc_first_pins_a_fresh_process():
    env = {k: v for k, v in os.environ.items()
           if k not in ("NPY_DISABLE_CPU_FEATURES", "OPENBLAS_CORETYPE", "OPENBLAS_NUM_THREADS", "MJASC_NATIVE_MATH")}
    code = ("import json, mjasc, numpy; from mjasc.core.portable_math import status; print(json.dumps(status()))")
    got = json.loads(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                    check=True).stdout)
    assert got["NPY_DISABLE_CPU_FEATURES"] == NUMPY_FEATURES_OFF and got["avx512_loops"] is False
    assert got["OPENBLAS_NUM_THREADS"] == BLAS_THREADS
    # numpy first: numpy's own choice, and status says so
    code = ("import json, numpy, mjasc; from mjasc.core.portable_math import status; print(json.dumps(status()))")
    got = json.loads(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                    check=True).stdout)
    assert got["NPY_DISABLE_CPU_FEATURES"] is None


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/maps")
def test_openblas_runs_on_one_thread_in_a_pinned_process():
    """OpenBLAS read the pin when it loaded: numpy's and scipy's copies of it (each wheel bundles
    its own) each run one thread — a LU factorisation splits its work by the count, and gives other
    bits on two threads than on one."""
    code = ("import ctypes, json, mjasc, numpy, scipy.linalg\n"
            "libs = sorted({ln.split()[-1] for ln in open('/proc/self/maps') if 'openblas' in ln and '.so' in ln})\n"
            "out = {}\n"
            "for path in libs:\n"
            "    lib = ctypes.CDLL(path)\n"
            "    for name in ('scipy_openblas_get_num_threads64_', 'scipy_openblas_get_num_threads', "
            "'openblas_get_num_threads'):\n"
            "        if hasattr(lib, name):\n"
            "            out[path.rsplit('/', 1)[-1]] = getattr(lib, name)()\n"
            "            break\n"
            "print(json.dumps(out))\n")
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "GOTO_NUM_THREADS", "MJASC_NATIVE_MATH")}
    pinned = json.loads(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                                       check=True).stdout)
    if not pinned:
        pytest.skip("no OpenBLAS with a thread-count query is loaded (a system BLAS?)")
    assert set(pinned.values()) == {1}, pinned  # (numpy's and scipy's wheels each bundle one)
    if len(os.sched_getaffinity(0)) > 1:  # (OpenBLAS's default: one thread per core it may use)
        native = json.loads(subprocess.run([sys.executable, "-c", code], env={**env, "MJASC_NATIVE_MATH": "1"},
                                           capture_output=True, text=True, check=True).stdout)
        assert min(native.values()) > 1, native
