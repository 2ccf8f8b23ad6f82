"""The one pickle vpr-smr reads: a NumPy array of Python objects in a ``.npy`` (VPR-Bench's ``ground_truth_new.npy``,
rows of ``[query, [references]]``), through an unpickler that can build nothing but NumPy arrays, lists, tuples and
numbers (and the bytes of an array's data, which pickle protocol 2 writes through ``_codecs.encode``).

NumPy stores an object array as its ``.npy`` header followed by a pickle of the whole array. ``numpy.load`` would
need ``allow_pickle=True`` for it, which runs whatever the pickle names; here the header is parsed by NumPy's header
readers (``core.files.npy_header``) and the pickle after it by ``ArraysOnlyUnpickler``, whose ``find_class`` hands
out only the few callables NumPy's own pickles of arrays, dtypes and scalars name, and refuses any other with its
name. Pickle opcodes build strings, numbers, lists, tuples, dicts and sets without ``find_class``; the caller checks
the structure it gets.
"""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.files import npy_header

__all__ = ["ArraysOnlyUnpickler", "RefusedPickle", "load_object_npy"]


def _numpy_callables() -> dict[str, Any]:
    """The functions NumPy's pickles name to rebuild an array (``_reconstruct``; ``_frombuffer`` under pickle
    protocol 5) and a NumPy scalar, taken from NumPy's own ``__reduce_ex__`` (their modules are
    ``numpy.core.multiarray`` and ``numpy.core.numeric`` before NumPy 2, ``numpy._core....`` since, and importing the
    old names warns under NumPy 2)."""
    return {"_reconstruct": np.empty(0).__reduce__()[0], "scalar": np.int64(0).__reduce__()[0],
            "_frombuffer": np.arange(2).__reduce_ex__(5)[0]}


def _latin1_bytes(text: str, encoding: str) -> bytes:
    """What ``_codecs.encode(text, "latin1")`` builds, and nothing else: pickle protocol 2 has no opcode for bytes, so
    Python 3 writes the raw data of a NumPy array that way (VPR-Bench's helper downgrades its pickles to protocol 2)."""
    if not isinstance(text, str) or encoding.replace("-", "").lower() not in ("latin1", "iso88591"):
        raise RefusedPickle(f"_codecs.encode of {type(text).__name__} as {encoding!r}")
    return text.encode("latin1")


_NUMPY = _numpy_callables()
# (module, name) as a pickle names them -> what is built. Python 2's pickles name the builtins module __builtin__.
# ``range``: a Python 3 writer of VPR-Bench's lists as range(lo, hi) pickles it so; it holds numbers only.
ALLOWED: dict[tuple[str, str], Any] = {
    **{(f"numpy.{core}.multiarray", name): _NUMPY[name] for core in ("core", "_core")
       for name in ("_reconstruct", "scalar")},
    **{(f"numpy.{core}.numeric", "_frombuffer"): _NUMPY["_frombuffer"] for core in ("core", "_core")},
    ("_codecs", "encode"): _latin1_bytes,
    ("numpy", "ndarray"): np.ndarray,
    ("numpy", "dtype"): np.dtype,
    **{(module, name): kind for module in ("builtins", "__builtin__")
       for name, kind in (("list", list), ("tuple", tuple), ("range", range))},
}


class RefusedPickle(ValueError):
    """A pickle names a class or function that ``ArraysOnlyUnpickler`` does not build: ``args[0]`` is its
    ``module.name``. Nothing of the pickle was run."""


class ArraysOnlyUnpickler(pickle.Unpickler):
    """A ``pickle.Unpickler`` that builds NumPy arrays, dtypes and scalars, lists, tuples and numbers only."""

    def find_class(self, module: str, name: str) -> Any:
        try:
            return ALLOWED[module, name]
        except KeyError:
            raise RefusedPickle(f"{module}.{name}") from None


def load_object_npy(path: Path | str, what: str) -> np.ndarray:
    """The array of objects in the ``.npy`` file ``path``, unpickled by ``ArraysOnlyUnpickler``; ``what`` says what
    the file should hold (for errors). Raises ``RefusedPickle`` (the name refused) when the pickle names anything
    else, and ValueError naming ``path`` when it is not an array of objects or its pickle is damaged."""
    path = Path(path)
    header = npy_header(path, what)
    if not header.dtype.hasobject:
        raise ValueError(f"{path} holds an array of {header.dtype}, not {what} (an array of Python objects)")
    with open(path, "rb") as handle:
        handle.seek(header.data_start)
        try:
            # latin1: Python 2's pickles (VPR-Bench wrote its files with Python 2) hold NumPy's raw bytes as str
            array = ArraysOnlyUnpickler(handle, encoding="latin1").load()
        except RefusedPickle:
            raise
        except (pickle.UnpicklingError, EOFError, TypeError, ValueError, AttributeError, IndexError) as error:
            raise ValueError(f"{path}: its pickle cannot be read ({type(error).__name__}: {error}): the file is "
                             "damaged or truncated; write it again") from None
    if not isinstance(array, np.ndarray) or array.shape != header.shape:
        found = f"shape {array.shape}" if isinstance(array, np.ndarray) else type(array).__name__
        raise ValueError(f"{path}: its header says an array of shape {header.shape}, but its pickle holds {found}: "
                         "the file is damaged; write it again")
    return array
