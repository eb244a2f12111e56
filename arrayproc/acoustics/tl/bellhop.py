"""BELLHOP driver: write the ``.env`` of a range-independent environment, run bellhopcxx (or the
Fortran BELLHOP) and read the ``.shd`` result into a :class:`TLTable`.

The default :class:`BellhopEnv` is the SPL paper's appendix environment: Munk profile sampled at
7 depths (C-linear), vacuum surface, 1000 m flat bottom over an acousto-elastic halfspace
(1600 m/s, 1.8 g/cm³, 0.8 dB/λ), 50 Hz, source at 5 m, incoherent TL with geometric hat beams
('IG'), beams in ±90°, automatic number of beams and step, box 1800 m × 50.09 km.

Executables: the PyPI package ``whoi-uwapm`` ships an x86-64 ``bellhopcxx`` (C++ port of
BELLHOP, Pisha et al. 2023, GPL-3) and a Fortran ``bellhop`` linked against ``libgfortran.so.5``.
When the system has no libgfortran, the copy bundled in the numpy/scipy wheels (``*.libs``) is
put on ``LD_LIBRARY_PATH`` through a temporary directory of symlinks.
"""

from __future__ import annotations

import glob
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from arrayproc.acoustics.tl.shd import read_shd
from arrayproc.acoustics.tl.table import TLTable
from arrayproc.errors import ArrayprocError

__all__ = ["BellhopEnv", "MUNK_APPENDIX", "write_env", "find_executable", "run_bellhop",
           "run_arrivals"]

#: The SPL paper's appendix sound-speed profile (depth m, speed m/s). The printed "0.008" row is
#: an extraction error for 800.0 m (the profile is sorted in depth and 1504.30 m/s is the Munk
#: value at 800 m).
MUNK_APPENDIX = np.array([
    [0.0, 1548.52], [200.0, 1530.29], [250.0, 1526.69], [400.0, 1517.78],
    [600.0, 1509.49], [800.0, 1504.30], [1000.0, 1501.38]])


@dataclass
class BellhopEnv:
    """A range-independent 2-D BELLHOP environment (defaults: SPL paper appendix)."""

    title: str = "Munk profile"
    freq_hz: float = 50.0
    ssp: np.ndarray = field(default_factory=lambda: MUNK_APPENDIX.copy())
    ssp_option: str = "CVW"          # C-linear, vacuum top, attenuation in dB/wavelength
    depth_m: float = 1000.0
    bottom_speed: float = 1600.0
    bottom_density: float = 1.8      # g/cm³
    bottom_atten: float = 0.8        # units from ssp_option[2]: W = dB/λ, M = dB/m
    src_depths_m: tuple = (5.0,)
    rcv_depths_m: np.ndarray = field(default_factory=lambda: np.linspace(0.0, 1000.0, 101))
    ranges_m: np.ndarray = field(default_factory=lambda: np.linspace(0.0, 50e3, 5001))
    run_type: str = "IG"             # I = incoherent TL, G = geometric hat beams (Cartesian)
    n_beams: int = 0                 # 0 = BELLHOP chooses
    angles_deg: tuple = (-90.0, 90.0)
    step_m: float = 0.0              # 0 = automatic
    box_depth_m: float = 1800.0
    box_range_km: float = 50.09


def _vec(v) -> str:
    v = np.asarray(v, dtype=float).ravel()
    return " ".join(f"{x:.6g}" for x in v) + " /"


def write_env(env: BellhopEnv, path: str | Path) -> None:
    """Write ``env`` as a BELLHOP ``.env`` file (receiver ranges are given in km)."""
    rz = np.asarray(env.rcv_depths_m, float)
    rr = np.asarray(env.ranges_m, float) / 1000.0
    lines = [
        f"'{env.title}'",
        f"{env.freq_hz:.6g}",
        "1",
        f"'{env.ssp_option}'",
        f"0 0.0 {env.depth_m:.6g}",
        *(f"{z:.6g} {c:.6g} /" for z, c in np.asarray(env.ssp, float)),
        "'A' 0.0",
        f"{env.depth_m:.6g} {env.bottom_speed:.6g} 0.0 {env.bottom_density:.6g} "
        f"{env.bottom_atten:.6g} /",
        f"{len(env.src_depths_m)}",
        _vec(env.src_depths_m),
        f"{rz.size}",
        _vec(rz),
        f"{rr.size}",
        _vec(rr),
        f"'{env.run_type}'",
        f"{env.n_beams}",
        _vec(env.angles_deg),
        f"{env.step_m:.6g} {env.box_depth_m:.6g} {env.box_range_km:.6g}",
    ]
    Path(path).write_text("\n".join(lines) + "\n")


