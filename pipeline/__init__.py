"""The command line (``vpr-smr``) and the Snakemake workflow that calls it."""
