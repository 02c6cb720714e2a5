"""The compiled hydrodynamic step (mjasc.physics.hydro_kernels) gives the same bits as the numpy form
of Hydrodynamics.compute_bound it replaced, kept here as the reference."""

import mujoco
import numpy as np
import pytest

from mjasc.physics.hydro_kernels import hydro_features, linear_form, rotate_to_world
from tests.helpers import make_sim


class NumpyForm:
    """The numpy compute_bound (complex numbers for planar vectors), on its own buffers."""

    def __init__(self, h):
        n, S = h.n_vessels, h._cf_x.shape[1]
        self.h = h
        self._F = np.zeros((n, 41 + S))
        self._F_uv = self._F[:, 0:2].view(np.complex128)[:, 0]
        self._F_rel = self._F[:, 3:5].view(np.complex128)[:, 0]
        self._F_rb = self._F[:, 35 + S:37 + S].view(np.complex128)[:, 0]
        self._F_outer = self._F[:, 5:30].reshape(n, 5, 5)
        self._x_col = self._F[:, :5, None]
        self._x_row = self._F[:, None, :5]
        self._F_row = self._F[:, None, :]
        self._S = S
        self._strip_map = np.zeros((n, 5, S))
        self._strip_map[:, 2, :] = h._cf_x
        self._strip_map[:, 4, :] = 1.0
        self._arg = np.zeros(n, dtype=np.complex128)
        self._arg_imag = self._arg.imag
        self._rot = np.zeros(n, dtype=np.complex128)
        self._conj = np.zeros(n, dtype=np.complex128)
        self._cur = np.zeros(n, dtype=np.complex128)
        self._tmp5 = np.zeros((n, 5))
        self._w = np.zeros((n, 1, S))
        self._wabs = np.zeros((n, 1, S))
        self._aa = np.zeros((n, 2))
        self._tau = np.zeros((n, 1, 3))
        self._tau_xy = self._tau[:, 0, 0:2].view(np.complex128)[:, 0]
        self._tau_n = self._tau[:, 0, 2]
        self._F_x = self._F[:, :5]
        self._F_r = self._F[:, 2]
        self._F_xx = self._F[:, 30:35]
        self._F_ww = self._F[:, None, 35:35 + S]
        self._F_aa = self._F[:, 37 + S:39 + S]
        self._F_a2 = self._F[:, 39 + S:41 + S]

    def compute(self, qpos3, qvel3, activation, out, current_world, current_rate_world):
        psi, qvel_xy, yaw_rate = qpos3[:, 2], qvel3[:, 0:2].view(np.complex128)[:, 0], qvel3[:, 2]
        out_xy, out_n = out[:, 0:2].view(np.complex128)[:, 0], out[:, 2]
        rot, mul, absolute = self._rot, np.multiply, np.abs
        np.negative(psi, out=self._arg_imag)
        np.exp(self._arg, out=rot)
        mul(qvel_xy, rot, out=self._F_uv)
        self._F_r[:] = yaw_rate
        mul(current_world.view(np.complex128)[:, 0], rot, out=self._cur)
        np.subtract(self._F_uv, self._cur, out=self._F_rel)
        if current_rate_world is not None:
            mul(current_rate_world.view(np.complex128)[:, 0], rot, out=self._F_rb)
        mul(self._x_col, self._x_row, out=self._F_outer)
        absolute(self._F_x, out=self._tmp5)
        mul(self._tmp5, self._F_x, out=self._F_xx)
        if self._S:
            np.matmul(self._x_row, self._strip_map, out=self._w)
            absolute(self._w, out=self._wabs)
            mul(self._wabs, self._w, out=self._F_ww)
        absolute(activation, out=self._aa)
        mul(self._aa, activation, out=self._F_aa)
        mul(activation, activation, out=self._F_a2)
        np.matmul(self._F_row, self.h._G, out=self._tau)
        np.conjugate(rot, out=self._conj)
        mul(self._tau_xy, self._conj, out=out_xy)
        out_n[:] = self._tau_n


def _numpy_fuses_complex_multiply() -> bool:
    """Whether numpy's complex multiply rounds a·b − c·d once (FMA SIMD loops, x86-64-v3 and
    later), as the compiled kernels do: (1 + 2⁻³⁰)² − 1 is 2⁻²⁹ + 2⁻⁶⁰ fused, 2⁻²⁹ unfused."""
    x = np.array([1.0 + 2.0 ** -30 + 1j], dtype=np.complex128)
    return bool((x * x).real[0] != 2.0 ** -29)


#: On hardware where numpy does not fuse, the kernels (always fused: correctly rounded) differ from
#: the numpy form in the last bit of some products; then the comparison allows a few ulps.
_EXACT = _numpy_fuses_complex_multiply()


def _same(a, b):
    if not _EXACT:
        return np.allclose(a, b, rtol=1e-14, atol=1e-300, equal_nan=True)
    return np.array_equal(a, b, equal_nan=True) and np.array_equal(np.signbit(a), np.signbit(b))


def _states(rng, n, k):
    """k random joint states of n vessels, with exact zeros, signed zeros and ψ beyond ±π."""
    for t in range(k):
        q = np.column_stack([rng.normal(0, 50, (n, 2)), rng.uniform(-7, 7, n)])
        qd = np.column_stack([rng.normal(0, 1.5, (n, 2)), rng.normal(0, 0.4, n)])
        cur = rng.normal(0, 0.5, (n, 2))
        rate = rng.normal(0, 0.05, (n, 2))
        act = rng.uniform(-1, 1, (n, 2))
        if t % 4 == 0:  # at rest in still water, no thrust
            qd[:] = cur[:] = act[:] = rate[:] = 0.0
            q[:, 2] = rng.choice([0.0, -0.0, np.pi, -np.pi / 2], n)
        elif t % 4 == 1:
            qd[:, 1] = -0.0
            cur[:, 0] = -0.0
            act[0] = (-0.0, 1.0)
        yield q, qd, cur, rate, act


