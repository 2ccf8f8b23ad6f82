"""The 2-D arrays of the field's files: a NumPy ``.npy`` or ``.npz``, or a MATLAB ``.mat`` (v5 through SciPy, v7.3
through h5py), the variable chosen by name where a file holds several, shown as its own program shows it and
optionally transposed. Nothing is unpickled: an array of Python objects is refused in an ``.npz`` as in a ``.npy``.

MATLAB stores a v7.3 matrix column-major, so h5py shows MATLAB's ``R x Q`` variable as ``Q x R``: it is read back
as MATLAB shows it (``Transposed``, lazily: a block of MATLAB columns is a block of contiguous rows on disk).
"""

from __future__ import annotations

import zipfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from vpr_smr.core.files import NEVER_PICKLE, ZIP, file_kind, load_npy, mat_version, read_head, what_it_is

__all__ = ["ARRAY_SUFFIXES", "Transposed", "Variable", "open_array", "variables"]

ARRAY_SUFFIXES = (".npy", ".npz", ".mat")  # the files ``open_array`` reads, by suffix (any case)
# MATLAB classes of numbers and booleans (``logical`` is stored as uint8)
MATLAB_NUMERIC = frozenset({"double", "single", "logical", "int8", "uint8", "int16", "uint16", "int32", "uint32",
                            "int64", "uint64"})
# what v7.3 files hold beside the user's variables
MATLAB_INTERNAL = frozenset({"#refs#", "#subsystem#"})


@dataclass(frozen=True)
class Variable:
    """An array a file holds: its name, its shape as its program shows it, its type (NumPy dtype or MATLAB class),
    and whether it holds numbers or booleans."""

    name: str
    shape: tuple[int, ...]
    type: str
    numeric: bool

    def __str__(self) -> str:
        return f"{self.name} ({' x '.join(map(str, self.shape)) or 'scalar'} {self.type})"


class Transposed:
    """``source.T`` of a 2-D array-like that cannot transpose itself lazily (an h5py dataset): indexing swaps the two
    keys and transposes the block read. Its columns are the source's rows (``column_major``: read it by columns)."""

    column_major = True
    ndim = 2

    def __init__(self, source: Any) -> None:
        self.source = source
        self.shape: tuple[int, int] = (int(source.shape[1]), int(source.shape[0]))
        self.dtype = np.dtype(source.dtype)
        self.size = int(source.size)

    def __getitem__(self, key: Any) -> Any:
        rows, cols = key if isinstance(key, tuple) else (key, slice(None))
        return np.asarray(self.source[cols, rows]).T

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        whole = np.asarray(self.source[()]).T
        return whole if dtype is None else whole.astype(dtype)


def _text(value: Any) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _npz_variables(path: Path) -> list[Variable]:
    """The arrays of an ``.npz`` from their ``.npy`` headers alone (nothing is loaded or unpickled)."""
    found = []
    try:
        with zipfile.ZipFile(path) as archive:
            for member in archive.namelist():
                if not member.endswith(".npy"):
                    continue
                with archive.open(member) as handle:
                    version = np.lib.format.read_magic(handle)
                    shape, _, dtype = (np.lib.format.read_array_header_1_0(handle) if version == (1, 0) else
                                       np.lib.format.read_array_header_2_0(handle))
                found.append(Variable(member[:-4], tuple(int(n) for n in shape), str(dtype),
                                      np.dtype(dtype).kind in "biuf"))
    except (zipfile.BadZipFile, ValueError, OSError) as error:
        raise ValueError(f"{path} is not a readable NumPy .npz archive ({error}): write it again "
                         "(numpy.savez(path, name=matrix))") from None
    return found


def _mat5_variables(path: Path) -> list[Variable]:
    import scipy.io

    try:
        listed = scipy.io.whosmat(str(path))
    except (ValueError, TypeError, OSError) as error:
        raise ValueError(f"{path} is a MATLAB v5 file that cannot be read ({error}): save it again") from None
    return [Variable(str(name), tuple(int(n) for n in shape), str(kind), str(kind) in MATLAB_NUMERIC)
            for name, shape, kind in listed]


def _mat73_variable(name: str, item: Any) -> Variable:
    kind = _text(item.attrs.get("MATLAB_class", b""))
    if isinstance(item, h5py.Group):  # a struct, or a sparse matrix (MATLAB_sparse: its row count)
        sparse = "MATLAB_sparse" in item.attrs
        return Variable(name, (), f"sparse {kind}" if sparse else kind or "group", False)
    shape = tuple(int(n) for n in item.shape[::-1])  # as MATLAB shows it (column-major on disk)
    if item.attrs.get("MATLAB_empty", 0):  # an empty array stores its dimensions as its data
        shape = (0,) * max(len(shape), 2)
    return Variable(name, shape, kind or str(item.dtype), kind in MATLAB_NUMERIC and item.dtype.kind in "biuf")


def _mat73_variables(handle: h5py.File) -> list[Variable]:
    return [_mat73_variable(name, item) for name, item in handle.items() if name not in MATLAB_INTERNAL]


