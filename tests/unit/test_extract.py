
import h5py
import numpy as np
import pytest

from vpr_smr.datasets import DatasetError
from vpr_smr.descriptors import extract


def test_descriptors_file_and_skip(pair, tmp_path):
    out = tmp_path / "sad.h5"
    extract.main(pair, "sad", {"backend": "sad"}, out, batch_size=4, num_workers=1)
    with h5py.File(out, "r") as f:
        assert f["reference"].shape == (10, 2048) and f["query"].shape == (10, 2048)
        assert f["query_names"][0].decode() == "images-01000.png"
        assert f.attrs["distance"] == "mad" and f.attrs["method"] == "sad"
    stamp = out.stat().st_mtime_ns
    extract.main(pair, "sad", {"backend": "sad"}, out, batch_size=4, num_workers=1)
    assert out.stat().st_mtime_ns == stamp  # same provenance: not computed again
    extract.main(pair, "sad", {"backend": "sad", "patch": 4}, out, batch_size=4, num_workers=0)
    assert out.stat().st_mtime_ns != stamp  # other settings: computed again


def test_batched_equals_single(pair, tmp_path):
    extract.main(pair, "hog", {"backend": "hog"}, tmp_path / "a.h5", batch_size=3, num_workers=0)
    backend, _ = extract.build_backend("hog", {"backend": "hog"})
    with h5py.File(tmp_path / "a.h5", "r") as f:
        np.testing.assert_allclose(f["query"][4], backend.describe(pair.query.read(4)), rtol=1e-6)


def test_corrupt_image_in_a_worker_names_its_file(pair, tmp_path):
    bad = pair.query.images[7]
    bad.write_bytes(b"\x89PNG\r\n\x1a\n broken")
    with pytest.raises(DatasetError, match=f"cannot decode image {bad}"):
        extract.main(pair, "sad", {"backend": "sad"}, tmp_path / "x.h5", batch_size=4, num_workers=1)
    assert not (tmp_path / "x.h5").exists() and not (tmp_path / "x.h5.tmp").exists()


def test_provenance_records_every_setting_in_effect(pair, tmp_path):
    import json

    out = tmp_path / "hog.h5"
    extract.main(pair, "hog", {"backend": "hog", "cell": 8}, out, batch_size=4, num_workers=0)
    with h5py.File(out, "r") as f:
        settings = json.loads(f.attrs["backend_conf"])
    # The defaults (and the common preprocessing preset) are recorded, not only what the configuration wrote.
    assert settings == {"width": 128, "height": 64, "cell": 8, "block": 16, "bins": 9, "preprocessing": "official"}
