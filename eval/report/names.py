"""The names of the columns that the report's modules read from a row's cells (``rows.cells``), each spelt here
once; the row records of ``rows`` declare the columns themselves, as fields of these names."""

REDUCTION = "reduction_pct"  # the AOC reduction (%) of a removal against VPR+SM
REDUCTION_MEAN = "reduction_pct_mean"  # its mean over the seeds (the random scorer: over its own seeds)
AOC_VPR_SM = "aoc_vpr_sm"  # the area over VPR+SM's PR curve
AOC_VPR_SM_PRED = "aoc_vpr_sm_pred"  # the area over VPR+SM+Pred's
AOC = "aoc"  # a row's own AOC at its own maximum recall (the experiment adaptive_seq_len's rows)
RECALL_SINGLE = "recall_at_1_single"  # single-frame recall@1
RECALL_SEQUENCE = "recall_at_1_sequence"  # sequence recall@1
