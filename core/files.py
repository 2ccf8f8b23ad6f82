"""What a file is, from its first bytes alone (nothing is parsed or unpickled), and NumPy arrays read safely.

A user's file that is not what its name says (a CSV saved as ``.npy``, a pickle, an HDF5 file, a download that
stopped) is named for what it is, with the fix. No message passes on a library's advice to load unsafely: NumPy's
``allow_pickle`` is never turned on, and its refusal is told in our words.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

HEAD_BYTES = 512  # enough for every signature below (a tar header's "ustar" sits at byte 257)

EMPTY, NPY, HDF5, MAT, ZIP, GZIP, TAR, PICKLE, TEXT, UNKNOWN = (
    "empty", "npy", "hdf5", "mat", "zip", "gzip", "tar", "pickle", "text", "unknown")

KINDS = {  # what each kind is, as a message says it
    EMPTY: "empty (0 bytes)",
    NPY: "a NumPy .npy array",
    HDF5: "an HDF5 file",
    MAT: "a MATLAB .mat file",
    ZIP: "a zip archive (e.g. a NumPy .npz or a torch.save file)",
    GZIP: "gzip-compressed",
    TAR: "a tar archive",
    PICKLE: "a Python pickle",
    TEXT: "text",
    UNKNOWN: "not a format vpr-smr knows",
}


def read_head(path: Path | str) -> bytes:
    with open(path, "rb") as handle:
        return handle.read(HEAD_BYTES)


def text_start(head: bytes) -> str | None:
    """The beginning of ``head`` as text if it is text (UTF-8, no NUL, printable), else ``None``."""
    if not head or b"\0" in head:
        return None
    text = head.decode("utf-8", errors="replace").lstrip("\ufeff")
    printable = sum(c.isprintable() or c in "\t\r\n" for c in text if c != "\ufffd")
    return text if printable >= 0.95 * len(text) else None


def file_kind(head: bytes) -> str:
    """The kind of a file from its first ``HEAD_BYTES`` bytes: one of the keys of ``KINDS``."""
    if not head:
        return EMPTY
    signatures = ((b"\x93NUMPY", NPY), (b"\x89HDF\r\n\x1a\n", HDF5), (b"MATLAB ", MAT), (b"PK\x03\x04", ZIP),
                  (b"\x1f\x8b", GZIP))
    for signature, kind in signatures:
        if head.startswith(signature):
            return kind
    if head[257:262] == b"ustar":
        return TAR
    if text_start(head) is not None:
        return TEXT
    if head.startswith(b"\x80"):  # pickle protocol 2 and later
        return PICKLE
    return UNKNOWN


def mat_version(head: bytes) -> str | None:
    """``"7.3"`` (HDF5 inside, read with h5py) or ``"5"`` (read with SciPy) for a MATLAB ``.mat`` file's first
    bytes, None for anything else. MATLAB writes the version in the header's text and again as the 16-bit number at
    byte 124 (0x0200 for 7.3, 0x0100 for 5; the bytes 126-127, ``IM`` or ``MI``, give its byte order)."""
    if file_kind(head) != MAT:
        return None
    if head.startswith(b"MATLAB 7.3"):
        return "7.3"
    if len(head) >= 128:
        version = int.from_bytes(head[124:126], "little" if head[126:128] == b"IM" else "big")
        return "7.3" if version == 0x0200 else "5"
    return "5"


def _shown(head: bytes) -> str:
    """`` (it starts with 'a,b,c')`` for text, else empty."""
    text = text_start(head)
    return f" (it starts with {(text.strip().splitlines() or [''])[0][:40]!r})" if text is not None else ""


def what_it_is(head: bytes) -> str:
    """What a file is, from its first bytes, as a message says it: ``text (it starts with 'a,b,c')``."""
    return f"{KINDS[file_kind(head)]}{_shown(head)}"


SAVE_NUMBERS = "save the numbers with numpy.save(path, numpy.asarray(values, dtype=float))"
NEVER_PICKLE = "which vpr-smr never loads (unpickling can run code)"


def not_npy(path: Path, head: bytes, what: str) -> str:
    """Why ``path`` (``what`` it should hold) is not a ``.npy`` array, and the fix."""
    kind = file_kind(head)
    if kind == EMPTY:
        return f"{path} is empty (0 bytes), not {what} (a NumPy .npy array): write it again ({SAVE_NUMBERS})"
    if kind == PICKLE:
        return f"{path} is a Python pickle, not {what} (a NumPy .npy array), {NEVER_PICKLE}: {SAVE_NUMBERS}"
    return f"{path} is {what_it_is(head)}, not {what} (a NumPy .npy array): {SAVE_NUMBERS}"


@dataclass(frozen=True)
class NpyHeader:
    """What a ``.npy`` file's header says, and where its data (or, for an array of objects, its pickle) starts."""

    shape: tuple[int, ...]
    fortran_order: bool
    dtype: np.dtype[Any]
    data_start: int


def npy_header(path: Path | str, what: str = "a numeric array") -> NpyHeader:
    """The header of the ``.npy`` file ``path``, parsed by NumPy's header readers alone (no data is read, nothing
    is unpickled). A file that is not a ``.npy`` array or has a damaged header raises ValueError naming ``path``,
    what it is instead and the fix; ``what`` says what the file should hold."""
    path = Path(path)
    head = read_head(path)
    if file_kind(head) != NPY:
        raise ValueError(not_npy(path, head, what))
    with open(path, "rb") as handle:
        try:
            version = np.lib.format.read_magic(handle)
            shape, fortran_order, dtype = (np.lib.format.read_array_header_1_0(handle) if version == (1, 0) else
                                           np.lib.format.read_array_header_2_0(handle))
        except ValueError as error:
            raise ValueError(f"{path} has a damaged .npy header ({error}): write it again ({SAVE_NUMBERS})") from None
        return NpyHeader(tuple(int(n) for n in shape), bool(fortran_order), np.dtype(dtype), handle.tell())


def load_npy(path: Path | str, what: str = "a numeric array", mmap: bool = False) -> np.ndarray:
    """The array of a ``.npy`` file (a read-only memory map with ``mmap``), never unpickling anything. A file that
    is not a ``.npy`` array, an array of Python objects, or a truncated file raises ValueError naming ``path``,
    what it is instead and the fix; ``what`` says what the file should hold."""
    path = Path(path)
    header = npy_header(path, what)
    shape, dtype, data_start = header.shape, header.dtype, header.data_start
    if dtype.hasobject:
        raise ValueError(f"{path} holds an array of Python objects (dtype {dtype}, stored as a pickle), {NEVER_PICKLE},"
                         f" not {what}: {SAVE_NUMBERS}")
    needed = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    found = path.stat().st_size - data_start
    if found < needed:
        raise ValueError(f"{path} is truncated: its header says shape {tuple(shape)} of {dtype}, {needed} bytes of "
                         f"data, but it holds {found}: write it again (a copy or download that stopped?)")
    array: np.ndarray = np.load(path, mmap_mode="r" if mmap else None, allow_pickle=False)
    return array