def variables(path: Path | str) -> list[Variable]:
    """The arrays of an ``.npz`` or the variables of a ``.mat`` (v5 or v7.3), in the file's order; a ``.npy``
    holds one, named ``""``."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        return _npz_variables(path)
    if suffix == ".mat":
        version = _mat_version(path)
        if version == "5":
            return _mat5_variables(path)
        with _open_h5(path) as handle:
            return _mat73_variables(handle)
    if suffix == ".npy":
        array = load_npy(path, "an array", mmap=True)
        return [Variable("", tuple(array.shape), str(array.dtype), array.dtype.kind in "biuf")]
    raise ValueError(f"{path}: not a file of arrays vpr-smr reads (.npy, .npz or .mat)")


def _listed(found: Sequence[Variable]) -> str:
    return ", ".join(map(str, found)) or "nothing"


def choose(path: Path, found: Sequence[Variable], key: str | None, what: str, key_option: str) -> Variable:
    """The variable named ``key``, else the only 2-D numeric one; ValueError naming the file, what it holds and
    the option to choose with."""
    if key is not None:
        for variable in found:
            if variable.name == key:
                return variable
        raise ValueError(f"{path} has no variable {key!r}; it holds {_listed(found)}: give one of them with "
                         f"{key_option}")
    candidates = [v for v in found if v.numeric and len(v.shape) == 2]
    if len(candidates) == 1:
        return candidates[0]
    if not candidates:
        raise ValueError(f"{path} holds no 2-D array of numbers (it holds {_listed(found)}), not {what}: save the "
                         "matrix in it as a 2-D numeric (or logical) array")
    raise ValueError(f"{path} holds {len(candidates)} 2-D arrays of numbers ({_listed(candidates)}): choose "
                     f"{what} with {key_option} NAME")


def _mat_version(path: Path) -> str:
    head = read_head(path)
    version = mat_version(head)
    if version is None:
        raise ValueError(f"{path} is {what_it_is(head)}, not a MATLAB .mat file of version 5 or 7.3 (MATLAB "
                         "v4 files are not read): save it from MATLAB with save(path, name, '-v7.3') or from Python "
                         "with scipy.io.savemat")
    return version


@contextmanager
def _open_h5(path: Path) -> Iterator[h5py.File]:
    try:
        handle = h5py.File(path, "r")
    except OSError as error:
        raise ValueError(f"{path} is a MATLAB v7.3 file (HDF5) that cannot be opened ({error}): it is damaged or "
                         "truncated; save or copy it again") from None
    with handle:
        yield handle


def _npz_array(path: Path, variable: Variable, what: str) -> np.ndarray:
    if np.dtype(variable.type).hasobject:
        raise ValueError(f"{path}: its array {variable.name!r} holds Python objects (stored as a pickle), "
                         f"{NEVER_PICKLE}, not {what}: save the numbers with numpy.savez(path, name=matrix)")
    with np.load(path, allow_pickle=False) as archive:
        array: np.ndarray = archive[variable.name]
    return array


def _mat5_array(path: Path, variable: Variable, what: str) -> np.ndarray:
    import scipy.io
    import scipy.sparse

    value = scipy.io.loadmat(str(path), variable_names=[variable.name])[variable.name]
    if scipy.sparse.issparse(value):
        raise ValueError(f"{path}: variable {variable.name!r} is a sparse matrix, not {what} as vpr-smr reads it: "
                         f"save it full (in MATLAB: {variable.name} = full({variable.name}))")
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "biuf":
        raise ValueError(f"{path}: variable {variable.name!r} is {variable.type}, not {what}: save a numeric (or "
                         "logical) matrix")
    return value


@contextmanager
def open_array(path: Path | str, key: str | None = None, transpose: bool = False, what: str = "a 2-D array",
               key_option: str = "--key") -> Iterator[Any]:
    """The array of ``path`` as its program shows it (transposed with ``transpose``): a read-only memory map of a
    ``.npy``, the array ``key`` of an ``.npz`` (in memory), the variable ``key`` of a MATLAB v5 ``.mat`` (in
    memory, through SciPy) or of a v7.3 one (lazily, through h5py); without ``key``, the file's only 2-D numeric
    array. ``what`` says what the file should hold and ``key_option`` how to choose (for errors, which name the file,
    what it holds and the fix). The array is not checked beyond being numeric where the format says so."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{what} not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        if key is not None:
            raise ValueError(f"{key_option} {key}: {path} is a .npy, which holds one array; leave {key_option} out")
        array = load_npy(path, what, mmap=True)
        yield array.T if transpose else array
        return
    head = read_head(path)
    if suffix == ".npz":
        if file_kind(head) != ZIP:
            raise ValueError(f"{path} is {what_it_is(head)}, not a NumPy .npz archive: save "
                             "it with numpy.savez(path, name=matrix)")
        variable = choose(path, _npz_variables(path), key, what, key_option)
        array = _npz_array(path, variable, what)
        yield array.T if transpose else array
        return
    if suffix != ".mat":
        raise ValueError(f"{path}: {what} is read from a .npy, .npz or .mat file, not "
                         f"{suffix or 'a file without a suffix'}")
    if _mat_version(path) == "5":
        variable = choose(path, _mat5_variables(path), key, what, key_option)
        array = _mat5_array(path, variable, what)
        yield array.T if transpose else array
        return
    with _open_h5(path) as handle:
        variable = choose(path, _mat73_variables(handle), key, what, key_option)
        if not variable.numeric or len(variable.shape) != 2 or 0 in variable.shape:
            shown = ("empty" if 0 in variable.shape else variable.type if not variable.numeric
                     else f"of shape {' x '.join(map(str, variable.shape))}")
            raise ValueError(f"{path}: variable {variable.name!r} is {shown}, not {what}: save a 2-D numeric (or "
                             "logical) matrix")
        item = handle[variable.name]
        # h5py shows MATLAB's R x Q as Q x R: transposing twice is the dataset as stored
        yield item if transpose else Transposed(item)
