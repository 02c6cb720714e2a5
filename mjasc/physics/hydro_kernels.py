"""The per-step work of :meth:`mjasc.physics.hydrodynamics.Hydrodynamics.compute_bound` around its
one matrix product, as compiled loops over the vessels (all vessels in one call per physics step).

With the feature vector F (module notes in :mod:`mjasc.physics.hydrodynamics`, "MuJoCo
interface") the force on every hull is ``τ = F·G``. Per vessel n, body frame FLU, planar vectors as
complex numbers x + iy, a rotation a multiplication by ``e^{∓iψ}``:

:func:`hydro_features` writes F from MuJoCo's joint state and the shaft speeds::

    e^{−iψ} = cos(−ψ) + i sin(−ψ)
    u + iv   = (ẋ + iẏ)·e^{−iψ}                 body velocity [m/s]
    ν_c      = (V_c,x + iV_c,y)·e^{−iψ}          current in the body frame [m/s]
    u_r + iv_r = (u + iv) − ν_c
    RB       = (∂V_c/∂t + ∇V_c·ṗ)·e^{−iψ}        only when a current rate is given [m/s²]
    x = (u, v, r, u_r, v_r),  P_ij = x_i·x_j,  A_i = |x_i|·x_i
    w_k = (v_r + x_k·r) + 0,  CF_k = |w_k|·w_k   cross-flow strips
    a|a|, a·a                                    per propeller (port, starboard)

:func:`linear_form` writes τ = F·G as numpy's matmul gives it, and :func:`rotate_to_world` the world-frame force ``(τ_x + iτ_y)·conj(e^{−iψ})`` and the yaw
moment as is.

Bits. Each value is the expression numpy evaluated before, in the same order: a complex product
``a·b`` as numpy's complex multiply rounds it on FMA hardware (x86-64-v3 and later: real part
``fma(a.re, b.re, −a.im·b.im)``, imaginary part ``fma(a.re, b.im, a.im·b.re)``,
:func:`mjasc.core.compiled.fma`); ``e^{−iψ}`` as numpy's complex exp of a purely imaginary number
(``exp(0) = 1`` times cos and sin); the strip velocity as the (1 × 5)·(5 × S) matrix product
gave it (the exact products by 0 and 1 dropped; the sum starts from +0, so a zero is +0).
``tests/test_hydro_kernels.py`` keeps the numpy form and checks every output bit for bit.

τ = F·G: numpy's ``matmul`` of a (1 × K) row and a C-contiguous (K × 3) matrix is OpenBLAS's
``dgemv`` (row-major, transposed: its column-major "N" kernel on 3 rows, lda 3); on this machine
class (x86-64 with AVX2/FMA, OpenBLAS's Haswell/Zen kernels) that kernel sums each output as
``t + (a₀x₀ + a₁x₁)`` over pairs of K, four at a time, then ``t + a·x`` for the last K mod 4,
from t = +0 and without fused multiply-adds. :func:`linear_form` repeats that order;
``tests/test_hydro_kernels.py`` checks it against ``np.matmul`` with ``array_equal`` (bits, NaN
included) on the real shapes and on random ones (K = 1…89): if numpy's BLAS sums otherwise on
another machine, that test fails there.
"""

from __future__ import annotations

import math

from mjasc.core.compiled import fma, kernel

__all__ = ["hydro_features", "linear_form", "rotate_to_world"]


