"""The 2-D arrays of the field's files: a NumPy ``.npy`` or ``.npz``, or a MATLAB ``.mat`` (v5 through SciPy, v7.3
through h5py), the variable chosen by name where a file holds several, shown as its own program shows it and
optionally transposed. Nothing is unpickled: an array of Python objects is refused in an ``.npz`` as in a ``.npy``.

MATLAB stores a v7.3 matrix column-major, so h5py shows MATLAB's ``R x Q`` variable as ``Q x R``: it is read back
as MATLAB shows it (``Transposed``, lazily: a block of MATLAB columns is a block of contiguous rows on disk).

Every array is bounded before anything of its size is allocated: its shape and type are read from the file's headers
(a ``.npy`` header, each ``.npz`` member's ``.npy`` header, ``scipy.io.whosmat``, an HDF5 dataset's shape), and a
file declaring more than ``MAX_MATRIX_VALUES`` values, more data than it holds, or an array that would inflate in
memory to more than ``INFLATE_RATIO`` times its compressed bytes (beyond ``INFLATE_FREE``), is refused naming the
file, what it declares and the limit. What is read stays proportional to the file: a ``.npy`` and an uncompressed
``.npz`` member are memory-mapped, a v7.3 variable is read lazily.
"""

from __future__ import annotations

import math
import struct
import zipfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from vpr_smr.core.files import NEVER_PICKLE, ZIP, file_kind, load_npy, mat_version, read_head, what_it_is
from vpr_smr.core.io import open_h5

__all__ = ["ARRAY_SUFFIXES", "INFLATE_FREE", "INFLATE_RATIO", "MAX_MATRIX_VALUES", "Transposed", "Variable",
           "check_declared_size", "open_array", "variables"]

ARRAY_SUFFIXES = (".npy", ".npz", ".mat")  # the files ``open_array`` reads, by suffix (any case)
# MATLAB classes of numbers and booleans (``logical`` is stored as uint8)
MATLAB_NUMERIC = frozenset({"double", "single", "logical", "int8", "uint8", "int16", "uint16", "int32", "uint32",
                            "int64", "uint64"})
# what v7.3 files hold beside the user's variables
MATLAB_INTERNAL = frozenset({"#refs#", "#subsystem#"})
MAT73 = "a MATLAB v7.3 .mat file (HDF5)"  # what open_h5 says such a file should be
# The bytes of one value of each MATLAB class (a v5 variable is read into memory as these)
MATLAB_BYTES = {"double": 8, "single": 4, "logical": 1, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2, "int32": 4,
                "uint32": 4, "int64": 8, "uint64": 8}
# The most values an array read from a file may declare: 2**32, 16 GiB of float32, five times the largest matrix of
# the benchmarks vpr-smr runs (Nordland's 27592 x 27592 frames, 0.76e9). Memory does not need it (what is read is
# bounded by the file's bytes, below); it refuses at once a header, or a v7.3 dataset of unwritten chunks, that
# declares a matrix no sequence matching could score in a day.
MAX_MATRIX_VALUES = 1 << 32
# What a compressed array (an .npz member of numpy.savez_compressed, a compressed MATLAB v5 variable) may take in
# memory once inflated: INFLATE_RATIO times its compressed bytes, or INFLATE_FREE whatever its ratio. Distances
# compress 1.1-3 to 1 (float noise in the low bits); a constant or all-zero matrix 1000 to 1, which is how a 3 MB file
# asks for 3.2 GB. INFLATE_FREE keeps the peak of a command under 400 MB.
INFLATE_RATIO = 32
INFLATE_FREE = 128 << 20


@dataclass(frozen=True)
class Variable:
    """An array a file holds: its name, its shape as its program shows it, its type (NumPy dtype or MATLAB class),
    and whether it holds numbers or booleans."""

    name: str
    shape: tuple[int, ...]
    type: str
    numeric: bool

    def __str__(self) -> str:
        return f"{self.name} ({_dims(self.shape) or 'scalar'} {self.type})"

    @property
    def values(self) -> int:
        return math.prod(self.shape)

    @property
    def nbytes(self) -> int:
        """Its bytes in memory (MATLAB's classes by ``MATLAB_BYTES``, else its NumPy dtype; 8 per value if neither)."""
        try:
            itemsize = MATLAB_BYTES.get(self.type) or np.dtype(self.type).itemsize
        except TypeError:
            itemsize = 8
        return self.values * itemsize


