"""The hostile-input table: each case builds its bad input in a work directory and
returns the ``arrayproc`` arguments that must fail cleanly (exit 2, one ``arrayproc: error:``
line naming the problem, no traceback, nothing new left, every input byte-identical).

Cases are grouped in classes (``Case.cls``); ``docs/reliability.md`` lists the classes and the
counts that ``tests/app/test_hostile.py`` measures.
"""

from __future__ import annotations

import os
import subprocess
import sys
import wave
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from arrayproc.io.geometry import line_array
from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import RecordingWriter

FS = 1000.0
N_CH = 4

CHAIN = '[input]\nblock = 256\n[[stage]]\ntype = "power"\n'

SCENARIO = """
[recording]
fs = 1024.0
duration = 2.0
sound_speed = 1500.0
seed = 1

[array]
type = "line"
n = 4
spacing = 0.75

[ownship]
start = [0.0, 0.0]
[[ownship.leg]]
course = 90.0
speed_kn = 5.0
duration = 2.0

[[source]]
name = "merchant"
start = [-1500.0, 2600.0]
depth = 5.0
course = 100.0
speed_kn = 12.0
tonals = [{ freq = 148.0, level_db = 150.0 }]

[propagation]
loss = "spherical"

[noise]
level_db = 60.0
"""

TRACKER = """[tracker]
filter = "ukf"
lr = true
model = "cv"
sigma_bearing_deg = 1.0
range_m = 3000.0
sigma_range_m = 1500.0
speed_mps = 5.0
sigma_speed_mps = 3.0
"""


def write_wav(path: Path, n: int = 2000, ch: int = 2, fs: int = 8000) -> Path:
    x = (np.random.default_rng(0).standard_normal((n, ch)) * 3000).astype("<i2")
    with wave.open(str(path), "wb") as w:
        w.setnchannels(ch)
        w.setsampwidth(2)
        w.setframerate(fs)
        w.writeframes(x.tobytes())
    return path


def make_base(d: Path) -> None:
    """The good inputs every case starts from."""
    rng = np.random.default_rng(7)
    x = rng.standard_normal((2048, N_CH)).astype(np.float32)
    nav = dict(time=np.array([0.0, 1.0, 2.0, 3.0]), position=np.zeros((4, 2)),
               heading=np.zeros(4))
    with RecordingWriter(d / "rec.h5", FS, N_CH, positions=line_array(N_CH, 0.5)) as w:
        w.append(x)
        w.set_nav(**nav)
    (d / "chain.toml").write_text(CHAIN)
    (d / "scenario.toml").write_text(SCENARIO)
    (d / "tracker.toml").write_text(TRACKER)
    (d / "geom.csv").write_text("x,y,z\n" + "".join(f"{-0.5 * i},0,0\n" for i in range(N_CH)))
    write_wav(d / "a.wav")
    with ProductsWriter(d / "prod.h5", source="rec.h5") as w:  # relative: beside it
        g = w.group("bearings", "bearings")
        g.append(time=np.arange(5.0), bearing_port_deg=np.full(5, 10.0),
                 bearing_stbd_deg=np.full(5, 170.0), cone_deg=np.full(5, 80.0),
                 snr_db=np.full(5, 10.0), level_db=np.full(5, 100.0),
                 freq_lo=np.full(5, 50.0), freq_hi=np.full(5, 400.0),
                 spl_db=np.full(5, 110.0))
        p = w.group("power", "power")
        p.append(time=np.arange(3.0), power_db=np.zeros((3, N_CH)))


@dataclass
class Case:
    id: str
    cls: str
    setup: Callable[[Path], list[str]]
    match: str = ""  # text the error line must contain
    status: int = 2


CASES: list[Case] = []


def case(cls: str, match: str = "", status: int = 2):
    def deco(f: Callable[[Path], list[str]]) -> Callable[[Path], list[str]]:
        CASES.append(Case(f.__name__, cls, f, match, status))
        return f
    return deco


def process(d: Path, rec: str = "rec.h5", chain: str = "chain.toml", out: str = "out.h5",
            *extra: str) -> list[str]:
    return ["process", str(d / rec), "-c", str(d / chain), "-o", out if out in ("", ".")
            or out.startswith("/") else str(d / out), "--no-progress", *extra]


