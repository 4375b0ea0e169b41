# Shared helpers: scene lists and paths derived from the config.

import json


DATA = config["data_dir"]
OUT = config["out_dir"]
RESULTS = config["results_dir"]


def _all_scene_names():
    from dataset_tools.synth import SCENES

    return sorted(SCENES)


def _expand(names):
    return _all_scene_names() if names == ["all"] else list(names)


SCENES = _expand(config["scenes"])
TRAIN_SCENES = _expand(config["train_scenes"])

unknown = sorted(set(SCENES + TRAIN_SCENES) - set(_all_scene_names()))
if unknown:
    raise WorkflowError(f"config: unknown scene name(s) {unknown}; known: {_all_scene_names()}")

wildcard_constraints:
    scene="|".join(SCENES + TRAIN_SCENES),


def synth_flags():
    flags = f"--seed {config['seed']}"
    if config["reduced"]:
        flags += " --reduced"
    return flags


def scene_dir(scene):
    """Scene folder the method stages read: generator poses, or the COLMAP rebuild (config `poses`)."""
    if config["poses"] == "colmap":
        return f"{DATA}_colmap/{scene}"
    return f"{DATA}/{scene}"


def all_targets():
    targets = [f"{scene_dir(s)}/scene.json" for s in SCENES]
    if TRAIN_SCENES:
        targets.append(f"{RESULTS}/3dgs_reconstruction.md")
    return targets
