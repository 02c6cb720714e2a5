"""Fossen's 3-DOF manoeuvring model (surge, sway, yaw), for all vessels at once.

Equations (Fossen 2021, ch. 6 and 10), body frame FLU, about the hull reference point CO::

    M_RB ν̇ + C_RB(ν) ν  +  M_A ν̇_r + C_A(ν_r) ν_r + D(ν_r) ν_r  =  τ_prop          (1)
    ν_r = ν − ν_c,    ν_c = R(ψ)ᵀ V_c(p, t)

MuJoCo integrates the rigid-body part ``M_RB ν̇ + C_RB(ν) ν`` itself (the hull's mass, centre of
gravity and inertia come from the MJCF). mjasc adds the hydrodynamic force

    τ_hyd = −M_A (ν̇ − ν̇_c) − C_A(ν_r) ν_r − D(ν_r) ν_r                               (2)

**Added mass, exactly and stably.** (2) needs ν̇ of the step being taken. Feeding back the
previous step's acceleration is an explicit loop with gain M_A/M_RB, which diverges as soon as the
added mass exceeds the rigid mass (Otter sway: 82.5 vs 80 kg; yaw: 25.7 vs ~17 kg·m²); low-pass
filtering it makes it stable but lags. Instead we solve (1) for ν̇ before MuJoCo does: in the
body frame ``M = M_RB + M_A`` is constant, so per vessel

    ν̇* = M⁻¹ [ τ_prop − C_RB(ν)ν − C_A(ν_r)ν_r − D(ν_r)ν_r + M_A ν̇_c ]            (3)

and we apply ``τ = τ_prop + τ_hyd(ν̇*)``. MuJoCo then computes ``M_RB ν̇ = τ − C_RB ν`` which
gives back exactly ν̇ = ν̇* (substitute (2) into it). No iteration, no lag, no stability limit
beyond that of the explicit damping terms. The forces are computed between ``mj_step1`` (positions
and velocities known) and ``mj_step2`` (acceleration and integration). Constraint forces (hull
contacts) are not known at that point, so during a contact they act on the rigid mass alone: a
collision is already a failed run, and the approximation is stated here.

**Current.** ``ν̇_c`` is the rate of change of the current in the body frame as seen along the
vessel's path: ``ν̇_c = −S(r) ν_c + R(ψ)ᵀ (∂V_c/∂t + ∇V_c · ṗ)`` with ``S(r) ν = (−r v, r u)``.
For a uniform steady current this is Fossen's ``(r v_c, −r u_c, 0)``; the whole model is then
Galilean invariant (motion relative to the water equals still-water motion), which the tests check.

**Damping** ``D(ν_r)ν_r``: linear ``−(X_u u_r, Y_v v_r, N_r r)``, quadratic surge ``−X_uu |u_r| u_r``,
nonlinear yaw ``N_r (1 + k_r |r|) r`` (Fossen's Otter), and strip-theory cross-flow drag on sway
and yaw (Fossen's ``crossFlowDrag``): ``Y = −½ρ T C_d Σ |v_r + x r|(v_r + x r) Δx``,
``N = −½ρ T C_d Σ x |v_r + x r|(v_r + x r) Δx`` over strips x ∈ [−L/2, L/2].

**Coriolis** (Fossen eq. 6.43/6.99 in 3 DOF, identical in FRD and FLU)::

    C_RB(ν)ν  = (−m x_g r² − m v r,  m u r − m y_g r²,  m x_g u r + m y_g v r)
    C_A(ν_r)ν_r = (−(a22 v_r + a23 r) r,  a11 u_r r,  (a22 v_r + a23 r) u_r − a11 u_r v_r)

with ``a_ij`` the positive added masses ``M_A = −[[X_u̇,0,0],[0,Y_v̇,Y_ṙ],[0,N_v̇,N_ṙ]]``. The
``(a11 − a22) u_r v_r`` yaw term is the Munk moment that makes the Otter directionally unstable
above ~1.2 m/s in open loop.

Everything is computed for all N vessels at once on (N,) arrays: no Python loop per vessel.
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass
from typing import Sequence

import numpy as np

from mjasc.core.config_tables import ConfigError, check_params, param
from mjasc.physics.hydro_kernels import hydro_features, linear_form, rotate_to_world

__all__ = ["HydroCoefficients", "rigid_body_mass_matrix", "Hydrodynamics"]


_FOSSEN_SIGN = "must be finite and ≤ 0 (Fossen's sign: hydrodynamic derivatives are negative)"


def _derivative(doc: str, unit: str, default: float = MISSING):
    """A hydrodynamic derivative: ≤ 0 by Fossen's sign convention."""
    return param(default, maximum=0.0, phrase=_FOSSEN_SIGN, unit=unit, doc=doc)