def chain_text(d: Path, text: str) -> list[str]:
    (d / "bad.toml").write_text(text)
    return process(d, chain="bad.toml")


def edit_h5(d: Path, fn: Callable[[h5py.File], None], name: str = "bad.h5") -> Path:
    p = d / name
    p.write_bytes((d / "rec.h5").read_bytes())
    with h5py.File(p, "r+") as f:
        fn(f)
    return p


def scenario_edit(d: Path, old: str, new: str) -> list[str]:
    assert old in SCENARIO
    (d / "bad.toml").write_text(SCENARIO.replace(old, new))
    return ["simulate", str(d / "bad.toml"), "-o", str(d / "out.h5"), "--no-progress"]


def tracker_text(d: Path, text: str) -> list[str]:
    (d / "bad.toml").write_text(text)
    return ["track", str(d / "prod.h5"), "-c", str(d / "bad.toml"), "-o", str(d / "out.h5"),
            "--no-progress"]


# == 1. an output that is an input ==========
O = "output is an input"


@case(O, "same file as the input")
def process_over_recording(d):
    return process(d, out="rec.h5")


@case(O, "same file as the input")
def process_over_chain(d):
    return process(d, out="chain.toml")


@case(O, "same file as the input")
def process_over_symlink_to_recording(d):
    os.symlink(d / "rec.h5", d / "link.h5")
    return process(d, out="link.h5")


@case(O, "same file as the input")
def process_over_hard_link_to_recording(d):
    os.link(d / "rec.h5", d / "hard.h5")
    return process(d, out="hard.h5")


@case(O, "same file as the input")
def process_over_recording_by_relative_path(d):
    os.mkdir(d / "sub")
    return process(d, out="sub/../rec.h5")


@case(O, "same file as the input")
def process_over_geometry(d):
    return process(d, "rec.h5", "chain.toml", "geom.csv", "--geometry", str(d / "geom.csv"))


@case(O, "same file as the input")
def import_over_wav(d):
    return ["import", str(d / "a.wav"), "-o", str(d / "a.wav")]


@case(O, "same file as the input")
def import_over_geometry(d):
    return ["import", str(d / "a.wav"), "--geometry", str(d / "geom.csv"), "-o",
            str(d / "geom.csv")]


@case(O, "same file as the input")
def simulate_over_scenario(d):
    return ["simulate", str(d / "scenario.toml"), "-o", str(d / "scenario.toml")]


@case(O, "same file as the input")
def track_over_products(d):
    return ["track", str(d / "prod.h5"), "-c", str(d / "tracker.toml"), "-o", str(d / "prod.h5")]


@case(O, "same file as the input")
def track_over_config(d):
    return ["track", str(d / "prod.h5"), "-c", str(d / "tracker.toml"), "-o",
            str(d / "tracker.toml")]


@case(O, "same file as the input")
def track_over_source_recording(d):
    return ["track", str(d / "prod.h5"), "-c", str(d / "tracker.toml"), "-o", str(d / "rec.h5")]


@case(O, "same file as the input")
def plot_over_products(d):
    return ["plot", str(d / "prod.h5"), "-o", str(d / "prod.h5")]


@case(O, "same file as the input")
def plot_over_symlinked_products(d):
    os.symlink(d / "prod.h5", d / "p.png")
    return ["plot", str(d / "prod.h5"), "--kind", "bearings", "-o", str(d / "p.png")]


# == 2. targets that are not regular files ==========
T = "non-regular output"


@case(T, "is a device")
def process_to_dev_null(d):
    return process(d, out="/dev/null")


@case(T, "is a device")
def simulate_to_dev_null(d):
    return ["simulate", str(d / "scenario.toml"), "-o", "/dev/null"]


@case(T, "not a directory")
def process_to_dot(d):
    return process(d, out=".")


@case(T, "output path is empty")
def process_to_empty_string(d):
    return process(d, out="")


@case(T, "is a directory")
def process_to_directory(d):
    os.mkdir(d / "outdir")
    return process(d, out="outdir")


@case(T, "not a directory")
def process_to_trailing_slash(d):
    return process(d) [:-2] + [str(d / "x") + "/", "--no-progress"]


