"""The README's "A five-minute tour" runs as written, from an empty folder outside the
checkout, and writes nothing into the checkout; the shipped TOML files' comments name paths
that exist.

The default suite checks that every command of the tour parses (the CLI accepts its flags) and
that every file it names exists, either shipped or made by an earlier line of the tour; the
slow tests run the tour's shell blocks with bash in a temporary folder (the field-data block
only when the six-hydrophone recording is beside the checkout)."""

from __future__ import annotations

import fnmatch
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from arrayproc.app.cli import build_parser
from arrayproc.config import tomllib
from arrayproc.data import data_path
from tests.conftest import REPO, XAV

README = REPO / "README.md"
DATA = data_path()
LONG = {"simulate", "import", "process", "track", "tma", "batch", "export", "demo"}


# -- reading the tour ---------------------------------------------------------------------------
def tour_blocks() -> list[str]:
    """The ``sh`` blocks of the README section "A five-minute tour", in order."""
    text = README.read_text(encoding="utf-8")
    section = text.split("\n## A five-minute tour\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```sh\n(.*?)```", section, flags=re.S)


def is_field_block(block: str) -> bool:
    return re.search(r"^X=", block, flags=re.M) is not None


def commands(block: str) -> list[str]:
    """The block's commands: continuation lines joined, comments and blank lines dropped,
    ``a && b`` split."""
    joined = re.sub(r"\\\n\s*", " ", block)
    out = []
    for line in joined.splitlines():
        words = shlex.split(line, comments=True)
        if not words:
            continue
        cmd: list[str] = []
        for w in [*words, "&&"]:
            if w == "&&":
                out.append(shlex.join(cmd))
                cmd = []
            else:
                cmd.append(w)
    return out


def expand(word: str, env: dict[str, str]) -> str:
    return re.sub(r"\$(\w+)", lambda m: env[m[1]], word)


# -- every command parses, every file it names exists ------------------------------------------
def check_tour_commands(blocks: list[str], xav: Path | None) -> list[str]:
    """Walk the tour as the shell would, without running it: returns the outputs it makes.
    Fails on a command the CLI refuses, an input neither shipped nor made before, or a shell
    command other than the few the tour needs (so this check stays exact)."""
    parser = build_parser()
    env: dict[str, str] = {}
    made: set[str] = set()
    for block in blocks:
        if is_field_block(block) and xav is None:
            continue
        for cmd in commands(block):
            w = shlex.split(cmd)
            if w[0].startswith("D="):
                assert w == ["D=$(arrayproc", "data-dir)"], cmd
                env["D"] = str(DATA)
                continue
            if w[0].startswith("X="):
                env["X"] = str(xav)
                continue
            w = [expand(x, env) for x in w]
            if w[0] == "mkdir":
                assert w[1] == "-p", cmd
                made.update(d + "/" for d in w[2:])
                continue
            if w[0] == "cp":
                assert w[1] in made, f"{cmd}: {w[1]} is made by no earlier line"
                made.add(w[2])
                continue
            assert w[0] == "arrayproc", f"{cmd}: the tour runs arrayproc, mkdir and cp only"
            check_arrayproc(parser, w[1:], made, cmd)
    return sorted(made)


def check_arrayproc(parser, argv: list[str], made: set[str], cmd: str) -> None:
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # the CLI refused the flags
        pytest.fail(f"{cmd}: arrayproc refuses it (exit {e.code})")
    for key in ("chain", "config", "scenario", "geometry"):
        p = getattr(args, key, None)
        if p:
            assert Path(p).is_file(), f"{cmd}: {p} does not exist"
    ins = {"process": ["recording"], "info": ["file"], "plot": ["file"], "track": ["products"],
           "tma": ["products"], "export": ["files"], "import": ["wav"], "batch": ["inputs"]}
    for key in ins.get(args.command, []):
        v = getattr(args, key)
        for p in v if isinstance(v, list) else [v]:
            if args.command == "import":  # the shell expands the pattern: six mono WAVs
                n = len(list(Path(p).parent.glob(Path(p).name))) if "*" in p else \
                    int(Path(p).is_file())
                assert n == (6 if "*" in p else 1), f"{cmd}: {p} matches {n} files"
                continue
            ok = p in made or any(fnmatch.fnmatch(m, p) for m in made)
            assert ok, f"{cmd}: {p} is made by no earlier line of the tour"
    out = getattr(args, "output", None)
    if out:
        made.add(out)
        parent = str(Path(out).parent)
        assert parent == "." or parent + "/" in made or out.endswith("/"), \
            f"{cmd}: the folder of {out} is made by no earlier line"


