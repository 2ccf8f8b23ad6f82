"""The classic backends' arithmetic in NumPy, with rules that give the same bytes on every machine.

OpenCV's ``cvtColor``, ``resize`` and ``HOGDescriptor`` choose a SIMD path (or IPP) by the CPU, and those paths
round differently (fused multiply-adds, another summation order, a polynomial arctangent evaluated with or without
FMA): HOG descriptors differed by up to 3.6e-7 between two machines, enough to reorder near-ties. Here:

- ``grey``: OpenCV's 8-bit rule, in integers: ``(4899 R + 9617 G + 1868 B + 8192) >> 14``.
- ``resize_area``: the exact area average (each output pixel is the mean of the source over its footprint) as a
  ratio of integers, rounded to nearest, ties to even. It is OpenCV's ``INTER_AREA`` when both sides shrink or
  both grow (OpenCV rounds its own weights, so a pixel may differ by one grey level at non-integer factors); an
  integer enlargement repeats pixels, exactly as OpenCV.
- ``hog``: OpenCV's ``HOGDescriptor`` (unsigned gradients, Gaussian block window, trilinear voting, L2-Hys) in
  float64 with only correctly rounded operations (+, -, *, /, sqrt) in a fixed order, OpenCV's arctangent
  polynomial in place of ``atan2``, the window's exponentials computed in decimal arithmetic, histogram sums in the
  input's order (``np.bincount``), block norms as running sums (``np.cumsum``), the descriptor's norm an
  exactly rounded sum (``math.fsum``); rounded to float32 once, at the end.

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
def _hog_layout(width: int, height: int, cell: int, block: int, bins: int) -> tuple[np.ndarray, ...]:
    """The votes' geometry, as OpenCV's HOG cache builds it: per (block, pixel of the block, cell it votes for),
    the image pixel, the first histogram entry of that cell in the descriptor, and the weight (Gaussian window
    times the bilinear cell weight); votes of weight 0 (a cell outside the block) are left out."""
    stride = cell  # block stride = cell size (the backend's configuration)
    blocks_x, blocks_y = (width - block) // stride + 1, (height - block) // stride + 1
    cells = block // cell
    sigma = block / 4  # OpenCV's default window sigma: (block width + block height) / 8
    half = block / 2
    window = np.array([[_exp(-((i - half) ** 2 + (j - half) ** 2) / (2 * sigma * sigma)) for j in range(block)]
                       for i in range(block)])
    pixel, entry, weight = [], [], []
    block_values = cells * cells * bins
    for bx in range(blocks_x):  # OpenCV's order: blocks column by column, cells column by column
        for by in range(blocks_y):
            offset = (bx * blocks_y + by) * block_values
            for j in range(block):
                for i in range(block):
                    cx, cy = (j + 0.5) / cell - 0.5, (i + 0.5) / cell - 0.5
                    x0, y0 = math.floor(cx), math.floor(cy)
                    fx, fy = cx - x0, cy - y0
                    for ix, wx in ((x0, 1 - fx), (x0 + 1, fx)):
                        for iy, wy in ((y0, 1 - fy), (y0 + 1, fy)):
                            if 0 <= ix < cells and 0 <= iy < cells and wx * wy > 0:
                                pixel.append((by * stride + i) * width + bx * stride + j)
                                entry.append(offset + (ix * cells + iy) * bins)
                                weight.append(window[i, j] * (wx * wy))
    return (np.array(pixel, dtype=np.int64), np.array(entry, dtype=np.int64), np.array(weight),
            np.array([blocks_x * blocks_y, block_values]))


def _row_sums(values: np.ndarray) -> np.ndarray:
    """Each row's sum from left to right (a running sum, whose order no SIMD path can change)."""
    sums: np.ndarray = np.cumsum(values, axis=1)[:, -1]
    return sums


def hog(image: np.ndarray, cell: int = 8, block: int = 16, bins: int = 9) -> np.ndarray:
    """OpenCV's ``HOGDescriptor((W, H), (block, block), (cell, cell), (cell, cell), bins).compute(image)`` of a
    grey uint8 image (one window, the whole image) in the exact float64 rules of this module, still float64 (the
    backend rounds to float32 once, after its own normalisation)."""
    height, width = image.shape
    pixel, entry, weight, (n_blocks, block_values) = _hog_layout(width, height, cell, block, bins)
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
    first = (low.astype(np.int64) % bins).ravel()
    second = (first + 1) % bins
    upper = (magnitude * share).ravel()
    lower = (magnitude - magnitude * share).ravel()
    size = int(n_blocks * block_values)
    # each histogram entry sums its lower-bin votes in vote order, then its upper-bin votes in vote order
    histogram = (np.bincount(entry + first[pixel], weights=lower[pixel] * weight, minlength=size)
                 + np.bincount(entry + second[pixel], weights=upper[pixel] * weight, minlength=size))
    blocks = histogram.reshape(int(n_blocks), int(block_values))
    # L2-Hys per block, as OpenCV: normalise (divisor + 0.1 per value), clip at 0.2, normalise again (+ 1e-3)
    scale = 1.0 / (np.sqrt(_row_sums(blocks * blocks)) + block_values * L2HYS_EPS_PER_VALUE)
    blocks = np.minimum(blocks * scale[:, None], L2HYS_CLIP)
    blocks = blocks * (1.0 / (np.sqrt(_row_sums(blocks * blocks)) + L2HYS_EPS))[:, None]
    return blocks.ravel()


def l2_normalised(values: np.ndarray) -> np.ndarray:
    """``values / ||values||`` (unchanged when all are 0), the norm an exactly rounded sum; float32."""
    values = np.asarray(values, dtype=np.float64)
    norm = math.sqrt(math.fsum(values * values))
    result: np.ndarray = (values / norm if norm > 0 else values).astype(np.float32)
    return result
