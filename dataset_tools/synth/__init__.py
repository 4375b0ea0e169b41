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

from inpaint360gs.core.exports import lazy_exports

# name -> module of this package, imported on first use: the workflow reads the catalogue at parse
# time without loading the renderer
_EXPORTS = {"render_view": "api", "View": "cameras", "SCENES": "catalogue", "scene_spec": "catalogue", "suite_scenes": "catalogue",
            "generate_scene": "generate", "Rendering": "render", "SynthScene": "scene", "build_scene": "scene", "load_scene": "scene",
            "seen_by_object_inclusive_views": "visibility"}  # fmt: skip
__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
