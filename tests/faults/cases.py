"""The fault table: faults of the environment and damaged inputs, each a case that builds its
situation in a work directory and returns the ``arrayproc`` command to run through the real
command line (a subprocess), with the exit status and the key text its one error line must
have. ``tests/faults/test_faults.py`` runs them; ``docs/reliability.md`` gives the counts.

Classes: disk full on a real tmpfs (several fill levels), write failures injected into the
guarded HDF5 writer (:data:`arrayproc.io.atomic.FAULT_ENV`: ENOSPC, EIO, EDQUOT at several
byte counts), a read-only file system, truncations at several offsets, bit flips in the
superblock and in chunk data, a dataset shorter than it declares, files open by a writer, the
memory limit. SIGKILL at seeded random times is in ``test_faults.py`` (it needs a second run).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from arrayproc.io.geometry import line_array
from arrayproc.io.products import ProductsWriter
from arrayproc.io.recording import RecordingWriter
from tests.app.hostile_cases import make_base

EXIT_WRITE = 74
EXIT_MEMORY = 75

# A chain whose products are a few tens of kB: large enough to fill a disk part-way.
CHAIN_BIG = ('[input]\nblock = 256\n[[stage]]\ntype = "cbf"\nnfft = 256\n'
             'beams = {start = 0.0, stop = 180.0, count = 31}\n'
             '[[stage]]\ntype = "integrate"\n[[stage]]\ntype = "btr"\n')

# Steering of 20,000 beams x 2,049 bins x 8 channels (2.6 GB): under the default limit of the
# chain's estimate (half the RAM), above an address-space limit of 3 GB.
CHAIN_HUGE = ('[input]\nblock = 4096\n[[stage]]\ntype = "cbf"\nnfft = 4096\n'
              'band = [10.0, 400.0]\nbeams = {start = 0.0, stop = 180.0, count = 20000}\n')


@dataclass
class Case:
    id: str
    cls: str
    setup: Callable[[Path], list[str]]
    match: str
    status: int
    env: dict[str, str] = field(default_factory=dict)
    default: bool = False  # in the default (fast) run
    rlimit_as: int | None = None  # the command's address-space limit, bytes


CASES: list[Case] = []
_ENV: dict[str, str] = {}


def case(cls: str, match: str, status: int, default: bool = False):
    def deco(f: Callable[[Path], list[str]]) -> Callable[[Path], list[str]]:
        CASES.append(Case(f.__name__, cls, f, match, status, dict(_ENV), default))
        return f
    return deco


def make_fault_base(d: Path) -> None:
    """The hostile table's inputs plus a longer 8-channel recording (4 chunks of 2048
    samples) and its chains."""
    make_base(d)
    x = np.random.default_rng(3).standard_normal((8192, 8)).astype(np.float32)
    with RecordingWriter(d / "long.h5", 1000.0, 8, positions=line_array(8, 0.75),
                         chunk_samples=2048) as w:
        w.append(x)
        w.set_nav(time=np.array([0.0, 10.0]), position=np.zeros((2, 2)), heading=np.zeros(2))
    (d / "big.toml").write_text(CHAIN_BIG)
    (d / "huge.toml").write_text(CHAIN_HUGE)
    # longer runs for the SIGKILL trials: 60 s of 8 channels, a 30 s scenario
    x = np.random.default_rng(4).standard_normal((60000, 8)).astype(np.float32)
    with RecordingWriter(d / "kill.h5", 1000.0, 8, positions=line_array(8, 0.75),
                         chunk_samples=2048) as w:
        w.append(x)
    scen = (d / "scenario.toml").read_text()
    (d / "kill_scenario.toml").write_text(scen.replace("duration = 2.0", "duration = 30.0"))
    with ProductsWriter(d / "btr.h5", source="long.h5") as w:  # what `plot` reads
        g = w.group("btr", "btr")
        g.set("cone_deg", np.linspace(0.0, 180.0, 19))
        g.append(time=np.arange(400.0), power_db=np.random.default_rng(5).normal(
            60.0, 3.0, (400, 19)))


# -- helpers ----------------------------------------------------------------------------------
MOUNTS: list[Path] = []


def tmpfs(d: Path, free: int | None, size: str = "256k", ro: bool = False) -> Path:
    """A tmpfs at ``d/disk`` with ``free`` bytes left (a filler file takes the rest)."""
    m = d / "disk"
    m.mkdir(exist_ok=True)
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(m)],
                   check=True, capture_output=True)
    MOUNTS.append(m)
    if free is not None:
        st = os.statvfs(m)
        avail = st.f_bavail * st.f_frsize
        with open(m / "filler", "wb") as fh:
            fh.write(b"\0" * max(0, avail - free))
    if ro:
        subprocess.run(["mount", "-o", "remount,ro", str(m)], check=True, capture_output=True)
    return m


def unmount_all() -> None:
    while MOUNTS:
        subprocess.run(["umount", "-l", str(MOUNTS.pop())], capture_output=True)


def can_mount() -> bool:
    """Whether this process may mount a tmpfs (root, no seccomp policy against it)."""
    import tempfile
    with tempfile.TemporaryDirectory() as t:
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=8k", "tmpfs", t],
                           capture_output=True)
        if r.returncode == 0:
            subprocess.run(["umount", t], capture_output=True)
        return r.returncode == 0


def process(d: Path, rec: str = "long.h5", chain: str = "big.toml",
            out: str = "out.h5") -> list[str]:
    return ["process", str(d / rec), "-c", str(d / chain), "-o", str(d / out), "--no-progress"]


def simulate(d: Path, out: str = "out.h5") -> list[str]:
    return ["simulate", str(d / "scenario.toml"), "-o", str(d / out), "--no-progress"]


def imports(d: Path, out: str = "out.h5") -> list[str]:
    return ["import", str(d / "a.wav"), "-o", str(d / out)]


def track(d: Path, out: str = "out.h5") -> list[str]:
    return ["track", str(d / "prod.h5"), "-c", str(d / "tracker.toml"), "-o", str(d / out),
            "--no-progress"]


def copy_bytes(d: Path, src: str, dst: str, edit: Callable[[bytearray], None]) -> Path:
    b = bytearray((d / src).read_bytes())
    edit(b)
    (d / dst).write_bytes(bytes(b))
    return d / dst


def chunk_offset(path: Path, name: str, k: int) -> int:
    with h5py.File(path, "r") as f:
        return int(f[name].id.get_chunk_info(k).byte_offset)


# == 1. disk full, a real tmpfs ==========
D = "disk full (tmpfs)"


def _full(cmd: Callable[..., list[str]], free: int) -> Callable[[Path], list[str]]:
    def setup(d: Path) -> list[str]:
        tmpfs(d, free)
        return cmd(d, out="disk/out.h5")
    return setup


for _free in (0, 4096, 8192, 12288):  # the products take 15 kB
    case(D, "No space left on device", EXIT_WRITE, default=_free == 8192)(
        _full(process, _free))
    CASES[-1].id = f"process_disk_full_{_free // 1024}k_free"
for _name, _cmd, _match, _dflt in (
        ("simulate", simulate, "needs about", False),  # refused before writing: size known
        ("import", imports, "needs about", False),
        ("track", track, "No space left on device", False)):
    case(D, _match, EXIT_WRITE, default=_dflt)(_full(_cmd, 0))
    CASES[-1].id = f"{_name}_disk_full"


@case(D, "No space left on device", EXIT_WRITE)
def export_disk_full(d):
    tmpfs(d, 0)
    return ["export", str(d / "prod.h5"), "--to", "raven", "-o", str(d / "disk/sel.txt")]


@case(D, "No space left on device", EXIT_WRITE)
def plot_disk_full(d):
    tmpfs(d, 0)
    return ["plot", str(d / "btr.h5"), "-o", str(d / "disk/p.png")]


# == 2. write failures injected into the guarded writer ==========
J = "write failure (injected)"
for _cmd, _spec, _match, _dflt in (
        (process, "ENOSPC@0", "No space left", False),
        (process, "ENOSPC@3000", "No space left", False),
        (process, "EIO@12000", "Input/output error", False),
        (process, "EDQUOT@8000", "quota", False),
        (simulate, "ENOSPC@60000", "No space left", True),
        (simulate, "EIO@2000", "Input/output error", False),
        (imports, "ENOSPC@20000", "No space left", False),
        (imports, "EDQUOT@0", "quota", False),
        (track, "EIO@1000", "Input/output error", False)):
    _ENV = {"ARRAYPROC_FAULT_INJECT": _spec}
    case(J, _match, EXIT_WRITE, default=_dflt)(lambda d, c=_cmd: c(d))
    CASES[-1].id = f"{_cmd.__name__}_{_spec.replace('@', '_at_')}"
_ENV = {}


# == 3. a read-only file system ==========
R = "read-only file system"


@case(R, "Read-only file system", EXIT_WRITE)
def process_read_only(d):
    tmpfs(d, None, ro=True)
    return process(d, out="disk/out.h5")


@case(R, "Read-only file system", EXIT_WRITE)
def simulate_read_only(d):
    tmpfs(d, None, ro=True)
    return simulate(d, out="disk/out.h5")


# == 4. truncated inputs ==========
T = "truncated"
for _frac, _dflt in ((0.01, False), (0.1, False), (1 / 3, True), (0.5, False), (0.9, False),
                     (0.999, False)):
    def _cut(d, frac=_frac):
        copy_bytes(d, "long.h5", "cut.h5", lambda b: b.__delitem__(slice(int(len(b) * frac),
                                                                          None)))
        return process(d, rec="cut.h5")
    case(T, "truncated", 2, default=_dflt)(_cut)
    CASES[-1].id = f"recording_cut_at_{_frac:.3f}"


@case(T, "truncated", 2)
def products_cut_to_track(d):
    copy_bytes(d, "prod.h5", "cut.h5", lambda b: b.__delitem__(slice(len(b) // 2, None)))
    return ["track", str(d / "cut.h5"), "-c", str(d / "tracker.toml"), "-o", str(d / "o.h5"),
            "--no-progress"]


@case(T, "truncated", 2)
def products_cut_to_plot(d):
    copy_bytes(d, "btr.h5", "cut.h5", lambda b: b.__delitem__(slice(len(b) * 2 // 3, None)))
    return ["plot", str(d / "cut.h5"), "-o", str(d / "p.png")]


# == 5. bit flips in the superblock ==========
S = "bit flip: superblock"
for _off, _bit, _dflt in ((0, 1, False), (5, 4, True), (8, 2, False), (13, 0, False),
                          (20, 3, False), (28, 5, False), (40, 0, False), (44, 7, False)):
    def _flip(d, off=_off, bit=_bit):
        def edit(b):
            b[off] ^= 1 << bit
        copy_bytes(d, "long.h5", "flip.h5", edit)
        return process(d, rec="flip.h5")
    case(S, "superblock", 2, default=_dflt)(_flip)
    CASES[-1].id = f"superblock_byte_{_off}_bit_{_bit}"


# == 6. bit flips in chunk data ==========
C = "bit flip: chunk data"
for _k, _at, _dflt in ((0, 17, False), (2, 5000, True), (3, 65000, False)):
    def _chunk(d, k=_k, at=_at):
        off = chunk_offset(d / "long.h5", "time_data", k) + at

        def edit(b):
            b[off] ^= 0x10
        copy_bytes(d, "long.h5", "flip.h5", edit)
        return process(d, rec="flip.h5")
    case(C, "damaged from t = ", 2, default=_dflt)(_chunk)
    CASES[-1].id = f"recording_chunk_{_k}_byte_{_at}"


@case(C, "damaged", 2)
def products_column_flip_to_plot(d):
    off = chunk_offset(d / "btr.h5", "btr/power_db", 0)

    def edit(b):
        b[off + 300] ^= 0x08
    copy_bytes(d, "btr.h5", "flip.h5", edit)
    return ["plot", str(d / "flip.h5"), "-o", str(d / "p.png")]


# == 7. a dataset shorter than it declares ==========
H = "dataset shorter than declared"


@case(H, "holds fewer samples than it declares", 2, default=True)
def recording_declared_longer(d):
    p = d / "short.h5"
    p.write_bytes((d / "long.h5").read_bytes())
    with h5py.File(p, "r+") as f:  # grown by a writer that died before writing the chunks
        f["time_data"].resize(16384, axis=0)
    return process(d, rec="short.h5")


# == 8. open by a writer ==========
W = "open by a writer"
LOCKER = """
import sys, time, h5py
f = h5py.File(sys.argv[1], "a")
print("ready", flush=True)
time.sleep(60)
"""
SWMR = """
import sys, time, h5py, numpy as np
f = h5py.File(sys.argv[1], "w", libver="latest")
d = f.create_dataset("time_data", data=np.zeros((8, 4), np.float32), maxshape=(None, 4))
d.attrs["sample_freq"] = 1000.0
f.swmr_mode = True
print("ready", flush=True)
time.sleep(60)
"""
WRITERS: list[subprocess.Popen] = []


def _writer(code: str, path: Path) -> subprocess.Popen:
    p = subprocess.Popen([sys.executable, "-c", code, str(path)], stdout=subprocess.PIPE,
                         text=True)
    assert p.stdout.readline().strip() == "ready"
    WRITERS.append(p)
    return p


def kill_writers() -> None:
    while WRITERS:
        p = WRITERS.pop()
        p.kill()
        p.wait()


@case(W, "held open by a writer", 2, default=True)
def recording_locked_by_writer(d):
    p = d / "busy.h5"
    p.write_bytes((d / "long.h5").read_bytes())
    _writer(LOCKER, p)
    return process(d, rec="busy.h5")


@case(W, "live writer", 2)
def recording_of_live_swmr_writer(d):
    _writer(SWMR, d / "live.h5")
    return process(d, rec="live.h5")


@case(W, "marked open for writing", 2)
def recording_of_dead_swmr_writer(d):
    _writer(SWMR, d / "dead.h5")
    kill_writers()  # SIGKILL: the file keeps the open-for-writing mark
    return process(d, rec="dead.h5")


# == 9. the memory limit ==========
M = "memory limit"


@case(M, "out of memory in stage 'cbf'", EXIT_MEMORY)
def process_allocation_above_address_space_limit(d):
    return process(d, chain="huge.toml")


CASES[-1].rlimit_as = 3 << 30


@case(M, "out of memory", EXIT_MEMORY, default=True)
def process_resident_above_max_memory(d):
    return [*process(d), "--max-memory", "100M"]


_ENV = {"ARRAYPROC_MAX_MEMORY": "100M"}


@case(M, "out of memory", EXIT_MEMORY)
def track_resident_above_env_limit(d):
    return track(d)


_ENV = {}
