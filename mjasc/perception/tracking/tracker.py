"""MultiTargetTracker: the tracks of one vessel, one :meth:`~MultiTargetTracker.step` per scan —
association, the batched IMM update, track management, outlines and team mates (thesis §3.2.1,
docs/thesis.md §2; :mod:`mjasc.perception.tracking` for the whole procedure).

A vessel's tracks live in the rows of a :class:`mjasc.perception.tracking.fleet.FleetTracker` (one
batched :class:`mjasc.perception.imm.IMMBank` for the tracks of many vessels, all predicted and
updated in one call): :class:`MultiTargetTracker` is one vessel's view of it (on its own, a
fleet of one). One step:

1. gated GNN association of the scan's target detections with the tracks
   (:mod:`~mjasc.perception.tracking.association`), a partly hidden detection's variance inflated
   by the unseen part of the track's radius;
2. manoeuvre detection on the associated tracks (:mod:`~mjasc.perception.tracking.manoeuvre`);
3. **update** of every track at once: assigned tracks with their detection (and its σ²), the
   others coast (``IMMBank.update(z, t, mask, measurement_variance)``);
4. track management (:mod:`~mjasc.perception.tracking.management`): confirmation, radius, static
   test, outlines of slow tracks (:mod:`~mjasc.perception.tracking.outlines`), then losses and
   merges;
5. births from the detections that no track claimed and that lie outside every track's gate and
   disc;
6. team mates matched from their broadcasts (:mod:`~mjasc.perception.tracking.team`).

Events (born, confirmed, lost, merged, with the reason) are kept for the recording. ``bank`` is a
read-only view of the vessel's rows (:class:`OwnerBank`): its ids, states, covariances, turn rates
and mode probabilities.
"""

from __future__ import annotations

import math

import numpy as np

from mjasc.core.estimates import TrackEstimate, predicted_to
from mjasc.perception.detection import Detections
from mjasc.perception.tracking.association import association_costs
from mjasc.perception.tracking.config import TrackingConfig
from mjasc.perception.tracking.fleet import FleetTracker, TrackEvent

__all__ = ["MultiTargetTracker", "TrackEvent", "OwnerBank"]


class OwnerBank:
    """Read-only view of one vessel's rows of a fleet's :class:`~mjasc.perception.imm.IMMBank`:
    the bank's read-outs restricted to them, track ids in the vessel's own numbering."""

    _READS = ("states", "positions", "headings", "speeds", "turn_rates", "times_s", "mode_probabilities",
              "state_covariances", "position_covariances", "model_states", "model_covariances",
              "velocity_initialized", "rejection_codes", "consecutive_gated")

    def __init__(self, fleet: FleetTracker, owner: int):
        self._fleet, self._owner = fleet, owner

    @property
    def config(self):
        return self._fleet.bank.config

    def __len__(self) -> int:
        return self._fleet.rows_of(self._owner).size

    def __getattr__(self, name):
        if name in OwnerBank._READS:
            f = self._fleet
            if name == "states":  # (read for the vessel's rows only: a fleet's bank holds every vessel's tracks)
                return f.bank.states_of(f.rows_of(self._owner))
            return getattr(f.bank, name)[f.rows_of(self._owner)]
        raise AttributeError(name)

    @property
    def track_ids(self) -> np.ndarray:
        f = self._fleet
        return f.cols.local_id[f.rows_of(self._owner)]

    @property
    def rejection_reasons(self) -> list[str]:
        f = self._fleet
        reasons = f.bank.rejection_reasons
        return [reasons[k] for k in f.rows_of(self._owner).tolist()]

    def index_of(self, track_id: int) -> int:
        """Row (in this view) of ``track_id``; ValueError if unknown."""
        rows = np.flatnonzero(self.track_ids == track_id)
        if rows.size == 0:
            raise ValueError(f"track_id: no track with id {track_id}")
        return int(rows[0])

    def estimate(self, track_id: int, radius_m: float = 0.0, **fields) -> TrackEstimate:
        """:meth:`mjasc.perception.imm.IMMBank.estimate` of one of the vessel's tracks."""
        f = self._fleet
        k = int(f.rows_of(self._owner)[self.index_of(track_id)])
        e = f.bank.estimate(int(f.bank.track_ids[k]), radius_m, **fields)
        from dataclasses import replace

        return replace(e, track_id=int(track_id))


