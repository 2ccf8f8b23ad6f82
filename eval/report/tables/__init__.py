"""The report's tables that are one module each: a module here declares its table as ``TABLE`` (a
``registry.Table``: its row record, how its rows are made from the run's inputs, its files and its section), and
``registry.TABLES`` lists it after ``registry.CORE_TABLES`` with no other edit (docs/extending.md, *A table*)."""

# The registry first: it imports each module here once, whole, whichever module a program imports first
from vpr_smr.eval.report import registry as registry
