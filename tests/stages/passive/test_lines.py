"""Line contacts (stage ``lines``) against closed forms: frequency and cone interpolation, SNR
over the TPSW background, one contact per line, false alarms on noise."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.special import gammainc, gammaincc

from arrayproc.chain import RunContext
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, TimeMeta
from arrayproc.dsp.windows import time_taper
from arrayproc.errors import ConfigError
from arrayproc.io.geometry import line_array
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.stages.beamform.cbf import CBF
from arrayproc.stages.passive.integrate import Integrate
from arrayproc.stages.passive.lines import Lines, line_runs

C = 1500.0
FS, N_H, D = 2048.0, 32, 0.75
NFFT, N_B = 512, 4          # 4 Hz bins, 4 snapshots integrated
DF = FS / NFFT


def tonal(n, cones, freqs, amps, sigma, rng):
    """Plane-wave tonals (exact per-hydrophone delays) in white noise of std ``sigma``, Pa."""
    pos = line_array(N_H, D)
    t = np.arange(n) / FS
    x = sigma * rng.standard_normal((n, N_H))
    for cone, f, a in zip(cones, freqs, amps):
        tau = pos[:, 0] * np.cos(np.deg2rad(cone)) / C
        x += a * np.cos(2 * np.pi * f * (t[:, None] + tau[None, :]) + rng.uniform(0, 6.28))
    return x, pos


def run_lines(x, pos, tmp_path, heading=0.0, **kw):
    cbf = CBF(nfft=NFFT, hop=NFFT, window="hann", band=[100.0, 900.0],
              beams={"start": 0.0, "stop": 180.0, "count": 181})
    integ = Integrate(snapshots=N_B, mode="blockwise")
    st = Lines(**kw)
    out = tmp_path / "l.h5"
    with ProductsWriter(out) as w:
        st.bind(RunContext(products=w))
        blocks = [Block(x[i:i + 8192].astype(np.float32), Domain.TIME, i / FS,
                        min(8192, x.shape[0] - i) / FS, FS, pos, None,
                        meta=TimeMeta(i, min(8192, x.shape[0] - i)))
                  for i in range(0, x.shape[0], 8192)]

        def with_heading(bs):
            for b in bs:  # no recording: the headings the chain would take from /nav
                heads = np.full(b.data.shape[0], heading)
                yield b.replace(meta=dataclasses.replace(b.meta, headings=heads))
        list(st.process(with_heading(integ.process(cbf.process(iter(blocks))))))
    return read_products(out)["lines"]


def beamwidth_deg(f, cone):
    """Half-power width of an unshaded line array's beam at cone angle ``cone``."""
    return np.rad2deg(0.886 * C / f / (N_H * D * np.sin(np.deg2rad(cone))))


def test_line_runs_split_and_merge():
    y = np.full(30, -5.0)
    y[[4, 5, 6]] = [14, 20, 15]          # one line over three bins
    y[[10, 11, 12, 13, 14]] = [13, 20, 15, 19, 13]  # two lines: valley > 3 dB below both
    y[[20, 21, 22]] = [15, 13.5, 15.5]   # shallow valley: one line
    runs = [tuple(map(int, r)) for r in line_runs(y, 12.0)]
    assert runs == [(4, 6, 5), (10, 12, 11), (13, 14, 13), (20, 22, 22)]
    assert line_runs(np.zeros(8), 1.0) == []