def test_tour_commands_parse_and_name_existing_files():
    blocks = tour_blocks()
    assert len(blocks) >= 4
    made = check_tour_commands(blocks, XAV if XAV.is_dir() else None)
    for f in ("tma.h5", "tdoa_tracks.h5", "tracks.rep", "active_tracks.h5", "out/"):
        assert f in made


def test_tour_starts_with_the_data_folder_and_never_names_the_checkout():
    """``D`` comes from ``arrayproc data-dir`` (any folder), not from a path relative to the
    checkout; nothing activates a virtual environment of the current folder."""
    text = "\n".join(tour_blocks())
    assert text.startswith("D=$(arrayproc data-dir)\n")
    assert "arrayproc/data" not in text and ".venv" not in text


def test_data_dir_prints_the_bundled_folder(capsys):
    from arrayproc.app.cli import main
    assert main(["data-dir"]) == 0
    out = capsys.readouterr().out
    assert out == f"{DATA}\n"
    assert (Path(out.strip()) / "chains" / "towed_passive.toml").is_file()


# -- the shipped TOML comments ------------------------------------------------------------------
DD = "$(arrayproc data-dir)"
FILE_RE = re.compile(r"[\w<>./-]*\w\.(?:toml|md|py|csv|json)\b")


def shipped_tomls() -> list[Path]:
    return sorted(DATA.rglob("*.toml"))


def comment_lines(path: Path) -> list[str]:
    return [ln.split("#", 1)[1] for ln in path.read_text(encoding="utf-8").splitlines()
            if "#" in ln]


