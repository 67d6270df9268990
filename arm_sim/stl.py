"""STL mesh loading, binary and ASCII, fast (pure numpy/numba, no rclpy).

:func:`load_stl` returns the triangles as a float32 array (F, 3, 3): face, corner, xyz, in the
file's own units (STL has none; a robot config's element ``scale`` converts them to metres).

- Binary STL (80-byte header, uint32 count, 50 bytes per facet) is read with one
  ``numpy.frombuffer``; the file size must match the count exactly.
- ASCII STL (``solid`` … ``endsolid``) is parsed by a single numba pass over the bytes that picks
  up every ``vertex x y z``; normals are ignored (recomputed by viewers).

Many exporters write binary files whose header starts with ``solid``: the size check decides.
Truncated or garbage files raise :class:`sim_runtime.errors.InputError` naming the file (and the
line for ASCII errors).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numba
import numpy as np

from sim_runtime.errors import InputError
from sim_runtime.inputfile import read_input_bytes

_BINARY_RECORD = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attr", "<u2")])
_HEADER_BYTES = 84
_UTF8_BOM = b"\xef\xbb\xbf"


def load_stl(path: str | os.PathLike[str]) -> np.ndarray:
    """Triangles (F, 3, 3) float32 of the binary or ASCII STL file at ``path``."""
    path = Path(path)
    return parse_stl(read_input_bytes(path, "STL file"), path)


def parse_stl(data: bytes, path: str | os.PathLike[str] = "<bytes>") -> np.ndarray:
    """Triangles (F, 3, 3) float32 of STL file contents ``data`` (``path`` names it in errors)."""
    size = len(data)
    if size >= _HEADER_BYTES:
        count = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
        if size == _HEADER_BYTES + count * _BINARY_RECORD.itemsize:
            if count == 0:
                raise InputError.at(path, None, "binary STL holds no triangles")
            triangles = np.empty((count, 3, 3), dtype=np.float32)
            bad = _copy_binary_vertices(
                np.frombuffer(data, dtype=np.uint8), triangles.reshape(-1).view(np.uint8), triangles.reshape(-1), count
            )
            if bad >= 0:
                raise InputError.at(path, None, f"triangle {bad} has a NaN or infinite coordinate")
            return triangles
    head = data[:1024].removeprefix(_UTF8_BOM)  # a text editor's byte-order mark before "solid"
    if head.lstrip().startswith(b"solid") and b"\x00" not in head:
        return _parse_ascii(data, path)
    if size < _HEADER_BYTES:
        raise InputError.at(
            path, None, f"not an STL file: {size} bytes, too short for a binary header and not ASCII ('solid' …)"
        )
    expected = _HEADER_BYTES + count * _BINARY_RECORD.itemsize
    raise InputError.at(
        path,
        None,
        f"truncated or corrupt binary STL: the header announces {count} "
        f"triangles ({expected} bytes) but the file has {size} bytes",
    )


@numba.njit(cache=True)
def _copy_binary_vertices(buf: np.ndarray, out_bytes: np.ndarray, out_floats: np.ndarray, count: int) -> int:
    """Copy the 36 vertex bytes of every 50-byte record (one pass, no unaligned numpy path) and
    return the first triangle with a NaN/inf coordinate, or -1."""
    bad = -1
    # Never past either buffer, whatever ``count`` says (the caller has checked it matches).
    count = min(count, (buf.shape[0] - 84) // 50, out_floats.shape[0] // 9, out_bytes.shape[0] // 36)
    for k in range(count):
        src = 84 + 50 * k + 12
        dst = 36 * k
        for j in range(36):
            out_bytes[dst + j] = buf[src + j]
        if bad < 0:
            for j in range(9 * k, 9 * k + 9):
                if not math.isfinite(out_floats[j]):
                    bad = k
                    break
    return bad


def _check_finite(triangles: np.ndarray, path: str | os.PathLike[str]) -> None:
    # one float64 sum (cannot overflow from float32 inputs) is NaN/inf exactly when some
    # coordinate is; much cheaper than a boolean mask over every coordinate
    if not math.isfinite(float(triangles.sum(dtype=np.float64))):
        face = int(np.argwhere(~np.isfinite(triangles))[0][0])
        raise InputError.at(path, None, f"triangle {face} has a NaN or infinite coordinate")


def _parse_ascii(data: bytes, path: str | os.PathLike[str]) -> np.ndarray:
    buf = np.frombuffer(data, dtype=np.uint8)
    # every vertex needs at least "vertex" + 3 one-digit numbers + separators: 12 bytes; np.empty
    # only reserves address space, so the generous bound costs nothing until written
    out = np.empty((len(data) // 12 + 3, 3), dtype=np.float32)
    count, error_at = _ascii_vertices(buf, out)

    newline = b"\n" if b"\n" in data[:65536] or b"\r" not in data[:65536] else b"\r"  # old Mac files end lines with CR

    def line_of(offset: int) -> int:
        return data.count(newline, 0, offset) + 1

    if error_at >= 0:
        raise InputError.at(path, line_of(error_at), "expected three numbers after 'vertex'")
    end = len(data[-4096:].rstrip()) + max(len(data) - 4096, 0)  # slices only the tail: no copy of the file
    tail = data[max(end - 4096, 0) : end].replace(b"\r", b"\n").rsplit(b"\n", 1)[-1].strip()
    if not tail.startswith(b"endsolid"):
        raise InputError.at(path, line_of(end), "truncated ASCII STL: the file does not end with 'endsolid'")
    if count == 0:
        raise InputError.at(path, None, "ASCII STL holds no triangles")
    if count % 3:
        raise InputError.at(path, None, f"ASCII STL has {count} vertices, not a multiple of 3")
    triangles = out[:count].reshape(-1, 3, 3).copy()
    _check_finite(triangles, path)
    return triangles


_VERTEX = np.frombuffer(b"vertex", dtype=np.uint8)
_POW10 = 10.0 ** np.arange(-60, 61)


@numba.njit(cache=True, inline="always")
def _is_space(c: int) -> bool:
    return c == 32 or c == 9 or c == 10 or c == 13 or c == 11 or c == 12


@numba.njit(cache=True)
def _parse_float(buf: np.ndarray, i: int, pow10: np.ndarray) -> tuple[float, int, bool]:
    """Parse a float at buf[i:] after skipping blanks; returns (value, next index, ok)."""
    n = buf.shape[0]
    while i < n and _is_space(buf[i]):
        i += 1
    sign = 1.0
    if i < n and (buf[i] == 45 or buf[i] == 43):  # - +
        if buf[i] == 45:
            sign = -1.0
        i += 1
    mant = 0.0
    digits = 0
    frac = 0
    while i < n and 48 <= buf[i] <= 57:
        mant = mant * 10.0 + (buf[i] - 48)
        digits += 1
        i += 1
    if i < n and buf[i] == 46:  # .
        i += 1
        while i < n and 48 <= buf[i] <= 57:
            mant = mant * 10.0 + (buf[i] - 48)
            digits += 1
            frac += 1
            i += 1
    if digits == 0:
        return 0.0, i, False
    exp = 0
    if i < n and (buf[i] == 101 or buf[i] == 69):  # e E
        i += 1
        esign = 1
        if i < n and (buf[i] == 45 or buf[i] == 43):
            if buf[i] == 45:
                esign = -1
            i += 1
        edigits = 0
        while i < n and 48 <= buf[i] <= 57:
            if exp < 100_000:  # beyond any float exponent; more digits must not wrap the integer
                exp = exp * 10 + (buf[i] - 48)
            edigits += 1
            i += 1
        if edigits == 0:
            return 0.0, i, False
        exp *= esign
    if i < n and not _is_space(buf[i]):
        return 0.0, i, False
    e10 = exp - frac
    if e10 < -60 or e10 > 60:
        return sign * mant * 10.0**e10, i, True
    return sign * mant * pow10[e10 + 60], i, True


@numba.njit(cache=True)
def _ascii_vertices_kernel(buf: np.ndarray, out: np.ndarray, word: np.ndarray, pow10: np.ndarray) -> tuple[int, int]:
    n = buf.shape[0]
    count = 0
    i = 0
    while i < n - 6:
        if buf[i] == 118 and (i == 0 or _is_space(buf[i - 1])):  # 'v'
            match = True
            for k in range(1, 6):
                if buf[i + k] != word[k]:
                    match = False
                    break
            if match and _is_space(buf[i + 6]):
                start = i
                if count >= out.shape[0]:  # more vertices than the caller made room for
                    return count, start
                j = i + 6
                for axis in range(3):
                    value, j, ok = _parse_float(buf, j, pow10)
                    if not ok:
                        return count, start
                    out[count, axis] = value
                count += 1
                i = j
                continue
        i += 1
    return count, -1


def _ascii_vertices(buf: np.ndarray, out: np.ndarray) -> tuple[int, int]:
    """Fill ``out`` with the vertices of ASCII STL bytes; returns (count, error offset or -1)."""
    count, error_at = _ascii_vertices_kernel(buf, out, _VERTEX, _POW10)
    return int(count), int(error_at)


def write_stl(path: str | os.PathLike[str], triangles: np.ndarray, *, ascii: bool = False, name: str = "mesh") -> None:
    """Write triangles (F, 3, 3) as a binary (default) or ASCII STL file with facet normals."""
    tri = np.asarray(triangles, dtype=np.float64)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0)
    path = Path(path)
    if ascii:
        rows = np.concatenate([normals[:, None, :], tri], axis=1).reshape(-1, 12)
        facet = (
            "  facet normal {:.6e} {:.6e} {:.6e}\n    outer loop\n"
            "      vertex {:.6e} {:.6e} {:.6e}\n      vertex {:.6e} {:.6e} {:.6e}\n"
            "      vertex {:.6e} {:.6e} {:.6e}\n    endloop\n  endfacet\n"
        )
        body = "".join(facet.format(*row) for row in rows.tolist())
        path.write_text(f"solid {name}\n{body}endsolid {name}\n")
        return
    records = np.zeros(len(tri), dtype=_BINARY_RECORD)
    records["normal"] = normals
    records["vertices"] = tri
    header = f"binary STL {name}".encode()[:80].ljust(80, b" ")
    with path.open("wb") as f:
        f.write(header)
        f.write(np.uint32(len(tri)).tobytes())
        f.write(records.tobytes())
