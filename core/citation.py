"""How to cite: the tool (at the version that made the results) and the SMR paper it implements.

CITATION.cff is the citation file of the repository; tests/unit/test_citation.py keeps these lines equal to it.
"""

PAPER = ("S. Hussaini, T. Fischer and M. Milford, \"Improving Visual Place Recognition with Sequence-Matching "
         "Receptiveness Prediction\", IEEE/RSJ International Conference on Intelligent Robots and Systems (IROS), "
         "2025. arXiv:2503.06840")
TOOL = "The vpr-smr developers, \"vpr-smr: sequence-matching receptiveness for visual place recognition\""


def how_to_cite(version: str) -> str:
    """One paragraph naming the tool's ``version`` (the one that wrote the results) and the paper."""
    return f"{TOOL}, version {version} (CITATION.cff); and the method: {PAPER}."
