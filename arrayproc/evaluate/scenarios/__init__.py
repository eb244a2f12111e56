"""Scenarios of the papers the toolkit reproduces, one module per paper or thesis chapter.

- :mod:`.lr_paper` — the L-R paper's section V: table I (side known and resolved) and the
  example run of fig. 4; its scenario and Monte Carlo kernel are
  :mod:`arrayproc.evaluate.montecarlo`.
- :mod:`.spl_paper` — the SPL paper's three bearings-and-level TMA scenarios (section 5),
  the RPF Monte Carlo and the paper's numbers.
- :mod:`.compact_paper` — the compact-array paper's Fig. 1 analogue (range and heading RMSE
  at the CPA against the CRLB).
- :mod:`.thesis_narrowband` — thesis 3.2.1.2 (figs. 3.8-3.9): the narrowband EKF against the
  per-sample CBF on a simulated tonal.
- :mod:`.thesis_delay` — thesis chapter 3 time-delay estimation (figs. 3.15, 3.16), GCC-PHAT
  under an echo, and compact-array localisation against the CRLB.
- :mod:`.thesis_passive` — thesis chapter 2 passive chain: CBF pattern, beamwidth, array
  gain, integration statistics, DFT filter, and the simulated end-to-end run.
- :mod:`.thesis_synthetic_aperture` — thesis chapter 2 PSAS, ETAM and IBF on simulated
  recordings (table 2.1b, figs. 2.8, 2.11, 2.12, two sources).
- :mod:`.thesis_tma` — thesis 3.3.3 batch TMA Monte Carlo (fig. 3.19).
- :mod:`.thesis_doppler_spread` — thesis fig. 4.4, matched-filter loss of BPSK and HFM
  echoes under time distortion.
- :mod:`.thesis_active` — thesis chapter 4, the simulated active scenario's contacts against
  the echo truth.
- :mod:`.active_tracking` — the multi-target tracker on those contacts, scored against the
  truth.
- :mod:`.beamformers` — MVDR, MUSIC and port/starboard closed forms and the triplet L-R
  recording (docs/validation/beamformers.md).
- :mod:`.realism` — multipath, reverberation and water-pulled-array set-ups with their closed
  forms (docs/validation/realism.md).
- :mod:`.follow` — the chain of the followed-recording runs.
- :mod:`.target_picture` — five towed-array scenarios of the passive target picture run end
  to end (docs/validation/target_picture.md), scored by
  :mod:`arrayproc.evaluate.target_picture`.

The SPL names are importable from here as well.
"""

from arrayproc.evaluate.scenarios.spl_paper import (
    SCENARIOS,
    ScenarioData,
    SPLScenario,
    get_scenario,
)

__all__ = ["SPLScenario", "SCENARIOS", "get_scenario", "ScenarioData"]
