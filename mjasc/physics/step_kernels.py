"""The Python-side work of one physics step before MuJoCo's, as one compiled call
(:meth:`mjasc.physics.simulation.Simulation.step`, the common case: hydrodynamics bound to MjData,
a uniform steady current).

A physics step is ``mj_step1`` (positions, velocities) then ``mj_step2`` (acceleration and
integration). mjasc adds three things: the moving obstacles' mocap poses at the step's time (read
by ``mj_step1``'s collision detection), the hydrodynamic and propeller force ``qfrc_applied``
(read by ``mj_step2``), and after ``mj_step2`` the divergence test. Neither ``mj_step1`` nor the
force reads what the other writes: the force depends on qpos, qvel and the shaft activations only,
which ``mj_step1`` leaves as they are (autoreset is off). So the whole step's work can run before
``mj_step1``, and one call (:func:`prepare_step`) does the previous step's fast divergence test,
the mocap poses, the force's features F and the contact gate's test (may two bodies touch at the
step's positions? :mod:`mjasc.physics.contact_gate`), τ = F·G in the order numpy's matrix
product (OpenBLAS's dgemv) sums it (:func:`~mjasc.physics.hydro_kernels.linear_form`) and its
rotation into ``qfrc_applied`` (:func:`~mjasc.physics.hydro_kernels.rotate_to_world`). Per step
that is one call before MuJoCo's step instead of ~15.

Bits: the traffic poses are :meth:`mjasc.physics.obstacles.MovingObstacleSet.rows`' expressions
(``math.cos``/``sin`` are the C library's in both) and the features are
:func:`~mjasc.physics.hydro_kernels.hydro_features` itself; ``tests/test_step_kernels.py`` checks
both, and whole steps against the sequence they replace, bit for bit. The fast divergence test
sums q̇² and q̈² in index order (numpy's ``dot`` may sum in another order, in the last bits): it
is only a filter, when it fails the exact tests of :class:`~mjasc.physics.divergence.DivergenceMonitor`
decide as before.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.compiled import kernel
from mjasc.physics.contact_gate import contacts_possible
from mjasc.physics.hydro_kernels import hydro_features, linear_form, rotate_to_world

__all__ = ["traffic_table", "traffic_poses", "traffic_state_at", "prepare_step", "fast_bounds_ok", "any_nonzero", "write_commands",
           "TRAFFIC_COLUMNS"]

#: The columns of a traffic table row (one moving obstacle), :func:`traffic_table`.
TRAFFIC_COLUMNS = ("kind", "mocap", "x0 | g0", "y0 | speed", "th0 | length", "v | path row", "w | last sample",
                   "small | sample step", "v/w", "-v/w", "cos th0", "sin th0")


def traffic_table(plain, mocap_rows, sample_step_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The moving obstacles of a :class:`~mjasc.physics.obstacles.MovingObstacleSet` (its plain
    constants ``_plain`` per obstacle, in order) as the arrays :func:`traffic_poses` reads:
    (M, 12) rows (:data:`TRAFFIC_COLUMNS`; kind 0 constant turn, 1 along a path) and the paths'
    sample tables (P, K, 4) = (γ, x, y, heading)."""
    rows, tables = [], []
    for (kind, p), mocap in zip(plain, mocap_rows):
        if kind == 0:
            x0, y0, th0, v, w, small, vw, nvw, c0, s0 = p
            rows.append([0.0, mocap, x0, y0, th0, v, w, float(small), vw, nvw, c0, s0])
        else:
            g0, pv, plen, g_row, xy_row, h_row, last_i = p
            rows.append([1.0, mocap, g0, pv, plen, float(len(tables)), float(last_i), sample_step_m,
                         0.0, 0.0, 0.0, 0.0])
            tables.append(np.column_stack([g_row, np.asarray(xy_row, dtype=float).reshape(-1, 2), h_row]))
    k = max((len(t) for t in tables), default=0)
    samples = np.zeros((len(tables), k, 4))
    for j, t in enumerate(tables):
        samples[j, :len(t)] = t
    return np.array(rows, dtype=float).reshape(-1, len(TRAFFIC_COLUMNS)), samples


@kernel
def obstacle_pose(row, samples, t):
    """(x, y [m], heading h [rad], speed [m/s]) of the moving obstacle of :func:`traffic_table`'s
    ``row`` at time t [s]: the expressions of :meth:`~mjasc.physics.obstacles.MovingObstacleSet.rows`
    (constant turn; or a path at constant speed interpolated in its sample table, the speed 0 once
    it has reached the path's end)."""
    if row[0] == 0.0:  # constant turn (thesis eq. 3.2)
        x0, y0, th0, v, w = row[2], row[3], row[4], row[5], row[6]
        th = th0 + w * t
        c, s = math.cos(th), math.sin(th)
        if row[7] != 0.0:
            vt = v * t
            dx, dy = vt * row[10], vt * row[11]
        else:
            dx, dy = row[8] * (s - row[11]), row[9] * (c - row[10])
        return x0 + dx, y0 + dy, th, v
    g0, pv, plen, tab, last_i, ds = row[2], row[3], row[4], samples[int(row[5])], int(row[6]), row[7]
    g = g0 + pv * t
    if plen < g:  # (Python's min(g, plen): the first unless the second is smaller)
        g = plen
    i0 = int(g / ds)
    if last_i < i0:
        i0 = last_i
    g_a = tab[i0, 0]
    span = tab[i0 + 1, 0] - g_a
    f = (g - g_a) / span if span > 0 else 0.0
    ax, ay, bx, by = tab[i0, 1], tab[i0, 2], tab[i0 + 1, 1], tab[i0 + 1, 2]
    return ax + f * (bx - ax), ay + f * (by - ay), tab[i0, 3], pv if g < plen else 0.0


