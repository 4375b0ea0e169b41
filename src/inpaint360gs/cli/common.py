"""The CLI layer every stage shares (``inpaint360gs`` and ``inpaint360gs-dataset``).

* One dispatcher (:func:`run_stages`): imports only the stage that runs, turns every failure into one
  line on stderr and a documented exit code (:mod:`inpaint360gs.core.errors`): 0 success, 1 internal
  error, 2 bad input or usage, 3 training diverged, 130 SIGINT, 143 SIGTERM. Set
  ``INPAINT360GS_DEBUG=1`` to get the traceback of an internal error.
* Clean interruptions: SIGTERM becomes a :class:`~inpaint360gs.core.errors.Terminated` exception in
  the main thread, so the atomic writers' ``finally`` blocks remove their temporaries (pycolmap's
  own SIGTERM handler, which prints a C++ stack dump, is replaced).
* Argument types that check values before any work starts: finite numbers, ranges, existing inputs,
  writable outputs.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import re
import signal
import sys
import warnings
from collections.abc import Callable
from pathlib import Path

from inpaint360gs.core.errors import (
    EXIT_CHECK,
    EXIT_DIVERGED,
    EXIT_INPUT,
    EXIT_INTERNAL,
    EXIT_SIGINT,
    EXIT_SIGTERM,
    CheckFailedError,
    InputError,
    Terminated,
    TrainingDivergedError,
)
from inpaint360gs.core.files import check_apart, path_problem  # noqa: F401  (check_apart: every CLI's, defined with the file rules)


class OneLineParser(argparse.ArgumentParser):
    """argparse with one-line usage errors: ``prog: error: message (see --help)``, exit 2."""

    def error(self, message: str):  # type: ignore[override]
        """Exit with the input-error status and a one-line message pointing to ``--help``."""
        self.exit(EXIT_INPUT, f"{self.prog}: error: {message} (see --help)\n")


def _on_sigterm(signum, frame):
    raise Terminated()


def _interruption(e: BaseException) -> BaseException | None:
    """The :class:`Terminated` or ``KeyboardInterrupt`` that ``e`` was raised from, if any: a signal
    handler's exception raised while a numba kernel returns comes back as a ``SystemError``
    ("returned a result with an exception set") chained to it."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, (Terminated, KeyboardInterrupt)):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


def install_signal_handlers() -> None:
    """SIGTERM -> :class:`Terminated`, SIGINT -> ``KeyboardInterrupt`` (after pycolmap's import, which
    installs glog's failure handler for SIGTERM)."""
    try:
        import pycolmap  # noqa: F401  (its import installs the handler we replace)
    except ImportError:
        pass
    signal.signal(signal.SIGTERM, _on_sigterm)
    signal.signal(signal.SIGINT, signal.default_int_handler)


def _one_line_warnings(prog: str) -> None:
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"{prog}: warning: {message}", file=sys.stderr if file is None else file)

    warnings.showwarning = show


def _first_line(e: BaseException) -> str:
    text = str(e).strip()
    return text.splitlines()[0] if text else type(e).__name__


# torch's allocators: "DefaultCPUAllocator: can't allocate memory: you tried to allocate 123 bytes",
# "CUDA out of memory. Tried to allocate 2.00 GiB"; numpy: "Unable to allocate 1.00 TiB for an array"
_ALLOC_FAILED = re.compile(r"can't allocate memory|out of memory|Unable to allocate", re.I)
_ALLOC_SIZE = re.compile(r"allocate (\d+) bytes|allocate ([\d.]+ ?[KMGTP]i?B)", re.I)


def _out_of_memory(e: BaseException) -> str:
    """One line for a failed allocation, with the size asked for when the message says it."""
    m = _ALLOC_SIZE.search(str(e))
    size = "" if m is None else f" (an allocation of {m.group(2) or _bytes(int(m.group(1)))} failed)"
    return f"out of memory{size}: try smaller images (--resize), fewer Gaussians, or a machine with more memory"


def _bytes(n: int) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.2f} {unit}"
        n /= 1024
    return f"{n} B"


def _os_error(e: OSError) -> str:
    """``path: OS reason`` of an OS error, on one line."""
    name = e.filename if e.filename is not None else ""
    return f"{name}{': ' if name else ''}{e.strerror or _first_line(e)}"