def test_frequency_cone_level_against_truth_and_crlb(tmp_path, rng):
    f0, cone, a, sigma = 301.3, 63.4, 0.15, 1.0  # 0.325 bin, 0.4 beam off the grids
    x, pos = tonal(NFFT * N_B * 40, [cone], [f0], [a], sigma, rng)
    rows = run_lines(x, pos, tmp_path, heading=20.0, threshold_db=12.0)
    n_t = np.unique(rows["time"]).size
    assert n_t == 40 and rows["time"].size == n_t  # one contact per snapshot
    err = rows["freq_hz"] - f0
    # CRLB of a tone's frequency in white noise, N samples per snapshot (Rife & Boorstyn):
    # var(f) >= 12 σ² / ((2π)² A² N³) · fs², with the N_H hydrophones and N_B snapshots
    # adding their samples (coherent in space, independent in time)
    crlb = 12 * sigma**2 / ((2 * np.pi) ** 2 * a**2 * N_H * N_B * NFFT**3) * FS**2
    rms = np.sqrt(np.mean(err**2))
    assert rms >= np.sqrt(crlb)              # no estimator beats the bound
    assert abs(err.mean()) < 0.05 * DF       # Gaussian interpolation bias on a Hann lobe
    assert rms < 0.1 * DF
    assert np.sqrt(np.mean((rows["cone_deg"] - cone) ** 2)) < 0.1 * beamwidth_deg(f0, cone)
    assert np.allclose(rows["bearing_port_deg"], (20.0 - rows["cone_deg"]) % 360)
    assert np.allclose(rows["bearing_stbd_deg"], (20.0 + rows["cone_deg"]) % 360)
    # beams 1 deg apart from 0: the vertex lies within one beam of the peak beam, and the peak
    # beam within a quarter beamwidth of the truth (noise moves the peak of a 12 deg beam)
    assert np.all(np.abs(rows["beam"] - rows["cone_deg"]) <= 1)
    assert np.all(np.abs(rows["beam"] - cone) < 0.25 * beamwidth_deg(f0, cone))
    # received level of the tone A²/2 at a hydrophone, dB re 1 µPa²
    assert abs(np.median(rows["level_db"]) - 10 * np.log10(a**2 / 2 / 1e-12)) < 0.5
    # half-power width of a Hann main lobe: 1.44 bins (a little more between bins)
    assert np.all((rows["bandwidth_hz"] > 1.2 * DF) & (rows["bandwidth_hz"] < 2.2 * DF))


@pytest.mark.parametrize("frac", [0.1, 0.25, 0.4])
def test_frequency_unbiased_between_bins_at_high_snr(tmp_path, frac):
    """A strong tone (lines 34 dB over TPSW, median) at 0.1-0.4 bin off the grid: the mean of
    40 contacts is within 0.005 bin of the truth (the bare dB parabola's Hann bias was
    0.011-0.013 bin here, 10 standard errors)."""
    f0 = 300.0 + frac * DF
    x, pos = tonal(NFFT * N_B * 40, [63.4], [f0], [1.0], 1.0, np.random.default_rng(7))
    rows = run_lines(x, pos, tmp_path, threshold_db=12.0)
    err = (rows["freq_hz"] - f0) / DF
    assert err.size == 40 and abs(err.mean()) < 0.005


def test_snr_of_a_known_tonal_against_tpsw(tmp_path, rng):
    f0, cone, a, sigma = 75 * DF, 60.0, 0.08, 1.0  # on a bin and on a beam
    x, pos = tonal(NFFT * N_B * 40, [cone], [f0], [a], sigma, rng)
    rows = run_lines(x, pos, tmp_path, threshold_db=6.0)
    w = time_taper("hann", NFFT)
    snr = N_H * NFFT * a**2 / (4 * sigma**2 * np.mean(w**2) / np.mean(w) ** 2)
    # TPSW's clipping at r = 2 lowers the background of Gamma(N_B, 1/N_B) noise to
    # E[x; x <= r] + P(x > r) (the clipped bins take the first-pass mean, about 1)
    r, k = 2.0, N_B
    bias = gammainc(k + 1, k * r) + gammaincc(k, k * r)
    expect = 10 * np.log10((1 + snr) / bias)
    m = np.abs(rows["freq_hz"] - f0) < DF
    assert m.sum() == 40
    assert abs(np.median(rows["snr_db"][m]) - expect) < 1.0


def test_one_contact_per_line_and_two_tonals_on_one_bearing(tmp_path, rng):
    # a strong tonal shows in many beams (sidelobes) and several bins: one contact; a second
    # tonal on the same bearing at another frequency: a second contact
    x, pos = tonal(NFFT * N_B * 10, [100.0, 100.0], [402.0, 603.0], [1.0, 0.1], 1.0, rng)
    rows = run_lines(x, pos, tmp_path, threshold_db=12.0)
    for t in np.unique(rows["time"]):
        f = np.sort(rows["freq_hz"][rows["time"] == t])
        assert f.size == 2 and abs(f[0] - 402.0) < 0.5 * DF and abs(f[1] - 603.0) < 0.5 * DF
    assert np.unique(rows["time"]).size == 10


