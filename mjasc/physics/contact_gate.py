"""A conservative gate around MuJoCo's collision detection: a physics step runs without it when no
two bodies can touch.

Most physics steps of a run have no contact at all, yet ``mj_step`` runs its collision detection
(broadphase, midphase) every step: bare ``mj_step`` on §6.4.1 is 7.6 µs with it, 4.8 without
(2026-12-04, this 2-core host). Before each step
(:func:`contacts_possible`, called by :func:`mjasc.physics.step_kernels.prepare_step`) the gate
asks whether any two geoms MuJoCo could pair may be within contact distance at the positions the
step's collision will use; when none can, the step runs with ``mjDSBL_CONTACT`` set
(:meth:`mjasc.physics.simulation.Simulation.step` toggles the flag and restores it after every
block of steps). MuJoCo's collision then only empties the contact list it would have left empty:
with contacts disabled ``mj_collision`` sets ``ncon = 0`` and clears the constraint arrays exactly
as it does before detecting, and every later use of contacts (constraints, passive contact forces)
is skipped for ``ncon == 0`` either way. So the bits are those of an ungated step
(``tests/test_contact_gate.py``). What a skipped detection leaves otherwise untouched is no result:
MjData's stack-use statistics (``maxuse_*``) and the midphase's drawing flags (``bvh_active``).

Measured: the gate is closed on every step of §6.4.1 and the demo; a physics step costs 2.6–3.5 µs
less (of ~15, micro) and ~33 µs less on the 50-vessel fleet (of ~125); the test itself adds ~0.16
µs to ``prepare_step``'s call. The runner's physics stage is 11 % shorter on §6.4.1 and the demo
(paired across processes, A/A within 3 %): ~1–2 % of a run without recording.

What the collision of a step sees: ``mj_step`` runs the kinematics from the current ``qpos`` and
``mocap_pos`` (the traffic's poses at the step's time, which ``prepare_step`` writes just before the
test), then the collision, then integrates. The gate reads the same ``qpos`` and ``mocap_pos``: the
positions are those of the step's own collision, not of the previous kinematics (no motion bound
is needed), and :data:`SLACK_M` is a margin against rounding only, far above it.

The bounds (all from the compiled model, once, :class:`ContactGate`):

* bodies are grouped by weld group (``body_weldid``: bodies joined without joints move as one);
  MuJoCo never pairs geoms of one weld group, nor two weld groups without degrees of freedom (static
  structures, mocap traffic: mujoco's documentation, "Collision detection", filter 3; tests check
  it on the installed MuJoCo). So the candidate pairs are (group with dofs, any other group);
* a moving group is a sphere about its weld body's origin: radius = max over its collidable geoms
  (``contype | conaffinity`` ≠ 0) of the distance from the origin to the geom's centre plus
  ``geom_rbound`` plus ``geom_margin`` (valid at any rotation about the origin). The origin comes
  from ``qpos`` for a body on a static parent whose joints are slides first, then rotations about
  the origin (the vessels: slide x, slide y, hinge yaw), or from ``mocap_pos`` for a mocap body;
* a static geom (weld group 0: the walls of polygons, circular islands) is its own box, the
  geom's bounding box (``geom_aabb``, its frame) grown by its margin: exact for the walls, which
  are boxes, where a bounding sphere of a long wall would cover much of the water;
* two groups are paired only if some contype of one meets some conaffinity of the other (the OR
  over each group's geoms: a superset of MuJoCo's pairs). ``<exclude>`` and the parent filter
  only remove pairs and are ignored (conservative).

Anything the gate cannot bound keeps it open for good (:attr:`ContactGate.reason` says why): a
plane or other geom without a bounding radius that could pair with a moving body, explicit
``<pair>`` elements, flexes, a moving body under another moving body, free joints, rotations not
about the body's origin. The metrics' collisions (``RunMetrics.check_contacts``) read MuJoCo's
contacts after a step: a closed gate means MuJoCo would have found none, so no collision is hidden.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["ContactGate", "contacts_possible", "SLACK_M", "TABLE_COLUMNS", "STATIC"]

#: Extra distance [m] added to every pair's bound: the positions are the step's own, exactly (module
#: docstring), so this covers rounding only (~1e-12 m), with room to spare.
SLACK_M = 0.5

#: The kind (column 0) of a static geom's row of :attr:`ContactGate.table`; 0 is a jointed body, 1 a
#: mocap body.
STATIC = 2.0

#: The columns of a moving group's row of :attr:`ContactGate.table`: kind 0 a jointed body (origin
#: from qpos) or 1 a mocap body (origin = mocap_pos[mocap]); the origin at qpos0 [m]; the bounding
#: radius [m] (half the slack included); up to three slide joints (qpos address, qpos0, world
#: axis); the origin as last computed [m]. A static geom's row (kind :data:`STATIC`) holds instead
#: its box: centre [m] (world), axes (the rows of geom_xmat: world from box frame, row-major) and
#: half extents [m] (margin and half the slack included), in columns 1–15.
TABLE_COLUMNS = ("kind", "mocap", "x0", "y0", "z0", "radius", "slides",
                 *(f"{c}{k}" for k in range(3) for c in ("adr", "q0_", "ax", "ay", "az")), "x", "y", "z")

_SLIDE = int(mujoco.mjtJoint.mjJNT_SLIDE)
_ROTATIONS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_BALL))


class ContactGate:
    """The gate's tables for one compiled model (module docstring): ``table`` (K + S, 25)
    (:data:`TABLE_COLUMNS`: the K moving groups' rows, then the S static geoms') and ``pairs``
    (P, 2) int64, rows of the table that may touch (a moving group first). The slack [m] is
    in the radii and half extents (half each). ``usable`` False (and ``reason``) when something
    cannot be bounded: the gate then stays open, with no pairs. The tables are the model's as
    given: a model whose geoms, margins or contact options change afterwards needs a new gate."""

    def __init__(self, model, slack_m: float = SLACK_M):
        self.reason: str | None = None
        self.table = np.zeros((0, len(TABLE_COLUMNS)))
        self.pairs = np.zeros((0, 2), dtype=np.int64)
        try:
            self._build(model, 0.5 * slack_m)  # (sets the tables at its end only)
        except _Unbounded as why:
            self.reason = str(why)

    @property
    def usable(self) -> bool:
        return self.reason is None

    @property
    def n_moving(self) -> int:
        """K: the table's first K rows are the moving groups."""
        return int(np.count_nonzero(self.table[:, 0] != STATIC))

    def _build(self, m, half_slack: float) -> None:
        if m.npair:
            raise _Unbounded("explicit <pair> elements")
        if m.nflex:
            raise _Unbounded("flexes")
        if m.opt.enableflags & int(mujoco.mjtEnableBit.mjENBL_OVERRIDE):
            raise _Unbounded("the contact override (its margin replaces the geoms')")
        scratch = mujoco.MjData(m)  # (qpos = qpos0, mocap at the bodies' positions: the model's own frame)
        mujoco.mj_kinematics(m, scratch)
        collidable = (m.geom_contype | m.geom_conaffinity) != 0
        weld = m.body_weldid[m.geom_bodyid]
        rows, bits = [], []  # bits: (OR of contype, OR of conaffinity, has dofs) per row
        for w in sorted({int(w) for w in weld[collidable] if w != 0}):
            geoms = collidable & (weld == w)
            rows.append(self._mover(m, scratch, w, np.flatnonzero(geoms), half_slack))
            bits.append((int(np.bitwise_or.reduce(m.geom_contype[geoms])),
                         int(np.bitwise_or.reduce(m.geom_conaffinity[geoms])), int(m.body_dofnum[w]) > 0))
        for g in np.flatnonzero(collidable & (weld == 0)):
            ct, ca = int(m.geom_contype[g]), int(m.geom_conaffinity[g])
            if not any(dof and (ct & a or t & ca) for t, a, dof in bits):
                continue  # (pairs with no moving body: never collided)
            if not m.geom_rbound[g] > 0 or m.geom_type[g] == int(mujoco.mjtGeom.mjGEOM_PLANE):
                raise _Unbounded(f"static geom {g} has no bounding radius (a plane?)")
            rot = scratch.geom_xmat[g].reshape(3, 3)
            centre = scratch.geom_xpos[g] + rot @ m.geom_aabb[g, :3]
            row = [0.0] * len(TABLE_COLUMNS)
            row[:16] = [STATIC, *centre, *rot.ravel(), *(m.geom_aabb[g, 3:] + m.geom_margin[g] + half_slack)]
            rows.append(row)
            bits.append((ct, ca, False))
        pairs = [(a, b) for a in range(len(bits)) for b in range(a + 1, len(bits))
                 if (bits[a][2] or bits[b][2]) and (bits[a][0] & bits[b][1] or bits[b][0] & bits[a][1])]
        self.table = np.array(rows, dtype=float).reshape(-1, len(TABLE_COLUMNS))
        self.pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)

    @staticmethod
    def _mover(m, scratch, w: int, geoms, half_slack: float) -> list:
        """Moving weld group ``w``'s row (:data:`TABLE_COLUMNS`) from the kinematics at qpos0."""
        origin = scratch.xpos[w]
        radius = 0.0
        for g in geoms:
            if not m.geom_rbound[g] > 0:
                raise _Unbounded(f"moving geom {g} has no bounding radius")
            radius = max(radius, float(np.linalg.norm(scratch.geom_xpos[g] - origin)) + m.geom_rbound[g]
                         + m.geom_margin[g])
        row = [0.0] * len(TABLE_COLUMNS)
        row[2:6] = [*origin, radius + half_slack]
        parent = int(m.body_parentid[w])
        if m.body_mocapid[w] >= 0:
            row[0], row[1] = 1.0, float(m.body_mocapid[w])
            if parent != 0:
                raise _Unbounded(f"mocap body {w} is not a child of the world")
            return row
        if m.body_weldid[parent] != 0:
            raise _Unbounded(f"body {w} moves with a moving parent")
        slides, rotating = [], False
        for j in range(int(m.body_jntadr[w]), int(m.body_jntadr[w] + m.body_jntnum[w])):
            kind = int(m.jnt_type[j])
            if kind == _SLIDE and not rotating:
                adr = int(m.jnt_qposadr[j])
                slides.append([float(adr), float(m.qpos0[adr]), *scratch.xaxis[j]])
            elif kind in _ROTATIONS and not np.any(m.jnt_pos[j]):
                rotating = True
            else:
                raise _Unbounded(f"body {w}: joint {j} is not a slide before rotations about the origin")
        if len(slides) > 3:
            raise _Unbounded(f"body {w} has more than three slide joints")
        row[6] = float(len(slides))
        for k, s in enumerate(slides):
            row[7 + 5 * k: 12 + 5 * k] = s
        return row