@case(T, "is a FIFO")
def process_to_fifo(d):
    os.mkfifo(d / "fifo")
    return process(d, out="fifo")


@case(T, "dangling symbolic link")
def process_to_dangling_symlink(d):
    os.symlink(d / "nowhere" / "x.h5", d / "dangling.h5")
    return process(d, out="dangling.h5")


@case(T, "output directory")
def process_into_missing_directory(d):
    return process(d, out="missing/out.h5")


@case(T, "not a directory")
def import_to_dot(d):
    return ["import", str(d / "a.wav"), "-o", "."]


@case(T, "is a directory")
def plot_to_directory(d):
    return ["plot", str(d / "prod.h5"), "-o", str(d)]


@case(T, "not a directory")
def demo_to_existing_file(d):
    return ["demo", "-o", str(d / "chain.toml"), "--no-progress"]


@case(T, "is a FIFO")
def info_on_fifo(d):
    os.mkfifo(d / "fifo.h5")
    return ["info", str(d / "fifo.h5")]


@case(T, "is a directory")
def info_on_directory(d):
    return ["info", str(d)]


# == 3. arguments out of range (writers must not leak a temporary file) ==========
A = "command-line numbers"


@case(A, "--seed")
def simulate_seed_2_64(d):
    return ["simulate", str(d / "scenario.toml"), "-o", str(d / "out.h5"), "--seed",
            str(2**64)]


@case(A, "--seed")
def simulate_seed_negative(d):
    return ["simulate", str(d / "scenario.toml"), "-o", str(d / "out.h5"), "--seed", "-1"]


@case(A, "--duration")
def simulate_duration_inf(d):
    return ["simulate", str(d / "scenario.toml"), "-o", str(d / "out.h5"), "--duration", "inf"]


@case(A, "--duration")
def simulate_duration_nan(d):
    return ["simulate", str(d / "scenario.toml"), "-o", str(d / "out.h5"), "--duration", "nan"]


@case(A, "--duration")
def simulate_duration_zero(d):
    return ["simulate", str(d / "scenario.toml"), "-o", str(d / "out.h5"), "--duration", "0"]


@case(A, "--line")
def process_line_inf(d):
    return process(d, "rec.h5", "chain.toml", "out.h5", "--line", "inf", "1")


@case(A, "--line")
def process_line_fractional(d):
    return process(d, "rec.h5", "chain.toml", "out.h5", "--line", "2.5", "1")


@case(A, "--line")
def process_line_spacing_nan(d):
    return process(d, "rec.h5", "chain.toml", "out.h5", "--line", "4", "nan")


@case(A, "--line")
def process_line_spacing_zero(d):
    return process(d, "rec.h5", "chain.toml", "out.h5", "--line", "4", "0")


@case(A, "--scale")
def import_scale_nan(d):
    return ["import", str(d / "a.wav"), "-o", str(d / "out.h5"), "--scale", "nan"]


@case(A, "--scale")
def import_scale_inf(d):
    return ["import", str(d / "a.wav"), "-o", str(d / "out.h5"), "--scale", "inf"]


@case(A, "--scale")
def import_scale_zero(d):
    return ["import", str(d / "a.wav"), "-o", str(d / "out.h5"), "--scale", "0"]


@case(A, "--sound-speed")
def import_sound_speed_zero(d):
    return ["import", str(d / "a.wav"), "-o", str(d / "out.h5"), "--sound-speed", "0"]


@case(A, "--sound-speed")
def import_sound_speed_nan(d):
    return ["import", str(d / "a.wav"), "-o", str(d / "out.h5"), "--sound-speed", "nan"]


@case(A, "--range-db")
def plot_range_db_nan(d):
    return ["plot", str(d / "prod.h5"), "-o", str(d / "x.png"), "--range-db", "nan"]


@case(A, "--max-memory")
def process_max_memory_garbage(d):
    return process(d, "rec.h5", "chain.toml", "out.h5", "--max-memory", "lots")


@case(A, "required")
def process_missing_chain_option(d):
    return ["process", str(d / "rec.h5"), "-o", str(d / "out.h5")]


# == 4. recording attributes and datasets of the wrong type ==========
R = "recording attributes"


