"""The model file on disk, read without torch: a ``torch.save`` zip archive, unpickled through an allow-list
into plain values and declared tensors, then the tensors' values into numpy; and the content hash a model
file records.

``torch.save`` writes a zip archive: ``<prefix>/data.pkl`` (the pickled object, in which every tensor is
a call of ``torch._utils._rebuild_tensor_v2`` on a persistent id ``("storage", torch.FloatStorage, key,
location, numel)``), ``<prefix>/data/<key>`` (each storage's raw bytes) and ``<prefix>/byteorder``.

- `read_archive`: the file's bytes, within a size limit, once they are a zip archive whose declared sizes
  are within the limits.
- `TorchArchive.payload`: data.pkl unpickled allowing only plain values (dict, list, tuple, str, int,
  float, bool, None), ``collections.OrderedDict``, the storage types and ``_rebuild_tensor_v2``; pickle
  opcodes that build or call anything else are refused before unpickling starts. A tensor comes out as a
  `StoredTensor`: its declared storage and view, no data read or allocated.
- `TorchArchive.read`: one tensor's values into numpy, after its entry's real size matched the declared one.

Any problem raises `ArchiveError`, one line without the file's name (the caller adds it).
"""

from __future__ import annotations

import collections
import hashlib
import io
import json
import os
import pickle
import pickletools
import struct
import zipfile
import zlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from contactnet.planning.normalizer import Normalizer

MODEL_FORMAT = "contactnet-model-v1"


class ArchiveError(ValueError):
    """A model file's archive that cannot be read safely: one-line problem, without the file's name."""


# ---- the content hash ----------------------------------------------------------------------------
def _float32(values: Any) -> np.ndarray:
    """C-contiguous float32 values of a numpy array or a torch tensor (no torch import: the tensor's own
    methods)."""
    if hasattr(values, "detach"):
        values = values.detach().cpu().float().contiguous().numpy()
    return np.ascontiguousarray(values, dtype=np.float32)


def content_hash(gait: str, robot: str, hidden: Any, state: Mapping[str, Any], normalizer: Normalizer) -> str:
    """``sha256:<hex>`` over what decides a model's scores and where it may be used: a JSON header (format,
    gait, robot, hidden sizes, the normalizer's ``to_dict()``, sorted keys), then for each state_dict entry in
    name order its name and shape and its values as little-endian float32. Metadata (training facts) is
    not covered. ``state`` holds numpy arrays or torch tensors (the same hash for the same values)."""
    digest = hashlib.sha256()
    head = {"format": MODEL_FORMAT, "gait": gait, "robot": robot, "hidden": [int(h) for h in hidden],
            "normalizer": normalizer.to_dict()}
    digest.update(json.dumps(head, sort_keys=True).encode())
    for name in sorted(state):
        values = _float32(state[name])
        digest.update(f"\n{name} {tuple(values.shape)}\n".encode())
        digest.update(values.astype("<f4", copy=False).tobytes())
    return f"sha256:{digest.hexdigest()}"


# ---- what the archive declares -------------------------------------------------------------------
@dataclass(frozen=True)
class StorageType:
    """A torch storage type as pickled (``torch.FloatStorage``): its element size, and the numpy dtype of
    its values when they are floating point (``"bfloat16"``: read as the top half of a float32)."""

    name: str
    itemsize: int
    float_dtype: str | None = None


STORAGE_TYPES: dict[str, StorageType] = {t.name: t for t in (
    StorageType("FloatStorage", 4, "f4"), StorageType("DoubleStorage", 8, "f8"),
    StorageType("HalfStorage", 2, "f2"), StorageType("BFloat16Storage", 2, "bfloat16"),
    StorageType("LongStorage", 8), StorageType("IntStorage", 4), StorageType("ShortStorage", 2),
    StorageType("CharStorage", 1), StorageType("ByteStorage", 1), StorageType("BoolStorage", 1),
    StorageType("ComplexFloatStorage", 8), StorageType("ComplexDoubleStorage", 16),
    StorageType("QInt8Storage", 1), StorageType("QUInt8Storage", 1), StorageType("QInt32Storage", 4),
    StorageType("QUInt4x2Storage", 1), StorageType("QUInt2x4Storage", 1))}


