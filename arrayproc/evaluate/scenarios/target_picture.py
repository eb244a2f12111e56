"""Five towed-array scenarios for the passive target picture (docs/validation/target_picture.md),
each run ``simulate → process → track → tma`` with the shipped files only
(:mod:`arrayproc.evaluate.target_picture`).

All share the shipped chain's array (32 hydrophones 0.75 m apart at 60 m, 2048 Hz), a tow
ship 250 m ahead and spherical spreading over a 60 dB re 1 µPa²/Hz sea; the ownship (5 kn)
turns in every one, so that each source's range is observable from bearings:

- :data:`TOWSHIP_MASKING` (10 min) — a loud tow ship (125 dB/Hz broadband) filling the
  forward sector of the BTR, three contacts: one on the bow inside it, one abeam, one on the
  quarter; a 60° turn to starboard.
- :data:`QUIET_SUBMERGED` (10 min) — a submerged source whose tonals (141, 138 dB) stand
  clear in the LOFAR and whose broad band (92 dB/Hz) is buried in the BTR, and a merchant
  (SPL paper's speed law); a 50° turn to port.
- :data:`CROSSING` (10 min) — two sources on the port side crossing in bearing mid-run, with
  different tonals; a 45° turn to starboard after the crossing.
- :data:`ENDFIRE_TURN` (10 min) — a target on the starboard bow carried through forward
  end-fire to port by the ownship's 45° turn (the measured cone folds at 0°).
- :data:`LONG_FOUR` (20 min) — four contacts at 3-7 km with unsteady tonals (finite coherence
  time, fading), two turns.

:data:`SHORT_TURN` (4 min, one source) is the reduced check of the default test suite.
:func:`scenario_toml` returns a scenario's TOML text (``arrayproc simulate`` input).
"""

from __future__ import annotations

__all__ = ["SCENARIOS", "scenario_toml", "TOWSHIP_MASKING", "QUIET_SUBMERGED", "CROSSING",
           "ENDFIRE_TURN", "LONG_FOUR", "SHORT_TURN"]

_HEAD = """[recording]
fs = 2048.0
duration = {duration}
sound_speed = 1500.0
seed = {seed}
start_time = "2026-01-01T00:00:00Z"

[array]
type = "line"
n = 32
spacing = 0.75
depth = 60.0

[propagation]
loss = "spherical"

[noise]
level_db = 60.0
[noise.towship]
distance = 250.0
depth = 4.0
tonals = [{{ freq = {tow_freq}, level_db = 150.0 }}]
[noise.towship.broadband]
band = [30.0, 900.0]
level_db = {tow_db}
"""

TOWSHIP_MASKING = _HEAD.format(duration=600.0, seed=11, tow_freq=81.0, tow_db=125.0) + """
[ownship]
start = [0.0, 0.0]
[[ownship.leg]]
course = 0.0
speed_kn = 5.0
duration = 300.0
[[ownship.leg]]
course = 60.0
speed_kn = 5.0
turn_rate = 1.0
duration = 300.0

[[source]]
name = "bow"
start = [1200.0, 4300.0]
depth = 8.0
course = 215.0
speed_kn = 8.0
tonals = [{ freq = 212.0, level_db = 148.0 }, { freq = 424.0, level_db = 143.0 }]
[source.broadband]
band = [60.0, 900.0]
level_db = 112.0

[[source]]
name = "abeam"
start = [-3900.0, 800.0]
depth = 6.0
course = 20.0
speed_kn = 7.0
tonals = [{ freq = 333.0, level_db = 145.0 }]
[source.broadband]
band = [60.0, 900.0]
model = "speed"

[[source]]
name = "quarter"
start = [2600.0, -3300.0]
depth = 10.0
course = 340.0
speed_kn = 9.0
tonals = [{ freq = 176.0, level_db = 147.0 }, { freq = 528.0, level_db = 141.0 }]
[source.broadband]
band = [60.0, 900.0]
level_db = 110.0
"""

QUIET_SUBMERGED = _HEAD.format(duration=600.0, seed=12, tow_freq=67.0, tow_db=118.0) + """
[ownship]
start = [0.0, 0.0]
[[ownship.leg]]
course = 270.0
speed_kn = 5.0
duration = 330.0
[[ownship.leg]]
course = 220.0
speed_kn = 5.0
turn_rate = 1.0
duration = 270.0

[[source]]
name = "submerged"
start = [-2200.0, 2800.0]
depth = 120.0
course = 160.0
speed_kn = 5.0
tonals = [{ freq = 287.0, level_db = 141.0, coherence_time = 40.0 },
          { freq = 461.0, level_db = 138.0, coherence_time = 40.0 }]
[source.broadband]
band = [100.0, 800.0]
level_db = 92.0

[[source]]
name = "merchant"
start = [1500.0, -4200.0]
depth = 5.0
course = 290.0
speed_kn = 13.0
tonals = [{ freq = 121.0, level_db = 152.0 }, { freq = 242.0, level_db = 147.0 }]
[source.broadband]
band = [60.0, 900.0]
model = "speed"
"""

