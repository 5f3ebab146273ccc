"""File names inside a run directory (`manigrasp bench --out RUN_DIR`), in one place.

    RUN_DIR/run.json          resolved config, identity, versions, seed, host (`bench.rundir`)
    RUN_DIR/results.sqlite    one row per trial (`bench.store`)
    RUN_DIR/report.md         the summary with its PNG plots (`bench.markdown`)
    RUN_DIR/recordings/       one rerun .rrd per recorded trial (`record.policy`)

A leaf module (no imports) so that both `bench` and `record` use it without
`record` importing `bench`.
"""

META_NAME = "run.json"
STORE_NAME = "results.sqlite"
REPORT_NAME = "report.md"
RECORDINGS_DIR = "recordings"
