"""The naive oracles of the tests: each rule of the method written literally from its definition, one value at a
time in plain Python (or numpy inside one query), and nothing else; likewise SALAD's aggregation and the DINOv2 ViT
of the SALAD and MegaLoc backends, loop by loop. Tests compare the package's vectorised code with these; nothing here
calls the package."""

from __future__ import annotations

import math
from fractions import Fraction
from typing import TYPE_CHECKING

import numpy as np

from vpr_smr.core.constants import EPS, GROUP_HALF_WIDTH, RECALL_AT

if TYPE_CHECKING:
    import torch

# --- the sequence matrix of the fixed matcher (method §4) --------------------------------------------------------


def sequence_matrix(distance_matrix: np.ndarray, seq_len: int) -> np.ndarray:
    """``S[i, j] = sum_{k < L} D[i + k, j + k]``, shape ``(R - L + 1) x (Q - L + 1)``, float64."""
    d = np.asarray(distance_matrix, dtype=np.float64)
    rows, cols = d.shape[0] - seq_len + 1, d.shape[1] - seq_len + 1
    return np.array([[sum(d[i + k, j + k] for k in range(seq_len)) for j in range(cols)] for i in range(rows)])


def single_frame_matches(distance_matrix: np.ndarray) -> np.ndarray:
    """Best reference per query: ``argmin_r D[r, q]`` (first index on ties)."""
    return np.argmin(distance_matrix, axis=0)


def sequence_matches(sequence: np.ndarray, seq_len: int) -> tuple[np.ndarray, np.ndarray]:
    """Reference index matched to each query ``a >= L - 1`` and its sequence distance ``min_i S[i, j]``."""
    best = np.argmin(sequence, axis=0)
    return best + seq_len - 1, sequence[best, np.arange(sequence.shape[1])]


def naive_sequence(distance_matrix, seq_len):
    """S by its definition and each query's sequence match, distance and single-frame match."""
    s = sequence_matrix(distance_matrix, seq_len)
    best = [min(range(s.shape[0]), key=lambda i: (s[i, j], i)) for j in range(s.shape[1])]
    return s, np.array(best) + seq_len - 1, s.min(0), distance_matrix.argmin(0)[seq_len - 1 :]



def tied_matrix(n_ref=600, n_query=120, seed=3):
    """Random distances with a stopped train: reference frames 200..215 are one frame repeated (equal rows),
    close to every query, and query frames 40..70 are one frame repeated (equal columns); so the best diagonals
    of many queries tie exactly."""
    rng = np.random.default_rng(seed)
    matrix = rng.random((n_ref, n_query)).astype(np.float32) + 0.5
    matrix[200:216] = rng.random(n_query).astype(np.float32) * 0.1
    matrix[:, 40:71] = matrix[:, 40:41]
    return matrix


# --- the fixed matcher's attributes (method §5), one query at a time ---------------------------------------------


