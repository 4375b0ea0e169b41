"""Synthetic 360° inpainting benchmark: procedurally textured analytic scenes rendered by a small ray caster.

Each scene has object-inclusive orbit captures, object-free ``test_`` captures, exact ground truth
(poses, instance ids, depth, unseen masks) and a sparse model from the true poses.

Public API:
  SCENES, scene_spec(name)                       the catalogue (classic ten + realistic family)
  suite_scenes("dev" | "test")                   the development / test suites
  generate_scene(name, out_dir, ...) -> Path     write out_dir/name atomically
  build_scene / load_scene -> SynthScene         a scene instance (spec + seed + size + views)
  render_view(scene, camera, with_objects=...)   RGB, depth, instance ids, hit points for any camera
  seen_by_object_inclusive_views(scene, points)  visibility oracle (point-leak checks)
"""

from dataset_tools.synth.api import render_view
from dataset_tools.synth.cameras import View
from dataset_tools.synth.catalogue import SCENES, scene_spec, suite_scenes
from dataset_tools.synth.generate import generate_scene
from dataset_tools.synth.render import Rendering
from dataset_tools.synth.scene import SynthScene, build_scene, load_scene
from dataset_tools.synth.visibility import seen_by_object_inclusive_views

__all__ = [
    "SCENES",
    "Rendering",
    "SynthScene",
    "View",
    "build_scene",
    "generate_scene",
    "load_scene",
    "render_view",
    "scene_spec",
    "seen_by_object_inclusive_views",
    "suite_scenes",
]