class MultiTargetTracker:
    """The tracks of one vessel. ``step(t, detections, origin)`` once per scan; ``estimates()``.
    ``fleet``: the :class:`FleetTracker` it is a vessel of (default: a fleet of its own)."""

    def __init__(self, config: TrackingConfig = TrackingConfig(), max_range_m: float = math.inf,
                 fleet: FleetTracker | None = None):
        if not isinstance(config, TrackingConfig):
            raise ValueError(f"config: expected a TrackingConfig, got {type(config).__name__}")
        self.fleet = FleetTracker(config) if fleet is None else fleet
        if self.fleet.config != config:
            raise ValueError("config: a vessel of a fleet's tracker shares the fleet's TrackingConfig")
        self.config = config
        self.max_range_m = float(max_range_m)
        self.owner = self.fleet.add_owner(self.max_range_m)
        self.bank = OwnerBank(self.fleet, self.owner)

    def __len__(self) -> int:
        return len(self.bank)

    def _rows(self) -> np.ndarray:
        return self.fleet.rows_of(self.owner)

    # ------------------------------------------------------------------ association
    def association_costs(self, z: np.ndarray, var: np.ndarray, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(n_tracks, m) squared Mahalanobis distances d²_ij and GNN costs d² + ln det S_ij for
        detections z (m, 2) with isotropic variances var (m,) or (n_tracks, m)
        (:func:`mjasc.perception.tracking.association.association_costs`)."""
        b = self.bank
        return association_costs(b.states, b.state_covariances, b.times_s, b.turn_rates, z, var, t_s)

    # ------------------------------------------------------------------ one scan
    def step(self, t_s: float, detections: Detections | None, origin_m=None, use=None, points_m=None) -> None:
        """Process one scan at t_s: associate, update every track, manage the track list.

        ``detections`` None (no scan) only coasts. ``use`` (m,) bool selects the detections for
        tracking (default: ``detections.targets``, the non-extended ones). ``origin_m`` is the
        sensor position (for the out-of-range test). ``points_m`` (k, 2): the scan's returns in
        world coordinates, in the order of ``detections.labels`` (for the outlines of slow tracks).
        """
        self.fleet.step([self.owner], [t_s], [detections], [origin_m], [use], [points_m])

    # ------------------------------------------------------------------ team mates
    def set_team_positions(self, positions: dict) -> None:
        """``{name: (t_b [s], position (2,) [m])}``: the team's latest broadcast positions."""
        self.fleet.set_team_positions(self.owner, positions)

    # ------------------------------------------------------------------ outputs
    @property
    def track_ids(self) -> np.ndarray:
        return self.bank.track_ids

    @property
    def confirmed(self) -> np.ndarray:
        """(n,) bool per row."""
        return self.fleet.cols.confirmed[self._rows()]

    def confirmed_fields(self) -> tuple:
        """The confirmed tracks at once: their indices in this vessel's rows (k,), ids (k,), states
        (k, 4) [x, y, θ, V] [m, m, rad, m/s] (θ in (−π, π]), static flags (k,) and team mates (list of
        k names or None) — the numbers of ``confirmed``, ``track_ids``, ``bank.states``, ``static``
        and ``team_members`` at those rows."""
        f = self.fleet
        rows = self._rows()
        ok = f.cols.confirmed[rows]
        conf, rows = np.flatnonzero(ok), rows[ok]
        return conf, f.cols.local_id[rows], f.bank.states_of(rows), f.cols.static[rows], f.team.members(rows)

    def confirmed_points(self, epoch=None) -> tuple:
        """The confirmed tracks as the recording draws them at standard detail: ids (k,), positions
        (k, 2) [m], static flags (k,) and team mates (list of k names or None) — the numbers of
        :meth:`confirmed_fields` without the row indices and the headings (no angle wrap). With an
        ``epoch`` (the record tick's time [s]) the fleet's vessels are read at once, once per epoch
        (:meth:`~mjasc.perception.tracking.fleet_views.FleetViews.confirmed_points_of`)."""
        return self.fleet.confirmed_points_of(self.owner, epoch)

    def scored_positions(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The confirmed tracks as :meth:`estimates` hands them on (bank order): their ids (k,),
        positions (k, 2) [m] predicted to ``t_s`` along their velocity
        (:func:`~mjasc.core.estimates.predicted_to`) and static flags (k,) — the
        ``track_id``, ``position_m`` moved on to t_s and ``is_static`` of those estimates, without
        making them (what a run's evaluation compares with the truth)."""
        f = self.fleet
        rows = self._rows()
        rows = rows[f.cols.confirmed[rows]]
        x = f.bank.state_rows[rows]
        return f.cols.local_id[rows], predicted_to(x[:, :2], f.bank.time_rows[rows], x[:, 2], x[:, 3], t_s), \
            f.cols.static[rows]

    @property
    def radii_m(self) -> np.ndarray:
        return self.fleet.cols.radius[self._rows()]

    @property
    def static(self) -> np.ndarray:
        return self.fleet.cols.static[self._rows()]

    @property
    def moved(self) -> np.ndarray:
        """(n,) bool per row: confirmed and once moved ``MOVED_M`` (:mod:`~mjasc.perception.tracking.management`)."""
        return self.fleet.cols.moved[self._rows()]

    @property
    def team_members(self) -> list:
        return self.fleet.team.members(self._rows())

    @property
    def manoeuvring(self) -> np.ndarray:
        """(n,) bool per row: the track is manoeuvring (its process noise is raised)."""
        return self.fleet.cols.manoeuvring[self._rows()]

    @property
    def counts(self) -> dict:
        return self.fleet.counts(self.owner)

    @property
    def events(self) -> list[TrackEvent]:
        return self.fleet.events[self.owner]

    @property
    def last_assignment(self) -> dict[int, int]:
        """{track id: detection index} of the last step."""
        return self.fleet.last_assignment(self.owner)

    def estimates(self, include_tentative: bool = False) -> list[TrackEstimate]:
        """TrackEstimate of every confirmed track (and tentative ones if asked)."""
        return self.fleet.estimates(self.owner, include_tentative)

    def report_rows(self):
        """The confirmed tracks as :class:`~mjasc.core.estimates.TrackRows` (the report's form:
        the estimates made on first read)."""
        return self.fleet.report_rows(self.owner)

    def outline(self, row: int) -> np.ndarray:
        """(k, 2) CCW outline [m] of the track in row ``row`` (of this vessel's rows): the hull of its
        returns united with its reflection through the track's centre, or the 12-gon around its
        disc (:mod:`mjasc.perception.tracking.outlines`)."""
        return self.fleet.outline(int(self._rows()[row]))

    def drain_events(self) -> list[TrackEvent]:
        ev = self.fleet.events[self.owner]
        self.fleet.events[self.owner] = []
        return ev
