rule descriptors:
    output:
        f"{OUT}/descriptors/{{dataset}}/{{method}}.h5",
    log:
        f"{OUT}/logs/descriptors/{{dataset}}/{{method}}.log",
    threads: 2
    resources:
        gpu=1,
    shell:
        "{CLI} descriptors --config {CONFIG_FILE} --dataset {wildcards.dataset} --method {wildcards.method}"
        " --out {output} > {log} 2>&1"
