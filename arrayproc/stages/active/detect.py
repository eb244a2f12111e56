"""``cfar``: CFAR detection on the matched-filter bank's output, clustering into contacts, and
the ``contacts`` product (docs/formats.md) with absolute Doppler (thesis eq. (4.9)).

Per beam of each ``matched_filter`` block the square-law plane (range-rate channels x lags) goes
through the CFAR of :mod:`arrayproc.stages.active.cfar` (CA, GO, SO or OS; 1-D along range when
the Doppler ``guard``/``train`` are 0, else 2-D over range x Doppler; threshold from ``pfa`` by
the closed forms). Adjacent cells form one cluster, whose peak lag and range rate are
interpolated. At the end of a ping, clusters from all beams are merged
(one echo shows on several beams, through the array's main lobe, side lobes and, above the
design frequency, grating lobes: greedy non-maximum suppression on the peak power, within
``merge_range_m`` of bistatic path / 2 and ``merge_cone_deg``; a candidate whose range rate
differs by more than ``merge_rate_mps`` from the kept one's is another echo, dropped only
if the kept one has at least its SNR: otherwise a false alarm on a beam loud with the
direct blast removes an echo on a quiet beam) and written as ``contacts`` rows:

- ``time``: echo reception time t_p + tau, s; ``ping``; ``waveform`` (name, bytes);
- ``range_m``: from the bistatic path c tau and the projector offset
  (:func:`arrayproc.stages.active.contacts.bistatic_range`); ``cone_deg`` (beam axis);
  ``bearing_port_deg`` / ``bearing_stbd_deg`` = heading -/+ cone, with the array's heading
  at the echo's reception (``/nav`` of the recording at the echo's middle, t_p + tau + T/2:
  the beams are formed on the array as it lies while the echo arrives, and the matched
  filter integrates over the pulse length T; without a recording, the heading at the
  transmission);
- ``range_rate_mps`` (positive opening); ``absolute_doppler_port_mps`` /
  ``absolute_doppler_stbd_mps`` = rdot + own closing (eq. (4.9) in the opening-positive
  convention) if the scatterer is to port / starboard: the array's leg with its speed at the
  reception, the projector's with the speed, heading and heading rate of the transmission
  (:func:`arrayproc.stages.active.contacts.ownship_closing_sides`; both rdot + U cos(cone)
  on a straight leg); ``absolute_doppler_mps`` their mean; ``moving`` = the smaller of the
  two magnitudes > ``moving_threshold`` (knots, default 2 as the thesis): still on neither
  side;
- ``snr_db``: peak over the CFAR's noise estimate, dB.

A Doppler-insensitive ping's contacts carry range rate 0 and absolute Doppler U cos(cone)
(not a measurement; ``moving`` is false). Each ping's contacts are also posted for a
``matched_filter`` stage in bracket mode. Blocks out: one per ping, domain ``CONTACTS``, with
the ping's PingMeta whose ``extra["contacts"]`` holds the rows and ``extra["cells"]`` the
cells the matched filter computed for the ping (also the ``cells`` column).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from arrayproc.chain import Block, Param, Stage, register
from arrayproc.chain.domains import Domain, PingMeta
from arrayproc.errors import ConfigError

from . import _common as cm
from .cfar import CfarConfig, cluster, detect
from .contacts import bearings, bistatic_range, merge, ownship_closing_sides

KNOT = 1852.0 / 3600.0


def _pair(v, where: str, key: str) -> tuple[int, int]:
    if isinstance(v, int) and not isinstance(v, bool):
        return int(v), 0
    if (isinstance(v, (list, tuple)) and len(v) == 2
            and all(isinstance(x, int) and not isinstance(x, bool) for x in v)):
        return int(v[0]), int(v[1])
    raise ConfigError(f"{where}: key {key!r} must be an integer (range cells) or [range, "
                      f"doppler] cells, got {v!r}")


@register
class Cfar(Stage):
    """CFAR, clustering and contacts (see module doc)."""

    kind = "cfar"
    accepts = frozenset({Domain.RANGE_DOPPLER})
    produces = Domain.CONTACTS
    params = {
        "method": Param("str", "ca", "CFAR: ca, go, so or os", choices=("ca", "go", "so", "os")),
        "pfa": Param("float", 1e-6, "design false-alarm probability per cell"),
        "guard": Param("any", [4, 0], "guard cells each side: range, or [range, doppler]"),
        "train": Param("any", [16, 0], "training cells each side: range, or [range, doppler]"),
        "os_quantile": Param("float", 0.75, "OS rank k = round(q N)"),
        "min_range_m": Param("float", 100.0, "contacts nearer than this are dropped, m", unit="m"),
        "moving_threshold": Param("float", 2.0, "|absolute Doppler| above which a contact is "
                                  "moving, knots", unit="kn"),
        "merge_range_m": Param("float", 0.0, "merge gate in range, m (0: 4 range cells c/(2B))",
                               unit="m"),
        "merge_rate_mps": Param("float", 0.0, "range rates closer than this are one echo's, "
                                "m/s (0: 4 steps of the bank's range-rate grid)", unit="m/s"),
        "merge_cone_deg": Param("float", 180.0, "merge gate in cone angle, deg (180: any "
                                "beam, which also folds grating and side lobes)", unit="deg"),
        "threads": Param("int", 0, "threads over the beams of a block (0: all cores)"),
    }

    def validate(self) -> None:
        w = f"stage {self.name!r}"
        g, t = _pair(self.guard, w, "guard"), _pair(self.train, w, "train")
        try:
            self.cfg = CfarConfig(self.method, self.pfa, g, t, self.os_quantile)
        except ConfigError as e:
            raise ConfigError(f"{w}: {str(e).removeprefix('cfar: ')}") from None
        self._tables = self.cfg.tables()

    def _beam(self, plane: np.ndarray) -> list:
        det = detect(plane, self.cfg, tables=self._tables)
        return cluster(det, plane)

    def process(self, blocks: Iterator[Block]) -> Iterator[Block]:
        out = self.products("contacts")
        nthreads = self.threads if self.threads > 0 else (os.cpu_count() or 1)
        pool = ThreadPoolExecutor(nthreads) if nthreads > 1 else None
        cand: list[tuple] = []
        cells = 0
        try:
            for b in blocks:
                pm = b.meta
                m = pm.extra
                planes = [b.data[j] for j in range(b.data.shape[0])]
                res = list(pool.map(self._beam, planes)) if pool else list(map(self._beam,
                                                                               planes))
                rr = m["range_rates"]
                for j, cls in enumerate(res):
                    for cl in cls:
                        rate = float(np.interp(cl.row, np.arange(rr.size), rr))
                        cand.append((m["cones"][j], (cl.col + m["lag0"]) / m["fs_bb"], rate,
                                     10 * np.log10(cl.peak / cl.noise), cl.peak))
                cells += int(m["cells"])
                if m["last"]:
                    rows = self._finish(b, cand, cells)
                    if out is not None and rows["time"].size:
                        out.append(**rows)
                    cm.post(self.ctx, self.name, pm.ping, m["kind"], rows)
                    meta = PingMeta(pm.ping, pm.waveform, pm.t_ping, pm.fc, pm.speed,
                                    pm.heading, pm.projector,
                                    {"contacts": rows, "cells": cells, "kind": m["kind"]})
                    yield Block(np.zeros(rows["time"].size), Domain.CONTACTS, b.t0, b.span,
                                b.fs, b.positions, pose=b.pose, index=b.index, meta=meta)
                    cand, cells = [], 0
                del b, planes, res  # the block's planes go before the next block is made
        finally:
            if pool is not None:
                pool.shutdown()

    def _nav_at(self, t: np.ndarray, pm: PingMeta) -> tuple[np.ndarray, np.ndarray]:
        """Array heading (deg) and speed (m/s) at the reception times ``t`` from the
        recording's navigation; the ping's (transmission) values without a recording."""
        nav = getattr(getattr(self.ctx, "recording", None), "nav", None)
        if nav is None or t.size == 0:
            return np.full(t.size, float(pm.heading)), np.full(t.size, float(pm.speed))
        _, hd, _, spd = nav.at(t)
        return np.asarray(hd, float), np.asarray(spd, float)

    def _turn_rate(self, pm: PingMeta) -> float:
        """Heading rate at the transmission, deg/s (central difference of ``/nav`` over
        +-0.5 s; 0 without a recording)."""
        nav = getattr(getattr(self.ctx, "recording", None), "nav", None)
        if nav is None:
            return 0.0
        _, hd, _, _ = nav.at(np.array([pm.t_ping - 0.5, pm.t_ping + 0.5]))
        return float(np.mod(hd[1] - hd[0] + 180.0, 360.0) - 180.0)

    def _finish(self, b: Block, cand: list, cells: int) -> dict:
        pm = b.meta
        m = pm.extra
        c = self.ctx.sound_speed
        if cand:
            cone, tau, rate, snr, peak = (np.array(v, float) for v in zip(*cand))
        else:
            cone = tau = rate = snr = peak = np.zeros(0)
        rng = bistatic_range(c * tau, cone, pm.projector, pm.speed, c)
        ok = np.isfinite(rng) & (rng >= self.min_range_m)
        cone, tau, rate, snr, rng, peak = (v[ok] for v in (cone, tau, rate, snr, rng, peak))
        gate = self.merge_range_m if self.merge_range_m > 0 else 4 * c / (2 * m["bandwidth"])
        # one echo, one lag and one range rate on every beam: merge on the path c tau (range
        # depends on the cone through the projector offset), strongest peak first; a
        # candidate at another range rate is dropped only by one of at least its SNR
        rr = m["range_rates"]
        rgate = (self.merge_rate_mps if self.merge_rate_mps > 0
                 else 4 * float(np.median(np.diff(rr))) if rr.size > 1 else np.inf)
        keep = merge(c * tau, cone, peak, 2 * gate, self.merge_cone_deg, rate, rgate, snr)
        cone, tau, rate, snr, rng = cone[keep], tau[keep], rate[keep], snr[keep], rng[keep]
        t_rx = b.t0 + tau
        # the beams integrate the echo over its length T: the cone is the one at the echo's
        # middle (a turn at 1 deg/s moves the heading by 2 deg over a 4 s pulse)
        hd_rx, u_rx = self._nav_at(t_rx + 0.5 * float(m.get("duration", 0.0)), pm)
        # eq. (4.9) with the projector's leg at the transmission and the array's at the
        # reception, for either side (contacts.ownship_closing_sides)
        dh = np.mod(hd_rx - pm.heading + 180.0, 360.0) - 180.0
        cl_port, cl_stbd = ownship_closing_sides(cone, pm.speed, u_rx, dh,
                                                 self._turn_rate(pm), pm.projector)
        absd_port, absd_stbd = rate + cl_port, rate + cl_stbd
        absd = 0.5 * (absd_port + absd_stbd)
        port, stbd = bearings(hd_rx, cone)
        # moving: still on neither side (the same as |absd| on a straight leg)
        moving = np.minimum(np.abs(absd_port), np.abs(absd_stbd)) > self.moving_threshold * KNOT
        if cm.insensitive(m["kind"]):
            moving[:] = False
        n = rng.size
        return {"time": t_rx, "ping": np.full(n, pm.ping, np.int64), "range_m": rng,
                "cone_deg": cone, "bearing_port_deg": port, "bearing_stbd_deg": stbd,
                "range_rate_mps": rate, "absolute_doppler_mps": absd,
                "absolute_doppler_port_mps": absd_port,
                "absolute_doppler_stbd_mps": absd_stbd, "snr_db": snr,
                "moving": moving, "waveform": np.full(n, str(pm.waveform).encode(), "S32"),
                "cells": np.full(n, cells, np.int64)}