def _dims(shape: Sequence[int]) -> str:
    return " x ".join(map(str, shape))


def _declares(path: Path, variable: Variable) -> str:
    """``path: its array 'D' declares 20000 x 20000 float64 (400000000 values, 3200000000 bytes)``."""
    name = f" {variable.name!r}" if variable.name else ""
    return (f"{path}: its array{name} declares {_dims(variable.shape) or 'a scalar'} {variable.type} "
            f"({variable.values} values, {variable.nbytes} bytes)")


def check_declared_size(path: Path, variable: Variable, *, compressed_bytes: int | None = None,
                        stored_bytes: int | None = None) -> None:
    """Refuse, before anything is allocated, an array declaring more than ``MAX_MATRIX_VALUES`` values, more bytes
    than the file holds for it (``stored_bytes``: the data an uncompressed file holds after its header), or, read from
    ``compressed_bytes``, more than those bytes may inflate to (``INFLATE_RATIO``, ``INFLATE_FREE``)."""
    if variable.values > MAX_MATRIX_VALUES:
        raise ValueError(f"{_declares(path, variable)}, more than the {MAX_MATRIX_VALUES} values vpr-smr reads from "
                         "a matrix file: give the matrix of the frames to score (a block of it, e.g. a split); "
                         "nothing of it was read")
    if stored_bytes is not None and stored_bytes < variable.nbytes:
        raise ValueError(f"{_declares(path, variable)}, but the file holds {stored_bytes} bytes of it: the file is "
                         "truncated or damaged (a copy or download that stopped?); write it again")
    most = max(INFLATE_FREE, INFLATE_RATIO * (compressed_bytes or 0))
    if compressed_bytes is not None and variable.nbytes > most:
        raise ValueError(f"{_declares(path, variable)} from {compressed_bytes} compressed bytes, more than they "
                         f"may inflate to in memory ({most} bytes: {INFLATE_RATIO} times as many, at least "
                         f"{INFLATE_FREE}): {_uncompressed(path)}, or check what it holds (a constant matrix?); "
                         "nothing of it was read")


def _uncompressed(path: Path) -> str:
    """How to save the array of ``path`` uncompressed, in its own program's words: read from disk as needed."""
    if path.suffix.lower() == ".mat":
        return ("save it uncompressed from MATLAB (save(path, name, '-v7.3'), read from disk as needed, or "
                "save(path, name, '-v7', '-nocompression'))")
    return "save it uncompressed (numpy.save, or numpy.savez rather than savez_compressed: read from disk as needed)"


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


@dataclass(frozen=True)
class _NpzMember:
    """An ``.npz`` member as its zip directory and ``.npy`` header declare it, nothing of its data read."""

    variable: Variable
    fortran_order: bool
    compressed: bool
    compress_size: int  # its bytes in the archive
    data_bytes: int  # its bytes after the .npy header, uncompressed, as the zip directory declares them
    data_offset: int | None  # where its data starts in the archive's file, for an uncompressed member


def _local_data_start(path: Path, info: zipfile.ZipInfo) -> int:
    """Where the member ``info``'s bytes start in the file: after its local header (30 bytes, its name and extra
    field, whose lengths the local header gives and may differ from the central directory's)."""
    with open(path, "rb") as handle:
        handle.seek(info.header_offset)
        local = handle.read(30)
    if len(local) < 30 or local[:4] != b"PK\x03\x04":
        raise zipfile.BadZipFile(f"no local header for {info.filename!r} at byte {info.header_offset}")
    name_length, extra_length = struct.unpack("<HH", local[26:30])
    return int(info.header_offset) + 30 + int(name_length) + int(extra_length)


