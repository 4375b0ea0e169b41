"""Provenance of the committed tables."""

from __future__ import annotations


def test_git_commit_provenance_ignores_results(tmp_path, monkeypatch):
    import subprocess

    from inpaint360gs.report.provenance import git_commit

    def git(*a):
        subprocess.run(["git", *a], cwd=tmp_path, check=True, capture_output=True)

    git("init", "-q")
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "t.md").write_text("old")
    (tmp_path / "code.py").write_text("x = 1")
    git("add", ".")
    git("-c", "user.email=a@b", "-c", "user.name=a", "commit", "-qm", "init")
    monkeypatch.chdir(tmp_path)
    clean = git_commit()
    assert len(clean) >= 7 and not clean.endswith("-dirty")
    (tmp_path / "results" / "t.md").unlink()  # Snakemake removes a job's outputs before rerunning it
    assert git_commit() == clean
    (tmp_path / "code.py").write_text("x = 2")
    assert git_commit() == clean + "-dirty"
