"""The workflow as an attack surface (docs/architecture.md, "Reliability"): every config value reaches
the shell quoted, the schema refuses unknown keys and impossible values, and a usage error is one
line with exit status 2 (``Snakefile``: ``config_error``; ``make benchmark``: ``workflow/check_args.py``).

Quoting is checked for real: the workflow is planned (a dry run printing its shell commands) with
shell code in every string a user sets, and each planned command is then run by bash with the
package's program swapped for one that records its arguments. No payload may run (its marker file
must not appear) and each must arrive as text inside one argument."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import jsonschema
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = yaml.safe_load((ROOT / "workflow" / "config" / "config.schema.yaml").read_text())
DEFAULTS = yaml.safe_load((ROOT / "workflow" / "config" / "config.yaml").read_text())
ARGV = f"{shlex.quote(sys.executable)} -c 'import sys, json; print(json.dumps(sys.argv[1:]))'"  # stands in for the CLIs


def plan(tmp: Path, settings: dict) -> list[str]:
    """The shell commands of a dry run of the workflow with ``settings`` (a config file); the run must plan."""
    cfg = tmp / "config.yaml"
    cfg.write_text(yaml.safe_dump(settings))
    cmd = [sys.executable, "-m", "snakemake", "-n", "-p", "--cores", "1", "--directory", str(ROOT), "--snakefile", str(ROOT / "Snakefile"), "--configfile", str(cfg)]
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert p.returncode == 0, (p.stdout + p.stderr)[-3000:]
    return [line.split("Shell command: ", 1)[1] for line in (p.stdout + p.stderr).splitlines() if line.startswith("Shell command: ")]


def execute(cmd: str, cwd: Path) -> list[str]:
    """Run a planned command in bash with its program (``inpaint360gs``, ``inpaint360gs-dataset``)
    replaced by one that prints its arguments; returns them (read from the command's own log)."""
    words = shlex.split(cmd)
    assert words[0] in ("inpaint360gs", "inpaint360gs-dataset"), cmd
    log = Path(words[len(words) - words[::-1].index(">")])  # the command's own log: its last redirection
    log.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run(["bash", "-c", ARGV + cmd[len(words[0]):]], cwd=cwd, timeout=60, check=False)
    return json.loads(log.read_text().splitlines()[0])


PAYLOADS = {  # kind -> shell code around a marker file name
    "dollar-paren": "$(touch {m})",
    "backticks": "`touch {m}`",
    "semicolon": "; touch {m}",
    "and": "&& touch {m}",
    "pipe": "| tee {m}",
    "redirect": "> {m}",
}
CLICK_PAYLOADS = {"dollar-paren": "x$(touch {m}).png:64,53", "backticks": "x`touch {m}`.png:64,53", "semicolon": "x;touch {m};.png:64,53",
                  "redirect": "x>{m}.png:64,53"}  # fmt: skip
EXTRA_RULES = {"segment": "inpaint360gs segment", "remove": "inpaint360gs remove", "inpaint": "inpaint360gs inpaint", "train": "inpaint360gs train"}


def _cases() -> list[tuple[str, str, str]]:
    """(case, where it goes, payload template)."""
    out = [(f"clicks-{k}", "clicks", v) for k, v in CLICK_PAYLOADS.items()]
    out += [(f"capture-clicks-{k}", "capture-clicks", v) for k, v in CLICK_PAYLOADS.items()]
    out += [(f"{rule}-extra-args-{k}", rule, "--flag " + v) for rule in EXTRA_RULES for k, v in PAYLOADS.items()]
    out += [(f"capture-photos-{k}", "capture-photos", "photos " + v) for k, v in PAYLOADS.items()]
    out += [(f"inception-weights-{k}", "inception", "w " + v) for k, v in PAYLOADS.items()]
    return out


CASES = _cases()


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """(the case folder, every planned command) with every payload of CASES in place, each naming its own marker."""
    tmp = tmp_path_factory.mktemp("inject")
    marks = {name: str(tmp / f"pwned_{i}") for i, (name, _, _) in enumerate(CASES)}
    text = {name: tpl.format(m=marks[name]) for name, _, tpl in CASES}
    by = lambda where: [text[n] for n, w, _ in CASES if w == where]  # noqa: E731
    extra = {rule: " ".join(by(rule)) for rule in EXTRA_RULES}
    settings = {
        "data_dir": str(tmp / "data"), "out_dir": str(tmp / "out"), "results_dir": str(tmp / "results"), "scenes": ["cone"], "train_scenes": ["cone"],
        "seeds": [0], "methods": ["full"], "clicks": {"cone": by("clicks")}, "inception_weights": " ".join(by("inception")),
        "captures": {f"k{i}": {"photos": p, "clicks": ["IMG_1.png:1,2"]} for i, p in enumerate(by("capture-photos"))}
        | {"kc": {"photos": str(tmp / "photos"), "clicks": by("capture-clicks")}},
        "segment": {"extra_args": extra["segment"]}, "remove": {"extra_args": extra["remove"]}, "inpaint": {"extra_args": extra["inpaint"]},
        "train": {"preset": "cpu", "schedule_scale": "auto", "extra_args": extra["train"]},
    }  # fmt: skip
    return tmp, marks, text, plan(tmp, settings)


@pytest.mark.parametrize("name", [c[0] for c in CASES])
def test_a_config_value_reaches_the_command_as_text(name, planned):
    tmp, marks, text, commands = planned
    mine = [c for c in commands if marks[name] in c]
    assert mine, f"no planned command holds the value of {name}"
    for cmd in mine:
        args = execute(cmd, tmp)
        assert not Path(marks[name]).exists(), f"the shell ran the payload of {name}: {cmd}"
        # run by a shell, the payload would have been consumed (a command's output, a redirection, a pipe)
        assert any(marks[name] in a for a in args), (args, text[name])


def test_paths_with_shell_code_are_quoted(tmp_path):
    """data_dir, out_dir, results_dir and a scene folder named with shell code: every planned command
    gets each path as one argument, and nothing runs."""
    weird = tmp_path / "a b;$(touch pwned)`touch pwned2`"
    scene = weird / "my scene $(touch pwned3)"
    scene.mkdir(parents=True)
    (scene / "scene.json").write_text("{}")
    settings = {"data_dir": str(weird / "data"), "out_dir": str(weird / "out"), "results_dir": str(weird / "results"), "scenes": ["cone", str(scene)],
                "train_scenes": ["scenes"], "seeds": [0], "methods": ["full"]}  # fmt: skip
    commands = plan(tmp_path, settings)
    ran = 0
    for cmd in commands:
        if not cmd.startswith("inpaint360gs"):
            continue
        args = execute(cmd, tmp_path)
        ran += 1
        assert any(str(weird) in a for a in args), (cmd, args)
    assert ran >= 10
    assert not any(p.name.startswith("pwned") for p in tmp_path.rglob("*")), sorted(tmp_path.rglob("pwned*"))


# --- the schema: unknown keys and impossible values refused, naming the setting -----------------------


def merged(**over) -> dict:
    cfg = json.loads(json.dumps(DEFAULTS))
    for k, v in over.items():
        cfg[k] = {**cfg[k], **v} if isinstance(v, dict) and isinstance(cfg.get(k), dict) and not k.startswith("_") else v
    return cfg


SCHEMA_CASES = {  # case -> (config overrides, text of the first complaint)
    "unknown-top-key-sedes": (dict(sedes=[7]), "sedes"),  # issue: a typo for seeds did nothing
    "unknown-top-key-scene": (dict(scene=["cone"]), "scene"),
    "unknown-train-key": (dict(train={"iteratons": 100}), "iteratons"),
    "unknown-segment-key": (dict(segment={"extra": "--x"}), "extra"),
    "unknown-distill-key": (dict(distill={"iters": 5}), "iters"),
    "unknown-remove-key": (dict(remove={"threshold": 0.5}), "threshold"),
    "unknown-inpaint-key": (dict(inpaint={"virtual_view": 5}), "virtual_view"),
    "unknown-capture-key": (dict(captures={"k": {"photos": "p", "clicks": ["a.png:1,2"], "photo": "q"}}), "photo"),
    "seeds-negative": (dict(seeds=[-1]), "-1"),
    "seeds-too-large": (dict(seeds=[2**33]), str(2**33)),
    "seeds-empty": (dict(seeds=[]), "[]"),
    "seeds-string": (dict(seeds=["0"]), "'0'"),
    "seed-negative": (dict(seed=-3), "-3"),
    "threads-zero": (dict(threads=0), "0"),
    "threads-string": (dict(threads="2"), "'2'"),
    "backend-unknown": (dict(backend="opengl"), "opengl"),
    "reduced-string": (dict(reduced="yes"), "yes"),
    "poses-unknown": (dict(poses="sfm"), "sfm"),
    "suite-unknown": (dict(suite="all"), "all"),
    "out-dir-empty": (dict(out_dir=""), "''"),
    "results-dir-empty": (dict(results_dir=""), "''"),
    "scene-entry-empty": (dict(scenes=[""]), "''"),
    "views-sweep-zero": (dict(views_sweep=[0]), "0"),
    "views-sweep-repeated": (dict(views_sweep=[8, 8]), "non-unique"),
    "virtual-views-zero": (dict(inpaint={"virtual_views": 0}), "0"),
    "distill-iterations-zero": (dict(distill={"iterations": 0}), "0"),
    "train-iterations-zero": (dict(train={"iterations": 0}), "0"),
    "train-schedule-scale-zero": (dict(train={"schedule_scale": 0}), "0"),
    "train-max-gaussians-negative": (dict(train={"max_gaussians": -1}), "-1"),
    "click-no-pixel": (dict(clicks={"cone": ["IMG_0017.png"]}), "IMG_0017.png"),
    "click-letters": (dict(clicks={"cone": ["IMG_0017.png:x,y"]}), "x,y"),
    "click-negative": (dict(clicks={"cone": ["IMG_0017.png:-1,3"]}), "-1,3"),
    "click-huge": (dict(clicks={"cone": ["IMG_0017.png:1" + "0" * 400 + ",3"]}), "IMG_0017"),
    "click-newline": (dict(clicks={"cone": ["IMG\n0017.png:1,3"]}), "IMG\\n0017"),
    "capture-no-photos": (dict(captures={"k": {"clicks": ["a.png:1,2"]}}), "photos"),
    "capture-resize-zero": (dict(captures={"k": {"photos": "p", "clicks": ["a.png:1,2"], "resize": 0}}), "0"),
    "capture-no-clicks": (dict(captures={"k": {"photos": "p", "clicks": []}}), "[]"),
}


@pytest.mark.parametrize("name", list(SCHEMA_CASES))
def test_the_schema_refuses(name):
    over, text = SCHEMA_CASES[name]
    errors = list(jsonschema.Draft202012Validator(SCHEMA).iter_errors(merged(**over)))
    assert errors, f"{name} passes the schema"
    assert any(text in e.message or text in ".".join(map(str, e.absolute_path)) for e in errors), [e.message for e in errors]


def test_the_defaults_and_the_shipped_configs_pass_the_schema():
    for f in ("config.yaml", "kitchen.yaml", "ci.yaml"):
        cfg = {**DEFAULTS, **yaml.safe_load((ROOT / "workflow" / "config" / f).read_text())}
        assert not list(jsonschema.Draft202012Validator(SCHEMA).iter_errors(cfg)), f


ONE_LINE = {  # --config values -> the text of the one line
    "sedes=[7]": "'sedes' was unexpected",
    "seeds=[-1]": "seeds.0: -1 is less than the minimum of 0",
    "threads=0": "threads: 0 is less than the minimum of 1",
    "remove={extra_args: '--x \"unclosed'}": "remove.extra_args",
    "methods=[magic]": "unknown method",
}


@pytest.mark.parametrize("config", list(ONE_LINE))
def test_a_bad_setting_is_one_line_and_exit_2(config, tmp_path):
    cmd = [sys.executable, "-m", "snakemake", "-n", "--cores", "1", "--directory", str(ROOT), "--snakefile", str(ROOT / "Snakefile"),
           "--config", f"data_dir={tmp_path}/d", f"out_dir={tmp_path}/o", f"results_dir={tmp_path}/r", config]  # fmt: skip
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=120)
    errors = [line for line in p.stderr.splitlines() if not line.startswith("Config file ")]  # Snakemake's own note
    assert p.returncode == 2 and len(errors) == 1 and errors[0].startswith("config: ") and ONE_LINE[config] in errors[0], p.stderr[-2000:]
    assert "Traceback" not in p.stdout + p.stderr