@dataclass(frozen=True)
class _Storage:
    """A persistent id of data.pkl: the storage in entry ``data/<key>``, its type and element count."""

    key: str
    type: StorageType
    numel: int


@dataclass(frozen=True)
class StoredTensor:
    """A tensor as the archive declares it: its storage (entry ``data/<key>``, type, element count) and
    the view on it (offset, shape and strides in elements). No data is read or allocated."""

    key: str
    storage: StorageType
    storage_numel: int
    offset: int
    shape: tuple[int, ...]
    stride: tuple[int, ...]

    @property
    def floating(self) -> bool:
        return self.storage.float_dtype is not None

    @property
    def stored_bytes(self) -> int:
        """What its storage declares (what torch would allocate to load it)."""
        return self.storage_numel * self.storage.itemsize


MAX_DIMS = 16
MAX_KEY_CHARS = 100
#: Zip entries of an archive (a model has at most 18 tensors and a few records): zipfile would build an
#: object of some 400 bytes for each entry a directory lists before anything else could be checked.
MAX_ENTRIES = 256

#: The pickle opcodes of plain values, memo, tensors' persistent ids, globals and calls: those torch.save
#: writes for dicts, lists, tuples, str, int, float, bool, None and tensors (protocol 2), all of which
#: torch's own weights_only loader reads. No BUILD, NEWOBJ, INST, OBJ, EXT (they make or change objects
#: of other types), no bytes, sets or text-protocol opcodes.
_ALLOWED_OPCODES = frozenset({
    "PROTO", "STOP", "MARK", "POP", "POP_MARK", "DUP", "EMPTY_DICT", "EMPTY_LIST", "EMPTY_TUPLE", "TUPLE",
    "TUPLE1", "TUPLE2", "TUPLE3", "APPEND", "APPENDS", "SETITEM", "SETITEMS", "BINPUT", "LONG_BINPUT",
    "BINGET", "LONG_BINGET", "NONE", "NEWTRUE", "NEWFALSE", "BININT", "BININT1", "BININT2", "LONG1",
    "BINFLOAT", "BINUNICODE", "SHORT_BINUNICODE", "GLOBAL", "REDUCE", "BINPERSID",
})


class _Refused(Exception):
    """Raised inside the unpickler with the whole problem text."""


def _check_opcodes(data: bytes) -> None:
    """Every opcode allowed, and memo indices given in order as a pickler does: a memo index is never more
    than the count of indices given before it (the C unpickler sizes its memo by the largest index, so
    ``LONG_BINPUT 4294967295`` alone would make it allocate 32 GB)."""
    memo: set[int] = set()
    for opcode, arg, _pos in pickletools.genops(data):
        if opcode.name not in _ALLOWED_OPCODES:
            raise _Refused(f"holds objects other than tensors and plain values (pickle opcode {opcode.name} "
                           "is not allowed)")
        if opcode.name in ("BINPUT", "LONG_BINPUT"):
            if arg > len(memo):
                raise _Refused(f"holds a malformed pickle (memo index {arg} out of order)")
            memo.add(arg)


def _excerpt(value: Any, limit: int = 60) -> str:
    try:
        text = repr(value)
    except RecursionError:
        return f"a deeply nested {type(value).__name__}"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _is_count(value: Any) -> bool:
    return type(value) is int and value >= 0


