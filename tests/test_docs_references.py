"""Docs that cannot go stale: every file, module and function that README.md, docs/**/*.md and
the package's docstrings name exists, and no pointer leads to a document that is not in the
repository (numbered work items or the old design notes), in the docs, the package (its
shipped TOML files included), the scripts, the tests and the build files.

Checked references:

- file paths (``arrayproc/...``, ``scripts/...``, ``tests/...``, ``docs/...``, a path inside the
  package such as ``chain/reader.py`` or under ``tests/``, relative links between the Markdown
  files) and test names (``tests/x/test_y.py::test_z``);
- dotted names ``arrayproc.x.y`` and ``arrayproc.x.y.name`` (attributes of classes included);
- ``module.name`` forms whose first part is a module of the package that only one module
  path ends with (``schema.groups_of_kind``, ``dsp.framing.FrameBuffer``);
- Sphinx roles with a bare name in a docstring (``:func:`solve```), which must be defined or
  imported in that module.

The checker functions take text, so the last tests plant stale references and check that
they are found.
"""

from __future__ import annotations

import ast
import builtins
import functools
import importlib
import importlib.util
import re
import sys
from pathlib import Path

import pytest

from arrayproc.config import read_toml

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "arrayproc"
TOP = ("arrayproc", "scripts", "tests", "docs")
EXT = "py|md|toml|png|json|jsonl|csv|lock|txt|html|svg"

_PATH = re.compile(rf"(?<![\w/.<>-])((?:\.\./|\./)*[A-Za-z0-9_][\w.-]*(?:/[\w.-]+)*/[\w.-]*"
                   rf"\.(?:{EXT}))\b")
_DIR = re.compile(r"(?<![\w/.-])((?:arrayproc|scripts|tests|docs)/(?:[\w.-]+/)+)(?![\w.])")
_TEST_NAME = re.compile(r"([\w./-]+\.py)::(\w+)")
_DOTTED = re.compile(r"(?<![\w.\"'])(arrayproc(?:\.\w+)+)")  # not a quoted string value
_TICKED = re.compile(r"`{1,2}~?([A-Za-z_][\w]*(?:\.[A-Za-z_]\w*)+)(?:\(\))?`{1,2}")
_ROLE = re.compile(r":(?:func|class|meth|mod|attr|data|obj|exc):`~?([A-Za-z_][\w.]*)`")
# "issue" followed by a number (or a bare number after "#" in brackets), the old design
# notes by name or by section
_POINTER = re.compile(r"(?i:\bissues?\s*#?\d+)|\(#\d+\)|\bDESIGN\b(?:\s*(?:section|§)|\.md)?")


def markdown_files() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def package_files() -> list[Path]:
    return sorted(PKG.rglob("*.py"))


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


@functools.cache
def modules() -> dict[str, Path]:
    """Every module of the package: dotted name -> file."""
    return {_module_name(p): p for p in package_files()}


@functools.cache
def short_names() -> dict[str, str]:
    """Dotted suffixes that only one module ends with (``schema``, ``dsp.fft``) -> module."""
    seen: dict[str, set[str]] = {}
    for mod in modules():
        parts = mod.split(".")
        for i in range(1, len(parts)):
            seen.setdefault(".".join(parts[i:]), set()).add(mod)
    return {k: next(iter(v)) for k, v in seen.items() if len(v) == 1}


@functools.cache
def top_level_names(mod: str) -> frozenset[str]:
    """Names a module defines or imports at its top level (no import is run)."""
    tree = ast.parse(modules()[mod].read_text())
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                names.update(n.id for n in ast.walk(t) if isinstance(n, ast.Name))
        elif isinstance(node, ast.Dict):  # lazy export tables (``_API = {"name": ...}``)
            names.update(k.value for k in node.keys
                         if isinstance(k, ast.Constant) and isinstance(k.value, str))
    return frozenset(names)


def _resolve_in(mod: str, rest: list[str]) -> bool:
    """Is ``mod.rest[0].rest[1]...`` an existing module attribute?"""
    if not rest:
        return True
    if len(rest) == 1 and rest[0] in top_level_names(mod):
        return True
    try:
        obj = importlib.import_module(mod)
    except ImportError as e:  # an optional dependency is missing: trust the static names
        if e.name and not e.name.startswith("arrayproc"):
            return rest[0] in top_level_names(mod)
        raise
    for part in rest:
        if not hasattr(obj, part):  # an instance attribute (``self.nav = ...``) of a class?
            return isinstance(obj, type) and obj.__module__ in modules() \
                and part in _members(obj.__module__)
        obj = getattr(obj, part)
    return True


