"""Package exports imported on first use (PEP 562): a package's ``__init__`` names what it exports
and from which of its modules, and importing the package (or one light module of it, such as its
settings) does not load the rest."""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module


def lazy_exports(package: str, exports: dict[str, str], namespace: dict) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package``: each name of ``exports`` (name -> module of the
    package) is read from ``package.<module>`` when first asked for; ``namespace`` is the package's
    ``globals()``. Another name raises :class:`AttributeError`."""

    def __getattr__(name: str):
        if name in exports:
            return getattr(import_module(f"{package}.{exports[name]}"), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(exports))

    return __getattr__, __dir__
