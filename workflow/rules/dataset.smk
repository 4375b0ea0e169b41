# Building the benchmark scenes (synthetic generator; optional COLMAP rebuild of their poses).


rule synth_scene:
    """Render one synthetic 360° scene (object-inclusive + object-free captures, GT, true-pose sparse model)."""
    output:
        scene_json=f"{DATA}/{{scene}}/scene.json",
    params:
        data=DATA,
        flags=synth_flags(),
    log:
        f"{OUT}/logs/synth_{{scene}}.log",
    shell:
        "inpaint360gs-dataset synth {params.data:q} --scenes {wildcards.scene} {params.flags} --overwrite --quiet > {log:q} 2>&1"


rule colmap_scene:
    """Re-derive a generated scene's poses and sparse points with joint pycolmap SfM on its images only
    (the dataset-building path; `poses: colmap`). Records pose accuracy vs the true poses."""
    input:
        scene_json=f"{DATA}/{{scene}}/scene.json",
    output:
        scene_json=f"{DATA}_colmap/{{scene}}/scene.json",
    params:
        src=lambda wc: f"{DATA}/{wc.scene}",
        dst=lambda wc: f"{DATA}_colmap/{wc.scene}",
        seed=config["seed"],
    threads: 2
    log:
        f"{OUT}/logs/colmap_{{scene}}.log",
    shell:
        "inpaint360gs-dataset synth-colmap {params.src:q} {params.dst:q} --seed {params.seed} --overwrite --no-progress > {log:q} 2>&1"
