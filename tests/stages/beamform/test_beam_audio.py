"""``listen`` and the ``beam_audio`` stage: two tonals from different cones, each beam's WAV
holds its own tonal ≥ 15 dB above the other, at the level of the closed-form beam pattern
(thesis eq. 2.13, :func:`arrayproc.sim.pattern.line_array_pattern`)."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.io.geometry import line_array
from arrayproc.sim.pattern import line_array_pattern
from arrayproc.sim.plane_wave import tonal_plane_wave
from arrayproc.stages.beamform.beam_audio import DelaySum, steering_advances
from tests.conftest import write_recording

sf = pytest.importorskip("soundfile")

FS, SECONDS, N, D = 4096.0, 4.0, 16, 0.75
TONALS = ((60.0, 400.0), (110.0, 700.0))  # (cone deg, Hz): each on a whole FFT bin


def two_tonals(tmp_path, rng):
    pos = line_array(N, D)
    n = int(FS * SECONDS)
    x = sum(tonal_plane_wave(n, FS, pos, c, f, phase=0.7 * i)
            for i, (c, f) in enumerate(TONALS))
    x = x + 1e-3 * rng.standard_normal(x.shape)
    return write_recording(tmp_path / "two.h5", x.astype(np.float32), fs=FS, positions=pos)


def line_level_db(y, fs, f):
    """Amplitude (dB) of a tone on a whole bin of a Hann-windowed spectrum."""
    w = np.hanning(y.size)
    spec = np.abs(np.fft.rfft(y * w)) * 2 / w.sum()
    k = int(round(f * y.size / fs))
    return 20 * np.log10(spec[k - 1:k + 2].max())


def expected_db(beam_cone, src_cone, f):
    return 20 * np.log10(abs(line_array_pattern(np.array([beam_cone]), src_cone, f, N, D)[0])
                         / N)


def test_each_beam_holds_its_own_tonal_at_the_closed_form_level(tmp_path, rng, capsys):
    rec = two_tonals(tmp_path, rng)
    rows = []
    for cone, _ in TONALS:
        out = tmp_path / f"beam_{cone:g}.wav"
        assert main(["listen", str(rec), "--cone", str(cone), "--start", "0.5",
                     "--duration", "3", "-o", str(out), "-q"]) == 0
        y, fs = sf.read(str(out))
        assert fs == FS and y.size == int(3 * FS)
        assert np.max(np.abs(y)) == pytest.approx(10 ** (-1 / 20), abs=1e-4)  # -1 dBFS
        levels = {c: line_level_db(y, fs, f) for c, f in TONALS}
        own = levels[cone]
        for c, f in TONALS:
            measured = levels[c] - own  # the other tonal relative to the beam's own
            closed = expected_db(cone, c, f)
            rows.append((cone, c, f, measured, closed))
            assert measured == pytest.approx(closed, abs=0.3), (cone, c)
            if c != cone:
                assert measured <= -15.0
    assert capsys.readouterr().err == ""


def test_delay_sum_streams_to_the_whole_record_result(rng):
    """Block sizes do not change the beam: the streaming buffer keeps what the delays need."""
    pos = line_array(8, 1.0)
    x = rng.standard_normal((3000, 8))
    tau = steering_advances(pos, np.array([0.3, 0.95, 0.0]), "cone", 1500.0)
    whole = DelaySum(tau, np.ones(8), 1000.0)
    ref = np.concatenate([whole.process(x), whole.flush()])
    parts = DelaySum(tau, np.ones(8), 1000.0)
    got = np.concatenate([parts.process(x[s:s + 77]) for s in range(0, 3000, 77)]
                         + [parts.flush()])
    assert got.shape == ref.shape == (3000,)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)


def _arrivals(rng, pos, k, fs, n, c=1500.0):
    """A band-limited (0.4 fs) white source s and its plane wave from unit vector k on the
    elements, x_n(t) = s(t + τ_n), τ_n = (r_n − r̄)·k / c, exact as a phase ramp (circular)."""
    f = np.fft.rfftfreq(n, 1 / fs)
    spec = np.fft.rfft(rng.standard_normal(n)) * (f < 0.4 * fs)
    tau = (pos - pos.mean(axis=0)) @ k / c
    x = np.fft.irfft(spec[None, :] * np.exp(2j * np.pi * f[None, :] * tau[:, None]), n).T
    return np.fft.irfft(spec, n), x


def test_any_geometry_steers_a_3d_array_exactly(rng):
    """A random 3-D array steered at a bearing and elevation gives back the source that
    arrives from there, to the fractional delay's accuracy."""
    from arrayproc.stages.beamform.beam_audio import delay_sum_for, steering_direction
    pos = rng.uniform(-2, 2, (12, 3))
    fs, n = 2000.0, 8000
    k, _ = steering_direction(bearing_deg=40.0, elevation_deg=20.0)
    s, x = _arrivals(rng, pos, k, fs, n)
    ds = delay_sum_for(pos, fs, 1500.0, bearing_deg=40.0, elevation_deg=20.0)
    y = np.concatenate([ds.process(x), ds.flush()])
    core = slice(100, n - 100)  # away from the zero padding at both ends
    rel_err = np.sqrt(np.mean((y[core] - s[core]) ** 2) / np.mean(s[core] ** 2))
    assert rel_err < 3e-3, rel_err
    other = delay_sum_for(pos, fs, 1500.0, bearing_deg=-100.0, elevation_deg=0.0)
    y2 = np.concatenate([other.process(x), other.flush()])
    assert np.mean(y2[core] ** 2) < 0.5 * np.mean(s[core] ** 2)


def test_beam_audio_stage_in_a_chain_writes_the_same_beam(tmp_path, rng):
    from arrayproc.app.api import load_chain, run_chain
    from arrayproc.io.recording import Recording
    rec = two_tonals(tmp_path, rng)
    chain = tmp_path / "c.toml"
    wav = tmp_path / "stage.wav"
    chain.write_text(f'[input]\nblock = 1000\n\n[[stage]]\ntype = "beam_audio"\n'
                     f'cone_deg = 60.0\noutput = "{wav}"\n', encoding="utf-8")
    with Recording(rec) as r:
        run_chain(r, load_chain(str(chain)))
    assert main(["listen", str(rec), "--cone", "60", "-o", str(tmp_path / "l.wav"), "-q"]) == 0
    a, _ = sf.read(str(wav))
    b, _ = sf.read(str(tmp_path / "l.wav"))
    np.testing.assert_allclose(a, b, atol=2 ** -22)


@pytest.mark.parametrize("args,needle", [
    (["--cone", "200"], "cone angle must lie in [0, 180]"),
    (["--cone", "60", "--band", "100", "5000"], "above the Nyquist"),
    (["--cone", "60", "--start", "99"], "beyond the recording's end"),
    (["--cone", "60", "--duration", "-1"], "--duration must be"),
])
def test_bad_listen_options_are_one_line(tmp_path, rng, capsys, args, needle):
    rec = write_recording(tmp_path / "r.h5", rng.standard_normal((4096, 4)).astype(np.float32),
                          fs=FS, positions=line_array(4, 0.75))
    out = tmp_path / "b.wav"
    assert main(["listen", str(rec), *args, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("arrayproc: error:") and needle in err and err.count("\n") == 1
    assert not out.exists()
