"""TrackColumns: every per-track column of a tracker that is not the IMM bank's, in one store — the
vessel and id of each track (:mod:`mjasc.perception.tracking.fleet`), management
(:mod:`~mjasc.perception.tracking.management`), manoeuvres (:mod:`~mjasc.perception.tracking.manoeuvre`),
team mates (:mod:`~mjasc.perception.tracking.team`) and outlines
(:mod:`~mjasc.perception.tracking.outlines`) — rows aligned with the bank's.

Births and drops change every column at once: one compiled :func:`appended_columns` writes the new
rows of every column into spare capacity, one compiled :func:`kept_columns` compacts every column
in place (instead of each component concatenating or indexing its own arrays: ~20 numpy calls per
birth or drop). The columns live in three tables by type, one row per column (float64, int64,
bool; each column contiguous) and a small object table (team mate names, hulls: compacted by one
numpy indexing); the components read and write them through views (``radius``, ``confirmed``, …,
``anchor`` (n, 2)), made again after every change of rows — a view read before a birth or drop is
stale after it.

Initial values of a new row (a track born at t [s] from a detection of radius r [m] at c (2,) [m]):
one update (history 1, scans 1, updates 1), confirmed iff ``confirm_now`` (M of N with M ≤ 1), not
static, no anchor (0, 0), not anchored, not moved, born and last updated at t, radius r; ε̄ = 2 and
not manoeuvring; no team mate, no hull, hull anchor c; its vessel and id as given.
"""

from __future__ import annotations

import numpy as np

from mjasc.core.compiled import kernel

__all__ = ["TrackColumns", "column", "appended_columns", "kept_columns"]

# float64 columns
BORN, LAST, RADIUS, ANCHOR_X, ANCHOR_Y, NIS, HULL_X, HULL_Y = range(8)
# int64 columns
OWNER, LOCAL_ID, HIST, SCANS, N_UPD = range(5)
# bool columns
CONFIRMED, STATIC, ANCHORED, MOVED, MANOEUVRING = range(5)
# object columns
TEAM, HULL = range(2)
_NF, _NI, _NB, _NO = 8, 5, 5, 2


def column(name: str, doc: str = "") -> property:
    """A component's attribute that is the store's column ``name`` (``self.cols.<name>``, a view);
    assigning to it writes the values into the column."""

    def get(self):
        return getattr(self.cols, name)

    def put(self, values):
        getattr(self.cols, name)[...] = values

    return property(get, put, doc=doc)


