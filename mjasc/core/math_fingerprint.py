"""A machine's math fingerprint: the bits it gives for the floating-point work a run rests on.

A run is a function of its scenario and seed only where every floating-point operation rounds the
same way. The operations that can differ between machines with the same locked packages are the
ones whose implementation a library picks by the CPU when it loads: numpy's SIMD loops (pinned
below AVX-512 by :mod:`mjasc.core.portable_math`), OpenBLAS's kernels (numpy's and scipy's linear
algebra), glibc's ``libm`` (numba's compiled ``math`` calls it), numba's own code generation for the
host CPU, and MuJoCo's step and ray casts. :func:`fingerprint` runs a fixed sample of each kind of
work mjasc does and hashes the results bit for bit: two processes with the same fingerprint compute
those samples identically. A sample cannot prove that every input rounds alike, but each
difference found so far (numpy's AVX-512 loops, OpenBLAS's kernels and thread count) shows in it,
and a different fingerprint means a run will not replay bit for bit.

It does not involve mjasc's own models, so it changes only when a package or the machine's math
does — not when mjasc's behaviour changes. The test suite compares it with a reference taken on
another CPU kind (tests/test_math_fingerprint.py). To check the machines of a Dask cluster, run
``python -m mjasc.core.math_fingerprint`` on each (or in a worker's environment) and compare the
``digest`` lines: a machine that differs replays a campaign's runs to other bits.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["fingerprint", "digest", "environment"]

#: Samples per numpy function (a few thousand values from every range a run feeds them).
_N = 4096


def _inputs() -> tuple[np.ndarray, np.ndarray]:
    """Two fixed samples: standard normals scaled over several decades (signs mixed), and their
    companion for two-argument functions. numpy's PCG64 and its normals are exact integer work plus
    tables, so they are themselves part of the fingerprint (``random``)."""
    rng = np.random.default_rng(20261206)
    scale = np.array([1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0, 1000.0])[rng.integers(0, 10, size=_N)]
    return rng.standard_normal(_N) * scale, rng.standard_normal(_N) * scale[::-1]


def _h(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str(a.dtype).encode() + str(a.shape).encode() + a.tobytes())
    return h.hexdigest()[:16]


@kernel
def _compiled_math(x, y):
    """numba's compiled math over the samples, as the kernels use it: libm's functions, a loop's
    running sum in its written order, an FMA-free multiply-add chain, a square root."""
    n = x.size
    out = np.empty((8, n))
    acc = 0.0
    for i in range(n):
        a, b = x[i], y[i]
        out[0, i] = math.atan2(a, b)
        out[1, i] = math.hypot(a, b)
        out[2, i] = math.sin(a) * math.cos(b)
        out[3, i] = math.exp(-abs(a)) + math.log1p(abs(b))
        out[4, i] = math.tanh(a)
        out[5, i] = math.sqrt(abs(a * b))
        acc = acc + a * b - 0.5 * a
        out[6, i] = acc
        out[7, i] = math.pow(abs(a) + 1e-3, 0.37)
    return out


_MJCF = """
<mujoco>
  <option timestep="0.02" integrator="Euler" gravity="0 0 0"/>
  <worldbody>
    <geom type="box" size="2 8 1" pos="12 0 0"/>
    <geom type="cylinder" size="1.5 1" pos="-6 5 0"/>
    <body name="a" pos="0 0 0">
      <joint name="ax" type="slide" axis="1 0 0" damping="4"/>
      <joint name="ay" type="slide" axis="0 1 0" damping="4"/>
      <joint name="az" type="hinge" axis="0 0 1" damping="2"/>
      <geom type="box" size="1 0.5 0.3" mass="30"/>
    </body>
    <body name="b" pos="4 1 0">
      <joint name="bx" type="slide" axis="1 0 0" damping="3"/>
      <joint name="by" type="slide" axis="0 1 0" damping="3"/>
      <joint name="bz" type="hinge" axis="0 0 1" damping="1"/>
      <geom type="capsule" size="0.5 1" euler="0 90 0" mass="20"/>
    </body>
  </worldbody>
  <actuator>
    <motor joint="ax" gear="40"/><motor joint="ay" gear="40"/><motor joint="az" gear="8"/>
    <motor joint="bx" gear="30"/><motor joint="by" gear="30"/><motor joint="bz" gear="6"/>
  </actuator>
