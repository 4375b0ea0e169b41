"""Bad-input cases for the CLIs, run in-process (docs/architecture.md, "Reliability").

A :class:`Case` prepares its inputs under a fresh folder and returns the command line and the text
(a file or an argument) the error line must name. :func:`check` runs it and asserts what every CLI
stage promises for bad input: the documented exit code, exactly one line on stderr that starts with
``<prog> <stage>:`` and names the offender, no traceback anywhere, and no change to any folder the
case touched (no new file, no ``.*.tmp*`` debris, a previous output left as it was).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from dataset_tools.cli import main as dataset_main
from inpaint360gs.cli import main as method_main
from inpaint360gs.core.errors import EXIT_INPUT

MAINS = {"inpaint360gs": method_main, "inpaint360gs-dataset": dataset_main}
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


@pytest.fixture(scope="module", autouse=True)
def restore_threads():
    """In-process ``train``/``render`` set torch's thread count (``--threads``): give the old one back.
    Autouse in every module that imports it."""
    import torch

    old = torch.get_num_threads()
    yield
    torch.set_num_threads(old)


@dataclass
class Ctx:
    """What a case's ``make`` gets: its own folder and the shared (read-only) fixtures."""

    tmp: Path
    request: pytest.FixtureRequest
    watched: list[Path] = field(default_factory=list)
    _readonly: list[Path] = field(default_factory=list)

    def fx(self, name: str) -> str:
        """Path of a module fixture (a scene folder, a model, ...); watched for changes too."""
        p = Path(self.request.getfixturevalue(name))
        self.watched.append(p if p.is_dir() else p.parent)
        return str(p)

    def path(self, rel: str) -> str:
        return str(self.tmp / rel)

    def file(self, rel: str, data: bytes | str = b"x") -> str:
        p = self.tmp / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data.encode() if isinstance(data, str) else data)
        return str(p)

    def dir(self, rel: str) -> str:
        (self.tmp / rel).mkdir(parents=True, exist_ok=True)
        return str(self.tmp / rel)

    def copy(self, name: str, rel: str | None = None) -> Path:
        """A private copy of fixture ``name`` to break (under this case's folder)."""
        src = Path(self.request.getfixturevalue(name))
        dst = self.tmp / (rel or src.name)
        shutil.copytree(src, dst) if src.is_dir() else shutil.copy2(src, dst)
        return dst

    def broken(self, name: str, fn) -> tuple[Path, Path]:
        """A private copy of fixture ``name`` passed through ``fn(root)``; returns (root, what ``fn``
        returned: the file or folder the error must name; the copy itself when ``fn`` returns None)."""
        root = self.copy(name)
        named = fn(root) if fn else None
        return root, root if named is None else named

    def readonly(self, rel: str) -> str:
        p = self.tmp / rel
        p.mkdir(parents=True, exist_ok=True)
        p.chmod(0o555)
        self._readonly.append(p)
        return str(p)

    def restore(self) -> None:
        for p in self._readonly:
            p.chmod(0o755)


@dataclass(frozen=True)
class Case:
    """``make(ctx) -> (argv, named)``: the command line and the text its error line must contain (a
    tuple: every one of them)."""

    id: str
    prog: str
    make: Callable[[Ctx], tuple[list[str], str]]
    code: int = EXIT_INPUT
    needs_permissions: bool = False  # read-only folders: meaningless as root

    @property
    def param(self):
        marks = [pytest.mark.skipif(IS_ROOT, reason="root ignores permissions")] if self.needs_permissions else []
        return pytest.param(self, id=self.id, marks=marks)


# --- ways to spoil an input; each returns the path the error must name --------------------------