def _rebuild_tensor_v2(storage: Any, offset: Any, size: Any, stride: Any, requires_grad: Any = False,
                       hooks: Any = None, metadata: Any = None) -> StoredTensor:
    """Stands for ``torch._utils._rebuild_tensor_v2`` in data.pkl: checks the declared view, reads nothing."""
    if not isinstance(storage, _Storage):
        raise _Refused(f"holds a tensor whose storage is {_excerpt(storage)}, not a stored one")
    shape_ok = isinstance(size, tuple) and len(size) <= MAX_DIMS and all(map(_is_count, size))
    if not (shape_ok and isinstance(stride, tuple) and len(stride) == len(size) and all(map(_is_count, stride))
            and _is_count(offset)):
        raise _Refused(f"holds a tensor with a malformed view (shape {_excerpt(size, 40)}, strides "
                       f"{_excerpt(stride, 40)}, offset {_excerpt(offset, 20)})")
    if type(requires_grad) is not bool or hooks not in (None, {}) or metadata not in (None, {}):
        raise _Refused("holds a tensor with gradient hooks or extra state, not a plain tensor")
    extent = 0 if 0 in size else 1 + sum((n - 1) * s for n, s in zip(size, stride, strict=True))
    if offset + extent > storage.numel:
        raise _Refused(f"holds a tensor of shape {_excerpt(size, 40)} that does not fit its storage "
                       f"{storage.key} of {storage.numel} elements")
    return StoredTensor(storage.key, storage.type, storage.numel, offset, size, stride)


class _Unpickler(pickle.Unpickler):
    """data.pkl's unpickler: the allowed globals only; tensors' persistent ids become `_Storage` records."""

    def __init__(self, data: bytes) -> None:
        super().__init__(io.BytesIO(data))
        self._storages: dict[str, _Storage] = {}

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) == ("torch._utils", "_rebuild_tensor_v2"):
            return _rebuild_tensor_v2
        if (module, name) == ("collections", "OrderedDict"):
            return collections.OrderedDict
        if module == "torch" and name in STORAGE_TYPES:
            return STORAGE_TYPES[name]  # not callable: only a persistent id may use it
        where = f"{module}.{name}".encode("ascii", "backslashreplace").decode()
        where = where if len(where) <= 60 else where[:57] + "..."
        raise _Refused(f"holds objects other than tensors and plain values ({where} is not allowed)")

    def persistent_load(self, pid: Any) -> _Storage:
        if not (isinstance(pid, tuple) and len(pid) == 5 and pid[0] == "storage"
                and isinstance(pid[1], StorageType) and type(pid[2]) is str and 0 < len(pid[2]) <= MAX_KEY_CHARS
                and type(pid[3]) is str and _is_count(pid[4])):
            raise _Refused(f"holds a malformed storage reference {_excerpt(pid)}")
        storage = _Storage(pid[2], pid[1], pid[4])
        if self._storages.setdefault(storage.key, storage) != storage:
            raise _Refused(f"declares storage {_excerpt(storage.key, 20)} twice, with different types or sizes")
        return storage


