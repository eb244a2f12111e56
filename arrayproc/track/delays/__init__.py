"""``measurements = "delays"``: recursive position tracking from hydrophone delays, thesis
section 3.2.2.2 (eqs. (3.37)-(3.40)).

Every row of a ``delays`` product (the ``tde`` stage: each hydrophone's delay to the reference
hydrophone in one snapshot) updates one source's position through the TDOA measurement model
(:class:`~arrayproc.track.models.tdoa.TDOA`, eqs. (3.38)-(3.39)) with any of the Gaussian filters
(EKF, UKF, CKF, GHF; :mod:`arrayproc.track.filters`). The element positions of each row are the
world positions of that snapshot's pose (the recording's ``/nav`` and array geometry,
:meth:`arrayproc.io.recording.Recording.poses`), so a towed array's motion between snapshots is
what synthesises the aperture the thesis speaks of.

State: the package's relative state (L-R paper eq. (1)), the source minus the observer, the
observer being the reference hydrophone. Motion (eq. (3.40)):

- ``motion = "static"`` (the thesis's choice, Φ = I on the absolute position): state [x, y];
  the relative position moves by the observer's displacement, x_k = x_{k−1} − (o_k − o_{k−1}),
  with an optional position random walk of intensity ``q`` (m²/s);
- ``motion = "cv"``: nearly constant velocity, state [x, y, ẋ, ẏ] (L-R paper eqs. (2)-(4),
  :class:`~arrayproc.track.models.motion.ConstantVelocity`), ``q`` the acceleration noise
  intensity (m²/s³).

Measurement noise: the delays of one row are all measured against one reference channel, so
their covariance is :func:`arrayproc.geo.tdoa.reference_covariance` of the row's σ (the
product's ``sigma`` column, or ``sigma_delay_s`` when set or when the product has none).
With ``array_motion`` (the default, as in ``arrayproc tma``) each row's delays are first
brought back to those of a static array, τ (1 + V·u/c) (:mod:`arrayproc.track.batch.motion`,
eqs. (M2), (M4); V the array's velocity from the navigation, u the row's plane-wave
direction): the wavefront crosses a moving array in a slightly different time, which moves
a line array's cone angle by about (v/c) cos θ cot θ (0.034° at 60° for 3 m/s) and, on the
20 m array of the validation, biased the static estimate by 4.5 m at 2 km (40 CRLB σ).
Missing delays (NaN), delays with ``corr < min_corr`` and rows with fewer than two usable
delays are left out (the track coasts through such a row).

Initialisation (from the first usable row): the plane-wave direction that fits the row's
delays best (least squares, :func:`arrayproc.track.batch.td_tma.plane_wave_directions`) and a
range prior ``range_m ± sigma_range_m`` along it (Ristic, Arulampalam & Gordon 2003, ch. 6:
the polar prior linearised into x, y), or with ``range_bank = [r_min, r_max, n]`` a bank of
n such priors at ranges spaced geometrically from r_min to r_max, each σ_r = r (ρ − 1)/2 with
ρ the ratio of neighbouring ranges (the range-parameterised filter bank, Peach 1995; Ristic
et al. 2003, ch. 6), run as hypotheses weighted by their likelihoods. One wide Gaussian prior
lets an EKF's first update, linearised far from a near source, throw the state across the
array (measured: 405 km off for a 2 km source with 6 ± 4 km). The bearing σ is the larger of
``sigma_bearing_deg`` and the fit's own σ (c σ_τ / ‖projected apertures‖ / sin θ). CV:
velocity 0 ± ``sigma_speed_mps`` per axis. A line array's delays give a cone angle, the same
for two mirror bearings (heading ∓ θ); ``side = "auto"`` runs both as hypotheses weighted by
their likelihoods (L-R paper eqs. (9)-(11)), ``port`` / ``starboard`` keeps one. The written
track is the mixture (eqs. (12)-(13)) of the hypotheses on the heavier side only
(``side_weight`` is the summed weight of the starboard hypotheses): a mixture over both sides
would put its mean between the mirrors, on the array's axis, until an ownship turn tells
them apart. Hypotheses whose
weight falls below 1e-9 are dropped. Optional gating (``gate_prob`` > 0): a row whose
normalised innovation exceeds the χ² quantile for every hypothesis is skipped.

Config (``arrayproc track DELAYS.h5 -c TRACKER.toml``)::

    [tracker]
    type = "delays"           # (older form: mode = "multi", measurements = "delays")
    filter = "ukf"            # ekf | ukf | ckf | ghf
    nav = "rec.h5"            # optional: recording with /nav and the array (default: source)
    [tracker.params]          # filter parameters (alpha/beta/kappa, gh_order)
    [tracker.delays]
    motion = "static"         # static (thesis eq. 3.40, Φ = I) | cv
    q = 0.0                   # static: m²/s; cv: m²/s³
    range_m = 5000.0          # initial range prior
    sigma_range_m = 3000.0
    range_bank = [1000.0, 20000.0, 6]  # optional: n priors from r_min to r_max (replaces
                              # range_m, sigma_range_m)
    sigma_bearing_deg = 0.5   # lower bound of the initial bearing σ
    sigma_speed_mps = 3.0     # cv: initial velocity σ per axis
    side = "auto"             # auto | port | starboard (line arrays)
    sigma_delay_s = 0.0       # > 0: this σ for every delay; 0: the product's sigma column
    min_corr = 0.0            # leave out delays with a lower peak correlation
    source_dz_m = 0.0         # source depth below the reference hydrophone, m
    gate_prob = 0.0           # > 0: χ² gate on the innovations
    group = ""                # delays group (default: the only one)
    array_motion = true       # correct the delays for the array's motion (below)
    confirm = [1, 1]          # several sources: M-of-N confirmation of a new track
    max_misses = 0            # several sources: delete after this many scans without a row

Several sources (:mod:`arrayproc.track.delays.sources`): a product with several rows at one
time (``tde`` with ``peaks`` > 1) gives several tracks: every track is a bank as above, the
rows of a scan are gated and assigned by global nearest neighbour, leftover rows start
tentative tracks confirmed by ``confirm`` and deleted after ``max_misses`` empty scans.
"""

from arrayproc.track.delays.config import (
    DELAYS_DEFAULTS,
    GAUSSIAN_FILTERS,
    check_delays_config,
    is_delays_config,
    load_delays_config,
)
from arrayproc.track.delays.initial import initial_hypotheses
from arrayproc.track.delays.run import read_delays, run_delays
from arrayproc.track.delays.sources import track_delay_sources
from arrayproc.track.delays.tracker import observer_states, track_delays
from arrayproc.track.models.static import StaticPosition
from arrayproc.track.models.tdoa import RowTDOA

__all__ = ["StaticPosition", "RowTDOA", "DELAYS_DEFAULTS", "GAUSSIAN_FILTERS",
           "is_delays_config", "load_delays_config", "check_delays_config",
           "initial_hypotheses", "track_delays", "observer_states", "read_delays",
           "run_delays", "track_delay_sources"]
