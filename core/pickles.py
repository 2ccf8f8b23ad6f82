"""The one pickle vpr-smr reads: a NumPy array of Python objects in a ``.npy`` (VPR-Bench's ``ground_truth_new.npy``,
rows of ``[query, [references]]``), through an unpickler that can build nothing but NumPy arrays, lists, tuples and
numbers (and the bytes of an array's data, which pickle protocol 2 writes through ``_codecs.encode``).

NumPy stores an object array as its ``.npy`` header followed by a pickle of the whole array. ``numpy.load`` would
need ``allow_pickle=True`` for it, which runs whatever the pickle names; here the header is parsed by NumPy's header
readers (``core.files.npy_header``) and the pickle after it by ``ArraysOnlyUnpickler``, whose ``find_class`` hands
out only the few callables NumPy's own pickles of arrays, dtypes and scalars name, and refuses any other with its
name. Pickle opcodes build strings, numbers, lists, tuples, dicts and sets without ``find_class``; the caller checks
the structure it gets.

What the pickle builds is bounded by the file's size: opcodes build at most one object per byte or two (an empty
list appended to a list, two bytes, takes about 64 bytes of memory: a few dozen bytes per byte at the most), and the
callables handed out that could build more (an array of a declared shape, ``list(range(...))``) first check what
they would build against ``BUILT_PER_BYTE`` bytes per byte of the file (``PickleTooLarge``, before allocating); an
array whose shape or dtype is not plainly numbers and a dtype is refused (``RefusedPickle``), never let through
uncounted. A ``range`` stays lazy: its reader checks its length before using it.
"""

from __future__ import annotations

import operator
import pickle
from pathlib import Path
from typing import Any

import numpy as np

from vpr_smr.core.files import npy_header

__all__ = ["ArraysOnlyUnpickler", "PickleTooLarge", "RefusedPickle", "load_object_npy"]


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
# ``range``: a Python 3 writer of VPR-Bench's lists as range(lo, hi) pickles it so; it holds numbers only. Arrays,
# lists and tuples are built by ``ArraysOnlyUnpickler.find_class``'s bounded versions of these.
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
# What a pickle may build through the callables above, in bytes per byte of the file (plus BUILT_SLACK): every
# element of an array or list it builds takes at least one byte of opcodes (a NumPy number's raw data takes its own
# size), and a Python reference takes 8 bytes. A tiny pickle cannot ask for a huge array or list(range(10**12)).
BUILT_PER_BYTE = 8
BUILT_SLACK = 1 << 20
REFERENCE_BYTES = 8  # an element of a list, tuple or object array
BY_FILE_SIZE = f"its file can hold ({BUILT_PER_BYTE} bytes per byte of the file, plus {BUILT_SLACK})"


class RefusedPickle(ValueError):
    """A pickle names a class or function that ``ArraysOnlyUnpickler`` does not build: ``args[0]`` is its
    ``module.name``. Nothing of the pickle was run."""


class PickleTooLarge(ValueError):
    """A pickle asks for more than ``BUILT_PER_BYTE`` bytes per byte of its file: ``args[0]`` says what and how
    much; it was refused before being allocated."""


class _Budget:
    """The bytes a pickle's arrays, lists and tuples may still take, charged before each is built."""

    def __init__(self, limit: int, why: str = BY_FILE_SIZE) -> None:
        self.limit = self.left = limit
        self.why = why

    def charge(self, what: str, n_bytes: int) -> None:
        if n_bytes > self.left:
            raise PickleTooLarge(f"would build {what} of {n_bytes} bytes, beyond the {self.limit} bytes {self.why}")
        self.left -= n_bytes

    def array(self, shape: Any, dtype: Any) -> None:
        """Charge an array of ``shape`` and ``dtype``; refuse one whose shape is not whole numbers (an int, or a
        tuple, list or array of them: NumPy takes each) or whose dtype is none, rather than build it uncounted."""
        items = shape.ravel().tolist() if isinstance(shape, np.ndarray) else (
            list(shape) if isinstance(shape, tuple | list) else [shape])
        try:
            dims = [operator.index(n) for n in items]
            itemsize = np.dtype(dtype).itemsize
        except (TypeError, ValueError) as error:
            raise RefusedPickle(f"an array of shape {type(shape).__name__} {str(shape)[:60]} and dtype "
                                f"{str(dtype)[:60]} ({error})") from None
        count = 1
        for n in dims:
            count *= max(n, 0)
        self.charge(f"an array of shape {tuple(dims)}", count * max(itemsize, 1))

    def sequence(self, kind: type, items: Any) -> Any:
        """``kind(items)`` (a list or tuple), charged by ``len(items)`` before it is built."""
        self.charge(f"a {kind.__name__} of {len(items)} items", REFERENCE_BYTES * len(items))
        return kind(items)


