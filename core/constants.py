"""Facts of the method that several stages use, each set here once (docs/method.md sections cited per constant).

Plain module-level values (ints, floats, tuples of them), and the two rules of the training-free scorers' window
that the attributes stage, the scorers and the workflow share (``half_window``, ``candidates_needed``): the compiled
kernels (``eval.matching.kernels``) read ``EPS`` and ``GROUP_HALF_WIDTH`` as globals, which numba freezes at compile
time.
"""

from __future__ import annotations

DEFAULT_TOLERANCE = 2  # method §1: a match is correct within 2 frames, for every dataset
METRICS = ("l2", "cosine", "mad")  # distances between descriptors (eval.matching.distances)

EPS = 1e-6  # added to every denominator of the attributes A1..A4 (method §5)
GROUP_HALF_WIDTH = 2  # W in the paper: the group of diagonal i is i-W .. i+W (A4, method §5)

# method §6: 0 correct before and after sequence matching, 1 before only, 2 after only, 3 wrong both
LABELS = (0, 1, 2, 3)
N_LABELS = len(LABELS)
KEPT_CLASSES = (0, 2)  # method §6: labels whose sequence match is correct; the predictor keeps these matches

MODES = ("paper", "standard")  # metric modes of the PR curves (eval.scoring.curves)

# The standard VPR metrics (eval.scoring.vpr_metrics): recall@N for these N, for each matcher: single-frame
# matching, sequence matching, and sequence matching with the predictor (removed matches count as not retrieved).
RECALL_AT = (1, 5, 10, 20)
MATCHERS = ("single", "sequence", "sequence_predictor")
# Trust levels of the trust-level ablation; pipeline/config_schema.json repeats them as the `trust_levels`
# default (a JSON schema cannot import), and tests/unit/test_config.py checks that both agree.
DEFAULT_TRUST_LEVELS = (0.0, 0.5, 0.7, 0.9, 1.0)

# method §11: velocities (reference frames per query frame) searched by sequence matching; (1.0,) is method §4's fixed
# slope-1 matcher, the paper's: the default of seqslam's settings (eval.matching.matchers.seqslam).
DEFAULT_VELOCITIES = (1.0,)

# method §12: the training-free scorers' settings, the defaults of their settings record (eval.scoring.scorers,
# whose declarations pipeline/config_schema.json's `baselines` is generated from). uniqueness looks for the smallest
# S outside the window |r - r*| <= r_window / 2 around the sequence match (OpenSeqSLAM2's rWindow); spread takes the
# K best end references.
DEFAULT_R_WINDOW = 10
DEFAULT_SPREAD_K = 10


def half_window(r_window: int) -> int:
    """``w``: uniqueness looks outside ``|r - r*| <= w`` (method §12). OpenSeqSLAM2 excludes ``|r - r*| <=
    r_window / 2``, which for whole references is ``floor(r_window / 2)`` (a ``round`` agrees for an even
    ``r_window``; Python's and MATLAB's ``round`` would disagree with each other for an odd one)."""
    if int(r_window) != r_window or r_window < 0:
        raise ValueError(f"r_window is a number of reference frames >= 0, got {r_window}")
    return int(r_window) // 2


def candidates_needed(r_window: int = DEFAULT_R_WINDOW, spread_k: int = DEFAULT_SPREAD_K) -> int:
    """How many of the smallest ``S`` (and ``D``) values per query the training-free scorers need (method §12):
    the smallest ``S`` outside a window of at most ``2 w + 1`` references is among the ``2 w + 2`` smallest, and
    spread takes the ``K`` smallest."""
    if int(spread_k) != spread_k or spread_k < 1:
        raise ValueError(f"spread_k is a number of end references >= 1, got {spread_k}")
    return max(2 * half_window(r_window) + 2, int(spread_k))

# The layout of the result files (predictors, evaluations, the speed experiment's): a job param of the rules that
# write them, so that a run made by an earlier layout writes them again instead of failing to read them; every result
# JSON records it as its "format" (core.records.FORMAT), and a file of another is refused. 2: predictor files record
# their matching, every reduction its outcome (0.5.0). 3: one codec writes every record, an embedded record as its
# own object, the first seed's numbers once. 4: Table II's numbers keyed by the splits' names; only the first
# predictor seed is cross-validated (the others' f1_cv is null). 5: bootstrap intervals over queries beside the
# numbers the tables show, the scorers against the predictor paired, a standard deviation of one seed null.
# 6: an outcome names a direction only where its interval earns it, sequence recall@N ranks the matcher's match
# first, predictor files record their sequence length, methods and training matrices (0.15.0). 7: a
# worse_from_zero outcome (the baseline's AOC 0) is said only where the interval of the AOC difference earns it,
# else the word that interval gives (0.17.0). 8: a from-zero outcome keeps the interval of the AOC difference that
# judged it (``Reduction.aoc_difference_ci``), which the tables write beside it: a file of 7 lacks it.
RESULTS_LAYOUT = 8
