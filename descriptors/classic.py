"""The classic backends' arithmetic in NumPy, with rules that give the same bytes on every machine.

OpenCV's ``cvtColor``, ``resize`` and ``HOGDescriptor`` choose a SIMD path (or IPP) by the CPU, and those paths
round differently (fused multiply-adds, another summation order, a polynomial arctangent evaluated with or without
FMA): HOG descriptors differed by up to 3.6e-7 between two machines, enough to reorder near-ties. Here:

- ``grey``: OpenCV's 8-bit rule, in integers: ``(4899 R + 9617 G + 1868 B + 8192) >> 14``.
- ``resize_area``: the exact area average (each output pixel is the mean of the source over its footprint) as a
  ratio of integers, rounded to nearest, ties to even. It is OpenCV's ``INTER_AREA`` when both sides shrink or
  both grow, up to one grey level (OpenCV rounds its own weights at non-integer factors, and its 2x2 reduction
  rounds ties up); an integer enlargement (the demo's 64x32 frames to HOG's 128x64) repeats pixels, exactly as
  OpenCV. Where one side shrinks and the other grows, OpenCV interpolates linearly instead.
- ``hog``: OpenCV's ``HOGDescriptor`` (unsigned gradients, Gaussian block window, trilinear voting, L2-Hys) in
  float64 with only correctly rounded operations (+, -, *, /, sqrt) in a fixed order: OpenCV's arctangent
  polynomial in place of ``atan2``, the window's exponentials computed in decimal arithmetic, each block's cells
  summed over the block's columns in order and then its rows in order, block norms as running sums
  (``np.cumsum``), the descriptor's norm an exactly rounded sum (``math.fsum``); rounded to float32 once, at the
  end. It agrees with OpenCV's own float32 result to about 1e-6.

No step depends on the CPU, the BLAS or a library's dispatch, so the result is the same bytes everywhere.
"""

from __future__ import annotations

import math
from decimal import Decimal, localcontext
from functools import cache

import numpy as np

# OpenCV's RGB -> grey weights for 8-bit images (BT.601 in 14-bit fixed point) and its rounding shift
GREY_WEIGHTS = (4899, 9617, 1868)
GREY_SHIFT = 14

# OpenCV's arctangent polynomial (fastAtan2, in degrees; max error about 0.01 degree), on c = min/max of |x|, |y|
ATAN_POLY = tuple(p * 180 / math.pi for p in (0.9997878412794807, -0.3258083974640975, 0.1555786518463281,
                                             -0.04432655554792128))
ATAN_EPS = 2.220446049250313e-16  # OpenCV adds DBL_EPSILON to the divisor
# L2-Hys: clip at 0.2 after a first normalisation whose divisor adds 0.1 per value; the second adds 1e-3
L2HYS_CLIP = 0.2
L2HYS_EPS_PER_VALUE = 0.1
L2HYS_EPS = 1e-3


def grey(image: np.ndarray) -> np.ndarray:
    """RGB uint8 ``H x W x 3`` -> grey uint8 ``H x W``, as OpenCV's ``COLOR_RGB2GRAY`` (integer arithmetic)."""
    rgb = image.astype(np.int32)
    total = rgb[..., 0] * GREY_WEIGHTS[0] + rgb[..., 1] * GREY_WEIGHTS[1] + rgb[..., 2] * GREY_WEIGHTS[2]
    result: np.ndarray = ((total + (1 << (GREY_SHIFT - 1))) >> GREY_SHIFT).astype(np.uint8)
    return result