def _rec_case(fn, *extra):
    def setup(d):
        return process(d, edit_h5(d, fn).name, "chain.toml", "out.h5", *extra)
    return setup


def _attr(obj, key, value):
    def fn(f):
        target = f[obj] if obj else f
        del target.attrs[key]
        target.attrs[key] = value
    return fn


def _replace(name, value):
    def fn(f):
        del f[name]
        f[name] = value
    return fn


def _group(name):
    def fn(f):
        del f[name]
        f.create_group(name)
    return fn


for _id, _fn, _m in [
    ("sample_freq_string", _attr("time_data", "sample_freq", "fast"), "sample_freq"),
    ("sample_freq_empty", _attr("time_data", "sample_freq", np.zeros(0)), "sample_freq"),
    ("sample_freq_two_values", _attr("time_data", "sample_freq", np.array([1.0, 2.0])),
     "sample_freq"),
    ("sample_freq_zero", _attr("time_data", "sample_freq", 0.0), "sample_freq"),
    ("sample_freq_nan", _attr("time_data", "sample_freq", np.nan), "sample_freq"),
    ("sound_speed_string", _attr("", "sound_speed", "water"), "sound_speed"),
    ("sound_speed_empty", _attr("", "sound_speed", np.zeros(0)), "sound_speed"),
    ("sound_speed_negative", _attr("", "sound_speed", -1500.0), "sound_speed"),
    ("format_version_string", _attr("", "format_version", "one"), "format_version"),
    ("format_version_fraction", _attr("", "format_version", 0.5), "format_version"),
    ("format_version_future", _attr("", "format_version", 99), "newer"),
    ("positions_string", _replace("array/positions", np.array([b"a", b"b", b"c", b"d"])),
     "/array/positions"),
    ("positions_empty", _replace("array/positions", np.zeros((0, 3))), "positions"),
    ("positions_group", _group("array/positions"), "/array/positions"),
    ("positions_nan", _replace("array/positions", np.full((N_CH, 3), np.nan)), "NaN"),
    ("array_is_dataset", _replace("array", np.zeros(3)), "/array"),
    ("gains_string", lambda f: f.create_dataset("array/gains", data=np.array([b"x"] * N_CH)),
     "/array/gains"),
    ("gains_group", lambda f: f.create_group("array/gains"), "/array/gains"),
    ("gains_wrong_length", lambda f: f.create_dataset("array/gains", data=np.ones(2)),
     "/array/gains"),
    ("dead_all", lambda f: f.create_dataset("array/dead", data=np.ones(N_CH, bool)), "dead"),
    ("nav_time_string", _replace("nav/time", np.array([b"t"] * 4)), "/nav/time"),
    ("nav_time_empty", _replace("nav/time", np.zeros(0)), "/nav/time"),
    ("nav_time_group", _group("nav/time"), "/nav/time"),
    ("nav_is_dataset", _replace("nav", np.zeros(4)), "/nav"),
    ("nav_heading_missing", lambda f: f.__delitem__("nav/heading"), "/nav/heading"),
    ("nav_position_shape", _replace("nav/position", np.zeros((4, 3))), "/nav/position"),
    ("nav_time_nan", _replace("nav/time", np.array([0.0, np.nan, 2.0, 3.0])), "/nav"),
    ("time_data_group", _group("time_data"), "/time_data"),
    ("time_data_strings", _replace("time_data", np.array([[b"a"] * N_CH] * 8)), "/time_data"),
    ("time_data_3d", _replace("time_data", np.zeros((8, N_CH, 2), np.float32)), "2-D"),
]:
    CASES.append(Case(_id, R, _rec_case(_fn), _m))


# == 5. HDF5 links ==========
L = "dangling links"


def _soft(name, target):
    def fn(f):
        if name in f:
            del f[name]
        f[name] = h5py.SoftLink(target)
    return fn


def _external(name):
    def fn(f):
        del f[name]
        f[name] = h5py.ExternalLink("/nonexistent/file.h5", "/x")
    return fn


