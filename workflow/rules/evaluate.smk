# Evaluation against the object-free test_ views (paper Sec. 4 "Metrics") and the paper's tables
# (Tab. 1-3, the supplementary per-scene and runtime tables) with provenance.


rule evaluate:
    """Every metric of a method's test_ renders (`inpaint360gs evaluate`), AMCR on the method's own
    removal masks at the test cameras (`--removal`, paper supp. Eq. 1), the fill's geometry against
    the true surface (`--model`: its final model); a scene without ground truth gets null metrics
    with the reason."""
    input:
        scene_json=lambda wc: f"{scene_dir(wc.scene)}/scene.json",
        stage=lambda wc: method_renders(wc)[0],
        removal=lambda wc: f"{removal_dir(wc, METHODS[wc.method]['association'])}/removal.json",
    output:
        f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/eval/{{method}}.json",
    params:
        scene_dir=lambda wc: scene_dir(wc.scene),
        renders=lambda wc: os.path.join(os.path.dirname(method_renders(wc)[0]), method_renders(wc)[1]),
        removed=lambda wc: removal_dir(wc, METHODS[wc.method]["association"]),
        model=lambda wc: os.path.join(os.path.dirname(method_model(wc)), "point_cloud.ply"),
        backend=BACKEND,
        inception=f"--inception-weights {shlex.quote(config['inception_weights'])}" if config["inception_weights"] else "",
    threads: THREADS
    resources:
        mem_mb=6000,
    log:
        f"{OUT}/logs/{{scene}}/seed{{seed}}/{{segmenter}}/methods/{{method}}/evaluate.log",
    benchmark:
        f"{OUT}/benchmarks/{{scene}}/seed{{seed}}/{{segmenter}}/methods/{{method}}/evaluate.tsv"
    shell:
        "inpaint360gs evaluate {params.renders:q} {params.scene_dir:q} {output:q} {params.inception}"
        " --removal {params.removed:q} --model {params.model:q} --backend {params.backend:q} --threads {threads} > {log:q} 2>&1"


rule score_removal:
    """What a run's removal took (`inpaint360gs score-removal`; docs/architecture.md, "Ground-truth
    removal scores"): AMCR over the training views (paper supp. Eq. 1) and, against a synthetic
    scene's gt/, residual, collateral and the true footprint share, with the limits a run must stay
    within. One per removal: every method with the same association shares it."""
    input:
        scene_json=lambda wc: f"{scene_dir(wc.scene)}/scene.json",
        removal=f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/removed/removal.json",
    output:
        f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/removal_scores.json",
    params:
        scene_dir=lambda wc: scene_dir(wc.scene),
        removed=lambda wc: f"{run_dir(wc)}/{wc.association}/removed",
        backend=BACKEND,
    threads: 1
    resources:
        mem_mb=4000,
    log:
        f"{OUT}/logs/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/score_removal.log",
    benchmark:
        f"{OUT}/benchmarks/{{scene}}/seed{{seed}}/{{segmenter}}/{{association}}/score_removal.tsv"
    shell:
        "inpaint360gs score-removal {params.scene_dir:q} {params.removed:q} {output:q} --backend {params.backend} --threads {threads} > {log:q} 2>&1"


rule record:
    """One self-describing record per (scene, seed, segmenter, method): labels, metrics, stage times, storage."""
    input:
        evaluation=f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/eval/{{method}}.json",
        removal_scores=lambda wc: f"{run_dir(wc)}/{METHODS[wc.method]['association']}/removal_scores.json",
        benchmarks=lambda wc: list(stage_benchmarks(wc).values()),
        stage=method_model,
    output:
        f"{OUT}/{{scene}}/seed{{seed}}/{{segmenter}}/records/{{method}}.json",
    params:
        labels=lambda wc: " ".join(
            "--label " + shlex.quote(f"{k}={v}")
            for k, v in dict(scene=wc.scene, seed=wc.seed, segmenter=wc.segmenter, method=wc.method, kind=METHODS[wc.method]["kind"],
                             name=METHODS[wc.method]["name"], **METHODS[wc.method].get("labels", {})).items()
        ),
        stages=lambda wc: " ".join("--stage " + shlex.quote(f"{k}={v}") for k, v in stage_benchmarks(wc).items()),
        model=lambda wc: os.path.join(os.path.dirname(method_model(wc)), "point_cloud.ply"),
    log:
        f"{OUT}/logs/{{scene}}/seed{{seed}}/{{segmenter}}/methods/{{method}}/record.log",
    shell:
        "inpaint360gs table record {output:q} {params.labels} --eval {input.evaluation:q} --removal-scores {input.removal_scores:q} {params.stages}"
        " --model {params.model:q} > {log:q} 2>&1"


rule paper_tables:
    """per_scene, table1_average, table3_ablation, table2_runtime (CSV, Markdown, LaTeX) + provenance.json;
    seed spreads and paired bootstrap intervals that resample scenes (docs/guide.md, "Tables of the paper");
    every run above a removal limit named under Tab. 1 and, with `keep_failed`, its test renders and
    removal masks copied into results_dir/failed/."""
    input:
        records=[f"{OUT}/{s}/seed{k}/{g}/records/{m}.json" for s, k, g, m in runs()],
    output:
        # the configuration of the run that writes the tables (every --config override applied), for
        # provenance; written by this rule so that it can never be older than the tables
        config=f"{RESULTS}/config.yaml",
        table1=f"{RESULTS}/table1_average.md",
        per_scene=f"{RESULTS}/per_scene.md",
        provenance=f"{RESULTS}/provenance.json",
        csv=[
            report(f"{RESULTS}/{t}.csv", caption=f"../report/{t}.rst", category="Tables", labels={"table": t})
            for t in ("table1_average", "table3_ablation", "table2_runtime", "table2_runtime_detail", "per_scene")
        ],
        sweep=[
            report(f"{RESULTS}/views_sweep.png", caption="../report/views_sweep.rst", category="Tables", labels={"table": "views_sweep"})
        ]
        if SWEEP and "full" in config["methods"]
        else [],
        failed=[directory(f"{RESULTS}/failed")] if config["keep_failed"] else [],
    params:
        out=RESULTS,
        seeds=" ".join(str(k) for k in SEEDS),
        keep_failed=f"--keep-failed {shlex.quote(RESULTS + '/failed')}" if config["keep_failed"] else "",
        config_text=yaml.safe_dump(dict(config), sort_keys=False),
    log:
        f"{OUT}/logs/paper_tables.log",
    shell:
        "printf '%s' {params.config_text:q} > {output.config:q} &&"
        " inpaint360gs table paper {input.records:q} --out-dir {params.out:q} --config {output.config:q}"
        " --seeds {params.seeds} {params.keep_failed} > {log:q} 2>&1"