@pytest.mark.parametrize("path", shipped_tomls(), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_shipped_toml_comments_name_existing_paths(path):
    """A file named in a comment is ``$(arrayproc data-dir)/…`` (shipped), a project path
    (``docs/``, ``tests/``, ``scripts/``, ``arrayproc/``) that exists in the checkout, or a bare
    name of a shipped file; every ``arrayproc`` command shown parses."""
    tomllib.loads(path.read_text(encoding="utf-8"))
    parser = build_parser()
    for line in comment_lines(path):
        for name in FILE_RE.findall(line.replace(DD, "<data>")):
            if name.startswith("<data>/"):
                assert (DATA / name[len("<data>/"):]).is_file(), f"{path.name}: {name}"
            elif name.split("/")[0] in ("docs", "tests", "scripts", "arrayproc"):
                assert (REPO / name).exists(), f"{path.name}: {name}"
            else:
                assert "/" not in name, f"{path.name}: {name} is relative to no folder"
                assert any(DATA.rglob(name)), f"{path.name}: {name}"
        words = line.replace(DD, str(DATA)).split()
        if words[:1] == ["arrayproc"]:
            argv = words[1:]
            try:
                args = parser.parse_args(argv)
            except SystemExit:
                pytest.fail(f"{path.name}: {line.strip()}: arrayproc refuses it")
            for key in ("chain", "config", "scenario"):
                p = getattr(args, key, None)
                if p:
                    assert Path(p).is_file(), f"{path.name}: {line.strip()}"


# -- running the tour ---------------------------------------------------------------------------
def repo_files() -> dict[str, int]:
    """Every file of the checkout outside hidden folders and ``__pycache__`` (where Python and
    numba cache compiled code) and its modification time."""
    out = {}
    for d, dirs, files in os.walk(REPO):
        dirs[:] = [x for x in dirs if not x.startswith(".") and x != "__pycache__"]
        for f in files:
            p = Path(d, f)
            out[str(p.relative_to(REPO))] = p.stat().st_mtime_ns
    return out


def run_tour(blocks: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """The blocks as one bash script (stop at the first failure) in ``cwd``, with this
    interpreter's ``arrayproc`` on the PATH and this checkout's package first."""
    script = "set -euo pipefail\n" + "\n".join(blocks)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    env.pop("ARRAYPROC_XAV", None)
    bindir = Path(sys.executable).parent
    if (bindir / "arrayproc").is_file():
        env["PATH"] = f"{bindir}{os.pathsep}{env.get('PATH', '')}"
    else:  # e.g. an interpreter without the entry point: the same command through -m
        script = f'arrayproc() {{ "{sys.executable}" -m arrayproc "$@"; }}\n' + script
    return subprocess.run(["bash", "-c", script], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=3600)


def summaries(stdout: str) -> dict[str, str]:
    return {m[1]: m[0] for m in re.finditer(r"^arrayproc: wrote (\S+) .*$", stdout, re.M)}


def check_summaries(blocks: list[str], stdout: str) -> None:
    """Every long command of the blocks printed its summary line (stdout is a pipe here)."""
    written = {k.rstrip("/") for k in summaries(stdout)}
    for block in blocks:
        for cmd in commands(block):
            w = shlex.split(cmd)
            if w[0] == "arrayproc" and w[1] in LONG:
                assert w[w.index("-o") + 1].rstrip("/") in written, (cmd, stdout)


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
def test_tour_runs_as_written(tmp_path):
    """Every block but the field data's, in order, in an empty folder: exit 0, every output
    made, a summary line per long command, the TMA and the TDOA tracker within 3 sigma of the
    static source, and the checkout unchanged."""
    import numpy as np

    from arrayproc.io.products import read_products
    blocks = [b for b in tour_blocks() if not is_field_block(b)]
    made = check_tour_commands(blocks, None)
    before = repo_files()
    work = tmp_path / "tour"
    work.mkdir()
    r = run_tour(blocks, work)
    assert r.returncode == 0, r.stderr[-3000:]
    for m in made:
        assert (work / m).exists(), m
    check_summaries(blocks, r.stdout)
    assert repo_files() == before, "the tour wrote into the checkout"

    scn = tomllib.loads((DATA / "scenarios" / "towed_static_source.toml").read_text())
    truth = np.array(scn["source"][0]["start"])
    tma = read_products(work / "tma.h5")["tma"]
    err = np.array([tma["x"][0], tma["y"][0]]) - truth
    sig = np.sqrt(np.diagonal(tma["crlb"][0])[:2])
    assert np.all(np.abs(err) < 3 * sig), (err, sig)
    trk = read_products(work / "tdoa_tracks.h5")["tracks"]
    err = np.array([trk["x"][-1], trk["y"][-1]]) - truth
    sig = np.sqrt(np.diagonal(trk["cov"][-1])[:2])
    assert np.all(np.abs(err) < 3 * sig), (err, sig)


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
@pytest.mark.skipif(not XAV.is_dir(), reason=f"the six-hydrophone recording is not at {XAV}")
def test_tour_field_data_runs(tmp_path):
    """The field-data block with ``X`` set to the recording beside the checkout (the README's
    ``../shared/data/xav-large-array`` seen from the checkout's folder)."""
    first, field = tour_blocks()[0], next(b for b in tour_blocks() if is_field_block(b))
    d_line = first.splitlines()[0]
    field = re.sub(r"^X=.*$", f"X={shlex.quote(str(XAV))}", field, count=1, flags=re.M)
    before = repo_files()
    r = run_tour([d_line, field], tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert (tmp_path / "positions.png").is_file()
    check_summaries([field], r.stdout)
    assert repo_files() == before