def _npz_members(path: Path) -> list[_NpzMember]:
    """The arrays of an ``.npz`` from its zip directory and their ``.npy`` headers alone (nothing is loaded or
    unpickled)."""
    found = []
    try:
        with zipfile.ZipFile(path) as archive:
            for info in archive.infolist():
                if not info.filename.endswith(".npy"):
                    continue
                with archive.open(info) as handle:
                    version = np.lib.format.read_magic(handle)
                    shape, fortran_order, dtype = (np.lib.format.read_array_header_1_0(handle) if version == (1, 0)
                                                   else np.lib.format.read_array_header_2_0(handle))
                    header_bytes = handle.tell()
                dtype = np.dtype(dtype)
                variable = Variable(info.filename[:-4], tuple(int(n) for n in shape), str(dtype),
                                    dtype.kind in "biuf")
                compressed = info.compress_type != zipfile.ZIP_STORED
                offset = None if compressed else _local_data_start(path, info) + header_bytes
                found.append(_NpzMember(variable, bool(fortran_order), compressed, info.compress_size,
                                        info.file_size - header_bytes, offset))
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as error:
        raise ValueError(f"{path} is not a readable NumPy .npz archive ({error}): write it again "
                         "(numpy.savez(path, name=matrix))") from None
    return found


def _npz_variables(path: Path) -> list[Variable]:
    return [member.variable for member in _npz_members(path)]


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
        with open_h5(path, MAT73) as handle:
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


def _npz_array(path: Path, variable: Variable, what: str, known_values: int = 0) -> np.ndarray:
    """The member ``variable`` of an ``.npz``: memory-mapped from the archive when it is stored uncompressed, else
    inflated in memory; bounded first (``check_declared_size``) by what its zip directory says it holds, and,
    compressed, by what its compressed bytes may inflate to unless it holds at most ``known_values`` values."""
    if np.dtype(variable.type).hasobject:
        raise ValueError(f"{path}: its array {variable.name!r} holds Python objects (stored as a pickle), "
                         f"{NEVER_PICKLE}, not {what}: save the numbers with numpy.savez(path, name=matrix)")
    member = next(m for m in _npz_members(path) if m.variable == variable)
    inflates = member.compressed and variable.values > known_values
    check_declared_size(path, variable, stored_bytes=member.data_bytes,
                        compressed_bytes=member.compress_size if inflates else None)
    if member.data_offset is not None:
        if path.stat().st_size < member.data_offset + variable.nbytes:
            check_declared_size(path, variable, stored_bytes=max(path.stat().st_size - member.data_offset, 0))
        if variable.values == 0:
            return np.empty(variable.shape, dtype=variable.type)
        return np.memmap(path, dtype=variable.type, mode="r", offset=member.data_offset, shape=variable.shape,
                         order="F" if member.fortran_order else "C")
    try:
        with np.load(path, allow_pickle=False) as archive:
            array: np.ndarray = archive[variable.name]
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as error:
        raise ValueError(f"{path}: its array {variable.name!r} cannot be read ({error}): the file is damaged or "
                         "truncated; write it again (numpy.savez(path, name=matrix))") from None
    return array


MAT5_COMPRESSED = 15  # miCOMPRESSED: a zlib-compressed element of a MATLAB v5 file (miMATRIX is 14)


def _mat5_compressed(path: Path) -> bool:
    """Whether a MATLAB v5 file holds compressed elements, from the tags of its top-level elements alone (8 bytes
    each: type and byte count, in the byte order its header's ``IM``/``MI`` gives)."""
    size = path.stat().st_size
    with open(path, "rb") as handle:
        head = handle.read(128)
        order = "<" if head[126:128] == b"IM" else ">"
        at = 128
        while at + 8 <= size:
            handle.seek(at)
            kind, length = struct.unpack(f"{order}II", handle.read(8))
            if kind == MAT5_COMPRESSED:
                return True
            at += 8 + length + (-length % 8)  # an element is padded to 8 bytes (a compressed one is not)
    return False


