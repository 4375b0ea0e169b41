# Real captures without ground truth (`captures:` in the config, e.g. workflow/config/kitchen.yaml):
# photos -> scene folder (structure from motion at a working size) -> `inpaint360gs run` from 3DGS to
# the inpainted scene -> the no-ground-truth scores and the before / removed / inpainted figure.


def capture(wc):
    return config["captures"][wc.capture]


rule build_capture:
    """`inpaint360gs-dataset build`: the capture's photos to a scene folder."""
    output:
        scene_json=f"{OUT}/captures/{{capture}}/scene/scene.json",
    params:
        photos=lambda wc: capture(wc)["photos"],
        scene=lambda wc: f"{OUT}/captures/{wc.capture}/scene",
        sfm_max_size=lambda wc: capture(wc).get("sfm_max_size", 800),
        downscale=lambda wc: f"--downscale {int(capture(wc)['resize'])}" if capture(wc).get("resize", 1) > 1 else "",
    threads: THREADS
    log:
        f"{OUT}/logs/captures/{{capture}}/build.log",
    benchmark:
        f"{OUT}/benchmarks/captures/{{capture}}/build.tsv"
    shell:
        "inpaint360gs-dataset build {params.photos:q} {params.scene:q} --sfm-max-size {params.sfm_max_size:q}"
        " {params.downscale} --threads {threads} --overwrite --no-progress > {log:q} 2>&1"


rule run_capture:
    """`inpaint360gs run`: every stage from 3DGS to the inpainted scene, at the capture's clicks.
    `--accept`: a result that fails the run's own check is kept and reported (check.json beside the
    scores), not deleted with a failed job."""
    input:
        scene_json=f"{OUT}/captures/{{capture}}/scene/scene.json",
    output:
        run_json=f"{OUT}/captures/{{capture}}/run/run.json",
    params:
        scene=lambda wc: f"{OUT}/captures/{wc.capture}/scene",
        out=lambda wc: f"{OUT}/captures/{wc.capture}/run",
        clicks=lambda wc: click_args(capture(wc)["clicks"]),
        resize=lambda wc: capture(wc).get("resize", 1),
        preset=lambda wc: capture(wc).get("preset", "cpu"),
        backend=BACKEND,
    threads: THREADS
    resources:
        mem_mb=16000,
        gpu=1 if BACKEND == "gsplat" else 0,
    log:
        f"{OUT}/logs/captures/{{capture}}/run.log",
    benchmark:
        f"{OUT}/benchmarks/captures/{{capture}}/run.tsv"
    shell:
        "inpaint360gs run {params.scene:q} {params.out:q} {params.clicks} --resize {params.resize:q} --preset {params.preset:q}"
        " --backend {params.backend:q} --threads {threads} --no-progress --accept > {log:q} 2>&1"


rule capture_scores:
    """`inpaint360gs capture-scores`: outside-the-hole PSNR, what stands in the footprint, the fill's
    texture, and the figure."""
    input:
        run_json=f"{OUT}/captures/{{capture}}/run/run.json",
    output:
        scores=f"{RESULTS}/captures/{{capture}}_scores.json",
        check=f"{RESULTS}/captures/{{capture}}_check.json",
        figure=report(
            f"{RESULTS}/captures/{{capture}}_removal.jpg",
            caption="../report/capture.rst",
            category="Real captures",
            labels={"capture": "{capture}", "figure": "before / removed / inpainted"},
        ),
    params:
        scene=lambda wc: f"{OUT}/captures/{wc.capture}/scene",
        run=lambda wc: f"{OUT}/captures/{wc.capture}/run",
        resize=lambda wc: capture(wc).get("resize", 1),
    threads: THREADS
    log:
        f"{OUT}/logs/captures/{{capture}}/scores.log",
    shell:
        "inpaint360gs capture-scores {params.scene:q} {params.run:q}/3dgs/point_cloud.ply {params.run:q}/distill {params.run:q}/removed"
        " {output.scores:q} --inpainted {params.run:q}/inpainted --figure {output.figure:q} --resize {params.resize:q}"
        " --threads {threads} > {log:q} 2>&1 && cp {params.run:q}/check.json {output.check:q}"