for _id, _fn, _m in [
    ("positions_dangling_soft_link", _soft("array/positions", "/nowhere"), "dangling"),
    ("positions_dangling_external_link", _external("array/positions"), "dangling"),
    ("nav_time_dangling_soft_link", _soft("nav/time", "/nowhere"), "dangling"),
    ("time_data_dangling_soft_link", _soft("time_data", "/nowhere"), "dangling"),
    ("gains_dangling_external_link", lambda f: f.__setitem__(
        "array/gains", h5py.ExternalLink("/nonexistent.h5", "/g")), "dangling"),
]:
    CASES.append(Case(_id, L, _rec_case(_fn), _m))


@case(L, "dangling")
def info_truth_dangling(d):
    p = edit_h5(d, _soft("truth", "/nowhere"))
    return ["info", str(p)]


@case(L, "/truth")
def info_truth_is_dataset(d):
    p = edit_h5(d, lambda f: f.create_dataset("truth", data=np.zeros(3)))
    return ["info", str(p)]


# == 6. broken files ==========
F = "broken files"


@case(F, "no such")
def missing_recording(d):
    return process(d, rec="nope.h5")


@case(F, "not an HDF5")
def text_as_recording(d):
    (d / "t.h5").write_text("hello")
    return process(d, rec="t.h5")


