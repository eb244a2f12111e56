"""WAV import: every sample format, length mismatch, refusals, and the real recording."""

from __future__ import annotations

import wave

import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.errors import FormatError
from arrayproc.io.geometry import read_geometry_csv
from arrayproc.io.recording import Recording
from arrayproc.io.wav import import_wavs, read_wav_frames, read_wav_info
from tests.conftest import XAV


def write_pcm(path, ints: np.ndarray, bits: int, fs: int = 8000) -> None:
    """Write integer samples (n, ch) with the standard library's wave module."""
    n, ch = ints.shape
    if bits == 8:
        raw = (ints + 128).astype(np.uint8).tobytes()
    elif bits == 16:
        raw = ints.astype("<i2").tobytes()
    elif bits == 24:
        v = ints.astype("<i4").reshape(-1)
        b = v.view(np.uint8).reshape(-1, 4)[:, :3]
        raw = b.tobytes()
    else:
        raw = ints.astype("<i4").tobytes()
    with wave.open(str(path), "wb") as w:
        w.setnchannels(ch)
        w.setsampwidth(bits // 8)
        w.setframerate(fs)
        w.writeframes(raw)


@pytest.mark.parametrize("bits", [8, 16, 24, 32])
def test_pcm_decoding_exact(tmp_path, bits):
    full = 2 ** (bits - 1)
    ints = np.array([[-full, full - 1], [0, 1], [-1, full // 2]], dtype=np.int64)
    write_pcm(tmp_path / "a.wav", ints, bits)
    info = read_wav_info(tmp_path / "a.wav")
    assert (info.bits, info.n_channels, info.n_frames, info.fs) == (bits, 2, 3, 8000)
    assert np.array_equal(read_wav_frames(info, 0, 3), ints / full)


@pytest.mark.parametrize("dtype", ["<f4", "<f8"])
def test_float_wav(tmp_path, dtype):
    import scipy.io.wavfile as wf
    x = np.array([[0.25, -0.5], [1.0, 0.0]], dtype=dtype)
    wf.write(tmp_path / "f.wav", 1000, x)
    info = read_wav_info(tmp_path / "f.wav")
    assert info.is_float and info.bits == np.dtype(dtype).itemsize * 8
    assert np.array_equal(read_wav_frames(info, 0, 2), x.astype(float))


def test_mono_files_unequal_length_cut_with_warning(tmp_path):
    a = np.arange(100).reshape(-1, 1)
    b = np.arange(130).reshape(-1, 1) * 2
    write_pcm(tmp_path / "a.wav", a, 16)
    write_pcm(tmp_path / "b.wav", b, 16)
    msgs = []
    info = import_wavs([tmp_path / "a.wav", tmp_path / "b.wav"], tmp_path / "r.h5",
                       warn=msgs.append, chunk=7)
    assert info["n_samples"] == 100 and len(msgs) == 1 and "b.wav (+30 samples)" in msgs[0]
    with Recording(tmp_path / "r.h5", positions=np.zeros((2, 3))) as r:
        x = r.read(dtype=np.float64)
        assert np.array_equal(x[:, 0], np.arange(100) / 32768.0)
        assert np.array_equal(x[:, 1], np.arange(100) * 2 / 32768.0)
        assert r.units == "FS"


def test_mismatched_rate_or_depth_refused(tmp_path, capsys):
    write_pcm(tmp_path / "a.wav", np.zeros((10, 1), int), 16, fs=8000)
    write_pcm(tmp_path / "b.wav", np.zeros((10, 1), int), 16, fs=16000)
    write_pcm(tmp_path / "c.wav", np.zeros((10, 1), int), 24, fs=8000)
    with pytest.raises(FormatError, match="b.wav: sample rate 16000 Hz differs"):
        import_wavs([tmp_path / "a.wav", tmp_path / "b.wav"], tmp_path / "r.h5")
    rc = main(["import", str(tmp_path / "a.wav"), str(tmp_path / "c.wav"), "-o",
               str(tmp_path / "r.h5")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err == [f"arrayproc: error: {tmp_path / 'c.wav'}: sample format 24-bit "
                               "PCM differs from a.wav (16-bit PCM)"]
    assert not (tmp_path / "r.h5").exists()


def test_not_a_wav(tmp_path):
    (tmp_path / "x.wav").write_bytes(b"not a wav at all")
    with pytest.raises(FormatError, match="not a WAV file"):
        read_wav_info(tmp_path / "x.wav")


@pytest.mark.skipif(not XAV.is_dir(), reason="needs ../shared/data beside the checkout")
def test_import_real_six_hydrophone_recording(tmp_path, capsys):
    """The field recording: 6 × 24-bit 32 kHz files, one 230 samples longer, CSV geometry."""
    wavs = sorted(XAV.glob("AMAR173.*.wav"))
    assert len(wavs) == 6
    out = tmp_path / "xav.h5"
    rc = main(["import", *map(str, wavs), "--geometry", str(XAV / "hydrophones_config_07-HI.csv"),
               "--sound-speed", "1484", "-o", str(out), "-q"])
    err = capsys.readouterr().err
    assert rc == 0
    assert "AMAR173.1.20190920T163858Z.wav (+230 samples)" in err
    geom = read_geometry_csv(XAV / "hydrophones_config_07-HI.csv")
    with Recording(out) as r:
        assert (r.n_channels, r.fs, r.n_samples) == (6, 32000.0, 544000)
        assert r.sound_speed == 1484.0 and r.start_time == "2019-09-20T16:38:58Z"
        assert np.allclose(r.positions, geom)
        assert np.allclose(r.positions[3], [0.028, 0.0, -0.002])  # the reference hydrophone
        x = r.read(100000, 100100, dtype=np.float64)
    # Samples are exactly the 24-bit integers / 2^23, file by file (independent decoder:
    # scipy reads 24-bit PCM as left-justified int32).
    import scipy.io.wavfile as wf
    for ch, w in enumerate(wavs):
        _, ref = wf.read(w)
        assert np.array_equal(x[:, ch], ref[100000:100100] / 2.0**31)
    assert np.all(np.abs(x) < 1) and x.std() > 0


@pytest.mark.skipif(not XAV.is_dir(), reason="needs ../shared/data beside the checkout")
def test_geometry_z_up_matches_the_deployment_depths(tmp_path):
    """The XAV configuration file's z axis points up: with --z-up the imported z (down) orders
    the hydrophones as the deployment sheet's depths do (deepest 7.70 m has the largest z)."""
    import csv

    from arrayproc.app.commands import geometry
    pos = geometry(geometry_file=str(XAV / "hydrophones_config_07-HI.csv"), z_up=True)
    raw = read_geometry_csv(XAV / "hydrophones_config_07-HI.csv")
    assert np.array_equal(pos[:, :2], raw[:, :2]) and np.array_equal(pos[:, 2], -raw[:, 2])
    with open(XAV / "deployment_info.csv", newline="") as f:
        depth = np.array([float(r["hydrophone_depth"]) for r in csv.DictReader(f)])
    # depth differences equal z differences (m), channel by channel
    assert np.allclose(pos[:, 2] - pos[3, 2], depth - depth[3], atol=0.02)


@pytest.mark.parametrize("given,expected,notice", [
    (["hyd1.wav", "hyd10.wav", "hyd11.wav", "hyd2.wav"],
     ["hyd1.wav", "hyd2.wav", "hyd10.wav", "hyd11.wav"], True),
    (["hyd1.wav", "hyd2.wav", "hyd10.wav"], ["hyd1.wav", "hyd2.wav", "hyd10.wav"], False),
    (["AMAR173.2.20190920T163858Z.wav", "AMAR173.1.20190920T163858Z.wav"],
     ["AMAR173.1.20190920T163858Z.wav", "AMAR173.2.20190920T163858Z.wav"], True),
    (["port.wav", "stbd.wav"], ["port.wav", "stbd.wav"], False),  # sorted already: kept
])
def test_channel_order_is_natural(given, expected, notice):
    from arrayproc.io.wav import channel_order
    order, msg = channel_order(given)
    assert order == expected
    assert (msg is not None) == notice


@pytest.mark.parametrize("given", [["stbd.wav", "port.wav"], ["h1.wav", "h01.wav"],
                                   ["b1.wav", "a2.wav"]])
def test_channel_order_refuses_what_no_number_decides(given):
    from arrayproc.io.wav import channel_order
    with pytest.raises(FormatError, match="ambiguous"):
        channel_order(given)