@kernel
def hydro_features(qpos3, qvel3, activation, current, rate, has_rate, cf_x, F, rot):
    """Write F (N, 41 + S) and e^{−iψ} as rot (N, 2) [cos, sin] for joint positions qpos3 (N, 3)
    (x, y, ψ), velocities qvel3 (N, 3) (ẋ, ẏ, ψ̇), world frame; shaft speeds activation (N, 2);
    the current (N, 2) [m/s] and, when has_rate, its rate (N, 2) [m/s²], world frame; strip
    positions cf_x (N, S) [m] (module docstring). F's current-rate columns are left as they are
    without a rate."""
    n_v = qpos3.shape[0]
    S = cf_x.shape[1]
    for n in range(n_v):
        c = math.cos(-qpos3[n, 2])
        s = math.sin(-qpos3[n, 2])
        rot[n, 0] = c
        rot[n, 1] = s
        qx, qy = qvel3[n, 0], qvel3[n, 1]
        u = fma(qx, c, -(qy * s))
        v = fma(qx, s, qy * c)
        r = qvel3[n, 2]
        cx, cy = current[n, 0], current[n, 1]
        u_r = u - fma(cx, c, -(cy * s))
        v_r = v - fma(cx, s, cy * c)
        if has_rate:
            ax, ay = rate[n, 0], rate[n, 1]
            F[n, 35 + S] = fma(ax, c, -(ay * s))
            F[n, 36 + S] = fma(ax, s, ay * c)
        x = (u, v, r, u_r, v_r)  # (a tuple: no array made per call)
        for i in range(5):
            F[n, i] = x[i]
            for j in range(5):
                F[n, 5 + 5 * i + j] = x[i] * x[j]
            F[n, 30 + i] = abs(x[i]) * x[i]
        for k in range(S):
            w = (v_r + cf_x[n, k] * r) + 0.0
            F[n, 35 + k] = abs(w) * w
        for p in range(2):
            a = activation[n, p]
            F[n, 37 + S + p] = abs(a) * a
            F[n, 39 + S + p] = a * a


@kernel
def linear_form(F, G, tau):
    """τ (N, 1, 3) ← F (N, K)·G (N, K, 3) per vessel (the body-frame force [N, N, N·m]), in the
    order of numpy's ``np.matmul(F[:, None, :], G, out=tau)`` (module docstring: OpenBLAS's dgemv,
    pairs of products added to a running sum, no FMA). The three sums of a vessel run side by side
    (independent chains the processor overlaps), each in that order."""
    K = F.shape[1]
    K4 = K - K % 4
    for n in range(F.shape[0]):
        t0 = t1 = t2 = 0.0
        i = 0
        while i < K4:
            f0, f1, f2, f3 = F[n, i], F[n, i + 1], F[n, i + 2], F[n, i + 3]
            t0 = t0 + (G[n, i, 0] * f0 + G[n, i + 1, 0] * f1)
            t1 = t1 + (G[n, i, 1] * f0 + G[n, i + 1, 1] * f1)
            t2 = t2 + (G[n, i, 2] * f0 + G[n, i + 1, 2] * f1)
            t0 = t0 + (G[n, i + 2, 0] * f2 + G[n, i + 3, 0] * f3)
            t1 = t1 + (G[n, i + 2, 1] * f2 + G[n, i + 3, 1] * f3)
            t2 = t2 + (G[n, i + 2, 2] * f2 + G[n, i + 3, 2] * f3)
            i += 4
        while i < K:
            f = F[n, i]
            t0 = t0 + G[n, i, 0] * f
            t1 = t1 + G[n, i, 1] * f
            t2 = t2 + G[n, i, 2] * f
            i += 1
        tau[n, 0, 0] = t0
        tau[n, 0, 1] = t1
        tau[n, 0, 2] = t2


@kernel
def rotate_to_world(tau, rot, out):
    """out (N, 3) ← the body force tau (N, 1, 3) rotated to world axes with conj(rot) (rot: e^{−iψ}
    as (N, 2) [cos, sin]); the yaw moment as is."""
    for n in range(tau.shape[0]):
        c = rot[n, 0]
        s = -rot[n, 1]
        tx, ty = tau[n, 0, 0], tau[n, 0, 1]
        out[n, 0] = fma(tx, c, -(ty * s))
        out[n, 1] = fma(tx, s, ty * c)
        out[n, 2] = tau[n, 0, 2]