@case(F, "truncated")
def truncated_recording(d):
    data = (d / "rec.h5").read_bytes()
    (d / "cut.h5").write_bytes(data[: len(data) // 2])
    return process(d, rec="cut.h5")


@case(F, "not an HDF5")
def empty_file_as_recording(d):
    (d / "e.h5").write_bytes(b"")
    return process(d, rec="e.h5")


@case(F, "not a WAV")
def text_as_wav(d):
    (d / "t.wav").write_text("hello")
    return ["import", str(d / "t.wav"), "-o", str(d / "out.h5")]


@case(F, "non-finite")
def geometry_xml_nan(d):
    (d / "g.xml").write_text('<MicArray><pos x="nan" y="0" z="0"/><pos x="1" y="0" z="0"/>'
                             '<pos x="2" y="0" z="0"/><pos x="3" y="0" z="0"/></MicArray>')
    return process(d, "rec.h5", "chain.toml", "out.h5", "--geometry", str(d / "g.xml"))


@case(F, "non-numeric")
def geometry_csv_text(d):
    (d / "g.csv").write_text("x,y,z\na,b,c\n")
    return process(d, "rec.h5", "chain.toml", "out.h5", "--geometry", str(d / "g.csv"))


@case(F, "rows")
def geometry_wrong_count(d):
    (d / "g.csv").write_text("x,y,z\n0,0,0\n1,0,0\n")
    return process(d, "rec.h5", "chain.toml", "out.h5", "--geometry", str(d / "g.csv"))


@case(F, "not an arrayproc products")
def plot_a_recording(d):
    return ["plot", str(d / "rec.h5"), "-o", str(d / "x.png")]


# == 7. chain configurations ==========
C = "chain config"

for _id, _text, _m in [
    ("type_is_list", '[[stage]]\ntype = ["cbf"]\n', "type"),
    ("type_is_table", '[[stage]]\ntype = {a = 1}\n', "type"),
    ("input_is_list", '[[stage]]\ntype = "power"\n[[stage]]\ntype = "power"\nname = "p2"\n'
     'input = ["power"]\n', "input"),
    ("name_is_list", '[[stage]]\ntype = "power"\nname = ["a"]\n', "name"),
    ("name_dot", '[[stage]]\ntype = "power"\nname = "."\n', "name"),
    ("name_slash", '[[stage]]\ntype = "power"\nname = "a/b"\n', "name"),
    ("name_dotdot", '[[stage]]\ntype = "power"\nname = ".."\n', "name"),
    ("block_string", '[input]\nblock = "big"\n[[stage]]\ntype = "power"\n', "block"),
    ("block_zero", '[input]\nblock = 0\n[[stage]]\ntype = "power"\n', "block"),
    ("input_is_array", 'input = [1]\n[[stage]]\ntype = "power"\n', "input"),
    ("stage_is_table", '[stage]\ntype = "power"\n', "stage"),
    ("stage_is_list_of_numbers", 'stage = [1, 2]\n', "stage"),
    ("unknown_top_level", '[[stage]]\ntype = "power"\n[extra]\n', "extra"),
    ("invalid_toml", '[[stage]\ntype = "power"\n', "TOML"),
    ("unknown_stage_type", '[[stage]]\ntype = "beamform"\n', "beamform"),
    ("unknown_stage_key", '[[stage]]\ntype = "power"\nbnd = [1.0, 2.0]\n', "bnd"),
    ("band_reversed", '[[stage]]\ntype = "power"\nband = [200.0, 100.0]\n', "band"),
    ("band_above_nyquist", '[[stage]]\ntype = "power"\nband = [600.0, 700.0]\n', "Nyquist"),
    ("power_ref_zero", '[[stage]]\ntype = "power"\nref = 0.0\n', "ref"),
    ("cbf_fractional_beam_count", '[[stage]]\ntype = "cbf"\nnfft = 64\n'
     'beams = {start = 0.0, stop = 180.0, count = 5.5}\n', "count"),
    ("cbf_beam_count_1e8", '[[stage]]\ntype = "cbf"\nnfft = 64\n'
     'beams = {start = 0.0, stop = 180.0, count = 100000000}\n', "working memory"),
    ("cbf_beams_string", '[[stage]]\ntype = "cbf"\nnfft = 64\nbeams = "all"\n', "beams"),
    ("dangling_input", '[[stage]]\ntype = "power"\ninput = "nope"\n', "nope"),
    ("duplicate_names", '[[stage]]\ntype = "power"\n[[stage]]\ntype = "power"\n', "duplicate"),
]:
    CASES.append(Case("chain_" + _id, C, (lambda t: lambda d: chain_text(d, t))(_text), _m))


@case(C, "UTF-8")
def chain_not_utf8(d):
    (d / "bad.toml").write_bytes(b"\xff\xfe[[stage]]\n")
    return process(d, chain="bad.toml")


@case(C, "chain")
def chain_is_directory(d):
    os.mkdir(d / "cdir")
    return process(d, chain="cdir")


# == 8. scenarios ==========
S = "scenario config"

for _id, _old, _new, _m in [
    ("speed_1e9", "speed_kn = 12.0", "speed_kn = 1e9", "speed"),
    ("faster_than_sound", "speed_kn = 12.0", "speed_kn = 3000.0", "sound"),
    ("tonal_level_1e6", "level_db = 150.0", "level_db = 1e6", "level_db"),
    ("source_name_empty", 'name = "merchant"', 'name = ""', "name"),
    ("source_name_slash", 'name = "merchant"', 'name = "a/b"', "name"),
    ("source_name_dot", 'name = "merchant"', 'name = "."', "name"),
    ("fs_string", "fs = 1024.0", 'fs = "fast"', "fs"),
    ("duration_inf", "duration = 2.0\nsound", "duration = inf\nsound", "duration"),
    ("array_n_list", "n = 4", "n = [4]", "n"),
    ("tonals_table", "tonals = [{ freq = 148.0, level_db = 150.0 }]",
     "tonals = { freq = 148.0 }", "tonals"),
    ("active_empty", "[noise]", "[active]\n[noise]", "active"),
    ("source_is_string", "[[source]]\nname", "source = \"x\"\n[[sourcex]]\nname", "source"),
]:
    CASES.append(Case("scenario_" + _id, S,
                      (lambda o, n: lambda d: scenario_edit(d, o, n))(_old, _new), _m))


# == 9. trackers ==========
K = "tracker config"

for _id, _text, _m in [
    ("filter_list", TRACKER.replace('filter = "ukf"', 'filter = ["ukf"]'), "filter"),
    ("params_string", TRACKER + 'params = "x"\n', "params"),
    ("cone_gate_string", TRACKER + 'cone_gate = "wide"\n', "cone_gate"),
    ("lr_string", TRACKER.replace("lr = true", 'lr = "yes"'), "lr"),
    ("sigma_list", TRACKER.replace("sigma_bearing_deg = 1.0", "sigma_bearing_deg = [1.0]"),
     "sigma_bearing_deg"),
    ("tracker_is_array", "tracker = [1, 2]\n", "tracker"),
    ("invalid_toml", "[tracker\n", "TOML"),
    ("nav_list", TRACKER + "nav = [1]\n", "nav"),
]:
    CASES.append(Case("tracker_" + _id, K, (lambda t: lambda d: tracker_text(d, t))(_text), _m))


@case("malformed products", "must be numeric")
def track_string_time_column(d):
    p = edit_h5(d, lambda f: None, "x.h5")
    p.write_bytes((d / "prod.h5").read_bytes())
    with h5py.File(p, "r+") as f:
        del f["bearings/time"]
        f["bearings/time"] = np.array([b"a"] * 5)
    return ["track", str(p), "-c", str(d / "tracker.toml"), "-o", str(d / "out.h5")]


@case("malformed products", "no bearings group")
def track_products_without_bearings(d):
    p = d / "nob.h5"
    with ProductsWriter(p, source="rec.h5") as w:
        w.group("power", "power").append(time=np.arange(2.0), power_db=np.zeros((2, 2)))
    return ["track", str(p), "-c", str(d / "tracker.toml"), "-o", str(d / "out.h5")]


# == 10. malformed products given to plot ==========
P = "malformed products"


def _products(d: Path, fill: Callable[[ProductsWriter], None]) -> Path:
    p = d / "bad_prod.h5"
    with ProductsWriter(p, source=str(d / "rec.h5")) as w:
        fill(w)
    return p


@case(P, "power_db")
def plot_btr_one_dimensional(d):
    p = _products(d, lambda w: w.group("btr", "btr").append(time=np.arange(4.0),
                                                              power_db=np.zeros(4)))
    return ["plot", str(p), "--kind", "btr", "-o", str(d / "x.png")]


@case(P, "rows")
def plot_lofar_zero_rows(d):
    def fill(w):
        g = w.group("lofar", "lofar")
        g.append(time=np.zeros(0), power_db=np.zeros((0, 3, 5)))
        g.set("cone_deg", np.array([0.0, 90.0, 180.0]))
        g.set("freq", np.arange(5.0))
    p = _products(d, fill)
    return ["plot", str(p), "--kind", "lofar", "-o", str(d / "x.png")]


@case(P, "time")
def plot_btr_string_time(d):
    p = _products(d, lambda w: w.group("btr", "btr").append(
        time=np.array([b"a", b"b"]), power_db=np.zeros((2, 3))))
    return ["plot", str(p), "--kind", "btr", "-o", str(d / "x.png")]


@case(P, "unknown kind")
def plot_unknown_kind(d):
    return ["plot", str(d / "prod.h5"), "--kind", "nope", "-o", str(d / "x.png")]


@case(P, "image extension")
def plot_unknown_extension(d):
    return ["plot", str(d / "prod.h5"), "-o", str(d / "x.xyz")]


@case(P, "image extension")
def plot_no_extension(d):
    return ["plot", str(d / "prod.h5"), "-o", str(d / "plotfile")]


@case(P, "plottable")
def plot_nothing_plottable(d):
    p = _products(d, lambda w: w.group("power", "power").append(time=np.arange(2.0),
                                                                  power_db=np.zeros((2, 2))))
    return ["plot", str(p), "-o", str(d / "x.png")]


# == 11. resources ==========
M = "resource guards"


@case(M, "working memory")
def process_max_memory_tiny(d):
    return process(d, "rec.h5", "chain.toml", "out.h5", "--max-memory", "1K")


@case(M, "working memory")
def process_many_beams_default_limit(d):
    return chain_text(d, '[[stage]]\ntype = "cbf"\nnfft = 4096\n'
                         'beams = {start = 0.0, stop = 180.0, count = 2000000000}\n')


# == 12. a file still being written ==========
W = "file being written"


WRITER = """
import sys, time, h5py, numpy as np
f = h5py.File(sys.argv[1], "w")
f.create_dataset("time_data", data=np.zeros((8, 4), np.float32))
f.flush()
print("ready", flush=True)
time.sleep(60)
"""


@case(W, "being written")
def recording_held_by_writer(d):
    # Another process has the file open for writing (HDF5 locks it) while we read.
    p = subprocess.Popen([sys.executable, "-c", WRITER, str(d / "busy.h5")],
                         stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    _OPEN.append(p)
    return ["info", str(d / "busy.h5")]


_OPEN: list[subprocess.Popen] = []


def close_open_writers() -> None:
    """Kill the writer processes (SIGKILL: no last writes to the file)."""
    while _OPEN:
        p = _OPEN.pop()
        p.kill()
        p.wait()
