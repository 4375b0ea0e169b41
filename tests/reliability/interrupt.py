"""Run one CLI command and send this process a signal at the N-th call into the package's own code,
counted from the CLI dispatcher (``run_stages``) on: an interruption at a chosen point of the
command, whatever the machine's speed.

``python interrupt.py SIGNAL N COUNT_FILE PROG STAGE ARGS...``: SIGNAL is INT, TERM, KILL or NONE
(run to the end); N the call at which it is sent; COUNT_FILE receives the number of calls made (the
uninterrupted run counts them, so that a test can draw N among them). :func:`run_counted` does the
same inside the calling process.
"""

from __future__ import annotations

import os
import signal
import sys

MARKS = (f"{os.sep}inpaint360gs{os.sep}", f"{os.sep}dataset_tools{os.sep}")


def run_counted(prog: str, argv: list[str], sig: int | None = None, at: int = 0) -> tuple[int, int]:
    """(exit code, calls into the package) of ``prog argv`` run here, ``sig`` sent at call ``at``."""
    if prog == "inpaint360gs":
        from inpaint360gs.cli import main as entry
    else:
        from dataset_tools.cli import main as entry
    calls, armed = 0, False

    def profile(frame, event, arg):
        nonlocal calls, armed
        if event == "call" and armed and any(m in frame.f_code.co_filename for m in MARKS):
            calls += 1
            if calls == at and sig is not None:
                os.kill(os.getpid(), sig)
        armed = armed or (event == "call" and frame.f_code.co_name == "run_stages")  # its signal handlers come first

    sys.setprofile(profile)
    try:
        code = entry(argv)
    finally:
        sys.setprofile(None)
    return code, calls


def main() -> int:
    sig_name, n, count_file, prog, *argv = sys.argv[1:]
    sig = None if sig_name == "NONE" else getattr(signal, f"SIG{sig_name}")
    code, calls = run_counted(prog, argv, sig, int(n))
    with open(count_file, "w") as f:
        f.write(f"{calls}\n")
    return code


if __name__ == "__main__":
    sys.exit(main())
