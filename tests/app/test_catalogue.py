"""``arrayproc stages [TYPE]``, ``-c NAME`` and the stage signatures and docstrings generated
from the declared keys."""

from __future__ import annotations

import inspect

import pytest

import arrayproc as ap
from arrayproc.app.catalogue import SHIPPED, resolve_config, shipped_names
from arrayproc.app.cli import main
from arrayproc.chain.stage import STAGES
from arrayproc.data import data_path
from arrayproc.errors import ConfigError
from arrayproc.stages import load_all

load_all()


def run(args, capsys):
    rc = main(list(args))
    out, err = capsys.readouterr()
    return rc, out, err


def test_stages_lists_every_type_with_domains(capsys):
    rc, out, err = run(["stages"], capsys)
    assert rc == 0 and not err
    lines = out.splitlines()
    assert [ln.split()[0] for ln in lines] == sorted(STAGES)
    cbf = next(ln for ln in lines if ln.startswith("cbf "))
    assert "time -> beams" in cbf and "beamformer" in cbf


@pytest.mark.parametrize("kind", sorted(STAGES))
def test_stage_keys_list_every_key(kind, capsys):
    rc, out, _ = run(["stages", kind], capsys)
    assert rc == 0
    keys = [ln.split()[0] for ln in out.splitlines()[3:]]
    assert keys == list(STAGES[kind].params) or (keys == ["keys"] and not STAGES[kind].params)
    for k, p in STAGES[kind].params.items():
        row = next(ln for ln in out.splitlines() if ln.split()[0] == k)
        assert p.default_text in row and (p.unit or "-") in row


def test_unknown_stage_type_is_one_line(capsys):
    rc, out, err = run(["stages", "cbff"], capsys)
    assert rc == 2 and not out
    assert err.count("\n") == 1 and "no stage type 'cbff' (known: " in err
    assert "active_beams, " in err


def test_shipped_name_resolves(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for folder, what in set(SHIPPED.values()):
        names = shipped_names(folder)
        assert names, folder
        assert resolve_config(names[0], folder, what) == str(data_path(folder, names[0] + ".toml"))
        assert resolve_config(names[0] + ".toml", folder, what).endswith(names[0] + ".toml")


def test_existing_path_wins_over_a_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "towed_passive").write_text("")
    assert resolve_config("towed_passive", "chains", "chain") == "towed_passive"
    assert resolve_config("sub/none.toml", "chains", "chain") == "sub/none.toml"


def test_unknown_name_lists_the_shipped_ones(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match="shipped: .*towed_passive"):
        resolve_config("towed_pasive", "chains", "chain")
    rc, out, err = run(["track", "x.h5", "-c", "nosuch", "-o", "t.h5"], capsys)
    assert rc == 2 and err.count("\n") == 1
    assert "nosuch: no such tracker file, nor a shipped tracker (shipped: " in err
    assert not list(tmp_path.iterdir())


def test_process_by_chain_name(tmp_path, rng, capsys):
    import numpy as np

    from arrayproc.io.geometry import line_array
    from tests.conftest import write_recording
    x = rng.standard_normal((8192, 4)).astype(np.float32)
    rec = write_recording(tmp_path / "rec.h5", x, fs=4000.0, positions=line_array(4, 0.5))
    rc, _, err = run(["process", str(rec), "-c", "power", "-o", str(tmp_path / "p.h5"), "-q"],
                     capsys)
    assert rc == 0, err
    assert (tmp_path / "p.h5").exists()


@pytest.mark.parametrize("kind", sorted(STAGES))
def test_signature_and_docstring_from_the_declarations(kind):
    cls = STAGES[kind]
    sig = inspect.signature(cls)
    assert list(sig.parameters) == ["name", *cls.params]
    for k, p in cls.params.items():
        par = sig.parameters[k]
        assert par.kind is inspect.Parameter.KEYWORD_ONLY
        assert (par.default is inspect.Parameter.empty) == p.required
    doc = inspect.getdoc(cls)
    assert "Parameters\n----------" in doc
    for k, p in cls.params.items():
        head = next(ln for ln in doc.splitlines() if ln.startswith(f"{k} : "))
        assert (p.unit in head) and (("required" in head) == p.required)
    assert inspect.signature(cls.__init__).parameters.keys() - {"self"} == sig.parameters.keys()


def test_help_of_cbf_lists_keys_not_values():
    import pydoc
    text = pydoc.render_doc(ap.CBF, renderer=pydoc.plaintext)
    assert "**values" not in text
    assert "nfft : int, default 2048, samples" in text
    assert "band : [lo, hi], optional, Hz" in text


def test_help_says_a_shipped_name_is_accepted(capsys):
    for cmd in ("process", "track", "tma", "simulate", "batch"):
        with pytest.raises(SystemExit):
            main([cmd, "--help"])
        out = " ".join(capsys.readouterr().out.split())
        assert "or the name of a shipped one" in out, cmd
