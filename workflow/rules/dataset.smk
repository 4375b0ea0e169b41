# Building the benchmark scenes (issue 2: synthetic generator; issue 3: COLMAP path).


rule synth_scene:
    """Render one synthetic 360° scene (object-inclusive + object-free captures, GT, true-pose sparse model)."""
    output:
        scene_json=f"{DATA}/{{scene}}/scene.json",
    params:
        flags=synth_flags(),
    log:
        f"{OUT}/logs/synth_{{scene}}.log",
    shell:
        "inpaint360gs-dataset synth {DATA} --scenes {wildcards.scene} {params.flags} --overwrite --quiet > {log} 2>&1"


rule colmap_scene:
    """Re-derive a generated scene's poses and sparse points with joint pycolmap SfM on its images only
    (the dataset-building path of issue 3; `poses: colmap`). Records pose accuracy vs the true poses."""
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
        "inpaint360gs-dataset synth-colmap {params.src} {params.dst} --seed {params.seed} --overwrite --no-progress > {log} 2>&1"
