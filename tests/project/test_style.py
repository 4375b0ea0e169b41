"""Docstrings say what the code does: no module docstring over 30 lines, no commit hash in the
package's source and no benchmark figures in its comments and docstrings (history and measured
figures belong in CHANGELOG.md, results/ and docs/)."""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SOURCES = sorted((ROOT / "src").rglob("*.py"))
MAX_DOCSTRING_LINES = 30
# 7 to 40 hex digits with a letter and a digit: how a commit hash looks (a file name's checksum, as in
# pt_inception-2015-12-05-6726825d.pth, and a named SHA-256 constant are not one)
HASH = re.compile(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}\b")
FILE_NAME = re.compile(r"[\w.-]+\.(?:pth|pt|onnx|ckpt|bin|npz|ply|png|json|txt)\b")


def _rel(p: Path) -> str:
    return str(p.relative_to(ROOT))


@pytest.mark.parametrize("path", SOURCES, ids=_rel)
def test_module_docstring_is_short(path: Path):
    doc = ast.get_docstring(ast.parse(path.read_text(), filename=str(path)), clean=False) or ""
    assert len(doc.splitlines()) <= MAX_DOCSTRING_LINES, f"{_rel(path)}: module docstring of {len(doc.splitlines())} lines"


def _hashes(text: str) -> list[tuple[int, str]]:
    found = []
    for n, line in enumerate(text.splitlines(), 1):
        if "SHA256" in line:
            continue
        found += [(n, m.group(0)) for m in HASH.finditer(FILE_NAME.sub("", line))]
    return found


@pytest.mark.parametrize("path", SOURCES, ids=_rel)
def test_no_commit_hash(path: Path):
    found = _hashes(path.read_text())
    assert not found, f"{_rel(path)}: commit-hash-like tokens {found} (history goes to CHANGELOG.md)"


def test_the_hash_check_itself():
    assert _hashes("# fixed in 8907571a (see 4f08135)") == [(1, "8907571a"), (1, "4f08135")]
    assert _hashes("weights pt_inception-2015-12-05-6726825d.pth; 1234567 steps; deadbeef") == []


# a benchmark figure in prose: "35 ms", "32.89 dB", "10x faster", "30 % slower", "0.76 s per image",
# "~15 s", or the word "measured" (a comment or docstring says why, with a pointer to results/README.md
# or CHANGELOG.md where the figures are). No allow-list: a word like "scored" says the same in prose.
FIGURE = re.compile(r"\b\d+(?:\.\d+)? ?(?:dB|ms)\b|\b\d+(?:\.\d+)? ?(?:x|×|%) (?:faster|slower)\b|\bmeasured\b"
                    r"|\b\d+(?:\.\d+)?(?:[-–]\d+(?:\.\d+)?)? ?s (?:per|on)\b|~\d+(?:\.\d+)? ?s\b", re.IGNORECASE)


def _prose(path: Path) -> list[tuple[int, str]]:
    """(line, text) of every comment and docstring of a source file."""
    text = path.read_text()
    out = [(t.start[0], t.string) for t in tokenize.generate_tokens(io.StringIO(text).readline) if t.type == tokenize.COMMENT]
    for node in ast.walk(ast.parse(text, filename=str(path))):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
                out += [(body[0].lineno + i, line) for i, line in enumerate(body[0].value.value.splitlines())]
    return out


def _figures(path: Path) -> list[tuple[int, str]]:
    return [(n, m.group(0)) for n, line in _prose(path) for m in FIGURE.finditer(line)]


@pytest.mark.parametrize("path", SOURCES, ids=_rel)
def test_no_benchmark_figures_in_comments(path: Path):
    found = _figures(path)
    assert not found, f"{_rel(path)}: benchmark figures in comments or docstrings {found} (they go to results/README.md or CHANGELOG.md)"


def test_the_figure_check_itself(tmp_path):
    src = tmp_path / "m.py"
    src.write_text('"""Fast: 35 ms -> 2 ms."""\n\n\ndef f():\n    """Measured on cone."""\n    # ~10x faster, 32.89 dB\n'
                   '    return "PSNR (dB)"  # a column title, no figure; 1-17 s on the CPU, ~15 s\n')
    assert sorted(_figures(src)) == [(1, "2 ms"), (1, "35 ms"), (5, "Measured"), (6, "10x faster"), (6, "32.89 dB"), (7, "1-17 s on"), (7, "~15 s")]
