from vpr_smr.pipeline.cli import run

run()
