"""report.html without a browser: the provenance of the descriptor files on the page, the version to cite, and the
template escaping what it is given (the page in a real browser: test_html_report.py)."""

import html


def test_provenance_of_descriptor_files_in_the_page(tmp_path):
    from vpr_smr.core.io import atomic_h5
    from vpr_smr.eval.report.build import main

    descriptors = tmp_path / "hog.h5"
    with atomic_h5(descriptors, {"dataset": "toy", "method": "hog", "checkpoint_sha256": "11" * 32,
                                 "frames_sha256": "22" * 32}):
        pass
    main(tmp_path / "run", config={"run": "toy", "seq_lens": [4]}, provenance={"vpr_smr_version": "9.9"},
         descriptor_paths=[descriptors])
    page = (tmp_path / "run" / "report.html").read_text()
    assert "11" * 32 in page and "22" * 32 in page and str(descriptors) in page
    assert "run: toy" in page and "seq_lens: [4]" in page and "9.9" in page
    # The version to cite is the one that made the results (the run's provenance), not the installed one.
    text = html.unescape(page)
    assert 'vpr-smr: sequence-matching receptiveness for visual place recognition", version 9.9' in text
    assert "Hussaini, T. Fischer and M. Milford" in text
    # what another machine may change, said in the provenance section
    provenance = text[text.index('<section id="provenance">'):text.index('<section id="configuration">')]
    assert "On another machine:" in provenance and "the same bytes on every CPU" in provenance
    # no experiment given: no section of one, nothing about Table I
    assert 'id="findings"' not in page and 'id="pr-curves"' not in page and "<img" not in page


def test_the_template_escapes_what_it_is_given(tmp_path):
    from vpr_smr.eval.report.build import main

    main(tmp_path / "run", config="note: <script>alert(1)</script> & more", provenance={"by": "<b>x</b>"})
    page = (tmp_path / "run" / "report.html").read_text()
    assert "<script>alert(1)</script>" not in page and "&lt;script&gt;alert(1)&lt;/script&gt; &amp; more" in page
    assert "<b>x</b>" not in page and page.count("<script>") == 1  # the page's own sorting script
