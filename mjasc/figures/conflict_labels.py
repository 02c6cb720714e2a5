"""Predicted-conflict labels on a top-down figure that stay legible: nearby conflicts merged into
numbered groups, a number by each group and a key that says what each number stands for.

A run predicts the same conflict again at every prediction (every few seconds), so its predicted
collision points pile up in one place; one label per point is unreadable. :func:`group_conflicts`
merges, in time order, each point into the first group whose anchor lies within
``merge_m`` metres (else it starts a group); :func:`label_conflicts` then merges groups whose
anchors fall closer than :data:`MERGE_MM` millimetres on paper or one label's diagonal, whichever
is larger, so that two number labels, each drawn up and right of its anchor, cannot overlap. The
key lists per number the vessels, the number of predictions, when they were made [s] and the
predicted conflict window ``[t_i, t_f]`` [s] (``∞``: it never ends within the horizon).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["ConflictGroup", "group_conflicts", "label_conflicts", "MERGE_MM", "LABEL_GID"]

#: Conflict labels whose anchors are closer than this on paper [mm] are merged.
MERGE_MM = 5.0
#: The gid of every number label (tests find them by it).
LABEL_GID = "conflict-label"


@dataclass
class ConflictGroup:
    """Predicted collision points merged into one label (world ENU [m], times [s])."""

    points: list = field(default_factory=list)  # (2,) each
    vessels: list = field(default_factory=list)  # vessel names, in order of appearance
    predicted_s: list = field(default_factory=list)  # when each prediction was made
    t_i: float = np.inf  # earliest predicted start of the conflict
    t_f: float = -np.inf  # latest predicted end

    @property
    def anchor(self) -> np.ndarray:
        return np.mean(self.points, axis=0)

    def add(self, vessel: str, t: float, point, t_i: float, t_f: float) -> None:
        self.points.append(np.asarray(point, float))
        if vessel not in self.vessels:
            self.vessels.append(vessel)
        self.predicted_s.append(float(t))
        self.t_i, self.t_f = min(self.t_i, float(t_i)), max(self.t_f, float(t_f))

    def merge(self, other: "ConflictGroup") -> None:
        self.points += other.points
        self.vessels += [v for v in other.vessels if v not in self.vessels]
        self.predicted_s += other.predicted_s
        self.t_i, self.t_f = min(self.t_i, other.t_i), max(self.t_f, other.t_f)

    def key_line(self, number: int) -> str:
        n = len(self.predicted_s)
        when = f"{min(self.predicted_s):.0f}" + (f"–{max(self.predicted_s):.0f}" if n > 1 else "")
        end = "∞" if not np.isfinite(self.t_f) else f"{self.t_f:.0f}"
        return (f"{number}: {', '.join(self.vessels)} — {n} prediction{'s' if n > 1 else ''} at t = {when} s, "
                f"conflict [{self.t_i:.0f}, {end}] s")


def group_conflicts(collision_points: dict, merge_m: float = 5.0) -> list[ConflictGroup]:
    """Groups of ``collision_points`` (vessel → list of (t, point (2,), t_i, t_f)): in time order,
    each point joins the first group whose anchor is within ``merge_m`` [m], else starts a group."""
    rows = sorted(((t, v, p, t_i, t_f) for v, pts in collision_points.items() for t, p, t_i, t_f in pts),
                  key=lambda r: r[0])
    groups: list[ConflictGroup] = []
    for t, v, p, t_i, t_f in rows:
        near = next((g for g in groups if np.hypot(*(g.anchor - p)) <= merge_m), None)
        if near is None:
            near = ConflictGroup()
            groups.append(near)
        near.add(v, t, p, t_i, t_f)
    return groups


def _merge_on_paper(groups: list[ConflictGroup], to_pixels, min_px: float) -> list[ConflictGroup]:
    """Merge groups whose anchors are closer than ``min_px`` display pixels until none are."""
    groups = list(groups)
    merged = True
    while merged and len(groups) > 1:
        merged = False
        px = to_pixels(np.array([g.anchor for g in groups]))
        d = np.hypot(*(px[:, None, :] - px[None, :, :]).transpose(2, 0, 1))
        np.fill_diagonal(d, np.inf)
        i, j = np.unravel_index(np.argmin(d), d.shape)
        if d[i, j] < min_px:
            a, b = sorted((i, j))
            groups[a].merge(groups.pop(b))
            merged = True
    return groups


def label_conflicts(ax, key_ax, collision_points: dict, colour="red", fontsize: float = 8.0,
                    key_fontsize: float = 7.0, max_key_lines: int = 12) -> list[ConflictGroup]:
    """Mark every predicted collision point on ``ax`` (a small cross), merge them (module docstring),
    number the groups in time order beside their anchors and write the key into ``key_ax``. Call
    after ``ax``'s limits and aspect are final. Returns the groups in number order."""
    fig = ax.figure
    for pts in collision_points.values():
        for _, p, _, _ in pts:
            ax.plot(*p, "x", color=colour, ms=4, mew=0.8, alpha=0.6)
    groups = group_conflicts(collision_points)
    if not groups:
        key_ax.text(0.0, 1.0, "no predicted conflicts", va="top", fontsize=key_fontsize, transform=key_ax.transAxes)
        return []
    fig.canvas.draw()  # final transforms (aspect, limits)
    renderer = fig.canvas.get_renderer()
    probe = ax.annotate("88", (0, 0), fontsize=fontsize, bbox=dict(boxstyle="round,pad=0.15", lw=0))
    box = probe.get_bbox_patch().get_window_extent(renderer) if probe.get_bbox_patch() else \
        probe.get_window_extent(renderer)
    probe.remove()
    min_px = max(MERGE_MM / 25.4 * fig.dpi, 1.05 * float(np.hypot(box.width, box.height)))
    groups = _merge_on_paper(groups, ax.transData.transform, min_px)
    groups.sort(key=lambda g: min(g.predicted_s))
    for k, g in enumerate(groups, 1):
        ax.annotate(str(k), g.anchor, xytext=(2, 2), textcoords="offset points", fontsize=fontsize, color=colour,
                    fontweight="bold", gid=LABEL_GID, annotation_clip=False,
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec=colour, lw=0.6, alpha=0.85))
    lines = [g.key_line(k) for k, g in enumerate(groups, 1)]
    if len(lines) > max_key_lines:
        lines = lines[:max_key_lines - 1] + [f"… and {len(lines) - max_key_lines + 1} more"]
    key_ax.text(0.0, 1.0, "predicted conflicts (own position at the closest approach, ×):\n" + "\n".join(lines),
                va="top", ha="left", fontsize=key_fontsize, color="black", transform=key_ax.transAxes, wrap=True)
    return groups