# Settings whose option is named otherwise than the setting (InputError.setting -> option dest); a
# setting not listed is shown as the option whose dest is its field name (with its config's prefix,
# OPTION_PREFIX), else as it is.
OPTION_OF_SETTING = {
    "VirtualViewsConfig.num_views": "virtual_views",
    "DensifyConfig.grad_threshold": "densify_grad_threshold",
    "DensifyConfig.gradient": "densify_gradient",
    "DistillConfig.iterations": "distill_iterations",
    "RefineConfig.iterations": "inpaint_iterations",
    "RefineConfig.variant": "refine_variant",
    "AssociationConfig.method": "association",
    "SamConfig.encoder": "sam_encoder",
    "SamConfig.decoder": "sam_decoder",
    "SamConfig.stability_score_thresh": "sam_stability_thresh",
    "SamConfig.min_mask_region_area": "sam_min_region_area",
    "clicks": "click",
    "ids": "id",
    "labels": "label",
    "stages": "stage_benchmarks",
    "evaluation": "eval",
}
OPTION_PREFIX = {"SamConfig": "sam_"}  # a config whose options all carry a prefix


def option_of(setting: str, parser: argparse.ArgumentParser | None) -> str:
    """How the command line names ``setting`` (an :class:`InputError` setting, ``/``-joined ones
    each): the option of ``parser`` that sets it, else the setting's own name."""
    actions, parsers = {}, [parser] if parser is not None else []
    while parsers:  # the stage's options, and those of its subcommands (``table record``)
        for a in parsers.pop(0)._actions:
            if isinstance(a, argparse._SubParsersAction):
                parsers.extend(a.choices.values())
            elif a.option_strings:
                actions.setdefault(a.dest, a)
    out = []
    for one in setting.split("/"):
        owner, _, name = one.rpartition(".")
        for dest in (OPTION_OF_SETTING.get(one), OPTION_PREFIX.get(owner, "") + name):
            if dest in actions:
                out.append(max(actions[dest].option_strings, key=len))
                break
        else:
            out.append(one)
    return "/".join(out)


def _parse(prog: str, stages: dict[str, tuple[str, str]], argv: list[str], description: str) -> tuple[argparse.Namespace, argparse.ArgumentParser]:
    """The parsed arguments of the stage ``argv`` names (only its module is imported) and that
    stage's parser; a usage error or --help raises SystemExit after printing (one line for an error)."""
    parser = OneLineParser(prog=prog, description=description)
    sub = parser.add_subparsers(dest="stage", metavar="STAGE", required=True, parser_class=OneLineParser)
    wanted = argv[0] if argv and not argv[0].startswith("-") else None
    for name, (module, help_text) in stages.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        if name == wanted:  # import only the module that runs
            importlib.import_module(module).add_arguments(p)
    args, extra = parser.parse_known_args(argv)
    if extra:  # reported by the stage's parser, so that the line names the stage
        sub.choices[args.stage].error(f"unrecognized arguments: {' '.join(extra)}")
    return args, sub.choices[args.stage]


