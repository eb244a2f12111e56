"""The ``nb_ekf`` stage behind the ``dft_filter`` stage: automatic start, products rows, key
checks."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.chain import Block, Pose, RunContext
from arrayproc.chain.domains import Domain, TimeMeta
from arrayproc.errors import ConfigError
from arrayproc.stages.condition.dft_filter import DFTFilter
from arrayproc.stages.narrowband.nb_ekf import NarrowbandEKFStage

from .synth import line, tonal

FS = 5120.0
X = line()
POS = np.stack([X, np.zeros_like(X), np.zeros_like(X)], axis=1)


class _Rows:
    def __init__(self):
        self.cols: dict[str, list] = {}

    def append(self, **cols):
        for k, v in cols.items():
            self.cols.setdefault(k, []).append(np.asarray(v))


class _Products:
    def __init__(self):
        self.groups: dict[str, _Rows] = {}
        self.kinds: dict[str, str] = {}

    def group(self, name, kind, stage=None, **attrs):
        self.kinds[name] = kind
        return self.groups.setdefault(name, _Rows())


def _blocks(dur=24.0, cone=65.0, speed=2.5, snr_db=-10.0, block_s=2.0):
    t = np.arange(int(dur * FS)) / FS
    y = tonal(t, X, cone, 697.0, speed, snr_db, seed=21).astype(np.float32)
    pose = Pose(np.zeros(2), 90.0, 0.0, speed, POS)
    n = int(block_s * FS)
    for i in range(0, t.size, n):
        yield Block(y[i:i + n], Domain.TIME, i / FS, y[i:i + n].shape[0] / FS, FS, POS,
                    pose, meta=TimeMeta(i, y[i:i + n].shape[0]))


@pytest.mark.parametrize("cplx", [True, False])
def test_stage_auto_start_and_rows(cplx):
    filt = DFTFilter(band=[677.0, 717.0], taper=0.2, decimate=64 if cplx else 3, complex=cplx)
    stage = NarrowbandEKFStage(output_rate=5.0, reinit_s=10.0)
    prod = _Products()
    stage.bind(RunContext(products=prod, sound_speed=1500.0, log=lambda m: None))
    n_in = sum(b.data.shape[0] for b in stage.process(filt.process(_blocks())))
    assert n_in > 0
    cone0, f0 = stage.start_values
    assert abs(cone0 - 65.0) < 0.5 and abs(f0 - 697.0) < 0.2
    assert prod.kinds == {"nb_ekf": "nb_tracks"}
    rows = {k: np.concatenate(v) for k, v in prod.groups["nb_ekf"].cols.items()}
    assert set(rows) == {"time", "cone_deg", "freq_hz", "sigma_cone_deg", "sigma_freq_hz",
                         "filter"}
    fs_out = FS / (64 if cplx else 3)
    assert np.all(np.abs(np.diff(rows["time"]) - 0.2) <= 1.0 / fs_out + 1e-9)
    assert rows["time"].size == 120
    late = rows["time"] > 8.0
    assert np.max(np.abs(rows["cone_deg"][late] - 65.0)) < 0.15
    assert np.max(np.abs(rows["freq_hz"][late] - 697.0)) < 0.1
    assert set(np.unique(rows["filter"])) == {0, 1}


def test_stage_writes_cbf_baseline():
    """``baseline = true`` adds group '<name>_cbf' of kind nb_tracks (filter -1) on the same
    output grid, within the fine-beam fan of the truth."""
    filt = DFTFilter(band=[677.0, 717.0], taper=0.2, decimate=64, complex=True)
    stage = NarrowbandEKFStage(name="nb", output_rate=5.0, baseline=True)
    prod = _Products()
    stage.bind(RunContext(products=prod, sound_speed=1500.0, log=lambda m: None))
    for _ in stage.process(filt.process(_blocks(dur=14.0))):
        pass
    assert prod.kinds == {"nb": "nb_tracks", "nb_cbf": "nb_tracks"}
    kal = {k: np.concatenate(v) for k, v in prod.groups["nb"].cols.items()}
    cbf = {k: np.concatenate(v) for k, v in prod.groups["nb_cbf"].cols.items()}
    np.testing.assert_allclose(cbf["time"], kal["time"])
    assert np.all(cbf["filter"] == -1)
    assert np.all(np.isnan(cbf["sigma_cone_deg"]))
    assert np.percentile(np.abs(cbf["cone_deg"] - 65.0), 90) < 1.0
    assert np.max(np.abs(cbf["freq_hz"] - 697.0)) < 0.3


@pytest.mark.parametrize("key, value", [("cone", 200.0), ("cone", "left"), ("freq", -1.0),
                                        ("noise", 0.0), ("reinit_s", 0.0),
                                        ("output_rate", -1.0), ("colour", 1)])
def test_bad_keys_name_the_key(key, value):
    with pytest.raises(ConfigError, match=key):
        NarrowbandEKFStage(**{key: value})


def test_not_a_line_array():
    pos = POS.copy()
    pos[3, 1] = 0.5
    b = Block(np.zeros((400, 64), np.complex64), Domain.TIME, 0.0, 5.0, 80.0, pos,
              meta=TimeMeta(0, 400, 697.5))
    stage = NarrowbandEKFStage(cone=60.0, freq=697.0)
    with pytest.raises(ConfigError, match="line array"):
        list(stage.process(iter([b])))
