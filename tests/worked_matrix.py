"""The 6 x 6 distance matrix whose every metric is worked out by hand (the VPR metrics' and the per-query CSV's
tests), and a stand-in predictor that decides what it is told."""

import numpy as np

# Rows are references r, columns queries q; tolerance 0 (only r = q is correct), L = 2.
D = np.array([
    [1, 5, 5, 5, 2, 5],
    [5, 3, 5, 5, 5, 0.5],
    [5, 2, 1, 5, 5, 5],
    [5, 5, 5, 4, 5, 5],
    [5, 5, 5, 1, 3, 5],
    [5, 5, 5, 2, 5, 0],
])
# Single-frame, per query q (column ascending, ties to the lower reference):
#   q0 [1,5,5,5,5,5]   match 0 right; the right reference ranks 0; distance 1
#   q1 [5,3,2,5,5,5]   match 2 wrong; r1 = 3 has one smaller value: rank 1; distance 2
#   q2 [5,5,1,5,5,5]   match 2 right, rank 0; distance 1
#   q3 [5,5,5,4,1,2]   match 4 wrong; r3 = 4 has two smaller: rank 2; distance 1
#   q4 [2,5,5,5,3,5]   match 0 wrong; r4 = 3 has one smaller: rank 1; distance 2
#   q5 [5,.5,5,5,5,0]  match 5 right, rank 0; distance 0
# Sequence, S[i, j] = D[i, j] + D[i+1, j+1], query a = j + 1, right diagonal i = j:
#   a1 (j0): 4, 7, 10, 10, 10   match i0 -> ref 1 right, rank 0; distance 4
#   a2 (j1): 10, 4, 7, 10, 10   match i1 -> ref 2 right, rank 0; distance 4
#   a3 (j2): 10, 10, 5, 6, 7    match i2 -> ref 3 right, rank 0; distance 5
#   a4 (j3): 10, 10, 10, 7, 6   match i4 -> ref 5 wrong; i3 = 7 ranks 1; distance 6
#   a5 (j4): 2.5, 10, 10, 10, 3 match i0 -> ref 1 wrong; i4 = 3 ranks 1; distance 2.5
# S.min 2.5, S.max 10; D.min 0, D.max 5. Labels a1..a5: 2, 0, 2, 3, 1.
SEQ_LEN, TOLERANCE = 2, 0

# The predictor's decision on a1..a5: classes 1, 0, 2, 3, 0 -> kept F, T, T, F, T (a1 right but removed, a4 wrong
# and removed, a5 wrong and kept).
DECISION = [1, 0, 2, 3, 0]


class FixedPredictor:
    """A stand-in for SMRPredictor: one fixed probability row per evaluated query, in query order."""

    classes_ = np.arange(4)

    def __init__(self, classes, confidence=0.7):
        self.rows = np.full((len(classes), 4), (1 - confidence) / 3)
        self.rows[np.arange(len(classes)), classes] = confidence

    def predict_proba(self, attributes):
        assert attributes.shape == (len(self.rows), 4)
        return self.rows
