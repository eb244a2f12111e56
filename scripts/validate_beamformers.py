"""Adaptive, subspace and port/starboard beamformers against closed forms: the numbers of
docs/results/validate_beamformers.json.

Parts (``--parts``, comma separated; all by default):

- ``resolution``: two independent broadband sources half a CBF beamwidth apart (N = 32,
  0.75 m, 800-1000 Hz, K = 64 snapshots per estimate, ``--groups`` estimates per SNR); the
  fraction of estimates in which MVDR (default loading), MUSIC (2 sources) and CBF show both
  peaks each within 0.3° of the truth, per element SNR −10 … 20 dB; the SNR at which half are
  resolved against the closed form for MVDR with the exact covariance (Woodbury; midpoint
  criterion: P(mid) < ½ (P(θ1) + P(θ2)) of the band-summed spectrum);
- ``wng``: MVDR white-noise gain and array gain against loading for an exact covariance (20 dB
  interferer 1.5° from the look, inside the main lobe) from the stage, against
  Sherman-Morrison; robustness to element position errors σ = 0.05 λ (at 900 Hz): the level
  of a 20 dB source at 60° in its own beam relative to its true CBF-scale level (signal
  self-nulling), with and without loading and with the WNG constraint;
- ``crb``: root-MUSIC RMSE against the stochastic CRB (Stoica & Nehorai 1990) over SNR, for
  one and two sources (N = 12, K = 100, ``--trials``);
- ``lr``: port/starboard rejection of twin and triplet arrays against kd, measured against
  the closed forms (delay-and-sum, cardioid with the WNG-loss cap);
- ``e2e`` (not in the default set): the simulated triplet recording of the end-to-end test,
  its BTR rejection against the closed form at the measured SNR;

and a figure per part in ``--out``.

    PYTHONPATH=. .venv/bin/python scripts/validate_beamformers.py --out OUT --json OUT/b.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from arrayproc.evaluate.scenarios.beamformers import (  # noqa: E402
    closed_form,
    exact_cov,
    rejection_closed_form,
    resolved,
    rmse_ratio,
    source_spectra,
)
from arrayproc.io.geometry import line_array, triplet_array, twin_line_array  # noqa: E402
from arrayproc.sim import snapshot_spectra as syn  # noqa: E402
from arrayproc.stages.beamform.lr_cbf import LRCBF, mirror_correlation, null_depth  # noqa: E402
from arrayproc.stages.beamform.music import MUSIC  # noqa: E402
from arrayproc.stages.beamform.mvdr import MVDR  # noqa: E402

C = syn.C
N, DX = 32, 0.75
FREQS = np.arange(800.0, 1000.1, 5.0)
BW = float(np.rad2deg(0.886 * C / (900.0 * N * DX)))
TRUTH = [90.0 - BW / 4, 90.0 + BW / 4]
LOADING = 0.01


def _cone_dirs(cones: np.ndarray) -> np.ndarray:
    d = np.zeros((len(cones), 3))
    d[:, 0] = np.cos(np.deg2rad(cones))
    return d


def mvdr_exact_broadband(snr_db: float, cones: np.ndarray, loading: float) -> np.ndarray:
    """Band-summed Capon estimate N²/a^H (R + δI)⁻¹ a for the exact covariance R = I +
    s (v1 v1^H + v2 v2^H), δ = loading·tr(R)/N (as the stage), by Woodbury:
    (R+δI)⁻¹ = [I − V (σ'²/s I + V^H V)⁻¹ V^H]/σ'², σ'² = 1 + δ."""
    pos = line_array(N, DX)
    s = 10 ** (snr_db / 10)
    delta = loading * (1 + 2 * s)
    sig = 1 + delta
    total = np.zeros(cones.size)
    for f in FREQS:
        fr = np.array([f])
        v = np.stack([syn.steer(pos, c, fr)[0] for c in TRUTH], 1)  # (N, 2)
        a = np.stack([syn.steer(pos, c, fr)[0] for c in cones], 1)  # (N, B)
        g = v.conj().T @ v
        b = v.conj().T @ a
        inner = np.linalg.solve(sig / s * np.eye(2) + g, b)
        form = (N - np.einsum("ib,ib->b", b.conj(), inner).real) / sig
        total += N * N / form
    return total


def mvdr_threshold(loading: float) -> float:
    """Per-element SNR (dB) above which the exact-covariance MVDR resolves (midpoint test)."""
    cones = np.array([TRUTH[0], 90.0, TRUTH[1]])

    def dip(snr_db: float) -> float:
        p = mvdr_exact_broadband(snr_db, cones, loading)
        return 0.5 * (p[0] + p[2]) - p[1]  # > 0: resolved

    return float(brentq(dip, -30.0, 40.0, xtol=1e-3))


def part_resolution(groups: int, rng: np.random.Generator,
                    snrs: np.ndarray | None = None) -> dict:
    pos = line_array(N, DX)
    snrs = np.arange(-10.0, 20.1, 2.5) if snrs is None else np.asarray(snrs, float)
    out: dict = {"snr_db": snrs.tolist(), "truth_deg": TRUTH, "cbf_width_deg": BW,
                 "groups": groups, "snapshots": 64}
    rates: dict[str, list[float]] = {"mvdr": [], "music": [], "cbf": []}
    beams = {"start": 84.0, "stop": 96.0, "count": 241}
    for snr in snrs:
        x = syn.spectra(pos, FREQS, TRUTH, snr, groups * 64, rng)
        mv = MVDR(beams=beams, snapshots=64, output="broadband", loading=LOADING)
        mu = MUSIC(beams=beams, snapshots=64, sources=2, output="broadband")
        p_mv = [o.data[0, 0] for o in mv.process(syn.blocks(x, FREQS, pos))]
        p_mu = [o.data[0, 0] for o in mu.process(syn.blocks(x, FREQS, pos))]
        p_cb = []
        for g in range(groups):
            xs = x[g * 64:(g + 1) * 64]
            r = np.einsum("kfc,kfd->fcd", xs, xs.conj()) / 64
            p_cb.append(mv.steering.form(r).sum(0))
        axis = mv.beam_axis
        rates["mvdr"].append(float(np.mean([resolved(p, axis, TRUTH) for p in p_mv])))
        rates["music"].append(float(np.mean([resolved(p, axis, TRUTH) for p in p_mu])))
        rates["cbf"].append(float(np.mean([resolved(p, axis, TRUTH) for p in p_cb])))
    out["resolved_fraction"] = rates

    def half(r: list[float]) -> float | None:
        r = np.asarray(r)
        above = np.flatnonzero(r >= 0.5)
        if not above.size:
            return None
        k = above[0]
        if k == 0:
            return float(snrs[0])
        return float(np.interp(0.5, [r[k - 1], r[k]], [snrs[k - 1], snrs[k]]))

    out["measured_50pct_snr_db"] = {k: half(v) for k, v in rates.items()}
    out["mvdr_closed_form_threshold_db"] = {"loading_0.01": mvdr_threshold(LOADING),
                                           "unloaded": mvdr_threshold(0.0)}
    return out


def part_wng(rng: np.random.Generator) -> dict:
    pos = line_array(N, DX)
    f = 900.0
    r, v, s2 = exact_cov(pos, f, 91.5, 20.0)
    a = syn.steer(pos, 90.0, np.array([f]))[0]
    rows = []
    for eps in (0.0, 1e-3, 0.01, 0.1, 1.0, 10.0, 100.0):
        d = eps * np.trace(r).real / N
        _, wng, outp = closed_form(a, v, s2, 1.0, d)
        st = MVDR(beams={"start": 90.0, "stop": 90.0, "count": 1}, loading=eps, power="output")
        st.prepare(pos, np.array([f]))
        got = st.spectrum(r[None], slice(0, 1))[0, 0] / N**2
        w = wng_of_loading(MVDR(beams={"start": 90.0, "stop": 90.0, "count": 1}, loading=eps,
                                wng_db=-30.0), pos, f, r)
        rows.append({"loading": eps, "wng_db_closed": 10 * np.log10(wng),
                     "wng_db_stage": 10 * np.log10(w), "ag_db_closed": 10 * np.log10(
                         (1 + s2) / outp), "ag_db_stage": 10 * np.log10((1 + s2) / got)})
    out: dict = {"interferer": {"cone_deg": 91.5, "inr_db": 20.0}, "look_deg": 90.0,
                 "rows": rows, "wng_max_db": 10 * np.log10(N),
                 "cbf_ag_db": 10 * np.log10((1 + s2) * N * N / (N + s2 * abs(np.vdot(v, a))**2))}
    out["position_errors"] = robustness(rng)
    return out


def robustness(rng: np.random.Generator, trials: int = 20) -> dict:
    """Level of a 20 dB source at cone 60° (plus a 30 dB interferer at 75°) in its own beam,
    relative to its true CBF-scale level N² s, when the elements sit off their nominal
    positions by Gaussian errors σ = 0.05 λ along the axis (λ at 900 Hz; phase errors
    2π σ cos 60°/λ = 0.16 rad rms), K = 256 snapshots; mean and worst over ``trials`` draws,
    and the mean without errors."""
    pos = line_array(N, DX)
    lam = C / 900.0
    fr = np.array([900.0])
    cases = {"loading 0": dict(loading=0.0), "loading 0.01": dict(loading=0.01),
             "loading 0.1": dict(loading=0.1), "loading 1": dict(loading=1.0),
             "wng >= 12 dB": dict(loading=0.0, wng_db=12.0)}
    res: dict = {k: [] for k in cases}
    res_ideal: dict = {k: [] for k in cases}
    for _ in range(trials):
        for err, store in ((0.05 * lam, res), (0.0, res_ideal)):
            true = pos.copy()
            true[:, 0] += rng.normal(0, err, N) if err else 0.0
            x = syn.spectra(true, fr, [60.0], 20.0, 256, rng)
            g = (rng.standard_normal((256, 1)) + 1j * rng.standard_normal((256, 1))) / np.sqrt(2)
            x += 10 ** 1.5 * g[..., None] * syn.steer(true, 75.0, fr)[None]  # 30 dB
            for name, kw in cases.items():
                st = MVDR(beams={"start": 60.0, "stop": 60.0, "count": 1}, snapshots=256,
                          **kw)
                p = next(iter(st.process(syn.blocks(x, fr, pos, per_block=256)))).data[0, 0, 0]
                store[name].append(10 * np.log10(p / (N * N * 100.0)))
    return {"sigma_over_lambda": 0.05, "trials": trials, "source": [60.0, 20.0],
            "interferer": [75.0, 30.0],
            "level_re_true_db": {k: {"mean": float(np.mean(v)), "worst": float(np.min(v)),
                                     "no_errors_mean": float(np.mean(res_ideal[k]))}
                                 for k, v in res.items()}}


def wng_of_loading(st: MVDR, pos: np.ndarray, f: float, r: np.ndarray) -> float:
    """Linear WNG of the stage's loaded weights, through its eigen path with a floor so low
    (−30 dB) that the fixed loading alone applies."""
    st.prepare(pos, np.array([f]))
    sigma = np.real(np.trace(r)) / N
    _, _, w = st._wng_power(r[None], np.array([st.loading * sigma]), slice(0, 1))
    return float(w[0, 0])


def part_crb(trials: int) -> dict:
    pos = line_array(12, DX)
    out: dict = {"n": 12, "snapshots": 100, "trials": trials, "rows": []}
    for cones in ([70.0], [84.0, 96.0]):
        for snr in (-5.0, 0.0, 5.0, 10.0, 20.0):
            ratio = rmse_ratio(pos, 900.0, cones, snr, 100, trials, seed=int(snr * 10 + 100))
            out["rows"].append({"cones": cones, "snr_db": snr,
                                "rmse_over_crb": [float(v) for v in ratio]})
    return out


def part_lr(rng: np.random.Generator) -> dict:
    out: dict = {"beta_deg": 60.0, "snr_db_per_element": 0.0, "rows": []}
    freqs = np.arange(100.0, 2000.1, 150.0)
    beams = {"start": -179.0, "stop": 180.0, "count": 360}
    for geometry in ("twin", "triplet"):
        pos = (twin_line_array(16, 0.75, 0.2) if geometry == "twin"
               else triplet_array(12, 0.75, 0.115))
        d = 0.2 if geometry == "twin" else np.sqrt(3) * 0.115
        n = pos.shape[0]
        x = source_spectra(pos, freqs, 60.0, 1.0, 1000, rng)
        q = np.abs(mirror_correlation(pos, np.array([60.0]), freqs, C)[:, 0]) ** 2
        for weights, loss in (("das", 10.0), ("cardioid", 10.0), ("cardioid", 60.0)):
            st = LRCBF(weights=weights, beams=beams, wng_loss_db=loss)
            y = np.concatenate([o.data for o in st.process(syn.blocks(x, freqs, pos, 250))])
            p = (np.abs(y) ** 2).mean(axis=0)
            look = np.argmin(np.abs(st.beam_axis - 60.0))
            mirror = np.argmin(np.abs(st.beam_axis + 60.0))
            got = 10 * np.log10(p[:, look] / p[:, mirror])
            gamma = (np.zeros_like(q) if weights == "das"
                     else null_depth(q, n, 10 * np.log10(n) - loss))
            want = rejection_closed_form(n, q, 1.0, gamma)
            out["rows"].append({"geometry": geometry, "weights": weights,
                                "wng_loss_db": loss, "kd": (2 * np.pi * freqs * d / C).tolist(),
                                "measured_db": got.tolist(), "closed_form_db": want.tolist(),
                                "max_abs_err_db": float(np.max(np.abs(got - want)))})
    return out


def part_e2e(out: Path) -> dict:
    """The triplet end-to-end test's recording (tests/stages/beamform/test_lr_chain.py)
    through lr_cbf → integrate → btr: the BTR rejection of the source (60° starboard) over
    its mirror, against the closed form with the per-element SNR per bin measured on the
    element spectra of the same scenario simulated with and without the source."""
    from arrayproc.chain import build_chain, run_chain
    from arrayproc.chain.block import Block
    from arrayproc.chain.domains import Domain, TimeMeta
    from arrayproc.evaluate.chains import chain_toml
    from arrayproc.evaluate.scenarios.beamformers import LR_TRIPLET_SCENARIO as SCENARIO
    from arrayproc.io.products import ProductsWriter, read_products
    from arrayproc.io.recording import Recording
    from arrayproc.sim.run import simulate_file
    from arrayproc.stages import load_all
    from arrayproc.stages.beamform._common import SpectraFramer

    load_all()  # every stage type, for the chain built below
    band = (800.0, 1200.0)
    recs = {}
    for name, text in (("with", SCENARIO), ("noise", SCENARIO.split("[[source]]")[0])):
        (out / f"e2e_{name}.toml").write_text(text)
        recs[name] = out / f"e2e_{name}.h5"
        simulate_file(out / f"e2e_{name}.toml", recs[name])
    psd = {}
    for name, path in recs.items():
        with Recording(path) as rec:
            x = rec.read()
            pos, fs = rec.positions, rec.fs
        fr = SpectraFramer(1024, 512, "hann", band)
        b = fr.push(Block(x, Domain.TIME, 0.0, x.shape[0] / fs, fs, pos, None,
                          meta=TimeMeta(0, x.shape[0])))
        psd[name] = (np.abs(b.data) ** 2).mean(axis=(0, 2))
        freqs = b.freqs
    snr = psd["with"] / psd["noise"] - 1.0
    spec = build_chain(chain_toml({"type": "lr_cbf", "band": list(band)},
                                  {"type": "integrate", "snapshots": 8}, {"type": "btr"}))
    prod = out / "e2e_p.h5"
    with Recording(recs["with"]) as rec, ProductsWriter(prod, source=str(recs["with"])) as w:
        run_chain(rec, spec, w)
    btr = read_products(prod)["btr"]
    ax = btr["cone_deg"]
    look, mirror = np.argmin(np.abs(ax - 60.0)), np.argmin(np.abs(ax + 60.0))
    got = btr["power_db"][:, look] - btr["power_db"][:, mirror]
    n = pos.shape[0]
    q = np.abs(mirror_correlation(pos, np.array([60.0]), freqs, C)[:, 0]) ** 2
    gamma = null_depth(q, n, 10 * np.log10(n) - 10.0)
    norm = n * (1 - 2 * gamma * q + gamma**2 * q) / (1 - gamma * q) ** 2
    mir = n * n * q * (1 - gamma) ** 2 / (1 - gamma * q) ** 2 * snr
    want = 10 * np.log10(np.sum(n * n * snr + norm) / np.sum(mir + norm))
    return {"snr_db_per_bin_mean": float(10 * np.log10(np.mean(snr))),
            "kd_design": float(2 * np.pi * 1000.0 * np.sqrt(3) * 0.1 / C),
            "btr_rejection_db": {"min": float(got.min()), "median": float(np.median(got)),
                                 "max": float(got.max())},
            "closed_form_db": float(want)}


def figures(res: dict, out: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    if "resolution" in res:
        r = res["resolution"]
        fig, ax = plt.subplots(figsize=(6, 4))
        for k, v in r["resolved_fraction"].items():
            ax.plot(r["snr_db"], v, "o-", label=k.upper())
        for k, v in r["mvdr_closed_form_threshold_db"].items():
            ax.axvline(v, ls="--", color="grey" if k == "unloaded" else "k",
                       label=f"MVDR closed form ({k.replace('_', ' ')})")
        ax.set_xlabel("per-element SNR per bin (dB)")
        ax.set_ylabel("fraction resolved, both within 0.3°")
        ax.set_title("Two sources 0.5 CBF beamwidths apart (N = 32, K = 64)")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(out / "beamformers_resolution.png", dpi=110)
        plt.close(fig)
    if "lr" in res:
        fig, axs = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
        for ax, geometry in zip(axs, ("twin", "triplet"), strict=True):
            for row in res["lr"]["rows"]:
                if row["geometry"] != geometry:
                    continue
                lab = row["weights"] + ("" if row["weights"] == "das"
                                        else f" (loss cap {row['wng_loss_db']:g} dB)")
                ln, = ax.plot(row["kd"], row["closed_form_db"], "-", label=lab + ", closed form")
                ax.plot(row["kd"], row["measured_db"], "o", color=ln.get_color(),
                        label=lab + ", measured")
            ax.set_xlabel("kd (cross-axis aperture, rad)")
            ax.set_title(f"{geometry}: source at 60° starboard, 0 dB per element")
            ax.grid(alpha=0.3)
        axs[0].set_ylabel("look over mirror beam power (dB)")
        axs[0].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "beamformers_lr_rejection.png", dpi=110)
        plt.close(fig)
    if "crb" in res:
        fig, ax = plt.subplots(figsize=(6, 4))
        for lab, cones in (("one source", [70.0]), ("two sources", [84.0, 96.0])):
            rows = [r for r in res["crb"]["rows"] if r["cones"] == cones]
            ax.plot([r["snr_db"] for r in rows], [max(r["rmse_over_crb"]) for r in rows], "o-",
                    label=lab)
        ax.axhline(1.0, color="k", ls="--", label="CRB")
        ax.set_xlabel("per-element SNR (dB)")
        ax.set_ylabel("root-MUSIC RMSE / √CRB (worst source)")
        ax.set_title("MUSIC against the stochastic CRB (N = 12, K = 100)")
        ax.legend()
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(out / "beamformers_crb.png", dpi=110)
        plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--parts", default="resolution,wng,crb,lr")
    ap.add_argument("--groups", type=int, default=50)
    ap.add_argument("--trials", type=int, default=500)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--snr", help="comma-separated SNRs (dB) of the resolution part "
                    "(default −10 … 20 every 2.5)")
    ap.add_argument("--out", default=".")
    ap.add_argument("--json")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    res: dict = {}
    parts = args.parts.split(",")
    if "resolution" in parts:
        snrs = None if args.snr is None else [float(v) for v in args.snr.split(",")]
        res["resolution"] = part_resolution(args.groups, rng, snrs)
    if "wng" in parts:
        res["wng"] = part_wng(rng)
    if "crb" in parts:
        res["crb"] = part_crb(args.trials)
    if "lr" in parts:
        res["lr"] = part_lr(rng)
    if "e2e" in parts:
        res["e2e"] = part_e2e(out)
    figures(res, out)
    text = json.dumps(res, indent=1, default=float)
    print(text)
    if args.json:
        Path(args.json).write_text(text)


if __name__ == "__main__":
    main()