def false_alarm_per_cell(thr_db: float) -> float:
    """P(a noise cell stands ``thr_db`` over its TPSW background): the cell is Gamma(N_B,
    1/N_B) (N_B integrated Hann snapshots, no overlap); the background is the clipping bias
    (see the SNR test) times a Gamma(K, 1/K) mean over the 2·(32 − 3) window bins, K reduced
    by the correlation of adjacent Hann bins (|ρ|² = 4/9 each side)."""
    from scipy.stats import gamma
    k, r = N_B, 2.0
    bias = gammainc(k + 1, k * r) + gammaincc(k, k * r)
    big_k = 2 * (32 - 3) * k / (1 + 2 * 4 / 9)
    b = np.linspace(0.5, 1.5, 4001)
    pb = gamma.pdf(b, big_k, scale=bias / big_k)
    return float(np.trapezoid(gammaincc(k, k * 10 ** (thr_db / 10) * b) * pb, b))


def test_false_contacts_on_noise_against_the_threshold(tmp_path, rng):
    n_snap = 60
    x, pos = tonal(NFFT * N_B * n_snap, [], [], [], 1.0, rng)
    n_f = int(round((900.0 - 100.0) / DF)) + 1
    for thr_db in (7.0, 12.0):
        rows = run_lines(x, pos, tmp_path, threshold_db=thr_db, max_lines=10_000)
        per = rows["time"].size / n_snap
        q = false_alarm_per_cell(thr_db)
        # between one beam per bin and every beam independent (union bound); at 12 dB the
        # bound is ~1e-13 per snapshot: no false contact at all
        assert per <= n_f * 181 * q
        if thr_db == 7.0:
            assert per >= n_f * q


def test_empty_result_is_a_valid_table(tmp_path, rng):
    x, pos = tonal(NFFT * N_B * 4, [], [], [], 1.0, rng)
    rows = run_lines(x, pos, tmp_path, threshold_db=40.0)
    assert rows["time"].shape == (0,) and rows["beam"].dtype == np.int64
    assert set(rows) >= {"time", "cone_deg", "bearing_port_deg", "bearing_stbd_deg",
                         "freq_hz", "bandwidth_hz", "level_db", "snr_db", "beam"}
    from arrayproc.plots import plot_file
    plot_file(str(tmp_path / "l.h5"), str(tmp_path / "e.png"), "lines")  # an empty plot
    assert (tmp_path / "e.png").stat().st_size > 0


def test_config_errors():
    with pytest.raises(ConfigError, match="'tpsw_gap'"):
        Lines(tpsw_window=4, tpsw_gap=4)
    with pytest.raises(ConfigError, match="'threshold_db'"):
        Lines(threshold_db=-1.0)


def broadband_plane_wave(n, cone, amp, pos, rng):
    """White noise of std ``amp`` arriving as a plane wave at ``cone`` (exact delays by FFT
    phase shifts): a loud broadband source such as a tow ship."""
    s = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, 1 / FS)
    tau = pos[:, 0] * np.cos(np.deg2rad(cone)) / C
    return amp * np.fft.irfft(s[:, None] * np.exp(2j * np.pi * f[:, None] * tau[None, :]), n,
                              axis=0)


@pytest.mark.parametrize("cone,bb_cone,a,bb", [
    (32.0, 30.0, 3.0, 10.0),   # inside the broadband source's beam (a tanker by a tow ship)
    (50.0, 40.0, 1.0, 10.0),   # on its beam's skirt
    (55.0, 40.0, 1.0, 10.0),
])
def test_a_tonal_beside_a_loud_broadband_source_points_at_itself(tmp_path, cone, bb_cone, a,
                                                                 bb):
    """A tonal within or beside the beam of a broadband source 20 dB louder per hydrophone:
    its ratio to the TPSW background is lowest in its own beam (the broadband raises that
    beam's background), so it crosses the threshold only on sidelobes. The line still gets
    the tonal's cone (the largest excess over the background, among beams significantly
    over it), within a quarter of the beamwidth; the beam of the largest level among those
    over the threshold was 19° off in the first case."""
    rng = np.random.default_rng(3)
    n = NFFT * N_B * 30
    x, pos = tonal(n, [cone], [400.0], [a], 1.0, rng)
    x += broadband_plane_wave(n, bb_cone, bb, pos, rng)
    rows = run_lines(x, pos, tmp_path, threshold_db=12.0)
    m = np.abs(rows["freq_hz"] - 400.0) < DF
    assert m.sum() >= 20
    assert abs(np.median(rows["cone_deg"][m]) - cone) < 0.25 * beamwidth_deg(400.0, cone)