class _Unbounded(Exception):
    """Something the gate cannot bound (its message says what)."""


@kernel
def contacts_possible(qpos, mocap_pos, table, pairs):
    """Whether some pair of :class:`ContactGate`'s rows may be within contact distance (slack
    included) with the bodies at ``qpos`` and ``mocap_pos`` (MjData's arrays, whole): each moving
    group's origin is written into its row's last three columns, then each pair is tested, sphere
    against sphere or sphere against a static box; True at the first that may touch (a NaN position
    may touch). With no pairs: False."""
    for k in range(table.shape[0]):
        row = table[k]
        if row[0] == STATIC:
            break  # (the static geoms' rows follow the moving groups')
        if row[0] == 1.0:
            mk = int(row[1])
            row[22], row[23], row[24] = mocap_pos[mk, 0], mocap_pos[mk, 1], mocap_pos[mk, 2]
        else:
            x, y, z = row[2], row[3], row[4]
            for s in range(int(row[6])):
                c = 7 + 5 * s
                dq = qpos[int(row[c])] - row[c + 1]
                x += row[c + 2] * dq
                y += row[c + 3] * dq
                z += row[c + 4] * dq
            row[22], row[23], row[24] = x, y, z
    for p in range(pairs.shape[0]):
        a, o = table[pairs[p, 0]], table[pairs[p, 1]]
        if o[0] != STATIC:
            dx, dy, dz = a[22] - o[22], a[23] - o[23], a[24] - o[24]
            reach = a[5] + o[5]
            if not dx * dx + dy * dy + dz * dz > reach * reach:
                return True
        else:
            dx, dy, dz = a[22] - o[1], a[23] - o[2], a[24] - o[3]
            gap2 = 0.0
            for i in range(3):  # (the offset along the box's axis i, beyond its half extent)
                u = abs(o[4 + i] * dx + o[7 + i] * dy + o[10 + i] * dz) - o[13 + i]
                if u > 0.0:
                    gap2 += u * u
            if not gap2 > a[5] * a[5]:
                return True
    return False
