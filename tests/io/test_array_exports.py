"""Labelled products and their NetCDF4/Zarr exports: for every product kind and every column
it declares, ``export --to netcdf|zarr`` then ``xarray.open_dataset`` gives the values
``read_products`` reads, with the dimensions, units and long names of the schema."""

from __future__ import annotations

import numpy as np
import pytest

from arrayproc.app.cli import main
from arrayproc.io.products import ProductsWriter, read_products
from arrayproc.io.schema import KINDS
from arrayproc.io.text import as_text

xr = pytest.importorskip("xarray")
pytest.importorskip("h5netcdf")
pytest.importorskip("zarr")

N_ROWS, SIZES = 5, (3, 4)  # rows, and the sizes of the data-set trailing dimensions


def _values(rng, col, n, axis_sizes):
    shape = (n,) + tuple(t if t is not None else axis_sizes[i]
                         for i, t in enumerate(col.trailing))
    if col.dtype == "bool":
        return rng.random(shape) > 0.5
    if col.dtype.startswith("S"):
        return np.array([f"w{i}".encode() for i in rng.integers(0, 9, n)], col.dtype)
    if col.dtype.startswith("i"):
        return rng.integers(-3, 100, shape).astype(col.dtype)
    return rng.standard_normal(shape).astype(col.dtype)


def _every_kind(path, rng, units="Pa"):
    """One group per declared kind with every column (required and optional) and axis."""
    with ProductsWriter(path, source="rec.h5", chain="[input]\nblock = 1\n") as w:
        w.set_units(units)
        for k in KINDS.values():
            g = w.group(f"g_{k.name}", k.name, beam_mode="cone")
            sizes = {"cone_deg": SIZES[0], "bearing_deg": SIZES[0], "elevation_deg": SIZES[0],
                     "freq": SIZES[1], "range_rate_mps": SIZES[0], "range_m": SIZES[1]}
            for a, col in k.axes.items():
                if a == "bearing_deg":  # one beam axis: cone angles
                    continue
                if a in sizes:
                    g.set(a, np.sort(rng.random(sizes[a])) * 100)
                else:  # a table axis (delay_peaks' channel pairs)
                    g.set(a, _values(rng, col, SIZES[0], SIZES))
            g.append(**{c: _values(rng, col, N_ROWS, SIZES) for c, col in k.columns.items()})
        w.group("empty_bearings", "bearings")  # a stage that found nothing
    return path


@pytest.fixture(scope="module")
def products(tmp_path_factory):
    return _every_kind(tmp_path_factory.mktemp("p") / "p.h5", np.random.default_rng(7))


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind in "SO" or b.dtype.kind in "SOU":
        a = np.array([as_text(x) for x in a.reshape(-1)]).reshape(a.shape)
        b = np.array([as_text(x) for x in b.reshape(-1)]).reshape(b.shape)
        return a.shape == b.shape and bool(np.all(a == b))
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("to,engine", [("netcdf", "h5netcdf"), ("zarr", "zarr")])
def test_export_round_trips_every_kind(products, tmp_path, to, engine, capsys):
    out = tmp_path / ("p.nc" if to == "netcdf" else "p.zarr")
    assert main(["export", str(products), "--to", to, "-o", str(out), "-q"]) == 0
    assert capsys.readouterr().out == ""
    ref = read_products(products)
    root = xr.open_dataset(out, engine=engine)
    assert list(root.attrs["groups"]) == [n for n in ref if n != "/"]
    assert root.attrs["units"] == "Pa" and root.attrs["source"] == "rec.h5"
    checked = set()
    for name, g in ref.items():
        if name == "/":
            continue
        with xr.open_dataset(out, group=name, engine=engine) as ds:
            assert ds.attrs["kind"] == g.kind
            k = KINDS[g.kind]
            for col, v in g.items():
                if col in ("kind", "stage", "attrs"):
                    continue
                assert col in ds.variables, (name, col)
                assert _same(ds[col].values, v), (name, col)
                decl = k.columns.get(col) or k.axes[col]
                assert ds[col].attrs["long_name"] == decl.long_name
                checked.add((g.kind, col))
    declared = {(k.name, c) for k in KINDS.values() for c in (*k.columns, *k.axes)
                if c != "bearing_deg"}
    assert declared <= checked  # every column of every kind went through