@dataclass(frozen=True)
class HydroCoefficients:
    """One hull's hydrodynamic derivatives (Fossen's signs: negative derivatives), FLU body frame.

    Added mass [kg, kg·m, kg·m²]: X_udot, Y_vdot, Y_rdot, N_vdot, N_rdot.
    Linear damping [N·s/m, N·m·s]: X_u, Y_v, N_r (negative). Quadratic surge X_uu [N·s²/m²].
    Nonlinear yaw gain N_r_nonlinear_gain [s/rad]: N = N_r (1 + gain |r|) r.
    Cross-flow drag: drag_coefficient_2d, strips, water_density_kg_m3, length_m, draft_m.
    """

    X_udot: float = _derivative("surge added mass derivative (−a11)", "kg")
    Y_vdot: float = _derivative("sway added mass derivative (−a22)", "kg")
    N_rdot: float = _derivative("yaw added mass derivative (−a33)", "kg·m²")
    X_u: float = _derivative("linear surge damping", "N·s/m")
    Y_v: float = _derivative("linear sway damping", "N·s/m")
    N_r: float = _derivative("linear yaw damping", "N·m·s")
    Y_rdot: float = param(0.0, unit="kg·m", doc="sway–yaw added mass coupling (−a23)")
    N_vdot: float = param(0.0, unit="kg·m", doc="yaw–sway added mass coupling (−a32)")
    X_uu: float = _derivative("quadratic surge damping", "N·s²/m²", 0.0)
    N_r_nonlinear_gain: float = param(0.0, nonneg=True, unit="s/rad", doc="k_r of N = N_r (1 + k_r |r|) r")
    cross_flow: bool = param(False, doc="strip-theory cross-flow drag on sway and yaw")
    drag_coefficient_2d: float = param(0.0, doc="2-D cross-flow drag coefficient C_d (Hoerner)")
    strips: int = param(20, doc="number of strips over the length")
    water_density_kg_m3: float = param(1025.0, unit="kg/m³", doc="water density ρ")
    length_m: float = param(1.0, unit="m", doc="hull length L of the strips")
    draft_m: float = param(0.0, unit="m", doc="draft T of the strips")

    def __post_init__(self):
        check_params(self, "hydrodynamics")
        self.check(self, "hydrodynamics")

    @staticmethod
    def check(config: "HydroCoefficients", where: str) -> None:
        """Cross-flow drag needs strips over a hull of positive length and draft; the added mass's
        sway–yaw couplings must be equal (M_A symmetric, as ideal flow gives it: the added-mass
        Coriolis term C_A(ν_r)ν_r is written with a23 alone and conserves energy only then)."""
        if config.cross_flow and (config.strips < 1 or config.length_m <= 0 or config.draft_m <= 0):
            raise ConfigError(f"{where}.cross_flow: needs strips ≥ 1, length_m > 0 and draft_m > 0")
        if config.Y_rdot != config.N_vdot:
            raise ConfigError(f"{where}.N_vdot: must equal Y_rdot (the added-mass matrix is symmetric), got "
                              f"N_vdot = {config.N_vdot:g}, Y_rdot = {config.Y_rdot:g}")

    @property
    def added_mass(self) -> np.ndarray:
        """Positive-definite 3×3 added-mass matrix M_A over (u, v, r)."""
        return -np.array(
            [[self.X_udot, 0.0, 0.0], [0.0, self.Y_vdot, self.Y_rdot], [0.0, self.N_vdot, self.N_rdot]]
        )


