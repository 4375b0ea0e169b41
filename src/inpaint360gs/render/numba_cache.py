"""Where numba keeps its on-disk cache of our compiled kernels (imported before any kernel is defined).

Numba caches beside the sources (``__pycache__``) by default. In a read-only install, and when the
user has not set ``NUMBA_CACHE_DIR``, the cache goes to ``$XDG_CACHE_HOME/inpaint360gs/numba``
(default ``~/.cache/...``) so the first compile is paid once per machine, not per process.
"""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir_for(package_dir: Path, env: dict[str, str]) -> str | None:
    """The cache folder to use: None = numba's default (beside the sources), else a user cache folder."""
    if env.get("NUMBA_CACHE_DIR"):
        return None
    pycache = package_dir / "__pycache__"
    if os.access(pycache if pycache.is_dir() else package_dir, os.W_OK):
        return None
    base = env.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return str(Path(base) / "inpaint360gs" / "numba")


def configure() -> None:
    """Point numba at the cache folder; must run before the kernels are decorated (numba picks the locator then)."""
    target = cache_dir_for(Path(__file__).resolve().parent, dict(os.environ))
    if target is not None:
        import numba.core.config

        os.environ["NUMBA_CACHE_DIR"] = target
        numba.core.config.CACHE_DIR = target


configure()
