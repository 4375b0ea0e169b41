"""Run one CLI command and send this process a signal at the N-th call into the package's own code:
an interruption at a chosen point of the stage's work, independent of the machine's speed.

``python interrupt.py SIGNAL N COUNT_FILE PROG STAGE ARGS...``: SIGNAL is INT, TERM, KILL or NONE
(run to the end); N the call at which it is sent; COUNT_FILE receives the number of calls made (the
uninterrupted run counts them, so that a test can draw N among them).
"""

from __future__ import annotations

import os
import signal
import sys


def main() -> int:
    sig_name, n, count_file, prog, *argv = sys.argv[1:]
    sig = None if sig_name == "NONE" else getattr(signal, f"SIG{sig_name}")
    n = int(n)
    calls = 0
    marks = (f"{os.sep}inpaint360gs{os.sep}", f"{os.sep}dataset_tools{os.sep}")

    if prog == "inpaint360gs":
        from inpaint360gs.cli import main as entry
    else:
        from dataset_tools.cli import main as entry

    def profile(frame, event, arg):
        nonlocal calls
        if event == "call" and any(m in frame.f_code.co_filename for m in marks):
            calls += 1
            if calls == n and sig is not None:
                os.kill(os.getpid(), sig)

    sys.setprofile(profile)
    try:
        code = entry(argv)
    finally:
        sys.setprofile(None)
        with open(count_file, "w") as f:
            f.write(f"{calls}\n")
    return code


if __name__ == "__main__":
    sys.exit(main())
