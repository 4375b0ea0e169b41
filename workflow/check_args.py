"""``make benchmark``'s look at ``SNAKEMAKE_ARGS`` before Snakemake starts: every ``--configfile``
names a file that holds a YAML mapping. Snakemake answers a missing or broken config file with its
own traceback; this answers with one line naming the file, and exit status 2 (README, "Errors,
interruptions and resuming").

    python workflow/check_args.py [the arguments Snakemake gets]
"""

from __future__ import annotations

import sys

import yaml


def problem(argv: list[str]) -> str | None:
    """Why the arguments ``argv`` cannot start the workflow, or None."""
    files, i = [], 0
    while i < len(argv):
        word = argv[i]
        if word.startswith(("--configfile=", "--configfiles=")):
            files.append(word.split("=", 1)[1])
        elif word in ("--configfile", "--configfiles"):
            j = i + 1
            while j < len(argv) and not argv[j].startswith("-"):
                files.append(argv[j])
                j += 1
            if j == i + 1:
                return f"{word}: expected a file after it"
            i = j - 1
        i += 1
    for f in files:
        try:
            with open(f, encoding="utf-8") as fh:
                data = yaml.safe_load(fh)
        except FileNotFoundError:
            return f"--configfile {f}: no such file"
        except (OSError, UnicodeDecodeError) as e:
            return f"--configfile {f}: cannot be read ({getattr(e, 'strerror', None) or e})"
        except yaml.YAMLError as e:
            return f"--configfile {f}: not valid YAML ({str(e).splitlines()[0]})"
        if not isinstance(data, dict):
            return f"--configfile {f}: must hold a mapping of settings (workflow/config/README.md)"
    return None


if __name__ == "__main__":
    why = problem(sys.argv[1:])
    if why:
        print(f"make benchmark: {why}", file=sys.stderr)
    sys.exit(2 if why else 0)