# ---- the archive ---------------------------------------------------------------------------------
class TorchArchive:
    """A ``torch.save`` zip archive in memory, its zip directory read and its sizes checked (`read_archive`)."""

    def __init__(self, data: bytes, listing: zipfile.ZipFile, prefix: str, pickle_entry: zipfile.ZipInfo,
                 byteorder: str) -> None:
        self.data = data  #: the file's bytes
        self._zip = listing
        self.prefix = prefix  #: the archive's folder (``archive`` for files torch writes)
        self._pickle_entry = pickle_entry
        self.byteorder = byteorder  #: ``"<"`` or ``">"``, of the storages' values

    def payload(self) -> Any:
        """data.pkl unpickled: plain values, OrderedDicts and `StoredTensor` declarations."""
        data = _read_checked(self._zip, self._pickle_entry)
        try:
            _check_opcodes(data)
            return _Unpickler(data).load()
        except _Refused as exc:
            raise ArchiveError(str(exc)) from None
        except RecursionError:
            raise ArchiveError("cannot be read as a torch file: its data is nested too deeply") from None
        except Exception as exc:  # noqa: BLE001 - any failure of a hostile pickle is one line
            raise ArchiveError(f"cannot be read as a torch file, corrupt? ({type(exc).__name__})") from None

    def read(self, tensor: StoredTensor) -> np.ndarray:
        """The values of a floating-point tensor (a new array, native byte order: float16, float32 or float64;
        bfloat16 as float32). Its entry must hold exactly the bytes its storage declares."""
        if not tensor.floating:
            raise ArchiveError(f"tensor in storage {tensor.key} is not floating point")
        raw = self._entry_bytes(tensor.key, tensor.stored_bytes)
        kind = tensor.storage.float_dtype
        base = np.dtype("u2" if kind == "bfloat16" else kind).newbyteorder(self.byteorder)
        values = np.frombuffer(raw, dtype=base, count=tensor.storage_numel)
        view = np.lib.stride_tricks.as_strided(values[tensor.offset:], shape=tensor.shape,
                                               strides=tuple(s * base.itemsize for s in tensor.stride))
        if kind == "bfloat16":
            return (view.astype(np.uint32) << 16).view(np.float32)
        return view.astype(base.newbyteorder("="))

    def check_checksums(self, tensors: Iterable[StoredTensor]) -> None:
        """The zip checksums (CRC-32) of the tensors' entries; torch does not check them."""
        for key in sorted({t.key for t in tensors}):
            info = self._zip.getinfo(f"{self.prefix}/data/{key}")
            if info.compress_type == zipfile.ZIP_STORED and zlib.crc32(self._stored(info)) != info.CRC:
                raise ArchiveError(f"is damaged: the zip checksum of {info.filename} does not match (the file "
                                   "was changed after it was saved)")

    def _entry_bytes(self, key: str, size: int) -> bytes | memoryview:
        name = f"{self.prefix}/data/{key}"
        try:
            info = self._zip.getinfo(name)
        except KeyError:
            raise ArchiveError(f"has no entry {_excerpt(name)} for a tensor's storage") from None
        if info.file_size != size:
            raise ArchiveError(f"entry {_excerpt(name)} holds {info.file_size} bytes, its tensor's storage "
                               f"declares {size}")
        if info.compress_type == zipfile.ZIP_STORED:
            return self._stored(info)  # its checksum: `check_checksums`, once the content hash had its say
        return _read_checked(self._zip, info)

    def _stored(self, info: zipfile.ZipInfo) -> memoryview:
        """An uncompressed entry's bytes, located through its local header, the checksum not checked."""
        header = self.data[info.header_offset: info.header_offset + zipfile.sizeFileHeader]
        if len(header) != zipfile.sizeFileHeader or header[:4] != zipfile.stringFileHeader:
            raise ArchiveError(f"cannot be read as a torch file, corrupt? (entry {_excerpt(info.filename)})")
        fields = struct.unpack(zipfile.structFileHeader, header)
        start = (info.header_offset + zipfile.sizeFileHeader + fields[zipfile._FH_FILENAME_LENGTH]
                 + fields[zipfile._FH_EXTRA_FIELD_LENGTH])
        if info.compress_size != info.file_size or start + info.file_size > len(self.data):
            raise ArchiveError(f"cannot be read as a torch file, corrupt? (entry {_excerpt(info.filename)})")
        return memoryview(self.data)[start: start + info.file_size]

def _read_checked(listing: zipfile.ZipFile, info: zipfile.ZipInfo) -> bytes:
    """An entry's bytes through zipfile: decompressed within its declared size, its checksum checked."""
    try:
        return listing.read(info)
    except zipfile.BadZipFile as exc:
        if "CRC" in str(exc):
            raise ArchiveError(f"is damaged: the zip checksum of {_excerpt(info.filename)} does not match "
                               "(the file was changed after it was saved)") from None
        raise ArchiveError(f"cannot be read as a torch file, corrupt? ({type(exc).__name__})") from None
    except Exception as exc:  # noqa: BLE001 - zlib, NotImplementedError (compression), EOFError ...
        raise ArchiveError(f"cannot be read as a torch file, corrupt? ({type(exc).__name__})") from None


