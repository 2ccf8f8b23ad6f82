"""The progress a stage writes into its log reads back with the numbers written: the tqdm bar, the per-step lines,
the descriptors stage (images, by batch) and the training of several seeds."""

import io
import re

import pytest

from vpr_smr.core import progress
from vpr_smr.core.progress import parse_progress, progress_bar, read_progress, write_progress


def states(text):
    """Every progress state of a log, in order, as (desc, done, total, unit)."""
    found = [parse_progress(piece) for piece in re.split(r"[\r\n]", text)]
    return [(p.desc, p.done, p.total, p.unit) for p in found if p is not None]


def test_the_bar_reads_back_with_the_numbers_fed():
    out = io.StringIO()
    with progress_bar(total=3576, unit="images", desc="reference", file=out, min_interval_s=0) as bar:
        for step in (8, 8, 8, 5):
            bar.update(step)
        last = parse_progress(out.getvalue())
    assert (last.desc, last.done, last.total, last.unit) == ("reference", 29, 3576, "images")
    assert 0 <= last.elapsed_s < 60 and last.fraction == 29 / 3576
    # each update, then the final state again as the bar closes
    assert states(out.getvalue()) == [("reference", n, 3576, "images") for n in (0, 8, 16, 24, 29, 29)]

    # redraws held back by the least interval: closing the bar still writes its last state
    out = io.StringIO()
    with progress_bar(total=10, unit="images", file=out, min_interval_s=3600) as bar:
        bar.update(4)
        bar.update(4)
    assert states(out.getvalue()) == [("", 0, 10, "images"), ("", 8, 10, "images")]
    assert out.getvalue().endswith("\n")


def test_a_step_line_reads_back_and_gives_the_rate():
    out = io.StringIO()
    write_progress(2, 5, "seeds", 122.44, file=out)
    write_progress(7, 9, "tiles", 3.5, desc="pass 2: left", file=out)
    assert out.getvalue().count("\n") == 2
    first, second = (parse_progress(line) for line in out.getvalue().splitlines())
    assert (first.desc, first.done, first.total, first.unit, first.elapsed_s) == ("", 2, 5, "seeds", 122.4)
    assert (second.desc, second.done, second.total, second.unit, second.elapsed_s) == ("pass 2: left", 7, 9, "tiles",
                                                                                       3.5)
    assert second.rate == 2.0 and first.rate == pytest.approx(2 / 122.4)
    assert parse_progress(progress.format_progress(0, 5, "seeds", 0.0)).rate is None
    with pytest.raises(ValueError, match="unit without spaces"):
        write_progress(1, 2, "two words", 1.0)


def test_the_last_state_is_read_from_the_tail_only(tmp_path):
    log = tmp_path / "job.log"
    state = "reference: 1234/3576 images (35 %) in 10.0 s"
    log.write_text("x" * 10_000 + "\n\r" + state + "\n2026-11-23 vpr_smr INFO: a line after it\n")
    assert (read_progress(log).done, read_progress(log).elapsed_s) == (1234, 10.0)
    # a tail that starts inside the state would read "234/3576": the cut piece is not read
    cut = len(log.read_bytes()) - log.read_text().index("234/3576")
    assert read_progress(log, tail_bytes=cut) is None
    assert read_progress(log, tail_bytes=cut + len("reference: 1")) is None  # whole, but maybe not to us
    assert read_progress(log, tail_bytes=cut + len("\rreference: 1")).done == 1234  # from its carriage return
    assert read_progress(tmp_path / "missing.log") is None
    # a state with something written after it on its line is no state
    assert parse_progress("\r" + state + "2026-11-23 vpr_smr INFO: text") is None


def test_descriptors_count_images_by_batch(pair, tmp_path, monkeypatch, capsys):
    from vpr_smr.descriptors import extract

    monkeypatch.setattr(progress, "MIN_INTERVAL_S", 0.0)  # every update written
    extract.main(pair, "sad", {"backend": "sad"}, tmp_path / "sad.h5", batch_size=4, num_workers=0)
    # 10 images per traverse in batches of 4, the last state again as each bar closes
    assert states(capsys.readouterr().err) == [(role, n, 10, "images") for role in ("reference", "query")
                                               for n in (0, 4, 8, 10, 10)]


def test_training_several_seeds_writes_a_line_per_seed(tmp_path, capsys):
    import numpy as np
    from training_sets import train_job

    from vpr_smr.eval.matching.attributes import query_features, write_features
    from vpr_smr.eval.predictor import train

    rng = np.random.default_rng(3)
    paths = []
    for name in ("a", "b"):  # two methods' train splits: a diagonal in noise, some matches wrong
        paths.append(tmp_path / f"{name}.h5")
        write_features(paths[-1], query_features(rng.random((40, 40)) + 0.6 * (1 - np.eye(40)), 3), {})
    params = {"hidden_layer_sizes": [8], "max_iter": 20}
    train.main(train_job(paths, tmp_path / "p.h5", params, seeds=3, seq_len=3))
    assert states(capsys.readouterr().err) == [("", n, 3, "seeds") for n in range(4)]
    train.main(train_job(paths[:1], tmp_path / "q.h5", params, seq_len=3))  # one seed: no fraction worth showing
    assert states(capsys.readouterr().err) == []