def naive_attributes(distance_matrix, seq_len, n_ranks):
    """A literal transcription of the fixed matcher's attributes (method §5), one query at a time."""
    dn = distance_matrix / np.where(distance_matrix.max(0) == 0, 1, distance_matrix.max(0))
    n_ref, n_query = dn.shape
    n_diag = n_ref - seq_len + 1
    out, refs = [], []
    for a in range(seq_len - 1, n_query):
        window = dn[:, a - seq_len + 1 : a + 1]
        diag = np.array([[window[d + c, c] for c in range(seq_len)] for d in range(n_diag)])
        full, past = diag.sum(1), diag[:, :-1].sum(1)
        rowpast = window[:, :-1].sum(1)
        order = sorted(range(n_diag), key=lambda d: (full[d], d))
        rows = []
        for k in range(n_ranks):
            i = order[k]
            lo = seq_len * (i // seq_len)
            block = np.mean([full[m] for m in range(lo, min(n_diag - 1, lo + seq_len - 1) + 1)])
            group = np.mean([full[m] for m in range(max(0, i - 2), min(n_diag - 1, i + 2) + 1)])
            rows.append([
                sorted(past)[k] / (sorted(rowpast)[k] + EPS),
                sorted(window[:, -1])[k] / (diag[i, -1] + EPS),
                past[i] / (block + EPS),
                past[i] / (group + EPS),
            ])
        out.append(rows)
        refs.append([order[k] + seq_len - 1 for k in range(n_ranks)])
    return np.array(out), np.array(refs)


# the keys of ``SequenceMatcher.block_features`` that ``naive_features`` gives
KEYS = ("attributes", "rank_references", "single_match", "sequence_match", "sequence_distance", "sequence_max",
        "sequence_velocity")


# --- velocity search (method §11, and §5 on the index i), one query at a time, in plain Python ------------------


def naive_trajectory(end_ref, query, seq_len, v):
    """``T_v(r)``: the (reference, query) cells, ``k = 0 .. L-1``, or None when ``r - o_0(v) < 0``."""
    cells = [(end_ref - math.floor(v * (seq_len - 1 - k) + 0.5), query - seq_len + 1 + k) for k in range(seq_len)]
    return cells if cells[0][0] >= 0 else None


def naive_sum(matrix, cells):
    acc = 0.0
    for row, col in cells:
        acc += float(matrix[row, col])
    return acc


def naive_mean(values):
    return sum_in_order(values) / len(values)


def naive_query(d, dn, a, seq_len, n_ranks, velocities):
    """Everything ``velocity_block_features`` reports for query ``a`` of the matrix ``d`` (``dn`` = D / colmax)."""
    n_ref = d.shape[0]
    # closest to 1 as written (exact decimal arithmetic), then the smaller
    by_tie_rule = sorted(velocities, key=lambda v: (abs(Fraction(repr(v)) - 1), v))
    best = {}  # r -> (S, v*, cells)
    for r in range(n_ref):
        for v in by_tie_rule:
            cells = naive_trajectory(r, a, seq_len, v)
            if cells is not None:
                s = naive_sum(d, cells)
                if r not in best or s < best[r][0]:
                    best[r] = (s, v, cells)
    r_min = min(best)
    ends = list(range(r_min, n_ref))
    assert ends == sorted(best)  # every reference from r_min on has a trajectory
    n_index = len(ends)
    traj = [[float(dn[row, col]) for row, col in best[r][2]] for r in ends]
    full = [sum_in_order(t) for t in traj]
    past = [sum_in_order(t[:-1]) for t in traj]
    rowpast = [sum_in_order([float(dn[r, c]) for c in range(a - seq_len + 1, a)]) for r in range(n_ref)]
    order = sorted(range(n_index), key=lambda i: (full[i], i))
    seq_i = min(range(n_index), key=lambda i: (best[ends[i]][0], i))
    rows = []
    for k in range(n_ranks):
        i = order[k]
        lo = seq_len * (i // seq_len)
        block = naive_mean([full[m] for m in range(lo, min(n_index - 1, lo + seq_len - 1) + 1)])
        group = naive_mean([full[m] for m in range(max(0, i - GROUP_HALF_WIDTH),
                                                   min(n_index - 1, i + GROUP_HALF_WIDTH) + 1)])
        rows.append([
            sorted(past)[k] / (sorted(rowpast)[k] + EPS),
            sorted(float(dn[r, a]) for r in range(n_ref))[k] / (traj[i][seq_len - 1] + EPS),
            past[i] / (block + EPS),
            past[i] / (group + EPS),
        ])
    column = [float(d[r, a]) for r in range(n_ref)]
    return {
        "attributes": rows,
        "rank_references": [ends[i] for i in order[:n_ranks]],
        "single_match": min(range(n_ref), key=lambda r: (column[r], r)),
        "sequence_match": ends[seq_i],
        "sequence_distance": best[ends[seq_i]][0],
        "sequence_max": max(best[r][0] for r in ends),
        "sequence_velocity": best[ends[seq_i]][1],
    }


def sum_in_order(values):
    acc = 0.0
    for value in values:
        acc += value
    return acc


def naive_features(matrix, seq_len, n_ranks, velocities):
    d = np.asarray(matrix, dtype=np.float64)
    col_max = [max(float(d[r, c]) for r in range(d.shape[0])) or 1.0 for c in range(d.shape[1])]
    dn = np.array([[float(d[r, c]) / col_max[c] for c in range(d.shape[1])] for r in range(d.shape[0])])
    per_query = [naive_query(d, dn, a, seq_len, n_ranks, velocities) for a in range(seq_len - 1, d.shape[1])]
    return {key: np.array([q[key] for q in per_query]) for key in KEYS}


# --- recall@N (method §8.6) -------------------------------------------------------------------------------------


def stable_top(values, n):
    """The ``n`` best indices of ``values``: ascending, equal values by the lower index."""
    return sorted(range(len(values)), key=lambda i: (values[i], i))[:n]


def naive_recalls(d, seq_len, tolerance):
    """recall@N of single-frame (every query) and sequence matching, one query at a time."""
    n_ref, n_query = d.shape
    single = {n: np.mean([any(abs(r - q) <= tolerance for r in stable_top(list(d[:, q]), n))
                          for q in range(n_query)]) for n in RECALL_AT}
    s = sequence_matrix(d, seq_len)
    sequence = {n: np.mean([any(abs(i + seq_len - 1 - (j + seq_len - 1)) <= tolerance
                                for i in stable_top(list(s[:, j]), n)) for j in range(s.shape[1])])
                for n in RECALL_AT}
    return single, sequence


# --- SALAD's optimal-transport aggregation and the DINOv2 ViT (the SALAD and MegaLoc backends) --------------------


def naive_sinkhorn(scores: np.ndarray, dustbin: float, iters: int = 3) -> np.ndarray:
    """Probability-space Sinkhorn on one ``(m, n)`` score matrix; returns the plan times ``n + m``."""
    m, n = scores.shape
    kernel = np.exp(np.vstack([scores, np.full((1, n), dustbin)]))
    row_mass = np.array([1.0] * m + [n - m]) / (n + m)
    col_mass = np.full(n, 1.0 / (n + m))
    row_scale, col_scale = np.ones(m + 1), np.ones(n)
    for _ in range(iters):
        row_scale = row_mass / (kernel @ col_scale)
        col_scale = col_mass / (kernel.T @ row_scale)
    return row_scale[:, None] * kernel * col_scale[None, :] * (n + m)


def naive_aggregate(params: dict[str, np.ndarray], features: np.ndarray, token: np.ndarray) -> np.ndarray:
    """SALAD on one image: ``features`` ``(n, C)`` patch tokens, ``token`` ``(C,)``; loops over clusters."""
    def mlp(x: np.ndarray, prefix: str, second: int) -> np.ndarray:
        w1, b1 = params[f"{prefix}.0.weight"], params[f"{prefix}.0.bias"]
        w2, b2 = params[f"{prefix}.{second}.weight"], params[f"{prefix}.{second}.bias"]
        w1, w2 = w1.reshape(w1.shape[0], -1), w2.reshape(w2.shape[0], -1)
        return np.maximum(x @ w1.T + b1, 0) @ w2.T + b2

    local = mlp(features, "cluster_features", 3)  # (n, l)
    scores = mlp(features, "score", 3).T  # (m, n)
    global_token = mlp(token, "token_features", 2)
    plan = naive_sinkhorn(scores, float(params["dust_bin"]))[:-1]  # drop the dustbin row
    clusters = np.zeros((local.shape[1], plan.shape[0]))  # (l, m)
    for cluster in range(plan.shape[0]):
        vector = (plan[cluster][:, None] * local).sum(axis=0)
        clusters[:, cluster] = vector / np.linalg.norm(vector)
    # Channel-major layout: entry l * m + cluster.
    descriptor = np.concatenate([global_token / np.linalg.norm(global_token), clusters.reshape(-1)])
    return descriptor / np.linalg.norm(descriptor)


def naive_vit_tokens(sd: dict[str, torch.Tensor], image: torch.Tensor, depth: int,
                     heads: int) -> torch.Tensor:
    """DINOv2 forward written out with explicit formulas (float64); returns final-normed tokens (1 + n, D)."""
    import torch
    import torch.nn.functional as F

    def layer_norm(x: torch.Tensor, prefix: str) -> torch.Tensor:
        centred = x - x.mean(-1, keepdim=True)
        return centred / torch.sqrt((centred**2).mean(-1, keepdim=True) + 1e-6) * sd[f"{prefix}.weight"] + sd[
            f"{prefix}.bias"]

    def linear(x: torch.Tensor, prefix: str) -> torch.Tensor:
        return x @ sd[f"{prefix}.weight"].T + sd[f"{prefix}.bias"]

    p = "backbone.model."
    height, width = image.shape[-2:]
    gh, gw = height // 14, width // 14
    patches = image.reshape(3, gh, 14, gw, 14).permute(1, 3, 0, 2, 4).reshape(gh * gw, 3 * 14 * 14)
    kernel = sd[p + "patch_embed.proj.weight"].reshape(-1, 3 * 14 * 14)
    x = patches @ kernel.T + sd[p + "patch_embed.proj.bias"]
    pos = sd[p + "pos_embed"]
    grid = F.interpolate(pos[:, 1:].reshape(1, 37, 37, -1).permute(0, 3, 1, 2),
                         scale_factor=((gh + 0.1) / 37, (gw + 0.1) / 37), mode="bicubic", antialias=False)
    x = torch.cat([sd[p + "cls_token"][0] + pos[0, :1], x + grid[0].flatten(1).T])
    dim = x.shape[1]
    head_dim = dim // heads
    for i in range(depth):
        b = f"{p}blocks.{i}."
        qkv = linear(layer_norm(x, b + "norm1"), b + "attn.qkv")
        heads_out = []
        for h in range(heads):
            q, k, v = (qkv[:, s * dim + h * head_dim: s * dim + (h + 1) * head_dim] for s in range(3))
            weights = torch.exp(q @ k.T / math.sqrt(head_dim))
            heads_out.append((weights / weights.sum(1, keepdim=True)) @ v)
        x = x + sd[b + "ls1.gamma"] * linear(torch.cat(heads_out, 1), b + "attn.proj")
        hidden = linear(layer_norm(x, b + "norm2"), b + "mlp.fc1")
        hidden = 0.5 * hidden * (1 + torch.erf(hidden / math.sqrt(2)))
        x = x + sd[b + "ls2.gamma"] * linear(hidden, b + "mlp.fc2")
    return layer_norm(x, p + "norm")


# --- the training-free scorers (method §12), one query at a time ---------------------------------------------------


def naive_end_sums(d, a, seq_len, velocities):
    """``{r: S[r, a]}`` of every end reference with a trajectory (method §11; the fixed matcher at ``(1.0,)``), by
    the definition, in plain Python."""
    by_tie_rule = sorted(velocities, key=lambda v: (abs(Fraction(repr(v)) - 1), v))
    best = {}
    for r in range(d.shape[0]):
        for v in by_tie_rule:
            cells = naive_trajectory(r, a, seq_len, v)
            if cells is not None:
                s = naive_sum(d, cells)
                if r not in best or s < best[r]:
                    best[r] = s
    return best


def naive_windowed_uniqueness(values, window):
    """SeqSLAM's windowed uniqueness of one query, literally: ``values`` maps each candidate reference to its value;
    ``r*`` the lowest reference of the smallest value; the smallest value with ``|r - r*| > window`` over it; 1 when
    none lies outside or both are 0 (at or below 0: rounding of 0), +inf when only the best is."""
    best_ref = min(values, key=lambda r: (values[r], r))
    best = values[best_ref]
    outside = [values[r] for r in values if abs(r - best_ref) > window]
    if not outside:
        return 1.0
    second = min(outside)
    if best <= 0:
        return 1.0 if second <= 0 else math.inf
    return second / best


def naive_scores(d, seq_len, velocities, r_window, spread_k, positions, correct, seed=0):
    """Every training-free scorer's ``c_a`` of every evaluated query, from method §12's definitions one query at a
    time: S by its definition (no candidates), sorts by (value, reference), ``np.std`` of the chosen positions
    (``(R, d)`` positions: the root of the summed per-axis variances). ``correct``: the sequence matches' verdicts."""
    d = np.asarray(d, dtype=np.float64)
    window = r_window // 2
    out = {name: [] for name in ("uniqueness", "single_uniqueness", "spread", "distance")}
    for a in range(seq_len - 1, d.shape[1]):
        sums = naive_end_sums(d, a, seq_len, velocities)
        out["uniqueness"].append(naive_windowed_uniqueness(sums, window))
        out["single_uniqueness"].append(naive_windowed_uniqueness({r: float(d[r, a]) for r in range(d.shape[0])},
                                                                  window))
        best = sorted(sums, key=lambda r: (sums[r], r))[:spread_k]
        chosen = np.asarray(positions, dtype=np.float64)[best]
        spread = np.std(chosen) if chosen.ndim == 1 else math.sqrt(sum(np.var(chosen[:, k])
                                                                         for k in range(chosen.shape[1])))
        out["spread"].append(-spread)
        out["distance"].append(-min(sums.values()))
    n = d.shape[1] - seq_len + 1
    out["random"] = list(np.random.default_rng(seed).permutation(n).astype(float))
    out["oracle"] = [1.0 if c else 0.0 for c in correct]
    return {name: np.array(values, dtype=np.float64) for name, values in out.items()}


def naive_removed(confidence, budget):
    """The queries a scorer removes at a budget: the ``budget`` lowest confidences, equal ones by the lower index."""
    return set(sorted(range(len(confidence)), key=lambda n: (confidence[n], n))[:budget])


def naive_oracle_removed(distances, correct, budget):
    """The oracle's removal: the wrong matches of smallest sequence distance first (then the lower index), at most
    all of them."""
    wrong = [n for n in range(len(correct)) if not correct[n]]
    return set(sorted(wrong, key=lambda n: (distances[n], n))[:budget])


# --- the threshold rules of method §16: counts by loops, SciPy's beta quantile per step of the search ---------


def naive_counts(conf: list[float], correct: list[bool], t: float | None) -> tuple[int, int]:
    n = k = 0
    for c, y in zip(conf, correct, strict=True):
        if t is not None and c >= t:
            n += 1
            k += not y
    return n, k


def naive_empirical(conf: list[float], correct: list[bool], p: float) -> float | None:
    for t in sorted(set(conf)):  # ascending: the first that reaches p is the smallest
        n, k = naive_counts(conf, correct, t)
        if n and (n - k) / n >= p:
            return t
    return None


def naive_guaranteed(conf: list[float], correct: list[bool], p: float, delta: float) -> float | None:
    ordered = sorted(conf, reverse=True)
    m = len(ordered)
    if not m:
        return None
    n_steps = max(1, math.ceil(math.log2(m)))
    lo, hi, kept = 0, m, None
    for _ in range(n_steps):
        if hi <= lo:
            break
        z = math.ceil((lo + hi) / 2)
        t = ordered[z - 1]
        n, k = naive_counts(conf, correct, t)
        bound = 1.0 if k == n else _beta_ppf(1 - delta / n_steps, k + 1, n - k)
        if bound <= 1 - p:
            kept, lo = t, z
        else:
            hi = z
    return kept


def _beta_ppf(q: float, a: float, b: float) -> float:
    from scipy.stats import beta  # here: the other oracles need no SciPy statistics

    return float(beta.ppf(q, a, b))
