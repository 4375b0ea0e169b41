"""Atomic writers leave nothing behind when interrupted, even between creating the temporary and
learning its name (an interruption there once left a ``.train_log.csv.<pid>.<random>.tmp.csv``)."""

from __future__ import annotations

import tempfile

import pytest

from inpaint360gs.io.atomic import atomic_dir, atomic_path


@pytest.mark.parametrize("which", ["path", "dir"])
def test_interrupt_right_after_the_temporary_is_created_leaves_nothing(tmp_path, monkeypatch, which):
    real = tempfile.mkstemp if which == "path" else tempfile.mkdtemp

    def interrupted(*args, **kwargs):
        real(*args, **kwargs)  # the temporary exists ...
        raise KeyboardInterrupt  # ... and the interruption lands before its name is returned

    monkeypatch.setattr(tempfile, "mkstemp" if which == "path" else "mkdtemp", interrupted)
    writer = atomic_path(tmp_path / "log.csv") if which == "path" else atomic_dir(tmp_path / "out")
    with pytest.raises(KeyboardInterrupt):
        with writer:
            pass
    assert list(tmp_path.iterdir()) == []


def test_an_interrupted_writer_keeps_the_published_file_and_other_targets_temporaries(tmp_path):
    (tmp_path / "log.csv").write_text("old\n")
    with atomic_path(tmp_path / "log.csv.bak") as other:  # another target's temporary, in progress
        other.write_text("x")
        with pytest.raises(KeyboardInterrupt):
            with atomic_path(tmp_path / "log.csv") as tmp:
                tmp.write_text("new\n")
                raise KeyboardInterrupt
        assert other.exists()
    assert (tmp_path / "log.csv").read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log.csv", "log.csv.bak"]
