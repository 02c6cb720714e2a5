"""The same bits on every x86-64 CPU with AVX2: numpy's and OpenBLAS's loops pinned below AVX-512,
OpenBLAS on one thread.

numpy chooses its compiled loops when it is imported, by the CPU it runs on. On CPUs with AVX-512,
its float64 ``sin``, ``cos``, ``exp``, ``log``, ``arctan2``, ``power`` and others run other
implementations than on AVX2-only CPUs, and those round differently in the last bit or few (numpy
accepts up to 4 ulp between its implementations; numpy issue 23523). A closed-loop simulation turns
one ulp into a different trajectory within seconds: the same scenario and seed would give other
bits, and now and then another outcome, on a laptop than on a cluster node. OpenBLAS, numpy's and
scipy's linear algebra, also picks its kernels by CPU, and its LU factorisation and solve split the
work by its thread count, one per core by default: a 200 × 200 ``lu_factor`` (the potential field's
panels) gives other bits on one thread than on two (measured), so a run would also depend on how
many cores a machine has — and Dask's workers set ``OPENBLAS_NUM_THREADS=1`` while a command on the
same machine would use every core.

So that a run is a function of its scenario and seed on any x86-64 CPU with AVX2 and FMA (Intel
since Haswell, AMD since Zen), importing mjasc — before numpy is imported — sets, unless the
variable is set already or ``MJASC_NATIVE_MATH=1``:

* ``NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL AVX512_SPR"`` (numpy's run-time dispatch stops at
  x86-64-v3: AVX2 + FMA), on x86-64;
* ``OPENBLAS_CORETYPE="Haswell"`` (OpenBLAS's AVX2 kernels), on x86-64 CPUs that have AVX2 and FMA;
* ``OPENBLAS_NUM_THREADS="1"``, on every architecture (the same bits whatever the core count).

They are read once, when numpy and scipy load OpenBLAS: a program that imported numpy before mjasc
keeps numpy's own choice (:func:`status` says which; set the variables in the environment to pin it
then). CPUs without AVX2, and other architectures (aarch64), keep numpy's loops and give their own
bits. The cost is small: mjasc's arrays and matrices are small (a second BLAS thread does not pay
for its hand-off on them), and its hot loops are compiled (numba) anyway.
:mod:`mjasc.core.math_fingerprint` checks the result on a sample of that work: machines whose digests
differ will not repeat each other's runs.
"""

from __future__ import annotations

import os
import platform
import sys

__all__ = ["NUMPY_FEATURES_OFF", "BLAS_CORE", "BLAS_THREADS", "pin", "status", "cpu_flags"]

#: numpy's dispatch targets above x86-64-v3, turned off (numpy ≥ 2.3 names; ``numpy._core`` lists them).
NUMPY_FEATURES_OFF = "X86_V4 AVX512_ICL AVX512_SPR"
#: OpenBLAS's kernels for every AVX2 + FMA CPU.
BLAS_CORE = "Haswell"
#: OpenBLAS's threads (its LU splits the work by their number).
BLAS_THREADS = "1"

_X86 = ("x86_64", "amd64")


def cpu_flags() -> set[str]:
    """The CPU's feature flags (Linux ``/proc/cpuinfo``; empty where there is none)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def pin(environ=None, modules=None, machine: str | None = None, flags: set[str] | None = None) -> dict:
    """Set the variables of the module docstring in ``environ`` (default ``os.environ``) where they
    apply and are not set yet; nothing once numpy is in ``modules`` (default ``sys.modules``) or with
    ``MJASC_NATIVE_MATH=1``. Returns what it set (name → value)."""
    environ = os.environ if environ is None else environ
    modules = sys.modules if modules is None else modules
    if environ.get("MJASC_NATIVE_MATH") == "1" or "numpy" in modules:
        return {}
    set_now = {}
    if "OPENBLAS_NUM_THREADS" not in environ:
        set_now["OPENBLAS_NUM_THREADS"] = BLAS_THREADS
    machine = (platform.machine() if machine is None else machine).lower()
    if machine not in _X86:
        environ.update(set_now)
        return set_now
    if "NPY_DISABLE_CPU_FEATURES" not in environ:
        set_now["NPY_DISABLE_CPU_FEATURES"] = NUMPY_FEATURES_OFF
    flags = cpu_flags() if flags is None else flags
    if "OPENBLAS_CORETYPE" not in environ and {"avx2", "fma"} <= flags:
        set_now["OPENBLAS_CORETYPE"] = BLAS_CORE
    environ.update(set_now)
    return set_now


def status() -> dict:
    """What numpy runs with now: ``avx512_loops`` (True: numpy dispatches to AVX-512 loops, and runs
    give other bits than on AVX2-only CPUs), the variables as set, and the CPU's architecture."""
    from numpy._core._multiarray_umath import __cpu_features__

    return {"machine": platform.machine(),
            "avx512_loops": any(__cpu_features__.get(f, False) for f in NUMPY_FEATURES_OFF.split()),
            "NPY_DISABLE_CPU_FEATURES": os.environ.get("NPY_DISABLE_CPU_FEATURES"),
            "OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE"),
            "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS")}