# --- make benchmark: the config files Snakemake is given -----------------------------------------------


def _check_args():
    sys.path.insert(0, str(ROOT / "workflow"))
    try:
        import check_args
    finally:
        sys.path.pop(0)
    return check_args


MAKE_CASES = {  # SNAKEMAKE_ARGS words (given the tmp folder) -> text of the one line
    "configfile-missing": (lambda t: ["--configfile", f"{t}/nope.yaml"], "no such file"),  # issue: Snakemake's own traceback
    "configfile-missing-equals": (lambda t: [f"--configfile={t}/nope.yaml"], "no such file"),
    "configfile-second-missing": (lambda t: ["--configfile", str(ROOT / "workflow/config/ci.yaml"), f"{t}/nope.yaml", "-n"], "nope.yaml"),
    "configfile-no-file": (lambda t: ["-n", "--configfile"], "expected a file"),
    "configfile-not-yaml": (lambda t: ["--configfile", _put(t / "bad.yaml", "a: [1\n")], "not valid YAML"),
    "configfile-a-list": (lambda t: ["--configfile", _put(t / "list.yaml", "- 1\n- 2\n")], "mapping"),
    "configfile-a-folder": (lambda t: ["--configfile", str(t)], "cannot be read"),
}


def _put(path: Path, text: str) -> str:
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("name", list(MAKE_CASES))
def test_make_benchmark_checks_its_config_files(name, tmp_path):
    words, text = MAKE_CASES[name]
    why = _check_args().problem(words(tmp_path))
    assert why is not None and text in why, why


def test_make_benchmark_with_a_missing_config_file_is_one_line(tmp_path):
    if not (ROOT / ".venv" / "bin" / "python").exists():
        pytest.skip("make benchmark runs in the repository's .venv")
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MAKELEVEL", "MFLAGS")}  # also when the tests run under make
    p = subprocess.run(["make", "-s", "benchmark", f"SNAKEMAKE_ARGS=--configfile {tmp_path}/nope.yaml -n"], cwd=ROOT, capture_output=True, text=True, timeout=120, env=env)
    ours = [line for line in p.stderr.splitlines() if not re.match(r"make(\[\d+\])?: ", line)]  # make's own "Error 2" line follows
    assert p.returncode != 0 and ours == [f"make benchmark: --configfile {tmp_path}/nope.yaml: no such file"], p.stderr
    assert "Traceback" not in p.stdout + p.stderr
