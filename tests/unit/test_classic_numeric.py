"""The classic backends give the same bytes whatever path OpenCV takes, and agree with OpenCV's plain path."""

from collections.abc import Iterator
from contextlib import contextmanager

import cv2
import numpy as np
import pytest

from vpr_smr.datasets import read_image
from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.descriptors import backend_class
from vpr_smr.descriptors.classic import grey, hog, l2_normalised, resize_area

FRAMES = [DEFAULT_ROOT / season / f"images-{index:05d}.png" for season in ("summer", "winter")
          for index in (10, 1000, 7000, 21000, 35760)]


@contextmanager
def optimised(flag: bool) -> Iterator[None]:
    before = cv2.useOptimized()
    cv2.setUseOptimized(flag)
    try:
        yield
    finally:
        cv2.setUseOptimized(before)


@pytest.fixture(scope="module")
def images() -> list[np.ndarray]:
    return [read_image(path) for path in FRAMES if path.is_file()]


@pytest.mark.parametrize("method", ["hog", "sad"])
def test_descriptors_are_the_same_bytes_with_and_without_opencv_optimisations(images, method):
    assert len(images) == len(FRAMES)
    backend = backend_class(method)()
    with optimised(True):
        fast = np.stack([backend.describe(image) for image in images])
    with optimised(False):
        plain = np.stack([backend.describe(image) for image in images])
    assert fast.dtype == plain.dtype == np.float32
    assert fast.tobytes() == plain.tobytes()


def test_grey_is_opencvs_rule_exactly(images):
    for flag in (True, False):
        with optimised(flag):
            for image in images:
                np.testing.assert_array_equal(grey(image), cv2.cvtColor(image, cv2.COLOR_RGB2GRAY))


def test_resize_area_by_hand():
    # footprints of 1.5 pixels: (0 + 3/2) / 1.5 = 1, (3/2 + 6) / 1.5 = 5
    np.testing.assert_array_equal(resize_area(np.array([[0, 3, 6]], np.uint8), 2, 1), [[1, 5]])
    # ties to even: 1.5 -> 2, 2.5 -> 2; 2 x 2 -> 1 x 1: (1 + 2 + 3 + 5) / 4 = 2.75 -> 3
    np.testing.assert_array_equal(resize_area(np.array([[1, 2]], np.uint8), 1, 1), [[2]])
    np.testing.assert_array_equal(resize_area(np.array([[2, 3]], np.uint8), 1, 1), [[2]])
    np.testing.assert_array_equal(resize_area(np.array([[1, 2], [3, 5]], np.uint8), 1, 1), [[3]])
    # an integer enlargement repeats pixels
    np.testing.assert_array_equal(resize_area(np.array([[7, 9]], np.uint8), 4, 2), [[7, 7, 9, 9]] * 2)


def test_resize_area_agrees_with_opencv(images):
    with optimised(False):
        for image in images:
            g = grey(image)
            # the demo's case (64x32 frames to HOG's 128x64): pixel repetition, exactly OpenCV's
            expected = cv2.resize(g, (128, 64), interpolation=cv2.INTER_AREA)
            np.testing.assert_array_equal(resize_area(g, 128, 64), expected)
            large = np.repeat(np.repeat(g, 5, axis=0), 5, axis=1)  # 320x160
            for size in ((64, 32), (48, 24), (100, 50)):
                ours = resize_area(large, *size).astype(int)
                theirs = cv2.resize(large, size, interpolation=cv2.INTER_AREA).astype(int)
                assert np.abs(ours - theirs).max() <= 1  # OpenCV rounds its own weights at non-integer factors


def test_hog_agrees_with_opencvs_plain_path_to_float32_rounding(images):
    descriptor = cv2.HOGDescriptor((128, 64), (16, 16), (8, 8), (8, 8), 9)
    with optimised(False):
        for image in images:
            g = cv2.resize(cv2.cvtColor(image, cv2.COLOR_RGB2GRAY), (128, 64), interpolation=cv2.INTER_AREA)
            theirs = np.asarray(descriptor.compute(g)).ravel()
            ours = hog(g)
            assert ours.shape == theirs.shape == (3780,)
            # OpenCV accumulates in float32: about 1e-6 of the block-normalised values (at most 0.2 after clipping)
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=2e-6)


def test_l2_normalised_by_hand():
    np.testing.assert_array_equal(l2_normalised(np.array([3.0, 4.0])), np.array([0.6, 0.8], np.float32))
    np.testing.assert_array_equal(l2_normalised(np.zeros(3)), np.zeros(3, np.float32))


def test_hog_settings_it_cannot_compute_are_each_named_with_their_values():
    from vpr_smr.descriptors.hog import HOG

    with pytest.raises(ValueError, match=r"^hog: height 60 is not a multiple of cell 8; bins is 1, at least 2 are "
                                         r"needed: set the method's settings so \(the defaults: width 128, height 64, "
                                         r"cell 8, block 16, bins 9\)$"):
        HOG({"height": 60, "bins": 1})
    with pytest.raises(ValueError, match=r"^hog: block 32 is larger than the 24x16 image: "):
        HOG({"width": 24, "height": 16, "block": 32})
