# The workflow ships inside the package (pipeline/Snakefile), so that an installed wheel runs it too:
#   vpr-smr run configs/<run>.yaml        or   snakemake --configfile configs/<run>.yaml --profile pipeline/profiles/local
include: "pipeline/Snakefile"