def resolve_dotted(name: str) -> bool:
    """``arrayproc.x.y[.attr...]``: the longest module prefix, then attributes."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        if ".".join(parts[:i]) in modules():
            return _resolve_in(".".join(parts[:i]), parts[i:])
    return False


def resolve_short(token: str) -> bool | None:
    """``module.name``: True/False when the first part is one of the package's modules,
    None when the token is not a reference to the package (``np.matmul``, ``rec.blocks``)."""
    parts = token.split(".")
    shorts = short_names()
    for i in range(len(parts) - 1, 0, -1):
        key = ".".join(parts[:i])
        if key in toml_tables():  # a key of a configuration table (``tracker.level``)
            return None
        if key in shorts:
            if _resolve_in(shorts[key], parts[i:]):
                return True
            if _other_module(parts[0]):  # ``io.BytesIO``, ``distributed.LocalCluster``
                return None
            return False
    return None


@functools.cache
def toml_tables() -> frozenset[str]:
    """Names of the tables in the shipped TOML files (``stage``, ``beams``, ``tracker``): a
    ``table.key`` token is a configuration key, not a module attribute."""
    names: set[str] = set()

    def walk(d: dict) -> None:
        for k, v in d.items():
            if isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
                names.add(k)
                for x in v:
                    walk(x)
            elif isinstance(v, dict):
                names.add(k)
                walk(v)

    for f in sorted((PKG / "data").rglob("*.toml")):
        walk(read_toml(f, "shipped TOML")[0])
    return frozenset(names)


@functools.cache
def _other_module(name: str) -> bool:
    """Is ``name`` also a top-level module outside the package (stdlib or installed)?"""
    return name in sys.stdlib_module_names or importlib.util.find_spec(name) is not None


def stale_paths(text: str, base: Path) -> list[str]:
    """File paths in ``text`` (written in ``base``'s folder) that do not exist."""
    out = []
    for m in _PATH.finditer(text):
        p = m.group(1)
        first = Path(p).parts[0]
        if p.startswith("../shared/data/"):  # the field recordings beside a checkout
            continue
        if first in TOP:
            candidates = [ROOT / p]
        elif (PKG / first).is_dir():  # inside the package, or its mirror under tests/
            candidates = [PKG / p, ROOT / "tests" / p, base.parent / p]
        elif p.startswith(".") or base.suffix == ".md" and (base.parent / first).exists():
            candidates = [base.parent / p]
        else:  # not a path of the repository (an example output such as ``out/rec.h5``)
            continue
        if not any(c.exists() for c in candidates):
            out.append(p)
    out += [d for d in _DIR.findall(text) if not (ROOT / d).is_dir()]
    for path, name in _TEST_NAME.findall(text):  # ``tests/x/test_y.py::test_z``
        files = [ROOT / path, ROOT / "tests" / path, base.parent / path]
        f = next((f for f in files if f.is_file()), None)
        if f is not None and not re.search(rf"^\s*(?:async\s+)?(?:def|class)\s+{name}\b",
                                           f.read_text(), re.M):
            out.append(f"{path}::{name}")
    return out


def stale_names(text: str) -> list[str]:
    """Dotted names of the package and ``module.name`` forms in ``text`` that do not resolve."""
    out = [n for n in _DOTTED.findall(text)
           if not re.fullmatch(EXT + "|yaml|yml|h5|wav", n.rsplit(".", 1)[1])
           and not resolve_dotted(n)]
    for token in _TICKED.findall(text):
        if token.startswith("arrayproc.") or re.fullmatch(EXT, token.rsplit(".", 1)[1]):
            continue  # checked above, or a file name
        if resolve_short(token) is False:
            out.append(token)
    return out


def docstrings(path: Path) -> list[tuple[str, str]]:
    """(where, docstring) of a module and of its classes and functions."""
    tree = ast.parse(path.read_text())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                out.append((getattr(node, "name", "module"), doc))
    return out


def stale_roles(doc: str, mod: str) -> list[str]:
    """Sphinx roles naming a bare name that the module neither defines nor imports."""
    out = []
    for name in _ROLE.findall(doc):
        if name.startswith("arrayproc."):
            continue
        if "." in name:
            if resolve_short(name) is False:
                out.append(name)
        elif not (name in top_level_names(mod) or name in _members(mod)
                  or hasattr(builtins, name) or _sibling(mod, name) or _inherited(mod, name)):
            out.append(name)
    return out


@functools.cache
def _members(mod: str) -> frozenset[str]:
    """Methods, class attributes and ``self.x`` attributes of the module's classes."""
    tree = ast.parse(modules()[mod].read_text())
    names: set[str] = set()
    for c in ast.walk(tree):
        if not isinstance(c, ast.ClassDef):
            continue
        for n in c.body:
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)):
                names.add(n.name)
            elif isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name):
                names.add(n.target.id)
            elif isinstance(n, ast.Assign):
                names.update(t.id for t in n.targets if isinstance(t, ast.Name))
        names.update(a.attr for a in ast.walk(c) if isinstance(a, ast.Attribute)
                     and isinstance(a.value, ast.Name) and a.value.id == "self")
    return frozenset(names)


def _sibling(mod: str, name: str) -> bool:
    """A module of the same package (``:mod:`_covariance``` in ``stages/beamform``)."""
    package = mod if modules()[mod].name == "__init__.py" else mod.rpartition(".")[0]
    return f"{package}.{name}" in modules()


