"""What the format modules share: the data a reader returns, its error, polygon fans."""
from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

__all__ = ["FileFormatError", "MeshData", "fan_triangulate", "to_float32_precision"]


class FileFormatError(Exception):
    """The bytes are not a valid file of the format; the message says what is wrong
    (:func:`lodkit.io.load` turns it into a MeshIOError naming the file)."""


@dataclass
class MeshData:
    """What a reader found: arrays as in :class:`lodkit.Mesh` (faces may be out of range:
    the Mesh constructor reports that) plus notes for the load report."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    colors: np.ndarray | None = None
    uvs: np.ndarray | None = None
    notes: list = field(default_factory=list)


def fan_triangulate(counts: np.ndarray, flat: np.ndarray, notes: list, what: str = "face") -> np.ndarray:
    """Triangles from polygons given as per-polygon corner counts and their concatenated
    indices: polygon (a, b, c, d, ...) becomes the fan (a, b, c), (a, c, d), ... in order.
    A polygon with fewer than 3 corners is an error; when any polygon has more than 3, a
    note saying how many were triangulated is added to ``notes``."""
    counts = np.asarray(counts, dtype=np.int64)
    flat = np.asarray(flat, dtype=np.int64)
    if counts.size == 0:
        return np.zeros((0, 3), dtype=np.int64)
    if counts.min() < 3:
        bad = int(np.flatnonzero(counts < 3)[0])
        raise FileFormatError(f"{what} {bad} has {int(counts[bad])} corner(s); a face needs at least 3")
    if int(counts.sum()) != flat.size:
        raise FileFormatError(f"the {what} lists hold {flat.size} indices, their counts say {int(counts.sum())}")
    if np.all(counts == 3):
        return flat.reshape(-1, 3)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    n_tri = counts - 2
    first = np.repeat(start, n_tri)                      # corner 0 of each polygon, per triangle
    k = np.arange(int(n_tri.sum())) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri)   # 0.. within polygon
    tris = np.stack([flat[first], flat[first + k + 1], flat[first + k + 2]], axis=1)
    poly = counts > 3
    sizes = ", ".join(f"{int(c)}: {int(n)}" for c, n in zip(*np.unique(counts[poly], return_counts=True)))
    notes.append(f"{int(poly.sum())} polygon {what}s (corners: count {{{sizes}}}) were fan-triangulated "
                 f"into {int(n_tri[poly].sum())} triangles")
    return tris


def to_float32_precision(values: np.ndarray) -> np.ndarray:
    """float64 values rounded to float32, as Open3D's OBJ/OFF/STL readers parsed them (kept so
    that meshes loaded from text files are the same as before lodkit read them itself)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return values.astype(np.float32).astype(np.float64)


def parse_reals_obj(tokens: list[bytes]) -> np.ndarray:
    """Decimal tokens to float32-precision float64 values the way Open3D 0.20's OBJ reader
    computed them -- ``float(integer part) + float(float(fraction digits) / float(10**n))``
    in float32 arithmetic, which is not always the correctly rounded float32 -- so meshes
    load bit for bit as they did through Open3D (measured on the shared meshes). Tokens
    with an exponent, nan, inf and other forms are converted by numpy (correctly rounded);
    a token that is not a number raises ValueError."""
    n = len(tokens)
    if n == 0:
        return np.zeros(0)
    arr = np.array(tokens, dtype=np.bytes_)
    width = arr.dtype.itemsize
    out = np.empty(n)
    if width > 40:
        return arr.astype(np.float64)
    ch = arr.view(np.uint8).reshape(n, width)
    digit = (ch >= 48) & (ch <= 57)
    neg = ch[:, 0] == 45
    start = (neg | (ch[:, 0] == 43)).astype(np.int64)
    dot = ch == 46
    pad = ch == 0
    col = np.arange(width)
    ndots = dot.sum(axis=1)
    length = width - pad.sum(axis=1)
    # plain: [sign] digits [. digits], at most 18 digits on either side, no padding inside
    body = (col[None, :] >= start[:, None]) & (col[None, :] < length[:, None])
    plain = (np.all(~body | digit | dot, axis=1) & (ndots <= 1)
             & np.all(pad == (col[None, :] >= length[:, None]), axis=1))
    dot_at = np.where(ndots == 1, np.argmax(dot, axis=1), length)
    n_int = dot_at - start
    n_frac = np.where(ndots == 1, length - dot_at - 1, 0)
    plain &= (n_int + n_frac > 0) & (n_int <= 18) & (n_frac <= 18)
    d = np.where(digit, ch.astype(np.int64) - 48, 0)
    ip = np.zeros(n, dtype=np.int64)
    fp = np.zeros(n, dtype=np.int64)
    for j in range(width):
        in_int = plain & (j >= start) & (j < dot_at)
        ip = np.where(in_int, ip * 10 + d[:, j], ip)
        in_frac = plain & (j > dot_at) & (j < length)
        fp = np.where(in_frac, fp * 10 + d[:, j], fp)
    with np.errstate(over="ignore"):
        pow10 = np.power(10.0, n_frac.astype(np.float64)).astype(np.float32)
        value = ip.astype(np.float32) + (fp.astype(np.float32) / pow10)
    value = np.where(neg, -value, value)
    fast = plain & (fp < 1 << 24) & (ip < 1 << 24)
    out[fast] = value[fast].astype(np.float64)
    long = plain & ~fast                   # more digits than float32 holds: correctly rounded
    if long.any():
        out[long] = arr[long].astype(np.float64)
    for i in np.flatnonzero(~plain):       # exponents, nan, inf: one by one (rare)
        out[i] = _parse_real_slow(arr[i])
    return out


_REAL = re.compile(rb"^([+-]?)(\d*)(?:\.(\d*))?(?:[eE]([+-]?\d{1,4}))?$")


def _parse_real_slow(tok: bytes) -> float:
    """One token as :func:`parse_reals_obj` computes it (exponents: the mantissa times
    float32(10**exponent), in float32; long mantissas: correctly rounded)."""
    m = _REAL.match(tok)
    if m is None or not (m.group(2) or m.group(3)):
        return float(np.float64(tok.decode("latin-1")))   # nan, inf; ValueError for garbage
    sign, ip, fp, ex = m.groups()
    fp = fp or b""
    ipv, fpv = int(ip or b"0"), int(fp or b"0")
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        if ipv < 1 << 24 and fpv < 1 << 24:
            mant = np.float32(ipv) + np.float32(fpv) / np.float32(10.0 ** min(len(fp), 308))
        else:
            mant = np.float32(float(ip + b"." + fp if fp else ip or b"0"))
        if ex is not None:
            e = int(ex)
            # 10.0 ** 309 overflows a Python float (OverflowError, not inf): the float32
            # result is inf from 1e39 on anyway
            mant = np.float32(mant * np.float32(10.0 ** e if -330 < e < 309 else (0.0 if e < 0 else np.inf)))
    v = float(mant)
    return -v if sign == b"-" else v
