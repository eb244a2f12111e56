"""BTR and LOFAR products, TPSW normalisation, truth geometry and the sonar plots."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.chain import build_chain, run_chain
from arrayproc.chain.block import Block
from arrayproc.chain.domains import Domain, Integration, SnapshotMeta
from arrayproc.dsp.tpsw import tpsw
from arrayproc.io.geometry import line_array
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.recording import Recording, RecordingWriter
from arrayproc.io.truth import cone_angles, tonal_frequencies
from arrayproc.plots import plot_file
from arrayproc.sim.plane_wave import tonal_plane_wave
from arrayproc.stages.passive.btr import BTR
from arrayproc.stages.passive.lofar import LOFAR
from tests.conftest import cbf_stage, chain_toml

C = 1500.0


def tpsw_reference(x: np.ndarray, half: int, gap: int, clip: float) -> np.ndarray:
    """Direct two-pass split-window mean, bin by bin."""
    n = x.size

    def split_mean(v):
        out = np.empty(n)
        for i in range(n):
            idx = [j for j in range(max(0, i - half), min(n, i + half + 1)) if abs(j - i) > gap]
            out[i] = np.mean(v[idx]) if idx else v[i]
        return out

    m1 = split_mean(x)
    return split_mean(np.where(x > clip * m1, m1, x))


def test_tpsw_matches_reference_and_normalises_noise(rng):
    x = rng.exponential(1.0, (3, 200))
    x[:, 77] += 40.0  # a line
    got = tpsw(x, 16, 2, 2.0)
    for r in range(3):
        assert np.allclose(got[r], tpsw_reference(x[r], 16, 2, 2.0))
    big = rng.exponential(3.0, (50, 400))
    ratio = big / tpsw(big, 32, 3, 2.0)
    # clipping at r·m1 replaces the exponential tail above r by the mean, so the background
    # of exponential (N_B = 1) noise is E = 1 − r e^{−r} times the true mean
    r = 2.0
    assert abs(ratio.mean() * (1 - r * np.exp(-r)) - 1) < 0.05
    assert (x / got)[:, 77].min() > 10  # the line stands out


def power_blocks(p: np.ndarray, freqs, beams, times):
    yield Block(p, Domain.POWER, float(times[0]), 1.0, 1000.0,
                np.zeros((2, 3)), None, np.asarray(freqs, float), np.asarray(beams, float),
                meta=SnapshotMeta(np.asarray(times, float), np.zeros(len(times)), 1000, 1000,
                                  "none", 1.0, integration=Integration(1, "blockwise", False)))


def test_btr_and_lofar_rows(tmp_path, rng):
    p = rng.exponential(1.0, (5, 40, 7)).astype(np.float32)
    freqs = 100.0 + np.arange(40)
    beams = np.linspace(0, 180, 7)
    times = np.arange(5) * 2.0
    out = tmp_path / "p.h5"
    with ProductsWriter(out) as w:
        btr = BTR(band=[110.0, 120.0])
        lof = LOFAR(beams=[31.0, 150.0], normalise="none")
        lof_t = LOFAR(name="lofar_tpsw", beams="all", tpsw_window=8)
        from arrayproc.chain import RunContext
        for s in (btr, lof, lof_t):
            s.bind(RunContext(products=w))
        for s in (btr, lof, lof_t):
            passed = list(s.process(power_blocks(p, freqs, beams, times)))
            assert passed[0].data is p  # sinks pass their blocks on
    g = read_products(out)
    sel = (freqs >= 110) & (freqs <= 120)
    want = 10 * np.log10(p[:, sel, :].sum(1).astype(float) / 1e-12)
    assert np.allclose(g["btr"]["power_db"], want, atol=1e-4)
    assert np.array_equal(g["btr"]["cone_deg"], beams)
    assert np.array_equal(g["btr"]["time"], times)
    lo = g["lofar"]
    assert np.array_equal(lo["cone_deg"], [30.0, 150.0])
    assert lo["power_db"].shape == (5, 2, 40)
    assert np.allclose(lo["power_db"][:, 1], 10 * np.log10(p[:, :, 5] / 1e-12), atol=1e-4)
    lt = g["lofar_tpsw"]
    assert lt["power_db"].shape == (5, 7, 40)
    bg = tpsw(p.transpose(0, 2, 1), 8, 3, 2.0)
    assert np.allclose(lt["power_db"], 10 * np.log10(p.transpose(0, 2, 1) / bg), atol=1e-4)


def write_truth_recording(path, fs=2048.0, n_h=32, dx=0.75, dur=24.0, seed=3):
    """Static array heading 0 (north) and one tonal+broadband source at a known cone angle:
    exact plane waves (no propagation delay), so truth and data agree."""
    r = np.random.default_rng(seed)
    pos = line_array(n_h, dx)
    n = int(dur * fs)
    src_xy = np.array([2000.0 * np.sin(np.deg2rad(60.0)), 2000.0 * np.cos(np.deg2rad(60.0))])
    # cone 60°: bearing 60° from north
    x = tonal_plane_wave(n, fs, pos, 60.0, 300.0, amp=0.3, phase=0.0, c=C)
    x += 0.5 * r.standard_normal((n, n_h))
    with RecordingWriter(path, fs, n_h, positions=pos) as w:
        w.append(x.astype(np.float32))
        w.set_nav(np.array([0.0, dur]), np.zeros((2, 2)), np.zeros(2))
        w.write_group("truth/sources/tonal", {
            "time": np.array([0.0, dur]), "position": np.stack([src_xy, src_xy]),
            "velocity": np.zeros((2, 2))},
            attrs={"depth": 0.0, "tonal_freqs": [300.0], "kind": "source"})
    return path


CHAIN = chain_toml(cbf_stage(1024, [100.0, 600.0], 91, hop=512),
                   {"type": "integrate", "snapshots": 4}, {"type": "btr"},
                   {"type": "lofar", "input": "integrate"},
                   {"type": "bearings", "input": "integrate", "lines": True}, block=4096)


def test_chain_products_truth_and_plots(tmp_path):
    rec_path = write_truth_recording(tmp_path / "rec.h5")
    prod = tmp_path / "prod.h5"
    with Recording(rec_path) as rec:
        t = np.array([1.0, 10.0])
        assert np.allclose(cone_angles(rec, t)["tonal"], 60.0)
        assert np.allclose(tonal_frequencies(rec, t)["tonal"], 300.0)  # static: no Doppler
        with ProductsWriter(prod, source=str(rec_path), chain=CHAIN) as w:
            run_chain(rec, build_chain(CHAIN), w)
    g = read_products(prod)
    assert g["btr"]["power_db"].shape == (g["btr"]["time"].size, 91)
    # the LOFAR line at 300 Hz in the 60° beam, 10+ dB over the TPSW background
    lo = g["lofar"]
    b60 = int(np.argmin(np.abs(lo["cone_deg"] - 60.0)))
    f300 = int(np.argmin(np.abs(lo["freq"] - 300.0)))
    assert np.all(lo["power_db"][:, b60, f300] > 10)
    rows = g["bearings"]
    line = (rows["freq_lo"] <= 300.0) & (rows["freq_hi"] >= 300.0)
    assert line.sum() >= lo["time"].size
    assert np.all(np.abs(rows["cone_deg"][line] - 60.0) < 0.5)
    for kind, extra in (("btr", {}), ("lofar", {"beam": 60.0}), ("lofar", {})):
        png = tmp_path / f"{kind}{len(extra)}.png"
        plot_file(str(prod), str(png), kind, range_db=20.0, **extra)
        assert png.stat().st_size > 10_000
    plot_file(str(prod), str(tmp_path / "nt.png"), "btr", truth=False)


def test_plot_errors_are_one_line(tmp_path):
    from arrayproc.errors import ArrayprocError
    p = tmp_path / "empty.h5"
    with ProductsWriter(p):
        pass
    with pytest.raises(ArrayprocError, match="no btr product"):
        plot_file(str(p), str(tmp_path / "x.png"), "btr")


def test_plot_command_line(tmp_path):
    from arrayproc.app.cli import main
    rec_path = write_truth_recording(tmp_path / "rec.h5", dur=12.0)
    prod = tmp_path / "prod.h5"
    chain = tmp_path / "chain.toml"
    chain.write_text(CHAIN)
    assert main(["process", str(rec_path), "-c", str(chain), "-o", str(prod), "-q"]) == 0
    for kind in ("btr", "lofar"):
        out = tmp_path / f"{kind}.png"
        assert main(["plot", str(prod), "--kind", kind, "--beam", "60", "--range-db", "25",
                     "-o", str(out)]) == 0
        assert out.stat().st_size > 10_000


def test_btr_plot_of_3d_beams(tmp_path, rng):
    """3-D beams (bearing × elevation): the BTR shows the elevation nearest horizontal."""
    from arrayproc.chain import RunContext
    p = rng.exponential(1.0, (4, 10, 6)).astype(np.float32)
    beams = np.array([[b, e] for e in (-20.0, 0.0) for b in (0.0, 120.0, 240.0)])
    out = tmp_path / "p3.h5"
    with ProductsWriter(out) as w:
        btr = BTR()
        btr.bind(RunContext(products=w))
        list(btr.process(power_blocks(p, 100.0 + np.arange(10), beams, np.arange(4.0))))
    g = read_products(out)["btr"]
    assert np.array_equal(g["elevation_deg"], beams[:, 1])
    png = tmp_path / "b3.png"
    plot_file(str(out), str(png), "btr")
    assert png.stat().st_size > 5_000
