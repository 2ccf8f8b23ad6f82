"""A deprecated plugin form warns where its user sees it: Python shows a plain DeprecationWarning only where it is
attributed to ``__main__``, and a plugin's old declaration is met inside vpr-smr's own modules."""

import subprocess
import sys
import textwrap


def _stderr(code: str) -> str:
    # a fresh interpreter with Python's default warning filters (pytest's own capture would show any warning)
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, check=True)
    return done.stderr


def test_a_bare_function_loader_warns_by_default():
    err = _stderr("""
        from vpr_smr.datasets.loaders import as_loader
        def route(root, name="x"):
            return None
        as_loader("route", route)
        as_loader("route", route)
    """)
    assert err.count("Deprecated:") == 1, err  # once per function
    assert "dataset loader 'route'" in err and "Loader(function, Settings)" in err


def test_a_backend_with_the_old_dicts_warns_by_default():
    err = _stderr("""
        from vpr_smr.descriptors.base import Backend
        class Old(Backend):
            default_conf = {"size": 4}
            settings_help = {"size": "pixels"}
    """)
    assert "descriptor backend __main__.Old declares its settings as default_conf" in err, err