def _inherited(mod: str, name: str) -> bool:
    """A method or attribute that a class of the module inherits (``flush`` of a writer)."""
    try:
        obj = importlib.import_module(mod)
    except ImportError:
        return False
    return any(hasattr(c, name) for c in vars(obj).values()
               if isinstance(c, type) and c.__module__ == mod)


def pointers(text: str) -> list[str]:
    return [m.group(0) for m in _POINTER.finditer(text)]


# ---------------------------------------------------------------------------------------------

def _rel(p: Path) -> str:
    return str(p.relative_to(ROOT))


@pytest.mark.parametrize("path", markdown_files(), ids=_rel)
def test_markdown_names_only_what_exists(path):
    text = path.read_text()
    stale = stale_paths(text, path) + stale_names(text)
    assert not stale, f"{_rel(path)} names what does not exist: {sorted(set(stale))}"


def test_package_names_only_what_exists():
    stale = []
    for path in package_files():
        mod = _module_name(path)
        stale += [f"{_rel(path)}: {p}" for p in stale_paths(path.read_text(), path)]
        for where, doc in docstrings(path):
            stale += [f"{_rel(path)} ({where}): {n}"
                      for n in stale_names(doc) + stale_roles(doc, mod)]
    assert not stale, "stale references in the package:\n" + "\n".join(sorted(set(stale)))


def test_scripts_and_tests_name_only_what_exists():
    stale = []
    for d in ("scripts", "tests"):
        for path in sorted((ROOT / d).rglob("*.py")):
            if path == Path(__file__).resolve():
                continue  # the planted references below
            stale += [f"{_rel(path)}: {p}" for p in stale_paths(path.read_text(), path)]
            stale += [f"{_rel(path)} ({where}): {n}"
                      for where, doc in docstrings(path) for n in stale_names(doc)]
    assert not stale, "stale references:\n" + "\n".join(sorted(set(stale)))


def test_no_pointer_to_documents_outside_the_repository():
    files = markdown_files() + [ROOT / "pyproject.toml", ROOT / "Makefile"] + [
        f for d in ("arrayproc", "scripts", "tests") for ext in ("py", "toml")
        for f in sorted((ROOT / d).rglob(f"*.{ext}"))]
    found = [f"{_rel(f)}: {p}" for f in files for p in pointers(f.read_text())]
    assert not found, f"{len(found)} pointers:\n" + "\n".join(found)


# the checker itself: planted stale references are found, real ones pass --------------------

def test_checker_finds_planted_stale_references():
    base = ROOT / "docs" / "architecture.md"
    text = ("See `arrayproc/workers.py`, tests/test_no_such.py, `chain/no_such.py`, docs/none/,\n"
            "[x](no_such.md), `tests/test_layers.py::test_no_such`, `arrayproc.dsp.no_such`,\n"
            "`arrayproc.io.recording.NoSuch`,\n"
            "`schema.no_such_function` and ``dsp.fft.NoPlan``.")
    assert sorted(stale_paths(text, base)) == ["arrayproc/workers.py", "chain/no_such.py",
                                               "docs/none/", "tests/test_layers.py::test_no_such",
                                               "tests/test_no_such.py"]
    assert stale_names(text) == ["arrayproc.dsp.no_such", "arrayproc.io.recording.NoSuch",
                                 "schema.no_such_function", "dsp.fft.NoPlan"]
    assert stale_roles(":func:`no_such` and :class:`Recording`", "arrayproc.io.recording") \
        == ["no_such"]
    assert stale_roles(":mod:`no_such_sibling`", "arrayproc.stages.beamform.cbf") \
        == ["no_such_sibling"]
    design = "DESI" + "GN"  # spelt in two so that this file passes its own test
    planted = (f"as in iss{'ue'} 12 and {design} section 5, see {design}.md; {design} § 3; "
               f"Iss{'ues'} 12-19; ({design} 5, {design}\n section 2); a design note")
    assert pointers(planted) == [f"iss{'ue'} 12", f"{design} section", f"{design}.md",
                                 f"{design} §", f"Iss{'ues'} 12", design, f"{design}\n section"]


def test_checker_accepts_what_exists():
    base = ROOT / "docs" / "architecture.md"
    text = ("`arrayproc/dsp/workers.py`, tests/test_layers.py, `chain/reader.py`, "
            "`test_docs_references.py::test_checker_accepts_what_exists`, "
            "[t](architecture/tracking.md), arrayproc/track/models/, "
            "`arrayproc.dsp.fft.BufferedPlan`, "
            "`arrayproc.io.recording.Recording.read`, `schema.groups_of_kind`, `np.matmul`, "
            "`out/rec.h5`, ``io.BytesIO``, `tracker.level`, ``stage.beam_axis``")
    assert stale_paths(text, base) == []
    assert stale_names(text) == []
    assert stale_roles(":mod:`atomic` and :func:`open_h5`", "arrayproc.io.recording") == []
    # the writer's docstring (io/recording_writer.py): ``flush`` inherited from AtomicH5Writer
    assert stale_roles(":mod:`atomic` and :meth:`flush`", "arrayproc.io.recording_writer") == []
    assert stale_roles(":mod:`_kernels`", "arrayproc.stages.beamform.cbf") == []