def put(path: Path, data: bytes | str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def truncate(path: Path, keep: float = 0.5) -> Path:
    return put(path, path.read_bytes()[: int(path.stat().st_size * keep)])


def remove(path: Path, named: Path | None = None) -> Path:
    shutil.rmtree(path) if path.is_dir() else path.unlink()
    return named or path


def duplicate(src: Path, dst: Path) -> Path:
    """A byte-identical copy of ``src`` at ``dst``."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(src, dst)
    return dst


def garbage_count(sparse: Path) -> Path:
    """A points3D.bin whose header claims 10^12 points (pycolmap would allocate for minutes)."""
    return put(sparse / "points3D.bin", struct.pack("<Q", 10**12) + bytes(64))


def option_cases(prog: str, stage: str, argv: Callable[[Ctx, tuple[str, ...]], list[str]], table: dict[str, tuple]) -> list[Case]:
    """One case per ``table`` entry ``name: (args...)`` or ``name: ((args...), named)``: the command line
    ``argv(c, args)``, whose error must name ``named`` (default: the first flag, without its ``=value``)."""

    def make_for(args: tuple[str, ...], named: str):
        return lambda c: (argv(c, args), named)

    cases = []
    for name, entry in table.items():
        args, named = entry if isinstance(entry[0], tuple) else (entry, entry[0].split("=")[0])
        cases.append(Case(f"{stage}-{name}", prog, make_for(args, named)))
    return cases


# --- the ways an output folder argument can be wrong: (OUT to pass, what the error must name) --------


def _out_is_file(c: Ctx) -> tuple[str, str]:
    return c.file("out"), c.path("out")


def _out_under_file(c: Ctx) -> tuple[str, str]:
    return c.file("f") + "/out", c.path("f")


def _out_not_empty(c: Ctx) -> tuple[str, str]:
    c.file("out/keep.txt", "precious")
    return c.path("out"), c.path("out")


def _out_readonly(c: Ctx) -> tuple[str, str]:
    ro = c.readonly("ro")
    return ro + "/out", ro


BAD_OUTPUTS = {"out-is-file": _out_is_file, "out-under-file": _out_under_file, "out-exists": _out_not_empty, "out-readonly": _out_readonly}


def out_cases(prog: str, stage: str, before: Callable[[Ctx], list[str]], after: tuple[str, ...] = (),
              kinds: tuple[str, ...] = tuple(BAD_OUTPUTS)) -> list[Case]:
    """One case per wrong output folder in ``kinds``: ``before(c) + [OUT] + after``."""

    def make_for(bad):
        def make(c):
            out, named = bad(c)
            return [*before(c), out, *after], named

        return make

    return [Case(f"{stage}-{k}", prog, make_for(BAD_OUTPUTS[k]), needs_permissions=k == "out-readonly") for k in kinds]


def tree(root: Path) -> dict[str, tuple]:
    """Every entry under ``root`` (hidden ones too) -> (kind, mode, content hash)."""
    out = {}
    if not root.exists():
        return out
    for p in sorted(root.rglob("*")):
        st = p.lstat()
        digest = hashlib.sha256(p.read_bytes()).hexdigest() if stat.S_ISREG(st.st_mode) else ""
        out[str(p.relative_to(root))] = (stat.S_IFMT(st.st_mode), stat.S_IMODE(st.st_mode), digest)
    return out


def run_cli(prog: str, argv: list[str], capsys) -> tuple[int, str, str]:
    capsys.readouterr()
    code = MAINS[prog](argv)
    out, err = capsys.readouterr()
    return code, out, err


def check(case: Case, tmp_path: Path, request: pytest.FixtureRequest, capsys) -> str:
    """Run ``case``; assert the promises listed in the module docstring; return the error line."""
    ctx = Ctx(tmp_path / "case", request)
    ctx.tmp.mkdir()
    try:
        argv, named = case.make(ctx)
        roots = [ctx.tmp, *dict.fromkeys(ctx.watched)]
        before = {r: tree(r) for r in roots}
        code, out, err = run_cli(case.prog, argv, capsys)
        after = {r: tree(r) for r in roots}
    finally:
        ctx.restore()
    lines = err.strip().splitlines()
    changed = {r: sorted(k for k in before[r].keys() | after[r].keys() if before[r].get(k) != after[r].get(k)) for r in roots}
    if os.environ.get("BAD_INPUT_LOG"):  # one row per case (outcome and line), to read them all at once
        with open(os.environ["BAD_INPUT_LOG"], "a") as f:
            f.write("\t".join([case.id, str(code), str(len(lines)), str("Traceback" in out + err), str(any(changed.values())),
                                " | ".join(lines)]) + "\n")
    assert "Traceback" not in out + err, err
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}:\n{err}"
    line = lines[0]
    assert line.startswith(f"{case.prog} {argv[0]}: "), line
    for name in named if isinstance(named, tuple) else (named,):
        assert str(name) in line, f"{name!r} not named in: {line}"
    assert code == case.code, f"exit {code}, expected {case.code}: {line}"
    for r in roots:
        assert not changed[r], f"{line}\nchanged under {r}: {changed[r][:8]}"
    return line


def ids_unique(cases: list[Case]) -> list:
    ids = [c.id for c in cases]
    assert len(ids) == len(set(ids)), sorted(i for i in ids if ids.count(i) > 1)
    return [c.param for c in cases]