@cache
def _area_taps(source: int, target: int) -> tuple[np.ndarray, np.ndarray]:
    """Per output pixel, the source pixels its footprint overlaps and the integer overlaps (sum: ``source``).

    Output pixel k covers [k * source, (k + 1) * source) and source pixel i covers [i * target, (i + 1) * target),
    both in units of 1 / (source * target) of a source pixel; the overlaps are integers."""
    taps = -(-source // target) + 1
    first = np.arange(target) * source // target
    index = np.minimum(first[:, None] + np.arange(taps)[None, :], source - 1)
    start = np.maximum(index * target, (np.arange(target) * source)[:, None])
    end = np.minimum((index + 1) * target, (np.arange(target) + 1)[:, None] * source)
    weight = np.maximum(end - start, 0)
    weight[:, 1:][index[:, 1:] == index[:, :-1]] = 0  # a clamped repeat of the last pixel counts once
    return index, weight.astype(np.int64)


def resize_area(image: np.ndarray, width: int, height: int) -> np.ndarray:
    """Grey uint8 ``H x W`` -> ``height x width``: the exact area average, rounded to nearest (ties to even)."""
    rows, cols = image.shape
    if (cols, rows) == (width, height):
        return image.copy()
    x_index, x_weight = _area_taps(cols, width)
    y_index, y_weight = _area_taps(rows, height)
    src = image.astype(np.int64)
    across = sum(src[:, x_index[:, t]] * x_weight[:, t] for t in range(x_index.shape[1]))
    total = sum(across[y_index[:, t], :] * y_weight[:, t, None] for t in range(y_index.shape[1]))
    denominator = cols * rows
    quotient, remainder = np.divmod(np.asarray(total), denominator)
    up = (2 * remainder > denominator) | ((2 * remainder == denominator) & (quotient % 2 == 1))
    result: np.ndarray = (quotient + up).astype(np.uint8)
    return result


def _exp(value: float) -> float:
    """``exp(value)`` correctly rounded to float64 (decimal arithmetic, the same on every machine)."""
    with localcontext() as context:
        context.prec = 40
        return float(Decimal(value).exp())


@cache
def _block_weights(cell: int, block: int) -> np.ndarray:
    """``block x cells``: the weight of a block's pixel row (or column) ``i`` in its cell row (column) ``c``: the
    Gaussian window (sigma = block / 4, OpenCV's default; separable, so one factor per axis) times the linear weight
    between the centres of the two nearest cells, as OpenCV's HOG cache (a cell outside the block gets none)."""
    cells = block // cell
    sigma, half = block / 4, block / 2
    weights = np.zeros((block, cells))
    for i in range(block):
        gauss = _exp(-((i - half) ** 2) / (2 * sigma * sigma))
        position = (i + 0.5) / cell - 0.5
        low = math.floor(position)
        for c, share in ((low, 1 - (position - low)), (low + 1, position - low)):
            if 0 <= c < cells:
                weights[i, c] = gauss * share
    return weights


def row_sums(values: np.ndarray) -> np.ndarray:
    """Each row's sum from left to right (a running sum, whose order no SIMD path can change)."""
    sums: np.ndarray = np.cumsum(values, axis=1)[:, -1]
    return sums


def hog(image: np.ndarray, cell: int = 8, block: int = 16, bins: int = 9) -> np.ndarray:
    """OpenCV's ``HOGDescriptor((W, H), (block, block), (cell, cell), (cell, cell), bins).compute(image)`` of a
    grey uint8 image (one window, the whole image) in the exact float64 rules of this module, still float64 (the
    backend rounds to float32 once, after its own normalisation)."""
    height, width = image.shape
    values = image.astype(np.float64)
    # centred differences; the border rows and columns reflect (OpenCV's BORDER_REFLECT_101), giving 0 there
    dx = np.zeros_like(values)
    dy = np.zeros_like(values)
    dx[:, 1:-1] = values[:, 2:] - values[:, :-2]
    dy[1:-1, :] = values[2:, :] - values[:-2, :]
    magnitude = np.sqrt(dx * dx + dy * dy)
    ax, ay = np.abs(dx), np.abs(dy)
    c = np.minimum(ax, ay) / (np.maximum(ax, ay) + ATAN_EPS)
    c2 = c * c
    p1, p3, p5, p7 = ATAN_POLY
    degrees = (((p7 * c2 + p5) * c2 + p3) * c2 + p1) * c
    degrees = np.where(ax >= ay, degrees, 90.0 - degrees)
    degrees = np.where(dx < 0, 180.0 - degrees, degrees)
    degrees = np.where(dy < 0, 360.0 - degrees, degrees)
    # orientation bins of 180 / bins degrees centred on (k + 0.5) * 180 / bins; a vote is shared by the two nearest
    position = degrees / (180.0 / bins) - 0.5
    low = np.floor(position)
    share = position - low
    first = low.astype(np.int64) % bins
    second = (first + 1) % bins
    # votes: each pixel's magnitude shared between its two orientation bins (first != second, bins > 1)
    votes = np.zeros(height * width * bins)
    pixel = np.arange(height * width) * bins
    votes[pixel + first.ravel()] = (magnitude - magnitude * share).ravel()
    votes[pixel + second.ravel()] = (magnitude * share).ravel()
    votes = votes.reshape(height, width, bins)
    # each block's cells: the weighted sum over the block's columns in order, then over its rows in order
    weights = _block_weights(cell, block)
    cells, stride = block // cell, cell  # block stride = cell size (the backend's configuration)
    blocks_x, blocks_y = (width - block) // stride + 1, (height - block) // stride + 1
    across = np.zeros((height, blocks_x, cells, bins))
    for j in range(block):
        column = votes[:, j:j + stride * (blocks_x - 1) + 1:stride, :]  # (height, blocks_x, bins)
        across += column[:, :, None, :] * weights[j][None, None, :, None]
    down = np.zeros((blocks_y, cells, blocks_x, cells, bins))
    for i in range(block):
        row = across[i:i + stride * (blocks_y - 1) + 1:stride]  # (blocks_y, blocks_x, cells, bins)
        down += row[:, None] * weights[i][None, :, None, None, None]
    # OpenCV's order: blocks column by column, and within a block cells column by column
    blocks = down.transpose(2, 0, 3, 1, 4).reshape(blocks_x * blocks_y, cells * cells * bins)
    # L2-Hys per block, as OpenCV: normalise (divisor + 0.1 per value), clip at 0.2, normalise again (+ 1e-3)
    scale = 1.0 / (np.sqrt(row_sums(blocks * blocks)) + blocks.shape[1] * L2HYS_EPS_PER_VALUE)
    blocks = np.minimum(blocks * scale[:, None], L2HYS_CLIP)
    blocks = blocks * (1.0 / (np.sqrt(row_sums(blocks * blocks)) + L2HYS_EPS))[:, None]
    result: np.ndarray = blocks.ravel()
    return result


def l2_normalised(values: np.ndarray) -> np.ndarray:
    """``values / ||values||`` (unchanged when all are 0), the norm an exactly rounded sum; float32."""
    values = np.asarray(values, dtype=np.float64)
    norm = math.sqrt(math.fsum(values * values))
    result: np.ndarray = (values / norm if norm > 0 else values).astype(np.float32)
    return result