@pytest.mark.parametrize("vessel,n", [("otter", 1), ("otter", 3), ("delfim", 2), ("otter", 7)])
@pytest.mark.parametrize("with_rate", [False, True])
def test_compiled_step_equals_numpy_form(vessel, n, with_rate):
    sim = make_sim(vessel, n=n)
    h = sim.hydro
    ref = NumpyForm(h)
    rng = np.random.default_rng(n + 10 * with_rate)
    for q, qd, cur, rate, act in _states(rng, n, 40):
        rt = rate if with_rate else None
        out_ref, out = np.zeros((n, 3)), np.zeros((n, 3))
        ref.compute(q, qd, act, out_ref, cur, rt)
        h.bind(q, qd, act, out)
        h.compute_bound(cur, rt)
        assert _same(h._F, ref._F)
        assert _same(out, out_ref)


def test_bound_to_mujoco_memory_equals_numpy_form():
    """On MjData's own views (the runner's case), along a simulated run."""
    sim = make_sim("otter", n=3)
    h = sim.hydro
    ref = NumpyForm(h)
    d = sim.data
    d.act[:6] = [0.8, 0.5, -0.3, 0.9, 1.0, 1.0]
    vc = np.array([[0.2, -0.1]] * 3)
    for _ in range(200):
        mujoco.mj_step1(sim.model, d)
        out_ref = np.zeros((3, 3))
        ref.compute(sim._qpos3, sim._qvel3, sim._act_view, out_ref, vc, None)
        h.compute_bound(vc, None)
        assert _same(sim._qfrc3, out_ref)
        mujoco.mj_step2(sim.model, d)


def test_kernels_on_empty_fleet_and_no_strips():
    F, rot = np.zeros((0, 41)), np.zeros((0, 2))
    z = np.zeros((0, 3))
    hydro_features(z, z, np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2)), False, np.zeros((0, 0)), F, rot)
    rotate_to_world(np.zeros((0, 1, 3)), rot, z)
    F = np.full((1, 41), 7.0)
    hydro_features(np.zeros((1, 3)), np.ones((1, 3)), np.ones((1, 2)), np.zeros((1, 2)), np.zeros((1, 2)), False,
                   np.zeros((1, 0)), F, np.zeros((1, 2)))
    assert F[0, 35] == 7.0 and F[0, 36] == 7.0  # no rate: its columns untouched
    assert F[0, 0] == 1.0 and F[0, 37] == 1.0 and F[0, 39] == 1.0


def _linear_form_agrees(F, G):
    """linear_form against np.matmul(F[:, None, :], G, out=τ) (τ starting as NaN), every bit."""
    want, got = np.full((F.shape[0], 1, 3), np.nan), np.full((F.shape[0], 1, 3), 5.0)
    with np.errstate(invalid="ignore", over="ignore"):
        np.matmul(F[:, None, :], G, out=want)
        linear_form(F, G, got)
    return want.tobytes() == got.tobytes()


def test_linear_form_has_the_bits_of_numpys_matmul_on_a_run():
    """τ = F·G in OpenBLAS's dgemv order (hydro_kernels' docstring) on the real shapes and values:
    the G of three otters, F of a simulated run, each perturbed and with random signs."""
    sim = make_sim("otter", n=3)
    tau, rot, F, cf_x, G = sim.hydro.step_arrays()
    d, rng = sim.data, np.random.default_rng(3)
    d.act[:6] = [0.8, 0.5, -0.3, 0.9, 1.0, -1.0]
    d.qvel[:9] = rng.standard_normal(9)
    seen = []
    for _ in range(300):
        sim.hydro.compute_bound(np.array([[0.2, -0.1]] * 3), None)
        seen.append(F.copy())
        mujoco.mj_step(sim.model, d)
    bad = 0
    for f in seen:
        for _ in range(40):
            g = f * (1 + 1e-3 * rng.standard_normal(f.shape)) * rng.choice([-1.0, 1.0], size=f.shape)
            bad += not _linear_form_agrees(g, G)
    assert bad == 0


def test_linear_form_has_the_bits_of_numpys_matmul_on_random_shapes():
    """Every K = 1…89 (every remainder of K mod 4), 1–8 vessels, magnitudes over 12 decades, zeros of
    both signs, NaN and ±inf."""
    rng = np.random.default_rng(11)
    for K in range(1, 90):
        for n in (1, 3, 8):
            G = rng.standard_normal((n, K, 3)) * 10.0 ** rng.integers(-4, 5, size=(n, K, 3))
            G[rng.random(G.shape) < 0.1] = 0.0
            for rep in range(20):
                F = rng.standard_normal((n, K)) * 10.0 ** rng.integers(-6, 6, size=(n, K))
                u = rng.random(F.shape)
                F[u < 0.05], F[(u > 0.05) & (u < 0.08)] = 0.0, -0.0
                if rep % 5 == 4:
                    F[u > 0.99] = rng.choice([np.nan, np.inf, -np.inf])
                assert _linear_form_agrees(F, G), (K, n, rep)