def run_stages(prog: str, stages: dict[str, tuple[str, str]], argv: list[str] | None, description: str) -> int:
    """Parse ``argv`` for one of ``stages`` (name -> (module, help)) and run it; returns the exit code.
    Everything from the first import on is inside the error handling: an OS error in an argument
    check, or SIGINT / SIGTERM while the stage's modules load, is one line too."""
    argv = sys.argv[1:] if argv is None else argv
    where = " ".join([prog, *argv[:1]]) if argv and argv[0] in stages else prog
    old_show = warnings.showwarning
    signal.signal(signal.SIGTERM, _on_sigterm)  # now already: loading a stage takes seconds (torch)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    stage_parser = None
    try:
        try:
            args, stage_parser = _parse(prog, stages, argv, description)
        except SystemExit as e:  # --help (0) or a usage error (2, already printed on one line)
            return int(e.code or 0)
        where = f"{prog} {args.stage}"
        _one_line_warnings(where)
        install_signal_handlers()
        return int(importlib.import_module(stages[args.stage][0]).run(args) or 0)
    except InputError as e:
        if e.setting is not None:
            e = f"{option_of(e.setting, stage_parser)}: {e.message}"
        print(f"{where}: error: {e}", file=sys.stderr)
        return EXIT_INPUT
    except TrainingDivergedError as e:
        print(f"{where}: training diverged: {e}", file=sys.stderr)
        return EXIT_DIVERGED
    except CheckFailedError as e:
        print(f"{where}: check failed: {e}", file=sys.stderr)
        return EXIT_CHECK
    except KeyboardInterrupt:
        print(f"{where}: interrupted (partial outputs removed; rerun to continue)", file=sys.stderr)
        return EXIT_SIGINT
    except Terminated:
        print(f"{where}: terminated (partial outputs removed; rerun to continue)", file=sys.stderr)
        return EXIT_SIGTERM
    except OSError as e:  # disk full, permission denied, a path component that is a file, ...
        print(f"{where}: error: {_os_error(e)}", file=sys.stderr)
        return EXIT_INPUT
    except MemoryError as e:
        print(f"{where}: error: {_out_of_memory(e)}", file=sys.stderr)
        return EXIT_INPUT
    except Exception as e:  # a bug: still one line, the traceback on request
        signal_exc = _interruption(e)
        if signal_exc is not None:  # the signal's exception raised inside a compiled kernel's return (numba's SystemError wraps it)
            kind, code = ("terminated", EXIT_SIGTERM) if isinstance(signal_exc, Terminated) else ("interrupted", EXIT_SIGINT)
            print(f"{where}: {kind} (partial outputs removed; rerun to continue)", file=sys.stderr)
            return code
        if isinstance(e, RuntimeError) and _ALLOC_FAILED.search(str(e)):  # torch's allocator (CPU or CUDA): a resource, not a bug
            print(f"{where}: error: {_out_of_memory(e)}", file=sys.stderr)
            return EXIT_INPUT
        if os.environ.get("INPAINT360GS_DEBUG"):
            raise
        print(f"{where}: internal error: {type(e).__name__}: {_first_line(e)} (set INPAINT360GS_DEBUG=1 for the traceback)", file=sys.stderr)
        return EXIT_INTERNAL
    finally:
        warnings.showwarning = old_show
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


# --- argument types (argparse calls them; ArgumentTypeError becomes a one-line usage error) --------


def _number(kind: type, text: str):
    try:
        v = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {'an integer' if kind is int else 'a number'}, got {text!r}") from None
    if kind is float and not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return v


def number(
    kind: type = float, *, lo: float | None = None, hi: float | None = None, lo_open: bool = False, hi_open: bool = False
) -> Callable[[str], float | int]:
    """Argument type: a finite ``kind`` (int or float) within [lo, hi] (``lo_open`` / ``hi_open``: that end excluded)."""

    def parse(text: str):
        v = _number(kind, text)
        if lo is not None and (v < lo or (lo_open and v == lo)):
            raise argparse.ArgumentTypeError(f"must be {'>' if lo_open else '>='} {lo:g}, got {text}")
        if hi is not None and (v > hi or (hi_open and v == hi)):
            raise argparse.ArgumentTypeError(f"must be {'<' if hi_open else '<='} {hi:g}, got {text}")
        return v

    return parse


positive_int = number(int, lo=1)
nonneg_int = number(int, lo=0)
positive_float = number(float, lo=0.0, lo_open=True)
nonneg_float = number(float, lo=0.0)
fraction = number(float, lo=0.0, hi=1.0)


def _existing(folder: bool) -> Callable[[str], Path]:
    def parse(text: str) -> Path:
        problem = path_problem(text, folder=folder)
        if problem is not None:
            raise argparse.ArgumentTypeError(f"{text}: {problem}")
        return Path(text)

    return parse


existing_dir = _existing(folder=True)  # argument type: a folder that exists
existing_file = _existing(folder=False)  # argument type: a file that exists


def check_writable(path: str | Path, *, folder: bool) -> Path:
    """Raise :class:`InputError` unless ``path`` can be created or replaced as a folder (or file):
    not an existing file (folder), not an existing folder (file), no parent that is a file, writable."""
    p = Path(path)
    try:
        if os.path.lexists(p) and not p.exists():
            raise InputError("output path is a broken symbolic link or a symbolic link loop", p)
        if p.exists():
            if folder and not p.is_dir():
                what = "an empty file" if p.is_file() and p.stat().st_size == 0 else "a file" if p.is_file() else "not a folder"
                raise InputError(f"output path exists and is {what}, not a folder", p)
            if not folder and p.is_dir():
                raise InputError("output path is a folder, expected a file name", p)
            if not folder and not p.is_file():
                raise InputError(f"output path exists and {path_problem(p)}", p)
        parent = p.parent
        while not parent.exists():
            parent = parent.parent
        if not parent.is_dir():
            raise InputError(f"cannot create the output: {parent} is a file", p)
        if not os.access(parent, os.W_OK | os.X_OK) or (p.exists() and not os.access(p, os.W_OK)):
            raise InputError("output location is not writable", p if p.exists() else parent)
    except OSError as e:  # a name too long, a symbolic link loop in a parent, ...
        raise InputError(e.strerror or _first_line(e), path) from None
    return p


