"""Fixtures of the reliability suite (``chains.py``): built once per test process, never written."""

from __future__ import annotations

from pathlib import Path

import pytest

from reliability.chains import CENTRES, Chain, build_chain


@pytest.fixture(scope="session")
def chains(tmp_path_factory) -> dict[str, Chain]:
    base = tmp_path_factory.mktemp("chains")
    return {name: build_chain(base, name) for name in CENTRES}


@pytest.fixture(scope="session")
def chains_root(chains) -> Path:
    """The folder holding both chains (``data/`` and ``runs/``)."""
    return next(iter(chains.values())).scene.parents[1]
