"""The benchmark scripts are run by hand, not by the tests: at least each must parse."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted((ROOT / "benchmarks").glob("*.py"))


@pytest.mark.parametrize("path", SCRIPTS, ids=lambda p: p.name)
def test_benchmark_script_parses_and_has_a_docstring(path):
    tree = ast.parse(path.read_text(), filename=str(path))
    assert ast.get_docstring(tree), f"{path.name}: no module docstring saying what it measures and how to run it"


def test_the_scripts_are_found():
    assert len(SCRIPTS) >= 10 and any(p.name == "bench_removal_seeds.py" for p in SCRIPTS)
