import sys

from vpr_smr.pipeline.cli import main

sys.exit(main())
