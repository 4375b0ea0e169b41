# Inpainting after removal (paper Sec. 3.4-3.5): virtual views, unseen masks, recursive conditional
# RGB-D 2D inpainting, depth-guided initialisation, 3D hybrid fine-tuning. One job per method that
# inpaints (the full method, the per-view 2D baseline, ablations a-e), all on the shared removal.


rule inpaint:
    """`inpaint360gs inpaint` with the method's switches (common.smk, METHODS)."""
    input:
        scene_json=lambda wc: f"{scene_dir(wc.scene)}/scene.json",
        distill=lambda wc: f"{run_dir(wc)}/{METHODS[wc.method]['association']}/distill/distill.json",
        removal=lambda wc: f"{run_dir(wc)}/{METHODS[wc.method]['association']}/removed/removal.json",
    output:
        record=f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/methods/{{method}}/inpaint.json",
        grid=report(
            f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/methods/{{method}}/grid.png",
            caption="../report/grid.rst",
            category="Before / after",
            subcategory="{scene}",
            labels={"scene": "{scene}", "seed": "{seed}", "segmenter": "{segmenter}", "method": "{method}", "figure": "test views"},
        ),
        trajectory=report(
            f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/methods/{{method}}/trajectory.gif",
            caption="../report/trajectory.rst",
            category="Virtual trajectory",
            subcategory="{scene}",
            labels={"scene": "{scene}", "seed": "{seed}", "segmenter": "{segmenter}", "method": "{method}", "figure": "trajectory"},
        ),
    params:
        backend=BACKEND,
        scene_dir=lambda wc: scene_dir(wc.scene),
        distill=lambda wc: f"{run_dir(wc)}/{METHODS[wc.method]['association']}/distill",
        removed=lambda wc: f"{run_dir(wc)}/{METHODS[wc.method]['association']}/removed",
        out=lambda wc: f"{run_dir(wc)}/methods/{wc.method}",
        switches=lambda wc: METHODS[wc.method]["inpaint"],
        iterations="" if INPAINT_ITERATIONS is None else f"--inpaint-iterations {INPAINT_ITERATIONS}",
        views=VIRTUAL_VIEWS,
        extra=EXTRA["inpaint"],
    threads: THREADS
    resources:
        mem_mb=8000,
        gpu=1 if BACKEND == "gsplat" else 0,
    log:
        f"{OUT}/logs/{{scene}}/seed{{seed}}/{{segmenter}}/methods/{{method}}/inpaint.log",
    benchmark:
        f"{OUT}/benchmarks/{{scene}}/seed{{seed}}/{{segmenter}}/methods/{{method}}/inpaint.tsv"
    shell:
        # the method's switches come last: they override the configured defaults (e.g. L of a sweep run)
        "inpaint360gs inpaint {params.scene_dir:q} {params.distill:q} {params.removed:q} {params.out:q}"
        " {params.iterations} --virtual-views {params.views:q} --seed {wildcards.seed}"
        " --backend {params.backend:q} --threads {threads} --overwrite --no-progress {params.extra} {params.switches} > {log:q} 2>&1"