def _mat5_array(path: Path, variable: Variable, what: str, known_values: int = 0) -> np.ndarray:
    import scipy.io
    import scipy.sparse

    if variable.type in MATLAB_BYTES:
        size = path.stat().st_size
        if _mat5_compressed(path):
            check_declared_size(path, variable, compressed_bytes=size if variable.values > known_values else None)
        else:
            # MATLAB may store a class's values in a smaller type (a double 0/1 ground truth as uint8): an array
            # the caller knows must hold a byte per value
            least = variable.nbytes if variable.values > known_values else variable.values
            check_declared_size(path, variable, stored_bytes=size if size < least else None)
    try:
        value = scipy.io.loadmat(str(path), variable_names=[variable.name])[variable.name]
    except (ValueError, OSError, TypeError, EOFError, MemoryError) as error:  # scipy's words: "could not read bytes"
        raise ValueError(f"{_declares(path, variable)}, but it cannot be read ({type(error).__name__}: {error}): the "
                         "file is truncated or damaged (a copy or download that stopped?); save it again") from None
    if scipy.sparse.issparse(value):
        raise ValueError(f"{path}: variable {variable.name!r} is a sparse matrix, not {what} as vpr-smr reads it: "
                         f"save it full (in MATLAB: {variable.name} = full({variable.name}))")
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "biuf":
        raise ValueError(f"{path}: variable {variable.name!r} is {variable.type}, not {what}: save a numeric (or "
                         "logical) matrix")
    return value


@contextmanager
def open_array(path: Path | str, key: str | None = None, transpose: bool = False, what: str = "a 2-D array",
               key_option: str = "--key", known_values: int = 0) -> Iterator[Any]:
    """The array of ``path`` as its program shows it (transposed with ``transpose``): a read-only memory map of a
    ``.npy`` or of an uncompressed ``.npz`` member, the array ``key`` of a compressed ``.npz`` (in memory), the
    variable ``key`` of a MATLAB v5 ``.mat`` (in memory, through SciPy) or of a v7.3 one (lazily, through h5py);
    without ``key``, the file's only 2-D numeric array. ``what`` says what the file should hold and ``key_option``
    how to choose (for errors, which name the file, what it holds and the fix). Bounded before it is read
    (``check_declared_size``); ``known_values``: the values the caller knows the array may hold (the cells of the
    matrix a ground truth scores, or a ground truth's cap), which a compressed array may inflate to whatever its ratio.
    The array is not checked beyond being numeric where the format says so."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{what} not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        if key is not None:
            raise ValueError(f"{key_option} {key}: {path} is a .npy, which holds one array; leave {key_option} out")
        array = load_npy(path, what, mmap=True)  # memory-mapped, its data checked to be in the file
        check_declared_size(path, Variable("", tuple(array.shape), str(array.dtype), True))
        yield array.T if transpose else array
        return
    head = read_head(path)
    if suffix == ".npz":
        if file_kind(head) != ZIP:
            raise ValueError(f"{path} is {what_it_is(head)}, not a NumPy .npz archive: save "
                             "it with numpy.savez(path, name=matrix)")
        variable = choose(path, _npz_variables(path), key, what, key_option)
        array = _npz_array(path, variable, what, known_values)
        yield array.T if transpose else array
        return
    if suffix != ".mat":
        raise ValueError(f"{path}: {what} is read from a .npy, .npz or .mat file, not "
                         f"{suffix or 'a file without a suffix'}")
    if _mat_version(path) == "5":
        variable = choose(path, _mat5_variables(path), key, what, key_option)
        array = _mat5_array(path, variable, what, known_values)
        yield array.T if transpose else array
        return
    with open_h5(path, MAT73) as handle:
        variable = choose(path, _mat73_variables(handle), key, what, key_option)
        check_declared_size(path, variable)  # read lazily, in blocks: its values alone are bounded
        if not variable.numeric or len(variable.shape) != 2 or 0 in variable.shape:
            shown = ("empty" if 0 in variable.shape else variable.type if not variable.numeric
                     else f"of shape {' x '.join(map(str, variable.shape))}")
            raise ValueError(f"{path}: variable {variable.name!r} is {shown}, not {what}: save a 2-D numeric (or "
                             "logical) matrix")
        item = handle[variable.name]
        # h5py shows MATLAB's R x Q as Q x R: transposing twice is the dataset as stored
        yield item if transpose else Transposed(item)