def rigid_body_mass_matrix(mass_kg: float, cog_body_m: Sequence[float], izz_cog_kg_m2: float) -> np.ndarray:
    """3-DOF rigid-body mass matrix M_RB about CO (Fossen eq. 3.44 reduced to u, v, r).

    cog_body_m: (x_g, y_g) of the centre of gravity in the body frame [m].
    izz_cog_kg_m2: yaw moment of inertia about the centre of gravity.
    """
    x_g, y_g = float(cog_body_m[0]), float(cog_body_m[1])
    m = float(mass_kg)
    iz = izz_cog_kg_m2 + m * (x_g**2 + y_g**2)
    return np.array([[m, 0.0, -m * y_g], [0.0, m, m * x_g], [-m * y_g, m * x_g, iz]])


class Hydrodynamics:
    """Hydrodynamic + propeller forces for N vessels, solved with exact added mass (eq. 3).

    Construct once per model with each vessel's rigid-body mass matrix and coefficients; call
    :meth:`generalized_forces` once per physics step. Inputs and outputs are (N, ·) arrays.
    """

    def __init__(self, rigid_body_mass: np.ndarray, coefficients: Sequence[HydroCoefficients]):
        m_rb = np.asarray(rigid_body_mass, dtype=float).reshape(-1, 3, 3)
        if len(coefficients) != m_rb.shape[0]:
            raise ValueError(
                f"coefficients: {len(coefficients)} entries for {m_rb.shape[0]} rigid-body mass matrices"
            )
        n = m_rb.shape[0]
        self.n_vessels = n
        m_a = np.stack([c.added_mass for c in coefficients]) if n else np.zeros((0, 3, 3))
        self.rigid_body_mass = m_rb
        self.added_mass = m_a
        self.total_mass = m_rb + m_a
        self._m_inv = np.linalg.inv(self.total_mass) if n else np.zeros((0, 3, 3))
        # Rigid-body Coriolis constants (Fossen eq. 6.99): m, m·x_g, m·y_g.
        self._m = m_rb[:, 0, 0].copy()
        self._mxg = m_rb[:, 1, 2].copy()
        self._myg = -m_rb[:, 0, 2].copy()
        self._a11 = m_a[:, 0, 0].copy()
        self._a22 = m_a[:, 1, 1].copy()
        self._a23 = m_a[:, 1, 2].copy()
        self._a32 = m_a[:, 2, 1].copy()
        arr = lambda name: np.array([getattr(c, name) for c in coefficients], dtype=float)  # noqa: E731
        self._xu, self._yv, self._nr = arr("X_u"), arr("Y_v"), arr("N_r")
        self._xuu, self._nr_gain = arr("X_uu"), arr("N_r_nonlinear_gain")
        self._has_xuu = bool(np.any(self._xuu != 0.0))
        self._has_nr_gain = bool(np.any(self._nr_gain != 0.0))
        # Cross-flow strips as one padded (N, S) table: x positions and ½ρ T C_d Δx per strip
        # (zero weight for vessels without cross-flow or with fewer strips).
        strips = max([c.strips + 1 for c in coefficients if c.cross_flow], default=0)
        self._cf_x = np.zeros((n, strips))
        self._cf_w = np.zeros((n, strips))
        for i, c in enumerate(coefficients):
            if c.cross_flow:
                dx = c.length_m / c.strips
                self._cf_x[i, : c.strips + 1] = np.linspace(-c.length_m / 2, c.length_m / 2, c.strips + 1)
                self._cf_w[i, : c.strips + 1] = 0.5 * c.water_density_kg_m3 * c.draft_m * c.drag_coefficient_2d * dx
        self._has_cross_flow = strips > 0
        self._cf_wx = self._cf_w * self._cf_x

    # ------------------------------------------------------------------ model pieces (body frame)
    def damping_force(self, u_r, v_r, r):
        """−D(ν_r)ν_r as (X, Y, N) arrays: linear, quadratic surge, nonlinear yaw, cross-flow."""
        x = self._xu * u_r
        if self._has_xuu:
            x = x + self._xuu * np.abs(u_r) * u_r
        y = self._yv * v_r
        n = self._nr * r
        if self._has_nr_gain:
            n = n * (1.0 + self._nr_gain * np.abs(r))
        if self._has_cross_flow:
            w = v_r[:, None] + self._cf_x * r[:, None]
            ucf = np.abs(w) * w
            y = y - np.einsum("ij,ij->i", self._cf_w, ucf)
            n = n - np.einsum("ij,ij->i", self._cf_wx, ucf)
        return x, y, n

    def body_acceleration(self, nu, nu_c, nu_c_dot, tau_prop):
        """ν̇* of eq. (3) for body velocities ``nu`` (N,3), current ``nu_c`` (N,2) and its body-frame
        rate ``nu_c_dot`` (N,2), propeller force ``tau_prop`` (N,3). Returns (ν̇*, τ_hyd)."""
        u, v, r = nu[:, 0], nu[:, 1], nu[:, 2]
        u_r = u - nu_c[:, 0]
        v_r = v - nu_c[:, 1]
        dx, dy, dn = self.damping_force(u_r, v_r, r)
        # C_RB(ν)ν and C_A(ν_r)ν_r (module docstring).
        mr = self._m * r
        crb = (-self._mxg * r * r - mr * v, mr * u - self._myg * r * r, self._mxg * u * r + self._myg * v * r)
        sway_a = self._a22 * v_r + self._a23 * r
        ca = (-sway_a * r, self._a11 * u_r * r, sway_a * u_r - self._a11 * u_r * v_r)
        # M_A ν̇_c (ν̇_c has no yaw component: the current does not rotate the hull).
        ma_c0 = self._a11 * nu_c_dot[:, 0]
        ma_c1 = self._a22 * nu_c_dot[:, 1]
        ma_c2 = self._a32 * nu_c_dot[:, 1]
        h = np.stack([dx - ca[0], dy - ca[1], dn - ca[2]], axis=-1)  # −C_A ν_r − D ν_r
        rhs = tau_prop + h - np.stack(crb, axis=-1) + np.stack([ma_c0, ma_c1, ma_c2], axis=-1)
        nu_dot = np.einsum("nij,nj->ni", self._m_inv, rhs)
        rel = nu_dot.copy()
        rel[:, :2] -= nu_c_dot
        tau_hyd = h - np.einsum("nij,nj->ni", self.added_mass, rel)
        return nu_dot, tau_hyd

    # ------------------------------------------------------------------ MuJoCo interface (fast path)
    #
    # Everything applied to the hull, τ = τ_prop + τ_hyd(ν̇*), is *linear* in a feature vector F of
    # each vessel's state: because ν̇* of eq. (3) is linear in the right-hand side, which is linear
    # in these terms::
    #
    #   x      = (u, v, r, u_r, v_r)                 5   velocities (body frame)
    #   P_ij   = x_i x_j                             25  Coriolis / Munk / ν̇_c products (r v_c = r v − r v_r)
    #   A_i    = |x_i| x_i                           5   quadratic surge, nonlinear yaw
    #   CF_k   = |v_r + x_k r| (v_r + x_k r)         S   cross-flow strips
    #   RB     = R(ψ)ᵀ V̇_c                           2   current rate in the body frame
    #   TH     = a|a|, a²  (per side)                4   propeller thrust: k_f n_max² max(a|a|,0) + k_r n_min² min(a|a|,0)
    #                                                    with max(y,0) = (y + a²)/2, min(y,0) = (y − a²)/2 for y = a|a|
    #
    # so τ = F · G with a constant (K × 3) matrix G per vessel, assembled once in
    # :meth:`_linear_form` from exactly the terms of :meth:`body_acceleration`. One compiled product
    # then replaces ~50 small numpy calls: numpy's per-call overhead, not arithmetic, is the cost at
    # these sizes. ``tests/test_hydrodynamics.py`` checks F · G against body_acceleration.

    def attach_propellers(self, thrust_weights: np.ndarray) -> None:
        """Set the propeller part of the linear form from the (N, 4, 3) body force per unit of
        (max(a|a|,0) port, starboard, min(a|a|,0) port, starboard), a = normalized shaft speed.
        Stored per unit of the features (a|a| port, starboard, a² port, starboard)."""
        w = np.asarray(thrust_weights, dtype=float).reshape(self.n_vessels, 4, 3)
        pos, neg = w[:, 0:2], w[:, 2:4]
        self._thrust_weights = np.concatenate([0.5 * (pos + neg), 0.5 * (pos - neg)], axis=1)
        self._G = self._linear_form()

    def _linear_form(self) -> np.ndarray:
        n, S = self.n_vessels, self._cf_x.shape[1]
        K = 41 + S
        Q = np.zeros((n, K, 3))   # τ_prop + h, h = −C_A ν_r − D ν_r
        E = np.zeros((n, K, 3))   # −C_RB ν + M_A ν̇_c
        Cn = np.zeros((n, K, 3))  # ν̇_c padded with a zero yaw component
        U, V, R, UR, VR = range(5)
        P = lambda i, j: 5 + 5 * i + j  # noqa: E731
        A = lambda i: 30 + i  # noqa: E731
        CF0, RB0, TH0 = 35, 35 + S, 37 + S
        # damping (module docstring)
        Q[:, UR, 0] += self._xu
        Q[:, A(UR), 0] += self._xuu
        Q[:, VR, 1] += self._yv
        Q[:, R, 2] += self._nr
        Q[:, A(R), 2] += self._nr * self._nr_gain
        Q[:, CF0:CF0 + S, 1] -= self._cf_w
        Q[:, CF0:CF0 + S, 2] -= self._cf_wx
        # −C_A(ν_r)ν_r
        Q[:, P(VR, R), 0] += self._a22
        Q[:, P(R, R), 0] += self._a23
        Q[:, P(UR, R), 1] -= self._a11
        Q[:, P(VR, UR), 2] -= self._a22
        Q[:, P(R, UR), 2] -= self._a23
        Q[:, P(UR, VR), 2] += self._a11
        # propellers
        Q[:, TH0:TH0 + 4, :] += self._thrust_weights
        # −C_RB(ν)ν
        E[:, P(R, R), 0] += self._mxg
        E[:, P(V, R), 0] += self._m
        E[:, P(U, R), 1] -= self._m
        E[:, P(R, R), 1] += self._myg
        E[:, P(U, R), 2] -= self._mxg
        E[:, P(V, R), 2] -= self._myg
        # ν̇_c = (r v_c + RB_0, −r u_c + RB_1) with r v_c = r v − r v_r, r u_c = r u − r u_r
        Cn[:, P(R, V), 0] += 1.0
        Cn[:, P(R, VR), 0] -= 1.0
        Cn[:, RB0, 0] += 1.0
        Cn[:, P(R, U), 1] -= 1.0
        Cn[:, P(R, UR), 1] += 1.0
        Cn[:, RB0 + 1, 1] += 1.0
        ma_t = np.transpose(self.added_mass, (0, 2, 1))
        minv_t = np.transpose(self._m_inv, (0, 2, 1))
        E = E + Cn @ ma_t
        # τ = q − M_A (ν̇* − ν̇_c),  ν̇* = M⁻¹ (q + e)   (row-vector form: F·G)
        return Q - (Q + E) @ minv_t @ ma_t + Cn @ ma_t

    def allocate_buffers(self) -> None:
        """Preallocate the per-step work arrays (the fast path allocates nothing per step)."""
        n, S = self.n_vessels, self._cf_x.shape[1]
        self._F = np.zeros((n, 41 + S))
        self._S = S
        self._rot2 = np.zeros((n, 2))        # e^{−iψ} as (cos, sin) per vessel
        self._no_rate = np.zeros((n, 2))     # (the current rate's place when there is none)
        self._tau = np.zeros((n, 1, 3))
        self._bound = None

    def step_arrays(self) -> tuple:
        """The arrays a compiled step works on (after :meth:`allocate_buffers`; the step writes
        the first three, reads the last two): (τ (N, 1, 3), e^{−iψ} (N, 2) as (cos, sin), the
        features F (N, K), the cross-flow strips' x (N, S), the linear form G (N, K, 3)), K = 41 + S
        (:mod:`mjasc.physics.step_kernels`; τ = F·G)."""
        return self._tau, self._rot2, self._F, self._cf_x, self._G

    def bind(self, qpos3, qvel3, activation, out) -> None:
        """Bind the (N, 3) joint position/velocity arrays, the (N, 2) activation array and the
        (N, 3) output array (views of MjData's memory) once, for :meth:`compute_bound`."""
        self._bound = (qpos3, qvel3, activation, out)

    def generalized_forces(self, qpos3, qvel3, current_world, current_rate_world, activation, out) -> np.ndarray:
        """Write the generalized forces of MuJoCo's (x, y, yaw) joints for every vessel into ``out`` (N, 3).

        qpos3, qvel3: (N, 3) joint positions (x, y, ψ) and velocities (ẋ, ẏ, ψ̇), world frame.
        current_world: (N, 2) water velocity at each vessel [m/s]; current_rate_world: (N, 2)
        ∂V_c/∂t + ∇V_c·ṗ [m/s²] or None when the current is uniform and steady.
        activation: (N, 2) normalized shaft speeds (port, starboard).
        ``out`` receives ``R(ψ)(τ_prop + τ_hyd)``: the body force rotated to world axes, yaw moment as is.
        """
        self.bind(np.asarray(qpos3, dtype=float), np.asarray(qvel3, dtype=float), np.asarray(activation, dtype=float), out)
        self.compute_bound(np.asarray(current_world, dtype=float),
                           None if current_rate_world is None else np.asarray(current_rate_world, dtype=float))
        return out

    def compute_bound(self, current_world, current_rate_world):
        """The fast path of :meth:`generalized_forces` on the arrays given to :meth:`bind`: the
        features F of every vessel in one compiled pass, τ = F·G (numpy's matmul's bits) and τ
        rotated to world axes (:mod:`mjasc.physics.hydro_kernels`, the same bits as the numpy form
        it replaced)."""
        qpos3, qvel3, activation, out = self._bound
        has_rate = current_rate_world is not None
        hydro_features(qpos3, qvel3, activation, current_world, current_rate_world if has_rate else self._no_rate,
                       has_rate, self._cf_x, self._F, self._rot2)
        linear_form(self._F, self._G, self._tau)                                  # τ = F·G (body)
        rotate_to_world(self._tau, self._rot2, out)

    def kinetic_energy_relative(self, nu_r: np.ndarray) -> np.ndarray:
        """½ ν_rᵀ (M_RB + M_A) ν_r per vessel [J] (a Lyapunov function without thrust)."""
        return 0.5 * np.einsum("ni,nij,nj->n", nu_r, self.total_mass, nu_r)
