"""Meshes for the arm page: STL files read once, decimated for display, served as binary STL.

A browser draws a mesh of 756k faces, but parsing 38 MB of STL and uploading it stalls the page
for seconds and every later frame is slow. The page only shows the arm, so each file is reduced
to at most a display budget of faces by vertex clustering (vertices snapped to a grid, merged
per grid cell; triangles whose corners fall into fewer than three cells vanish). It keeps the
silhouette, needs only numpy, and takes well under a second for the 756k-face case. The result
is cached per file (path, size, modification time, budget): a file is read and reduced once
however many pages and arms show it.
"""

from __future__ import annotations

import hashlib
import os
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from arm_sim.stl import load_stl

DISPLAY_FACES = 50_000
"""Most faces a mesh is drawn with by default (0 = every face of the file)."""
CACHE_ENTRIES = 64
_STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attr", "<u2")])
_WELD_BITS = 20
"""Corners closer than extent / 2**20 are one vertex (STL repeats every shared corner)."""


@dataclass(frozen=True)
class DisplayMesh:
    """One mesh file ready for the browser: ``stl`` (binary STL bytes) and what was done to it."""

    key: str  # the URL name: a hash of the file's identity and the budget
    path: Path
    faces_in: int
    faces_out: int
    stl: bytes


def weld(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An STL triangle soup (F, 3, 3) as shared vertices (V, 3) float64 and faces (F, 3) int64."""
    corners = triangles.reshape(-1, 3).astype(np.float64)
    lo = corners.min(axis=0)
    extent = float((corners.max(axis=0) - lo).max()) or 1.0
    cells = np.floor((corners - lo) * ((2**_WELD_BITS - 1) / extent)).astype(np.int64)
    keys = (cells[:, 0] << (2 * _WELD_BITS)) | (cells[:, 1] << _WELD_BITS) | cells[:, 2]
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    return corners[first], inverse.reshape(-1, 3)


def _cluster_keys(vertices: np.ndarray, cells_per_axis: int) -> np.ndarray:
    lo = vertices.min(axis=0)
    extent = float((vertices.max(axis=0) - lo).max()) or 1.0
    cells = np.minimum(np.floor((vertices - lo) * (cells_per_axis / extent)), cells_per_axis - 1).astype(np.int64)
    n = cells_per_axis
    return (cells[:, 0] * n + cells[:, 1]) * n + cells[:, 2]


def cluster(vertices: np.ndarray, faces: np.ndarray, cells_per_axis: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertex clustering on a grid of ``cells_per_axis``³ cells over the mesh's bounding cube:
    one vertex per occupied cell (the mean of its vertices), faces kept when their corners are in
    three distinct cells, duplicates (the same cells in the same turning order) dropped."""
    _, cell_of_vertex = np.unique(_cluster_keys(vertices, cells_per_axis), return_inverse=True)
    count = int(cell_of_vertex.max()) + 1
    weights = np.bincount(cell_of_vertex, minlength=count).astype(np.float64)
    merged = np.stack(
        [np.bincount(cell_of_vertex, vertices[:, k], minlength=count) / weights for k in range(3)], axis=1
    )
    f = cell_of_vertex[faces]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    f = f[keep]
    # Rotate each triangle so its smallest index comes first: same triangle, same orientation, one key.
    start = np.argmin(f, axis=1)
    rows = np.arange(len(f))[:, None]
    f = f[rows, (start[:, None] + np.arange(3)) % 3]
    f = np.unique(f, axis=0) if len(f) else f
    return merged, f


def decimate(triangles: np.ndarray, max_faces: int) -> np.ndarray:
    """At most ``max_faces`` triangles (F', 3, 3) float32 that look like ``triangles`` (F, 3, 3);
    the input itself when it is small enough (or ``max_faces`` is 0)."""
    if max_faces <= 0 or len(triangles) <= max_faces:
        return triangles
    vertices, faces = weld(triangles)
    # A closed surface has about two faces per vertex: aim for max_faces / 2 occupied cells. The
    # number of occupied cells grows with the grid, so a bisection on the grid size finds it.
    target_cells = max(4, max_faces // 2)
    lo, hi = 2, 2
    while hi < 4096 and len(np.unique(_cluster_keys(vertices, hi))) < target_cells:
        lo, hi = hi, hi * 2
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if len(np.unique(_cluster_keys(vertices, mid))) <= target_cells:
            lo = mid
        else:
            hi = mid
    n = lo
    while True:  # open or ragged meshes have more faces per vertex: shrink until within budget
        merged, kept = cluster(vertices, faces, n)
        if len(kept) <= max_faces or n <= 2:
            break
        n = max(2, int(n * 0.85))
    return merged[kept].astype(np.float32)


def binary_stl(triangles: np.ndarray) -> bytes:
    """Binary STL bytes of ``triangles`` (F, 3, 3), with face normals (the browser shades by them)."""
    t = np.asarray(triangles, dtype=np.float32)
    normals = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
    records = np.zeros(len(t), dtype=_STL_RECORD)
    records["normal"] = normals
    records["vertices"] = t
    header = b"robot_sims studio display mesh".ljust(80, b" ")
    return header + np.uint32(len(t)).tobytes() + records.tobytes()


class MeshCache:
    """Display meshes by file and budget, each made once (thread-safe; the least recently used go
    beyond ``CACHE_ENTRIES``). ``get(key)`` is what the web route serves."""

    def __init__(self, entries: int = CACHE_ENTRIES) -> None:
        self._entries = entries
        self._by_identity: OrderedDict[tuple, DisplayMesh] = OrderedDict()
        self._by_key: dict[str, DisplayMesh] = {}
        self._lock = threading.Lock()
        self._making: dict[tuple, threading.Lock] = {}

    @staticmethod
    def identity(path: Path, max_faces: int) -> tuple:
        stat = path.stat()
        return (str(path.resolve()), stat.st_size, stat.st_mtime_ns, int(max_faces))

    def prepare(self, path: str | os.PathLike[str], max_faces: int = DISPLAY_FACES) -> DisplayMesh:
        """The display mesh of the STL file ``path`` (read and reduced on first use; slow for a big
        file: call it in a worker thread). Raises InputError for an unreadable or bad file."""
        path = Path(path)
        try:
            identity = self.identity(path, max_faces)
        except OSError:
            load_stl(path)  # raises the InputError naming the file
            raise
        with self._lock:
            found = self._by_identity.get(identity)
            if found is not None:
                self._by_identity.move_to_end(identity)
                return found
            making = self._making.setdefault(identity, threading.Lock())
        with making:  # two pages asking for one new file: it is read once
            with self._lock:
                found = self._by_identity.get(identity)
            if found is not None:
                return found
            triangles = load_stl(path)
            shown = decimate(triangles, max_faces)
            key = hashlib.sha1(repr(identity).encode()).hexdigest()[:20]
            mesh = DisplayMesh(key=key, path=path, faces_in=len(triangles), faces_out=len(shown), stl=binary_stl(shown))
            with self._lock:
                self._by_identity[identity] = mesh
                self._by_key[key] = mesh
                self._making.pop(identity, None)
                while len(self._by_identity) > self._entries:
                    _, old = self._by_identity.popitem(last=False)
                    self._by_key.pop(old.key, None)
            return mesh

    def get(self, key: str) -> DisplayMesh | None:
        with self._lock:
            return self._by_key.get(key)