def _bounded_callables(budget: _Budget) -> dict[Any, Any]:
    """The callables of ``ALLOWED`` that allocate by a size the pickle states, each charging ``budget`` first;
    keyed by the callable they replace."""

    class BoundedArray(np.ndarray):
        """``numpy.ndarray`` as a pickle builds it: by its constructor or ``_reconstruct`` and ``__setstate__``."""

        def __new__(cls, shape: Any, dtype: Any = float, *args: Any, **kwargs: Any) -> BoundedArray:
            budget.array(shape, dtype)
            return super().__new__(cls, shape, dtype, *args, **kwargs)

        def __setstate__(self, state: Any) -> None:
            if isinstance(state, tuple) and len(state) >= 4:  # ([version,] shape, dtype, is_fortran, data)
                budget.array(state[-4], state[-3])
            super().__setstate__(state)

    def reconstruct(subtype: Any, shape: Any, dtype: Any) -> Any:
        if subtype is not BoundedArray:
            raise RefusedPickle(f"_reconstruct of {getattr(subtype, '__name__', type(subtype).__name__)}")
        budget.array(shape, dtype)
        return _NUMPY["_reconstruct"](subtype, shape, dtype)

    return {np.ndarray: BoundedArray, _NUMPY["_reconstruct"]: reconstruct,
            list: lambda items=(): budget.sequence(list, items),
            tuple: lambda items=(): budget.sequence(tuple, items)}


class ArraysOnlyUnpickler(pickle.Unpickler):
    """A ``pickle.Unpickler`` that builds NumPy arrays, dtypes and scalars, lists, tuples and numbers only, and
    arrays, lists and tuples of ``limit`` bytes in all at most (``PickleTooLarge``, before allocating)."""

    def __init__(self, file: Any, *, limit: int, encoding: str = "ASCII", why: str = BY_FILE_SIZE) -> None:
        super().__init__(file, encoding=encoding)
        self._bounded = _bounded_callables(_Budget(limit, why))

    def find_class(self, module: str, name: str) -> Any:
        try:
            found = ALLOWED[module, name]
        except KeyError:
            raise RefusedPickle(f"{module}.{name}") from None
        return self._bounded.get(found, found)


def load_object_npy(path: Path | str, what: str, limit: tuple[int, str] | None = None) -> np.ndarray:
    """The array of objects in the ``.npy`` file ``path``, unpickled by ``ArraysOnlyUnpickler`` with
    ``BUILT_PER_BYTE`` bytes per byte of the file, or ``limit`` (bytes, and why, for errors: what the caller knows the
    file can hold) where that is less; ``what`` says what the file should hold (for errors). Raises
    ``RefusedPickle`` (the name refused) when the pickle names anything else, ``PickleTooLarge`` when it asks for
    more, and ValueError naming ``path`` when it is not an array of objects or its pickle is damaged."""
    path = Path(path)
    header = npy_header(path, what)
    if not header.dtype.hasobject:
        raise ValueError(f"{path} holds an array of {header.dtype}, not {what} (an array of Python objects)")
    most, why = BUILT_PER_BYTE * path.stat().st_size + BUILT_SLACK, BY_FILE_SIZE
    if limit is not None and limit[0] < most:
        most, why = limit
    with open(path, "rb") as handle:
        handle.seek(header.data_start)
        try:
            # latin1: Python 2's pickles (VPR-Bench wrote its files with Python 2) hold NumPy's raw bytes as str
            array = ArraysOnlyUnpickler(handle, limit=most, encoding="latin1", why=why).load()
        except (RefusedPickle, PickleTooLarge):
            raise
        except (pickle.UnpicklingError, EOFError, TypeError, ValueError, AttributeError, IndexError) as error:
            raise ValueError(f"{path}: its pickle cannot be read ({type(error).__name__}: {error}): the file is "
                             "damaged or truncated; write it again") from None
    if not isinstance(array, np.ndarray) or array.shape != header.shape:
        found = f"shape {array.shape}" if isinstance(array, np.ndarray) else type(array).__name__
        raise ValueError(f"{path}: its header says an array of shape {header.shape}, but its pickle holds {found}: "
                         "the file is damaged; write it again")
    return np.asarray(array)  # a plain ndarray (the pickle's arrays are built as BoundedArray)