class TrackColumns:
    """The per-track columns of a tracker (module docstring); ``n`` rows. ``confirm_now``: a new
    track is confirmed at birth (``confirm_hits ≤ 1``)."""

    def __init__(self, confirm_now: bool = False, capacity: int = 16):
        self.confirm_now = bool(confirm_now)
        self.n = 0
        self._f = np.zeros((_NF, capacity))
        self._i = np.zeros((_NI, capacity), dtype=np.int64)
        self._b = np.zeros((_NB, capacity), dtype=bool)
        self._o = np.full((_NO, capacity), None, dtype=object)
        self._made: dict[int, tuple] = {}  # n → the columns' views of the first n rows of these tables
        self._views()

    def __len__(self) -> int:
        return self.n

    def _views(self) -> None:
        """The columns' views of the first n rows (made once per n and tables: a tracker's rows go
        up and down by a few between the same counts; the same views of the same buffers)."""
        n = self.n
        v = self._made.get(n)
        if v is None or v[0].base is not self._f:  # (views of other tables: a copied store's)
            f, i, b = self._f[:, :n], self._i[:, :n], self._b[:, :n]  # (one row per column: unpacked below)
            born, last, radius, ax, ay, nis, hx, hy = f
            anchor = f[ANCHOR_X:ANCHOR_Y + 1].T  # (n, 2) [m]
            hull_anchor = f[HULL_X:HULL_Y + 1].T  # (n, 2) [m]
            if len(self._made) >= 64:
                self._made.clear()
            v = self._made[n] = (born, last, radius, nis, anchor, hull_anchor, *i, *b, *self._o[:, :n])
        (self.born, self.last, self.radius, self.nis, self.anchor, self.hull_anchor, self.owner, self.local_id, self.hist,
         self.scans, self.n_upd, self.confirmed, self.static, self.anchored, self.moved, self.manoeuvring, self.team,
         self.hull) = v

    def _grow(self, m: int) -> None:
        """Room for m rows (the first n copied into larger tables)."""
        cap = m + max(16, m // 2)
        n = self.n
        f, i, b = np.zeros((_NF, cap)), np.zeros((_NI, cap), dtype=np.int64), np.zeros((_NB, cap), dtype=bool)
        o = np.full((_NO, cap), None, dtype=object)
        f[:, :n], i[:, :n], b[:, :n], o[:, :n] = self._f[:, :n], self._i[:, :n], self._b[:, :n], self._o[:, :n]
        self._f, self._i, self._b, self._o = f, i, b, o
        self._made.clear()

    def append(self, t_s, radius, centres=None, owner=None, local_id=None) -> None:
        """k new rows (module docstring): born at t_s (scalar or (k,) [s]) from detections of
        ``radius`` (k,) [m] at ``centres`` (k, 2) [m] (None: zeros), of vessels ``owner`` (k,) with
        ids ``local_id`` (k,) (None: zeros). One compiled call."""
        radius = np.ascontiguousarray(radius, dtype=float).reshape(-1)
        k = radius.size
        t = np.asarray(t_s, dtype=float)
        if t.shape != (k,):
            t = np.broadcast_to(t, (k,))
        z = np.zeros(k, dtype=np.int64)
        m = self.n + k
        if m > self._f.shape[1]:
            self._grow(m)
        appended_columns(self._f, self._i, self._b, self.n, np.ascontiguousarray(t), radius,
                         np.zeros((k, 2)) if centres is None else np.ascontiguousarray(centres, dtype=float),
                         z if owner is None else owner, z if local_id is None else local_id, self.confirm_now)
        self._o[:, self.n:m] = None
        self.n = m
        self._views()

    def append_rows(self, t_s, radius, centres, owner, local_id) -> None:
        """:meth:`append` for a caller whose arrays are checked already (a fleet tracker's births):
        t_s, radius (k,) float, centres (k, 2) float, owner and local_id (k,) int64, each contiguous."""
        n = self.n
        m = n + t_s.size
        if m > self._f.shape[1]:
            self._grow(m)
        appended_columns(self._f, self._i, self._b, n, t_s, radius, centres, owner, local_id, self.confirm_now)
        self._o[:, n:m] = None
        self.n = m
        self._views()

    def reserve(self, m: int) -> tuple:
        """Room for m rows: the tables (f, i, b) that :func:`appended_columns` writes new rows into
        (a compiled caller's births, then :meth:`appended`)."""
        if m > self._f.shape[1]:
            self._grow(m)
            self._views()  # (the columns' views of the new tables: the same n rows, whether or not rows follow)
        return self._f, self._i, self._b

    def appended(self, k: int) -> None:
        """The k rows after the first n written by :func:`appended_columns` (into :meth:`reserve`'s
        tables): they are rows now (no team mate, no hull), as :meth:`append_rows` ends."""
        n = self.n
        m = n + k
        self._o[:, n:m] = None
        self.n = m
        self._views()

    def keep(self, keep: np.ndarray) -> None:
        """Keep the rows where ``keep`` (n,) bool is True, in order, in place (one compiled call
        and one numpy indexing of the object columns' rows from the first dropped one on; none when
        every row is kept)."""
        if type(keep) is not np.ndarray or keep.dtype != np.bool_:
            keep = np.asarray(keep, dtype=bool)
        if keep.shape != (self.n,):
            raise IndexError(f"keep: need shape ({self.n},), got {keep.shape}")
        self.kept(keep, kept_columns(keep, self._f, self._i, self._b))

    def kept(self, keep: np.ndarray, m: int) -> None:
        """After :func:`kept_columns` compacted the tables to the m rows where ``keep`` (n,) bool: the
        object columns compacted (one numpy selection of their rows from the first dropped one on: those
        before it stay where they are; none when every row is kept; one row dropped, a step's common
        drop: the rows after it moved up by one, a slice's copy) and the columns' views made."""
        n = self.n
        if m < n:
            f = int(keep.argmin())
            o = self._o
            if m == n - 1:
                o[:, f:m] = o[:, f + 1:n]
            else:
                o[:, f:m] = o[:, f:n].compress(keep[f:], axis=1)  # (= [:, keep[f:]], fewer steps in numpy)
        self.n = m
        self._views()


@kernel
def appended_columns(f, i, b, n, t, radius, centres, owner, local_id, confirm_now):
    """Rows n … n + k − 1 of the tables f (8, cap), i (5, cap), b (5, cap) written in place with the
    initial values of k new tracks (module docstring): t (k,) [s], radius (k,) [m], centres (k, 2)
    [m], owner and local_id (k,)."""
    for j in range(t.size):
        k = n + j
        f[BORN, k] = t[j]
        f[LAST, k] = t[j]
        f[RADIUS, k] = radius[j]
        f[ANCHOR_X, k] = 0.0
        f[ANCHOR_Y, k] = 0.0
        f[NIS, k] = 2.0
        f[HULL_X, k] = centres[j, 0]
        f[HULL_Y, k] = centres[j, 1]
        i[OWNER, k] = owner[j]
        i[LOCAL_ID, k] = local_id[j]
        i[HIST, k] = 1
        i[SCANS, k] = 1
        i[N_UPD, k] = 1
        b[CONFIRMED, k] = confirm_now
        b[STATIC, k] = False
        b[ANCHORED, k] = False
        b[MOVED, k] = False
        b[MANOEUVRING, k] = False


@kernel
def kept_columns(keep, f, i, b):
    """Every column of the tables f, i, b compacted in place to the rows where ``keep`` (n,) bool
    (``a[:m] = a[:n][keep]``, m returned)."""
    c = 0
    for k in range(keep.size):
        if keep[k]:
            if c != k:
                for a in range(f.shape[0]):
                    f[a, c] = f[a, k]
                for a in range(i.shape[0]):
                    i[a, c] = i[a, k]
                for a in range(b.shape[0]):
                    b[a, c] = b[a, k]
            c += 1
    return c