@kernel
def traffic_poses(t, table, samples, mocap_pos, mocap_quat):
    """Write each moving obstacle's pose at time t [s] (:func:`obstacle_pose`) into its mocap row
    (position x, y; the heading as the quaternion (cos h/2, 0, 0, sin h/2))."""
    for o in range(table.shape[0]):
        k = int(table[o, 1])
        x, y, h, _ = obstacle_pose(table[o], samples, t)
        mocap_pos[k, 0] = x
        mocap_pos[k, 1] = y
        mocap_quat[k, 0] = math.cos(0.5 * h)
        mocap_quat[k, 1] = 0.0
        mocap_quat[k, 2] = 0.0
        mocap_quat[k, 3] = math.sin(0.5 * h)


@kernel
def traffic_state_at(t, table, samples):
    """(positions (M, 2) [m], headings (M,) [rad], velocities (M, 2) [m/s]) of the moving obstacles
    of :func:`traffic_table`'s arrays at time t [s] (what
    :meth:`~mjasc.physics.obstacles.MovingObstacleSet.state` stacks): poses as
    :func:`obstacle_pose` has them, velocities ``v·(cos h, sin h)`` (a path: the speed while short
    of its end, else 0). New arrays, returned as (positions and velocities (2, M, 2), headings): two
    arrays to unbox (``pv, h = …; pv[0], h, pv[1]``)."""
    m = table.shape[0]
    pos_vel = np.empty((2, m, 2))
    pos, vel = pos_vel[0], pos_vel[1]
    heading = np.empty(m)
    for o in range(m):
        x, y, h, speed = obstacle_pose(table[o], samples, t)
        pos[o, 0] = x
        pos[o, 1] = y
        heading[o] = h
        vel[o, 0] = speed * math.cos(h)
        vel[o, 1] = speed * math.sin(h)
    return pos_vel, heading


@kernel
def prepare_step(check, qpos, qvel, qacc, act, fast_speed2, fast_acc2, t, table, samples, mocap_pos, mocap_quat,
                 current, cf_x, F, rot, G, tau, out, gate_table, gate_pairs):
    """One physics step's work before ``mj_step1`` (module docstring), for N vessels owning qpos,
    qvel [3i, 3i + 3) and act [2i, 2i + 2) (MjData's arrays, whole): with ``check``, first the
    fast divergence test of the step just taken, Σ q̇² ≤ fast_speed2 and Σ q̈² ≤ fast_acc2 — 0
    when it fails (then nothing is written); then the moving obstacles' mocap poses at time t
    (:func:`traffic_poses`), the features F (N, 41 + S) and e^{−iψ} ``rot`` of the hydrodynamic
    force for the uniform steady ``current`` (N, 2) (:func:`~mjasc.physics.hydro_kernels.hydro_features`,
    no current rate), τ = F·G (N, 1, 3) for the linear form G (N, 41 + S, 3)
    (:func:`~mjasc.physics.hydro_kernels.linear_form`, numpy's bits), the world-frame force
    ``out`` (N, 3) (``qfrc_applied``'s view, :func:`~mjasc.physics.hydro_kernels.rotate_to_world`)
    and the contact gate's test at the step's positions
    (:func:`~mjasc.physics.contact_gate.contacts_possible` on its tables ``gate_*``): 2 when two
    bodies may touch, 1 when none can (tables without pairs: 1)."""
    if check and not fast_bounds_ok(qvel, qacc, fast_speed2, fast_acc2):
        return 0
    traffic_poses(t, table, samples, mocap_pos, mocap_quat)
    n = F.shape[0]
    hydro_features(qpos[:3 * n].reshape((n, 3)), qvel[:3 * n].reshape((n, 3)), act[:2 * n].reshape((n, 2)),
                   current, current, False, cf_x, F, rot)
    linear_form(F, G, tau)
    rotate_to_world(tau, rot, out)
    return 2 if contacts_possible(qpos, mocap_pos, gate_table, gate_pairs) else 1


@kernel
def fast_bounds_ok(qvel, qacc, fast_speed2, fast_acc2):
    """The fast divergence test (:func:`prepare_step`'s, also after a block's last step): Σ q̇² ≤
    fast_speed2 and Σ q̈² ≤ fast_acc2, summed in index order (False on NaN)."""
    sv = 0.0
    for k in range(qvel.shape[0]):
        sv += qvel[k] * qvel[k]
    sa = 0.0
    for k in range(qacc.shape[0]):
        sa += qacc[k] * qacc[k]
    return sv <= fast_speed2 and sa <= fast_acc2


@kernel
def any_nonzero(counts):
    """Whether some entry of ``counts`` (MjData's warning counters) is not zero."""
    for k in range(counts.shape[0]):
        if counts[k] != 0:
            return True
    return False


@kernel
def write_commands(commands, ctrl, ctrl_adr):
    """``ctrl[ctrl_adr[i, p]] = min(max(commands[i, p], −1), 1)`` for N vessels' (N, 2) commands
    (numpy's ``np.minimum(np.maximum(c, −1), 1)``: the same values for finite c), when every
    command is finite; returns False (writing nothing) when one is not."""
    n = commands.shape[0]
    for i in range(n):
        for p in range(2):
            c = commands[i, p]
            if not (-np.inf < c < np.inf):
                return False
    for i in range(n):
        for p in range(2):
            c = commands[i, p]
            if c < -1.0:
                c = -1.0
            if c > 1.0:
                c = 1.0
            ctrl[ctrl_adr[i, p]] = c
    return True
