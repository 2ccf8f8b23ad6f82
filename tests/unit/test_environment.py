"""The numeric environment record: its keys, its JSON round trip, and that it never decides staleness."""

import hashlib
import json

import cv2
import h5py
import numpy as np

from vpr_smr.core import environment
from vpr_smr.core.environment import ENVIRONMENT_KEY, NumericEnvironment, ThreadPool
from vpr_smr.core.io import read_provenance
from vpr_smr.descriptors import extract

KEYS = {"machine", "cpu_model", "cpu_count", "simd", "cpu_flags_sha256", "thread_pools", "opencv",
        "opencv_optimised", "numpy", "python"}


def test_environment_round_trips_and_has_the_expected_keys():
    record = environment.current()
    data = record.to_json()
    assert set(data) == KEYS
    assert NumericEnvironment.from_json(data) == record
    assert record.opencv == cv2.__version__ and record.numpy == np.__version__
    # numpy is loaded, so its BLAS is among the pools, with a thread count
    assert any(pool.api == "blas" and pool.threads >= 1 for pool in record.thread_pools)
    assert set(data["thread_pools"][0]) == {"api", "library", "version", "threads", "kernel"}
    assert environment.recorded() == {"environment": data}


def test_environment_records_opencvs_optimisation_switch():
    before = cv2.useOptimized()
    try:
        cv2.setUseOptimized(False)
        assert environment.current().opencv_optimised is False
        cv2.setUseOptimized(True)
        assert environment.current().opencv_optimised is True
    finally:
        cv2.setUseOptimized(before)


def test_cpu_model_and_flags_from_cpuinfo(tmp_path, monkeypatch):
    cpuinfo = tmp_path / "cpuinfo"
    cpuinfo.write_text("processor\t: 0\nmodel name\t: Test CPU 9000\nflags\t\t: fpu sse4_2 fma avx2 avx512f\n\n"
                       "processor\t: 1\nmodel name\t: Other\nflags\t\t: fpu\n")
    monkeypatch.setattr(environment, "CPUINFO", cpuinfo)
    record = environment.current()
    assert record.cpu_model == "Test CPU 9000"
    assert record.simd == ("sse4_2", "avx2", "fma", "avx512f")  # in SIMD_FLAGS' order
    assert record.cpu_flags_sha256 == hashlib.sha256(b"avx2 avx512f fma fpu sse4_2").hexdigest()[:16]


def test_descriptor_files_record_the_environment_which_never_makes_them_stale(pair, tmp_path):
    out = tmp_path / "sad.h5"
    extract.main(pair, "sad", {"backend": "sad"}, out, batch_size=4, num_workers=0)
    stored = read_provenance(out)[ENVIRONMENT_KEY]
    assert NumericEnvironment.from_json(stored).cpu_count >= 1
    # another machine's record: the file is still done (information, not a setting)
    other = {**stored, "cpu_model": "another CPU", "thread_pools": [ThreadPool("blas", "mkl", "1", 8, "").to_json()]}
    with h5py.File(out, "a") as f:
        f.attrs[ENVIRONMENT_KEY] = json.dumps(other)
    stamp = out.stat().st_mtime_ns
    extract.main(pair, "sad", {"backend": "sad"}, out, batch_size=4, num_workers=0)
    assert out.stat().st_mtime_ns == stamp


def test_a_process_that_never_loaded_opencv_records_none_and_does_not_load_it():
    import subprocess
    import sys

    code = ("import sys, json; from vpr_smr.core import environment; data = environment.current().to_json(); "
            "print(json.dumps([data['opencv'], data['opencv_optimised'], 'cv2' in sys.modules]))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    assert json.loads(done.stdout) == [None, None, False]
    assert NumericEnvironment.from_json({**environment.current().to_json(), "opencv": None,
                                         "opencv_optimised": None}).opencv is None
