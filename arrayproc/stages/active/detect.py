"""``cfar``: CFAR detection on the matched-filter bank's output, clustering into contacts, and
the ``contacts`` product (DESIGN section 5) with absolute Doppler (thesis eq. (4.9)).

Per beam of each ``matched_filter`` block the square-law plane (range-rate channels x lags) goes
through the CFAR of :mod:`arrayproc.stages.active.cfar` (CA, GO, SO or OS; 1-D along range when
the Doppler ``guard``/``train`` are 0, else 2-D over range x Doppler; threshold from ``pfa`` by
the closed forms). Adjacent cells form one cluster, whose peak lag and range rate are
interpolated. At the end of a ping, clusters from all beams are merged
(one echo shows on several beams, through the array's main lobe, side lobes and, above the
design frequency, grating lobes: greedy non-maximum suppression on the peak power, within
``merge_range_m`` of bistatic path / 2 and ``merge_cone_deg``) and written as ``contacts``
rows:

- ``time``: echo reception time t_p + tau, s; ``ping``; ``waveform`` (name, bytes);
- ``range_m``: from the bistatic path c tau and the projector offset
  (:func:`arrayproc.stages.active.contacts.bistatic_range`); ``cone_deg`` (beam axis);
  ``bearing_port_deg`` / ``bearing_stbd_deg`` = heading -/+ cone;
- ``range_rate_mps`` (positive opening) and ``absolute_doppler_mps`` = rdot + U cos(cone)
  (eq. (4.9) in the opening-positive convention, U the array's speed at the ping);
  ``moving`` = |absolute Doppler| > ``moving_threshold`` (knots, default 2 as the thesis);
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
from .contacts import absolute_doppler, bearings, bistatic_range, merge

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
        "min_range_m": Param("float", 100.0, "contacts nearer than this are dropped, m"),
        "moving_threshold": Param("float", 2.0, "|absolute Doppler| above which a contact is "
                                  "moving, knots"),
        "merge_range_m": Param("float", 0.0, "merge gate in range, m (0: 4 range cells c/(2B))"),
        "merge_cone_deg": Param("float", 180.0, "merge gate in cone angle, deg (180: any "
                                "beam, which also folds grating and side lobes)"),
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
        finally:
            if pool is not None:
                pool.shutdown()

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
        # one echo, one lag on every beam: merge on the path c tau (range depends on the cone
        # through the projector offset), strongest peak first (equal noise on every beam)
        keep = merge(c * tau, cone, peak, 2 * gate, self.merge_cone_deg)
        cone, tau, rate, snr, rng = cone[keep], tau[keep], rate[keep], snr[keep], rng[keep]
        absd = absolute_doppler(rate, cone, pm.speed)
        port, stbd = bearings(pm.heading, cone)
        moving = np.abs(absd) > self.moving_threshold * KNOT
        if cm.insensitive(m["kind"]):
            moving[:] = False
        n = rng.size
        return {"time": b.t0 + tau, "ping": np.full(n, pm.ping, np.int64), "range_m": rng,
                "cone_deg": cone, "bearing_port_deg": port, "bearing_stbd_deg": stbd,
                "range_rate_mps": rate, "absolute_doppler_mps": absd, "snr_db": snr,
                "moving": moving, "waveform": np.full(n, str(pm.waveform).encode(), "S32"),
                "cells": np.full(n, cells, np.int64)}
