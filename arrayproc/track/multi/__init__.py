"""``[tracker] type = "multi"``: every target of a products file held as a track.

The measurement kinds, one :class:`~arrayproc.track.manage.manager.TrackManager` each:

- ``bearings`` (towed line array): a bearing / bearing-rate filter per track (nearly
  constant rate, BLK 2001 eq. 6.2.2-12, R from σ_cone / sin θ, the beam widening towards
  end-fire, thesis eq. 2.9): by default (``space = "bearing"``) a mirrored pair of
  true-bearing hypotheses weighted by their likelihoods
  (:mod:`arrayproc.track.manage.mirrored`), which coasts through ownship turns; or
  (``space = "cone"``) one filter in cone-angle space, where a line array's measurement is
  unambiguous but swings in turns. Rows of one scan closer than ``merge_deg`` (the broadband
  peak and the tonal lines of one source) form one measurement, its strongest row. Each track's rows
  then drive a TMA filter — by default the UKF with left-right resolution (L-R paper
  eqs. (9)-(13)), any filter of ``FILTERS`` by ``filter`` — from the same ``[tracker]`` keys as
  single mode.
- ``lines+bearings`` (towed line array, the default of ``multi_target.toml``) and ``lines``:
  the line contacts of a ``lines`` group (with their frequency) and the broadband rows of the
  ``bearings`` group; each track carries the mirrored bearing hypotheses and the received
  frequencies of its tonals (:mod:`arrayproc.track.multi.tonals`, ownship Doppler through
  :mod:`arrayproc.track.models.bearing_frequency`), association on bearing and frequency
  together (:mod:`arrayproc.track.multi.lines`); the TMA of each track as for bearings, and
  the tracks rows carry each point's measurement and the track's ``f_hz``.
- ``contacts`` (active): Cartesian CV tracks, EKF with the bearing-range-range-rate model
  (:mod:`arrayproc.track.models.bearing_range_rate`). A line array's contact has two
  candidate bearings (port, starboard); both enter as measurements (``mirror = true``), so a
  ghost track forms on the mirror side and dies when the ownship turns.
- ``positions`` (compact array): 3-D CV tracks, Kalman filter with each row's ``cov``.
- ``fused_bearings`` (two or more static compact arrays, one products file each:
  ``arrayproc track A.h5 B.h5 -c compact_fused.toml``): Cartesian CV tracks [x, y, ẋ, ẏ]
  in the recordings' local frame, updated by every array's azimuths through the bearing
  from that array (L-R paper eq. (7)), the arrays' scans in time order, started by the
  cross-fix of two arrays' free bearings (:mod:`arrayproc.track.multi.fused`).

Config (``[tracker]`` keys beside those of single mode)::

    type = "multi"                # (older form: mode = "multi")
    measurements = "bearings"     # bearings | lines+bearings | lines | contacts | positions
                                  # | fused_bearings
    association = "gnn"           # gnn | jpda
    gate_prob = 0.999             # P_G
    confirm = [3, 5]              # M of N
    max_misses = 5                # consecutive missed scans of a confirmed track
    hit_window = [3, 15]          # optional: delete a confirmed track with < 3 hits in 15 scans
    pd = 0.9                      # JPDA detection probability
    clutter_density = 1e-3        # JPDA, false measurements per unit of measurement space
    [tracker.bearing]             # the bearing tracker
    space = "bearing"             # bearing (mirrored hypotheses) | cone
    sigma_cone_deg = 0.7          # at broadside
    q_bearing = 0.002             # deg²/s³ (space = "bearing")
    turn_ref_deg_s = 0.1          # Q × (1 + (heading rate / turn_ref)²)
    q_cone = 0.05                 # deg²/s³ (space = "cone")
    merge_deg = 4.0
    sigma_rate_deg_s = 0.5        # initial cone-rate σ
    merge_d2 = 4.0                # duplicate confirmed tracks (d² of the cone states)
    [tracker.lines]               # lines+bearings | lines (beside [tracker.bearing])
    sigma_hz = 0.15               # a line's frequency σ
    sigma_line_deg_hz = 1250.0    # a line's cone σ at broadside: this / (f √(S/N)), deg
    min_sigma_line_deg = 0.2
    q_freq = 1e-4                 # Hz²/s³
    sigma_rate_hz_s = 0.02
    max_tonals = 4
    max_age_s = 60.0
    adopt_d2 = 1.0
    min_snr_db = 0.0
    same_source_deg = 1.0         # disjoint-tonal tracks together this long are one source
    same_source_scans = 10
    reid_s = 120.0                # a track continuing another after a gap (tonal signature)
    reid_hz = 1.0
    reid_deg = 20.0
    [tracker.contacts]
    sigma_bearing_deg = 2.0
    sigma_range_m = 20.0
    sigma_range_rate_mps = 0.3
    q = 0.01                      # m²/s³
    sigma_speed_mps = 5.0         # unobserved tangential speed at initiation
    mirror = true
    moving_only = false           # only contacts flagged moving enter (still clutter never does)
    min_snr_db = 0.0              # only contacts with snr_db at least this enter (0: all)
    [tracker.positions]
    q = 0.01
    sigma_speed_mps = 5.0
    [tracker.fused]               # fused_bearings
    sigma_bearing_deg = 1.0
    q = 0.01                      # m²/s³
    sigma_speed_mps = 5.0
    pair_s = 4.0                  # the two bearings of an initiating cross-fix within this
    min_cross_deg = 10.0          # near-parallel rays start no track
    max_range_m = 10000.0
    merge_deg = 4.0
    merge_d2 = 4.0
    persist = 4                   # a persistent free bearing may pair with a taken one
"""

from arrayproc.track.multi.bearings import bearing_scans, cone_filter, track_cones
from arrayproc.track.multi.compose import compose_manager
from arrayproc.track.multi.config import (
    MULTI_KEYS,
    SUB_PARAMS,
    check_multi_config,
    split_config,
    tracker_mode,
)
from arrayproc.track.multi.contacts import contact_scans, contacts_manager, drop_twin_births
from arrayproc.track.multi.fused import CrossFixInitiator, cross_fix_point, track_fused
from arrayproc.track.multi.fused_run import run_fused
from arrayproc.track.multi.lines import line_scans, line_table, track_lines
from arrayproc.track.multi.positions import positions_manager
from arrayproc.track.multi.run import confirmed_status, multi_target, run_multi
from arrayproc.track.multi.tma import resolved_side, tma_track
from arrayproc.track.multi.tonals import TonalBank, TonalGNN

__all__ = ["run_multi", "tracker_mode", "split_config", "check_multi_config", "multi_target",
           "bearing_scans", "cone_filter", "track_cones", "tma_track", "resolved_side",
           "contact_scans", "contacts_manager", "drop_twin_births", "positions_manager",
           "confirmed_status", "compose_manager", "MULTI_KEYS", "SUB_PARAMS",
           "line_table", "line_scans", "track_lines", "TonalBank", "TonalGNN",
           "run_fused", "track_fused", "cross_fix_point", "CrossFixInitiator"]