def test_dimensions_and_units_come_from_the_schema(products):
    from arrayproc.io.labelled import open_products
    with open_products(products, lazy=True) as p:
        lofar = p["g_lofar"]
        assert lofar.power_db.dims == ("time", "cone_deg", "freq")
        assert lofar.freq.attrs["units"] == "Hz"
        assert p["g_power"].power_db.dims == ("time", "channel")
        assert p["g_power"].power_db.attrs["units"] == "dB re 1 µPa"
        assert p["g_range_doppler"].level_db.dims == ("obs", "range_rate_mps", "range_m")
        assert p["g_btr"].power_db.chunks is not None  # lazy: a dask array
        np.testing.assert_array_equal(p["g_btr"].power_db.values,
                                      read_products(products)["g_btr"]["power_db"])
        tma = p["g_tma"]  # a table: a DataFrame, matrices one per row
        assert tma.shape[0] == N_ROWS and tma["cov"].iloc[0].shape == (4, 4)
        assert tma.attrs["units"]["x"] == "m"
        assert set(p["empty_bearings"].columns) == set(KINDS["bearings"].required())
        assert len(p["empty_bearings"]) == 0
    with open_products(products, tables="xarray") as p:
        assert p["g_tracks"].cov.dims == ("obs", "state_i", "state_j")
        assert list(p["g_tracks"].state_i.values) == ["x", "y", "vx", "vy"]


def test_full_scale_levels_say_so(tmp_path):
    from arrayproc.io.labelled import open_products
    path = _every_kind(tmp_path / "fs.h5", np.random.default_rng(1), units="FS")
    with open_products(path) as p:
        assert p["g_power"].power_db.attrs["units"] == "dB re FS"
        assert p["g_bearings"].attrs["units"]["level_db"] == "dB re FS"


def test_export_refuses_a_non_products_file_in_one_line(tmp_path, capsys):
    bad = tmp_path / "x.h5"
    bad.write_bytes(b"nope")
    assert main(["export", str(bad), "--to", "netcdf", "-o", str(tmp_path / "x.nc")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("arrayproc: error:") and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.h5"]


def test_zarr_export_replaces_a_store_but_not_another_directory(tmp_path, capsys):
    products = tmp_path / "one.h5"
    with ProductsWriter(products) as w:
        w.group("power", "power").append(time=np.arange(2.0), power_db=np.zeros((2, 3)))
    out = tmp_path / "p.zarr"
    assert main(["export", str(products), "--to", "zarr", "-o", str(out), "-q"]) == 0
    assert main(["export", str(products), "--to", "zarr", "-o", str(out), "-q"]) == 0
    other = tmp_path / "photos"
    other.mkdir()
    assert main(["export", str(products), "--to", "zarr", "-o", str(other)]) == 2
    assert "not a Zarr store" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.h5", "p.zarr", "photos"]


def test_recording_as_xarray(tmp_path, rng):
    from arrayproc.io.labelled import open_recording
    from arrayproc.io.recording import Recording, RecordingWriter
    path = tmp_path / "r.h5"
    pos = np.zeros((3, 3))
    pos[:, 0] = [0.0, -1.0, -2.0]
    x = rng.standard_normal((1000, 3)).astype(np.float32)
    with RecordingWriter(path, 500.0, 3, positions=pos) as w:
        w.append(x)
        w.set_array(gains=np.array([1.0, 2.0, 1.0]), dead=np.array([False, False, True]))
    ds = open_recording(path)
    assert ds.time_data.dims == ("time", "channel") and ds.time_data.attrs["units"] == "Pa"
    assert list(ds.channel.values) == [0, 1] and list(ds.x.values) == [0.0, -1.0]
    assert ds.time.values[2] == pytest.approx(2 / 500.0)
    with Recording(path) as r:
        np.testing.assert_array_equal(ds.time_data.isel(time=slice(100, 201)).values,
                                      r.read(100, 201))
        assert ds.time_data.sel(time=0.3, method="nearest").values.shape == (2,)
        np.testing.assert_array_equal(ds.time_data.sel(time=0.3, method="nearest").values,
                                      r.read(150, 151)[0])