def _gfortran_dir(tmp: Path) -> str | None:
    """A directory with ``libgfortran.so.5`` symlinked from a wheel's bundled copy, if needed."""
    import numpy  # noqa: F401  (locate site-packages)

    site = Path(np.__file__).resolve().parents[1]
    for cand in sorted(glob.glob(str(site / "*.libs" / "libgfortran-*.so.5*"))):
        d = tmp / "gfortran"
        d.mkdir(exist_ok=True)
        (d / "libgfortran.so.5").unlink(missing_ok=True)
        (d / "libgfortran.so.5").symlink_to(cand)
        for q in glob.glob(str(Path(cand).parent / "libquadmath-*.so*")):
            link = d / Path(q).name
            if not link.exists():
                link.symlink_to(q)
        return str(d)
    return None


def find_executable(name: str = "bellhopcxx") -> str:
    """Path of ``bellhopcxx`` or ``bellhop``: from PATH, else from the ``whoi_uwapm`` package."""
    exe = shutil.which(name)
    if exe:
        return exe
    try:
        import whoi_uwapm
    except ImportError:
        raise ArrayprocError(
            f"{name} not found: install it or `pip install whoi-uwapm` (x86-64 Linux)") from None
    cand = Path(whoi_uwapm.__file__).parent / name
    if not cand.exists():
        raise ArrayprocError(f"{name} not found in the whoi_uwapm package")
    if not os.access(cand, os.X_OK):
        cand.chmod(cand.stat().st_mode | 0o111)
    return str(cand)


def _run(env: BellhopEnv, executable: str, tmpp: Path, timeout_s: float, out: str) -> Path:
    """Write ``env`` into ``tmpp``, run the executable there, return its output file."""
    exe = find_executable(executable) if os.sep not in executable else executable
    is_cxx = "cxx" in Path(exe).name or "cuda" in Path(exe).name
    write_env(env, tmpp / "run.env")
    cmd = [exe, "-2", "-1", "run"] if is_cxx else [exe, "run"]
    envvars = dict(os.environ)
    if not is_cxx:
        gdir = _gfortran_dir(tmpp)
        if gdir:
            envvars["LD_LIBRARY_PATH"] = gdir + os.pathsep + envvars.get("LD_LIBRARY_PATH", "")
    proc = subprocess.run(cmd, cwd=tmpp, env=envvars, capture_output=True, text=True,
                          timeout=timeout_s, check=False)
    res = tmpp / out
    if proc.returncode != 0 or not res.exists():
        prt = (tmpp / "run.prt").read_text(errors="replace")[-2000:] if (
            tmpp / "run.prt").exists() else ""
        raise ArrayprocError(f"{exe} failed (status {proc.returncode}): "
                             f"{proc.stderr.strip()[-500:]} {prt}")
    return res


def run_arrivals(env: BellhopEnv, executable: str = "bellhopcxx",
                 workdir: str | Path | None = None, timeout_s: float = 600.0) -> list:
    """Run BELLHOP in arrivals mode (run type ``'A'``) and read the ``.arr`` file: one
    :class:`arrayproc.acoustics.tl.arrivals.Arrivals` per source depth."""
    from arrayproc.acoustics.tl.arrivals import read_arr

    env = BellhopEnv(**{**env.__dict__, "run_type": "A"})
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        return read_arr(_run(env, executable, Path(tmp), timeout_s, "run.arr"))


def run_bellhop(env: BellhopEnv | None = None, executable: str = "bellhopcxx",
                workdir: str | Path | None = None, timeout_s: float = 600.0) -> TLTable:
    """Run BELLHOP on ``env`` and return TL (dB) as a :class:`TLTable`.

    ``executable`` is ``"bellhopcxx"`` (run with ``-2 -1``: 2-D, single thread, so that the
    result does not depend on thread scheduling), ``"bellhop"`` (Fortran) or a path.
    """
    env = env or BellhopEnv()
    exe = find_executable(executable) if os.sep not in executable else executable
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        s = read_shd(_run(env, exe, Path(tmp), timeout_s, "run.shd"))
    tl = np.stack([s.tl(0, 0, i) for i in range(s.src_depths.size)])
    tl = np.minimum(tl, 300.0)   # shadow zones (p = 0) capped at 300 dB
    attrs = {"model": Path(exe).name, "freq_hz": env.freq_hz, "run_type": env.run_type,
             "ssp_option": env.ssp_option, "bottom": f"halfspace c={env.bottom_speed} "
             f"rho={env.bottom_density} atten={env.bottom_atten}", "depth_m": env.depth_m,
             "description": env.title}
    return TLTable(s.ranges, s.rcv_depths, s.src_depths, tl, attrs)
