# The object-aware Gaussian field (paper Sec. 3.2-3.3, Alg. 1): raw 2D masks, Key Object Management
# association (or the 2D tracker of ablation a), object-ID distillation, click selection and removal.
# Every method of a segmenter shares the segmentation; every method with the same association
# shares the association, the distilled field and the removal. All of it runs once per seed (the
# `seed` wildcard: --seed of segment and distill; associate and remove have no randomness of their
# own) on the scene's one 3DGS.


rule segment:
    """Raw 2D masks per training view (`inpaint360gs segment`)."""
    input:
        scene_json=lambda wc: f"{scene_dir(wc.scene)}/scene.json",
        model=f"{OUT}/{{scene}}/3dgs/point_cloud.ply",
    output:
        f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/segment/segment.json",
    params:
        backend=BACKEND,
        scene_dir=lambda wc: scene_dir(wc.scene),
        out=lambda wc: f"{run_dir(wc)}/segment",
        extra=EXTRA["segment"],
    threads: THREADS
    resources:
        mem_mb=4000,
    log:
        f"{OUT}/logs/{{scene}}/seed{{seed}}/{{segmenter}}/segment.log",
    benchmark:
        f"{OUT}/benchmarks/{{scene}}/seed{{seed}}/{{segmenter}}/segment.tsv"
    shell:
        "inpaint360gs segment {params.scene_dir:q} {input.model:q} {params.out:q} --segmenter {wildcards.segmenter}"
        " --seed {wildcards.seed} --backend {params.backend:q} --threads {threads} --overwrite --no-progress {params.extra} > {log:q} 2>&1"


rule associate:
    """View-consistent object masks (`inpaint360gs associate`; paper Eq. 2, Alg. 1; `tracker`: ablation a)."""
    input:
        scene_json=lambda wc: f"{scene_dir(wc.scene)}/scene.json",
        model=f"{OUT}/{{scene}}/3dgs/point_cloud.ply",
        segments=f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/segment/segment.json",
    output:
        f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/associate/objects.json",
    params:
        backend=BACKEND,
        scene_dir=lambda wc: scene_dir(wc.scene),
        segments=lambda wc: f"{run_dir(wc)}/segment",
        out=lambda wc: f"{run_dir(wc)}/{wc.association}/associate",
    threads: 1
    resources:
        mem_mb=4000,
    log:
        f"{OUT}/logs/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/associate.log",
    benchmark:
        f"{OUT}/benchmarks/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/associate.tsv"
    shell:
        "inpaint360gs associate {params.scene_dir:q} {input.model:q} {params.segments:q} {params.out:q}"
        " --method {wildcards.association} --overwrite > {log:q} 2>&1"


rule distill:
    """Object-ID distillation (`inpaint360gs distill`; paper Eq. 3-4)."""
    input:
        scene_json=lambda wc: f"{scene_dir(wc.scene)}/scene.json",
        model=f"{OUT}/{{scene}}/3dgs/point_cloud.ply",
        objects=f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/associate/objects.json",
    output:
        f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/distill/distill.json",
    params:
        backend=BACKEND,
        scene_dir=lambda wc: scene_dir(wc.scene),
        assoc=lambda wc: f"{run_dir(wc)}/{wc.association}/associate",
        out=lambda wc: f"{run_dir(wc)}/{wc.association}/distill",
        iterations=DISTILL_ITERATIONS,
    threads: THREADS
    resources:
        mem_mb=6000,
        gpu=1 if BACKEND == "gsplat" else 0,
    log:
        f"{OUT}/logs/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/distill.log",
    benchmark:
        f"{OUT}/benchmarks/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/distill.tsv"
    shell:
        "inpaint360gs distill {params.scene_dir:q} {input.model:q} {params.assoc:q} {params.out:q}"
        " --iterations {params.iterations:q} --seed {wildcards.seed} --backend {params.backend:q} --threads {threads}"
        " --overwrite --no-progress > {log:q} 2>&1"


def _clicks(wc):
    """Clicks from the config for this scene (else the CLI takes those its scene.json names), quoted."""
    return click_args(config["clicks"].get(wc.scene, []))


rule remove:
    """Click selection and removal (`inpaint360gs remove`; paper Sec. 3.3): edited PLY, masks left to fill, AMCR."""
    input:
        scene_json=lambda wc: f"{scene_dir(wc.scene)}/scene.json",
        distill=f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/distill/distill.json",
    output:
        f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/removed/removal.json",
    params:
        backend=BACKEND,
        scene_dir=lambda wc: scene_dir(wc.scene),
        distill=lambda wc: f"{run_dir(wc)}/{wc.association}/distill",
        out=lambda wc: f"{run_dir(wc)}/{wc.association}/removed",
        clicks=_clicks,
        extra=EXTRA["remove"],
    threads: 1
    resources:
        mem_mb=4000,
    log:
        f"{OUT}/logs/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/remove.log",
    benchmark:
        f"{OUT}/benchmarks/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/remove.tsv"
    shell:
        "inpaint360gs remove {params.scene_dir:q} {params.distill:q} {params.out:q} {params.clicks}"
        " --backend {params.backend:q} --threads {threads} --overwrite {params.extra} > {log:q} 2>&1"


rule render_removed:
    """The scene after removal at the test_ cameras: the "removal only" baseline."""
    input:
        scene_json=lambda wc: f"{scene_dir(wc.scene)}/scene.json",
        removal=f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/removed/removal.json",
    output:
        f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/removed_renders/render.json",
    params:
        backend=BACKEND,
        scene_dir=lambda wc: scene_dir(wc.scene),
        model=lambda wc: f"{run_dir(wc)}/{wc.association}/removed/point_cloud.ply",
        out=lambda wc: f"{run_dir(wc)}/{wc.association}/removed_renders",
    threads: 1
    log:
        f"{OUT}/logs/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/render_removed.log",
    benchmark:
        f"{OUT}/benchmarks/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/render_removed.tsv"
    shell:
        "inpaint360gs render {params.model:q} {params.scene_dir:q} {params.out:q} --split test"
        " --backend {params.backend:q} --threads {threads} --overwrite --no-progress > {log:q} 2>&1"
