# 3DGS reconstruction of each scene (paper Sec. 3.1) and its held-out-view table.


rule train_3dgs:
    """Train 3D Gaussian Splatting on the object-inclusive training views; evaluate on held-out views."""
    input:
        scene_json=lambda wc: f"{scene_dir(wc.scene)}/scene.json",
    output:
        ply=f"{OUT}/{{scene}}/3dgs/point_cloud.ply",
        metrics=f"{OUT}/{{scene}}/3dgs/metrics.json",
    params:
        scene_dir=lambda wc: scene_dir(wc.scene),
        out=lambda wc: f"{OUT}/{wc.scene}/3dgs",
        iterations=TRAIN["iterations"],
        schedule_scale=config["train"]["schedule_scale"],
        max_gaussians=TRAIN["max_gaussians"],
        backend=TRAIN["backend"],
        extra=EXTRA["train"],
        seed=config["seed"],
    threads: THREADS
    resources:
        mem_mb=6000,
        gpu=1 if TRAIN["backend"] == "gsplat" else 0,
    log:
        f"{OUT}/logs/train_3dgs_{{scene}}.log",
    benchmark:
        f"{OUT}/benchmarks/{{scene}}/train_3dgs.tsv"
    shell:
        # --resume --overwrite: an interrupted run continues from its checkpoint; a checkpoint made
        # with other settings or another scene is discarded and training starts afresh
        "inpaint360gs train {params.scene_dir:q} {params.out:q} --iterations {params.iterations:q}"
        " --schedule-scale {params.schedule_scale:q} --max-gaussians {params.max_gaussians:q}"
        " --backend {params.backend:q} --seed {params.seed:q} --threads {threads} --no-progress --resume --overwrite {params.extra} > {log:q} 2>&1"


rule table_3dgs:
    """Per-scene and average held-out PSNR/SSIM, time and memory of 3DGS training."""
    input:
        expand(f"{OUT}/{{scene}}/3dgs/metrics.json", scene=TRAIN_SCENES),
    output:
        md=f"{RESULTS}/3dgs_reconstruction.md",
        csv=f"{RESULTS}/3dgs_reconstruction.csv",
    log:
        f"{OUT}/logs/table_3dgs.log",
    shell:
        "inpaint360gs table reconstruction {input:q} --csv {output.csv:q} --md {output.md:q} > {log:q} 2>&1"