def _file_bytes(path: Path, max_bytes: int) -> bytes:
    if not path.exists():
        raise ArchiveError("no such file")
    if not path.is_file():
        raise ArchiveError("not a regular file")
    too_big = f"is larger than the largest allowed network needs ({max_bytes} bytes)"
    try:
        if path.stat().st_size > max_bytes:
            raise ArchiveError(too_big)
        with open(path, "rb") as handle:
            data = handle.read(max_bytes + 1)  # bounded even if the file grows meanwhile
    except OSError as exc:
        raise ArchiveError(f"cannot be read ({type(exc).__name__})") from None
    if not data:
        raise ArchiveError("is empty")
    if len(data) > max_bytes:
        raise ArchiveError(too_big)
    return data


def read_archive(path: str | os.PathLike, max_bytes: int, max_pickle_bytes: int) -> TorchArchive:
    """The file at ``path`` as a torch archive: at most ``max_bytes`` on disk and declared in all, at most
    ``max_pickle_bytes`` of pickled data (the values without the tensors' data)."""
    data = _file_bytes(Path(path), max_bytes)
    if not zipfile.is_zipfile(io.BytesIO(data)):  # a truncated archive has no directory
        raise ArchiveError("is not a complete torch file (truncated, or some other format)")
    try:
        end = zipfile._EndRecData(io.BytesIO(data))  # the directory's end record: how many entries it lists
        if end is not None and end[zipfile._ECD_ENTRIES_TOTAL] > MAX_ENTRIES:
            raise ArchiveError(f"holds {end[zipfile._ECD_ENTRIES_TOTAL]} zip entries, more than {MAX_ENTRIES}")
        listing = zipfile.ZipFile(io.BytesIO(data))
        entries = listing.infolist()
    except ArchiveError:
        raise
    except Exception as exc:  # noqa: BLE001 - BadZipFile, ValueError, OSError, struct.error ...
        raise ArchiveError(f"cannot be read as a torch file, corrupt? ({type(exc).__name__})") from None
    if not entries or "/" not in entries[0].filename:
        raise ArchiveError("is not a torch file (no archive folder)")
    prefix = entries[0].filename.split("/", 1)[0]
    pickled = max((e.file_size for e in entries if e.filename.endswith("data.pkl")), default=0)
    if pickled > max_pickle_bytes:
        raise ArchiveError(f"declares {pickled} bytes of metadata, more than {max_pickle_bytes}")
    if sum(e.file_size for e in entries) > max_bytes:
        raise ArchiveError(f"declares more content than the largest allowed network needs ({max_bytes} bytes)")
    try:
        pickle_entry = listing.getinfo(f"{prefix}/data.pkl")
    except KeyError:
        raise ArchiveError(f"is not a torch file (no {_excerpt(prefix, 30)}/data.pkl)") from None
    byteorder = "<"  # torch's default when the archive does not say (files of torch < 1.12)
    if f"{prefix}/byteorder" in listing.NameToInfo:
        info = listing.getinfo(f"{prefix}/byteorder")
        mark = _read_checked(listing, info) if info.file_size <= 8 else b"?"
        if mark not in (b"little", b"big"):
            raise ArchiveError(f"declares an unknown byte order {_excerpt(mark[:20])}")
        byteorder = "<" if mark == b"little" else ">"
    return TorchArchive(data, listing, prefix, pickle_entry, byteorder)


__all__ = ["MODEL_FORMAT", "STORAGE_TYPES", "ArchiveError", "StorageType", "StoredTensor", "TorchArchive",
           "content_hash", "read_archive"]
