"""Docstrings say what the code does: no module docstring over 30 lines, and no commit hash in the
package's source (history and measured figures belong in CHANGELOG.md, results/ and docs/)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
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
