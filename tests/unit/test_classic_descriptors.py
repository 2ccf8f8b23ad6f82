import cv2
import numpy as np

from vpr_smr.datasets import read_image
from vpr_smr.datasets.nordland_sample import DEFAULT_ROOT
from vpr_smr.descriptors import backend_class
from vpr_smr.descriptors.sad import patch_normalise


def test_patch_normalise_by_hand():
    grey = np.zeros((2, 4))
    grey[:, :2] = [[0, 2], [4, 6]]  # mean 3, population std sqrt(5)
    grey[:, 2:] = 7  # constant patch -> 0
    out = patch_normalise(grey, 2)
    np.testing.assert_allclose(out[:, :2], np.array([[-3, -1], [1, 3]]) / np.sqrt(5))
    np.testing.assert_array_equal(out[:, 2:], 0)


def test_sad_descriptor_of_a_real_frame():
    image = read_image(DEFAULT_ROOT / "summer" / "images-01000.png")
    sad = backend_class("sad")()
    values = sad.describe(image)
    assert values.shape == (2048,)
    grey = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY).astype(np.float64)  # already 64x32
    patch = grey[8:16, 16:24]
    expected = (patch - patch.mean()) / patch.std()
    np.testing.assert_allclose(values.reshape(32, 64)[8:16, 16:24], expected, rtol=1e-5, atol=1e-6)


def test_sad_resizes_larger_images():
    image = np.random.default_rng(0).integers(0, 255, (96, 160, 3), dtype=np.uint8)
    assert backend_class("sad")().describe(image).shape == (2048,)


def test_hog_dimension_and_norm():
    image = read_image(DEFAULT_ROOT / "winter" / "images-01000.png")
    values = backend_class("hog")().describe(image)
    # 128x64 window, 16x16 blocks every 8 px: 15 x 7 blocks of 4 cells x 9 bins
    assert values.shape == (15 * 7 * 36,)
    assert np.linalg.norm(values) == np.float32(1.0) or abs(np.linalg.norm(values) - 1) < 1e-5