</mujoco>
"""


def _mujoco_part() -> str:
    """MuJoCo's step (two bodies pushed into each other and a wall: contacts, damping, Euler) and a
    360-beam ray fan from one of them, as the range sensor casts it."""
    import mujoco

    m = mujoco.MjModel.from_xml_string(_MJCF)
    d = mujoco.MjData(m)
    t = np.arange(400) * 0.02
    ctrl = np.stack([np.sin(t), np.cos(0.7 * t), 0.3 * np.sin(1.3 * t), -np.cos(t), np.sin(0.4 * t), 0.2 + 0 * t], 1)
    states = np.empty((400, m.nq + m.nv))
    for k in range(400):
        d.ctrl[:] = ctrl[k]
        mujoco.mj_step(m, d)
        states[k, :m.nq], states[k, m.nq:] = d.qpos, d.qvel
    angles = np.arange(360) * (2 * math.pi / 360)
    vec = np.zeros((360, 3))
    vec[:, 0], vec[:, 1] = np.cos(angles), np.sin(angles)
    dist, gid = np.empty(360), np.empty(360, dtype=np.int32)
    pnt = np.array([d.qpos[0], d.qpos[1], 0.0])
    mujoco.mj_multiRay(m, d, pnt, vec.reshape(-1), None, 1, m.body("a").id, gid, dist, None, 360, 50.0)
    return _h(states, dist, gid)


def fingerprint() -> dict[str, str]:
    """The fingerprint: part name → the first 16 hex digits of the SHA-256 of its results' bytes.

    Parts: ``random`` (the samples), ``numpy_<name>`` per float64 ufunc a run calls, ``numpy_products``
    (matrix products of the IMM's and the potential field's sizes), ``numpy_linalg`` (inverse,
    symmetric eigenvalues, solve, least squares), ``scipy_lu`` (the potential field's LU solve),
    ``numba_math`` (:func:`_compiled_math`) and ``mujoco`` (:func:`_mujoco_part`)."""
    from scipy.linalg import lu_factor, lu_solve

    x, y = _inputs()
    parts = {"random": _h(x, y)}
    small = x / np.max(np.abs(x))  # (within [−1, 1]: arcsin, and tanh's interesting range)
    for name, value in (
            ("sin", np.sin(x)), ("cos", np.cos(x)), ("tanh", np.tanh(x)), ("tanh_small", np.tanh(small)),
            ("exp", np.exp(-np.abs(x))), ("expm1", np.expm1(small)), ("log", np.log(np.abs(x))),
            ("arctan2", np.arctan2(y, x)), ("arctan", np.arctan(x)), ("hypot", np.hypot(x, y)),
            ("sqrt", np.sqrt(np.abs(x))), ("arcsin", np.arcsin(small)), ("power", np.power(np.abs(x), 0.37))):
        parts["numpy_" + name] = _h(value)
    # products as the tracker's (k, 4, 4) covariances and the potential field's (k, m) @ (m, 2) take them
    a = small[:64 * 16].reshape(64, 4, 4)
    b = (y / np.max(np.abs(y)))[:64 * 16].reshape(64, 4, 4)
    field = small[:40 * 60].reshape(40, 60)
    parts["numpy_products"] = _h(a @ b, a @ np.swapaxes(b, 1, 2), field @ b.reshape(-1, 2)[:60], small[:60] @ field.T)
    spd = a @ np.swapaxes(a, 1, 2) + 0.1 * np.eye(4)  # (symmetric positive definite)
    square = field[:, :40] + 40 * np.eye(40)
    lsq = np.linalg.lstsq(field[:, :3], small[:40], rcond=None)[0]
    parts["numpy_linalg"] = _h(np.linalg.inv(spd[:, :3, :3]), np.linalg.eigvalsh(spd),
                               np.linalg.eigh(spd[:, :2, :2])[0], np.linalg.solve(square, small[:40]), lsq,
                               np.linalg.norm(field, axis=1))
    lu = lu_factor(square)
    parts["scipy_lu"] = _h(lu[0], lu_solve(lu, small[:40]), lu_solve(lu, field[:, :5]))
    parts["numba_math"] = _h(_compiled_math(x, y))
    parts["mujoco"] = _mujoco_part()
    return parts


def digest(parts: dict[str, str] | None = None) -> str:
    """One 16-hex-digit digest of :func:`fingerprint` (or of ``parts``)."""
    parts = fingerprint() if parts is None else parts
    return hashlib.sha256("".join(f"{k}={v};" for k, v in sorted(parts.items())).encode()).hexdigest()[:16]


def environment() -> dict[str, str]:
    """What the fingerprint depends on besides the CPU: the packages' and glibc's versions and the
    numpy/OpenBLAS pin (:func:`mjasc.core.portable_math.status`: numpy's AVX-512 loops on or off,
    OpenBLAS's kernels and threads)."""
    import platform

    import mujoco
    import numba
    import scipy

    from mjasc.core.portable_math import status

    pin = status()
    return {"numpy": np.__version__, "scipy": scipy.__version__, "numba": numba.__version__,
            "mujoco": mujoco.__version__, "libc": " ".join(platform.libc_ver()), "machine": platform.machine(),
            "avx512_loops": str(pin["avx512_loops"]), "openblas_coretype": str(pin["OPENBLAS_CORETYPE"]),
            "openblas_threads": str(pin["OPENBLAS_NUM_THREADS"])}


def main() -> None:
    """``python -m mjasc.core.math_fingerprint``: the digest, then every part and the environment."""
    parts = fingerprint()
    print(f"digest {digest(parts)}")
    for k, v in parts.items():
        print(f"{k} {v}")
    for k, v in environment().items():
        print(f"# {k} {v}")


if __name__ == "__main__":
    main()