CROSSING = _HEAD.format(duration=600.0, seed=13, tow_freq=74.0, tow_db=118.0) + """
[ownship]
start = [0.0, 0.0]
[[ownship.leg]]
course = 0.0
speed_kn = 5.0
duration = 360.0
[[ownship.leg]]
course = 45.0
speed_kn = 5.0
turn_rate = 1.0
duration = 240.0

[[source]]
name = "near"
start = [-2400.0, 2000.0]
depth = 6.0
course = 185.0
speed_kn = 11.0
tonals = [{ freq = 263.0, level_db = 146.0 }, { freq = 526.0, level_db = 141.0 }]
[source.broadband]
band = [60.0, 900.0]
level_db = 112.0

[[source]]
name = "far"
start = [-4700.0, -300.0]
depth = 8.0
course = 10.0
speed_kn = 6.0
tonals = [{ freq = 389.0, level_db = 149.0 }]
[source.broadband]
band = [60.0, 900.0]
level_db = 114.0
"""

ENDFIRE_TURN = _HEAD.format(duration=600.0, seed=14, tow_freq=88.0, tow_db=118.0) + """
[ownship]
start = [0.0, 0.0]
[[ownship.leg]]
course = 0.0
speed_kn = 5.0
duration = 300.0
[[ownship.leg]]
course = 45.0
speed_kn = 5.0
turn_rate = 1.0
duration = 300.0

[[source]]
name = "target"
start = [1300.0, 3600.0]
depth = 30.0
course = 285.0
speed_kn = 6.0
tonals = [{ freq = 247.0, level_db = 146.0 }, { freq = 494.0, level_db = 141.0 }]
[source.broadband]
band = [60.0, 900.0]
level_db = 108.0
"""

LONG_FOUR = _HEAD.format(duration=1200.0, seed=15, tow_freq=79.0, tow_db=120.0) + """
[ownship]
start = [0.0, 0.0]
[[ownship.leg]]
course = 90.0
speed_kn = 5.0
duration = 400.0
[[ownship.leg]]
course = 30.0
speed_kn = 5.0
turn_rate = 1.0
duration = 400.0
[[ownship.leg]]
course = 100.0
speed_kn = 5.0
turn_rate = 1.0
duration = 400.0

[[source]]
name = "tanker"
start = [-1000.0, 6500.0]
depth = 10.0
course = 120.0
speed_kn = 11.0
tonals = [{ freq = 108.0, level_db = 153.0, coherence_time = 30.0 },
          { freq = 216.0, level_db = 148.0, coherence_time = 30.0 }]
[source.broadband]
band = [60.0, 900.0]
model = "speed"

[[source]]
name = "fisher"
start = [3000.0, -2800.0]
depth = 4.0
course = 60.0
speed_kn = 4.0
tonals = [{ freq = 157.0, level_db = 144.0, fading_db = 2.0, fading_time = 20.0 },
          { freq = 314.0, level_db = 140.0, fading_db = 2.0, fading_time = 20.0 }]
[source.broadband]
band = [60.0, 900.0]
level_db = 108.0

[[source]]
name = "coaster"
start = [6500.0, 5000.0]
depth = 6.0
course = 235.0
speed_kn = 9.0
tonals = [{ freq = 365.0, level_db = 149.0, coherence_time = 30.0 }]
[source.broadband]
band = [60.0, 900.0]
level_db = 113.0

[[source]]
name = "submerged"
start = [-3500.0, -2000.0]
depth = 90.0
course = 45.0
speed_kn = 6.0
tonals = [{ freq = 441.0, level_db = 142.0, coherence_time = 40.0 },
          { freq = 589.0, level_db = 139.0, coherence_time = 40.0 }]
[source.broadband]
band = [100.0, 800.0]
level_db = 95.0
"""

#: a reduced check of the whole chain (the default test suite): 4 minutes, one source on the
#: starboard bow at 2.6 km, a 50° turn to port after 100 s
SHORT_TURN = _HEAD.format(duration=240.0, seed=16, tow_freq=83.0, tow_db=115.0) + """
[ownship]
start = [0.0, 0.0]
[[ownship.leg]]
course = 0.0
speed_kn = 5.0
duration = 100.0
[[ownship.leg]]
course = 310.0
speed_kn = 5.0
turn_rate = 1.0
duration = 140.0

[[source]]
name = "contact"
start = [1800.0, 1900.0]
depth = 10.0
course = 250.0
speed_kn = 7.0
tonals = [{ freq = 231.0, level_db = 147.0 }, { freq = 462.0, level_db = 142.0 }]
[source.broadband]
band = [60.0, 900.0]
level_db = 110.0
"""

#: name → scenario TOML text, in the table's order
SCENARIOS = {"towship_masking": TOWSHIP_MASKING, "quiet_submerged": QUIET_SUBMERGED,
             "crossing": CROSSING, "endfire_turn": ENDFIRE_TURN, "long_four": LONG_FOUR}


def scenario_toml(name: str) -> str:
    """The TOML text of scenario ``name`` (a key of :data:`SCENARIOS`)."""
    if name not in SCENARIOS:
        raise KeyError(f"no target-picture scenario {name!r} (one of {', '.join(SCENARIOS)})")
    return SCENARIOS[name]