def _writable(folder: bool) -> Callable[[str], Path]:
    def parse(text: str) -> Path:
        try:
            return check_writable(text, folder=folder)
        except InputError as e:
            raise argparse.ArgumentTypeError(str(e)) from None

    return parse


output_dir = _writable(folder=True)  # argument type: a folder to create or replace (checked before any work)
output_file = _writable(folder=False)  # argument type: a file to create or replace


# --- threads -----------------------------------------------------------------------------------------


def add_scene_arguments(parser: argparse.ArgumentParser, *, llffhold: bool = True, resize_note: str = "") -> None:
    """``--resize`` and (with ``llffhold``) ``--llffhold``: how a stage reads its scene folder
    (``io.scene.load_scene``, whose defaults they take); ``resize_note`` ends ``--resize``'s help."""
    from inpaint360gs.core import layout  # load_scene's defaults, without importing it (torch: seconds before the viewer's page can load)

    defaults = {"resize": layout.RESIZE, "llffhold": layout.LLFFHOLD}
    note = f"; {resize_note}" if resize_note else ""
    parser.add_argument("--resize", type=positive_int, default=defaults["resize"],
                        help=f"work on the images downscaled by this factor (images_<R>/ when present; default {defaults['resize']}{note})")  # fmt: skip
    if llffhold:
        parser.add_argument("--llffhold", type=nonneg_int, default=defaults["llffhold"],
                            help=f"every Nth non-test view is held out of training (default {defaults['llffhold']}; 0: none; the later stages take the value training took)")  # fmt: skip


def add_support_init_argument(parser: argparse.ArgumentParser, default: str) -> None:
    """Add ``--support-init {auto,on,off}`` (3DGS's start from support points; ``--support-init`` alone: on)."""
    parser.add_argument(
        "--support-init", nargs="?", const="on", default=default, choices=("auto", "on", "off"),
        help="3DGS also starts from points on the support plane where the SfM points leave the photos uncovered: "
        f"on, off, or auto (on when most of the support's cells are uncovered: a plain support; default {default})",
    )  # fmt: skip


def add_threads_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--threads`` (CPU threads for torch and numba; default: the usable cores) to ``parser``."""
    default = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    parser.add_argument("--threads", type=positive_int, default=default, help=f"CPU threads for torch and numba (default: {default}, the usable cores)")


def set_threads(n: int) -> None:
    """Limit torch's and numba's thread pools (both matter on a small shared CPU); make torch's first
    multi-threaded vector-math call reproducible (see below)."""
    import torch

    torch.set_num_threads(max(1, n))
    # torch computes exp, sqrt, log, ... on CPU with MKL's vector-math (VML) functions, splitting arrays
    # of more than a few thousand elements over its threads. When the process's *first* such call runs
    # on two threads at once, one thread's half of the output can round differently (CHANGELOG.md,
    # History), so the same training run would differ at rounding level from run to run. One tiny call
    # on this thread alone, before any parallel work, does that first-call set-up (tests/cli/test_threads.py).
    for dtype in (torch.float32, torch.float64):
        torch.ones(1, dtype=dtype).exp()
    try:
        import numba

        numba.set_num_threads(max(1, min(n, numba.config.NUMBA_NUM_THREADS)))
    except ImportError:
        pass


def backend_choices() -> list[str]:
    """:func:`inpaint360gs.render.backends.backend_choices` without importing the renderer (torch:
    seconds before the viewer's page can load): "auto" and the registry's names, one per
    ``render/<name>_backend.py`` file (tests/cli check that the two agree)."""
    import importlib.util
    import pkgutil

    spec = importlib.util.find_spec("inpaint360gs.render")
    return ["auto", *sorted(m.name.removesuffix("_backend") for m in pkgutil.iter_modules(spec.submodule_search_locations) if m.name.endswith("_backend"))]


def add_backend_argument(parser: argparse.ArgumentParser, default: str | None = "auto") -> None:
    """``--backend``; ``default`` None: the preset's (``inpaint360gs run --preset``)."""
    said = "the preset's" if default is None else default
    parser.add_argument("--backend", default=default, choices=backend_choices(), help=f"rasterizer backend (default {said})")
