"""File helpers every floor uses."""

from __future__ import annotations

import hashlib
from pathlib import Path


def sha256_file(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes, read in 1 MiB blocks (stage records identify inputs by it)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def read_json_object(path: str | Path) -> dict:
    """A JSON file that must hold an object (a stage record, scene.json); one-line errors otherwise."""
    import json

    from inpaint360gs.core.errors import InputError

    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"not valid JSON ({e})", path) from None
    if not isinstance(data, dict):
        raise InputError(f"{path.name} must hold a JSON object", path)
    return data
