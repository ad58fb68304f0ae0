"""Triangle meshes for mass properties: STL/OBJ readers and the checks the volume formulas need.

NumPy only. Vertices are (V, 3) float arrays in metres; faces are (F, 3) integer arrays of vertex
indices, wound counter-clockwise seen from outside (right-hand rule gives the outward normal).
:func:`rbenv.core.inertia.from_mesh` turns a checked mesh into mass properties.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from rbenv.core import validation as check
from rbenv.core.errors import InvalidParameterError, describe

__all__ = ["MeshError", "check_closed_oriented", "check_mesh_arrays", "load_mesh", "weld"]

# Vertices closer than this fraction of the mesh's coordinate scale are merged by `weld`.
_WELD_RTOL = 1e-9
# Documented caps: a mesh file is read only up to this size, and may hold this many triangles.
MAX_MESH_BYTES = 256 * 1024 * 1024
MAX_MESH_FACES = 2_000_000

_STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])
_STL_VERTEX = re.compile(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)", re.IGNORECASE)


class MeshError(InvalidParameterError):
    """A mesh or mesh file breaks a rule: closed, consistently oriented, valid indices, volume>0."""


def load_mesh(path) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh from an ASCII/binary ``.stl`` or an ``.obj`` file.

    Returns ``(vertices (V, 3) float, faces (F, 3) int)``. STL stores each triangle's corners
    separately, so coincident corners are welded (see :func:`weld`); OBJ polygons are
    fan-triangulated. Units are whatever the file uses (rbenv assumes metres). Only regular
    files of at most :data:`MAX_MESH_BYTES` bytes with at most :data:`MAX_MESH_FACES` triangles
    are read; anything else (a FIFO, ``/dev/zero``, a directory) raises :class:`MeshError`.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".stl", ".obj"):
        raise MeshError(f"mesh file {str(path)!r} must end in .stl or .obj, got {suffix!r}")
    try:
        data = check.read_regular_file("mesh file", path, max_bytes=MAX_MESH_BYTES)
    except InvalidParameterError as exc:
        raise MeshError(str(exc)) from None
    if suffix == ".stl":
        return weld(_read_stl(data, path))
    return _read_obj(data.decode("utf-8", errors="replace"), path)


def weld(triangles) -> tuple[np.ndarray, np.ndarray]:
    """Merge coincident corners of a triangle soup into an indexed mesh.

    triangles: (F, 3, 3) corner coordinates (m). Corners that agree after rounding to
    ``1e-9 ×`` the coordinate scale become one vertex. Triangles that collapse to a repeated
    index (zero area at that tolerance) are dropped: they carry no area and no volume.
    Returns ``(vertices (V, 3), faces (F', 3))``.
    """
    corners = np.asarray(triangles, dtype=float).reshape(-1, 3)
    scale = float(np.abs(corners).max(initial=0.0)) or 1.0
    keys = np.round(corners / (_WELD_RTOL * scale))
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    faces = inverse.reshape(-1, 3)
    return corners[first], faces[~_repeats_index(faces)]


def check_mesh_arrays(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """Validate array shapes, finiteness and face indices; return ``(vertices float, faces int64)``.

    vertices: (V, 3) in m; faces: (F, 3) integer indices into vertices. Raises
    :class:`MeshError` (NonFiniteError for NaN/inf vertices) naming the face and the rule.
    """
    v = check.finite_array("vertices", vertices)
    if v.ndim != 2 or v.shape[1] != 3 or len(v) < 3:
        raise MeshError(f"vertices must have shape (V >= 3, 3), got shape {v.shape}")
    try:
        f = np.asarray(faces)
    except (ValueError, TypeError, OverflowError):
        raise MeshError(f"faces must be an (F, 3) array of integer vertex indices, got "
                        f"{describe(faces)}") from None
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise MeshError(f"faces must have shape (F >= 1, 3) (triangles), got shape {f.shape}")
    if not np.issubdtype(f.dtype, np.integer):
        raise MeshError(f"faces must hold integer vertex indices, got dtype {f.dtype}")
    if len(f) > MAX_MESH_FACES:
        raise MeshError(f"mesh has {len(f)} faces; the limit is {MAX_MESH_FACES}")
    f = f.astype(np.int64)
    bad = np.flatnonzero(((f < 0) | (f >= len(v))).any(axis=1))
    if bad.size:
        raise MeshError(
            f"faces[{bad[0]}] = {describe(f[bad[0]])} indexes outside the {len(v)} vertices "
            f"(valid: 0..{len(v) - 1}); {bad.size} face(s) affected"
        )
    degenerate = np.flatnonzero(_repeats_index(f))
    if degenerate.size:
        raise MeshError(
            f"faces[{degenerate[0]}] = {describe(f[degenerate[0]])} repeats a vertex index; a "
            f"triangle needs three distinct vertices ({degenerate.size} degenerate face(s))"
        )
    return v, f


def check_closed_oriented(faces, n_vertices: int) -> None:
    """Require a closed, consistently oriented surface: each directed edge once, its reverse once.

    faces: (F, 3) int64, already index-checked. The signed-tetrahedron volume formulas are exact
    only for such surfaces; a hole or a flipped face silently gives a wrong tensor, so refuse.
    """
    f = np.asarray(faces, dtype=np.int64)
    tail = f.reshape(-1)
    head = np.roll(f, -1, axis=1).reshape(-1)
    keys = tail * n_vertices + head
    uniq, counts = np.unique(keys, return_counts=True)
    if (counts > 1).any():
        key = uniq[np.argmax(counts > 1)]
        where = np.flatnonzero(keys == key) // 3
        raise MeshError(
            f"mesh is inconsistently oriented: edge {key // n_vertices}->{key % n_vertices} is "
            f"used in the same direction by faces {where.tolist()}; neighbouring faces must "
            "traverse a shared edge in opposite directions (a flipped face, or an edge shared "
            "by more than two faces)"
        )
    open_edges = np.flatnonzero(~np.isin(head * n_vertices + tail, uniq))
    if open_edges.size:
        e = open_edges[0]
        raise MeshError(
            f"mesh is not closed: {open_edges.size} edge(s) belong to only one face, e.g. edge "
            f"{tail[e]}->{head[e]} of faces[{e // 3}]; a solid needs a watertight surface where "
            "every edge is shared by exactly two faces (use shell=True for an open surface)"
        )


def _repeats_index(faces: np.ndarray) -> np.ndarray:
    """(F,) bool: the face names some vertex twice."""
    a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
    return (a == b) | (b == c) | (c == a)


def _read_stl(data: bytes, path: Path) -> np.ndarray:
    """Triangle corners (F, 3, 3) from STL bytes; binary is recognised by its exact length."""
    if len(data) >= 84:
        n = int(np.frombuffer(data, "<u4", count=1, offset=80)[0])
        if len(data) == 84 + 50 * n:
            if n > MAX_MESH_FACES:
                raise MeshError(f"STL {str(path)!r} has {n} triangles; the limit is "
                                f"{MAX_MESH_FACES}")
            records = np.frombuffer(data, _STL_RECORD, count=n, offset=84)
            return _finite_corners(records["v"].astype(float), path)
    if not data.lstrip().lower().startswith(b"solid"):
        raise MeshError(
            f"{str(path)!r} is not an STL file: not 'solid ...' text, and its length "
            f"{len(data)} is not 84 + 50 × (triangle count in the header)"
        )
    found = _STL_VERTEX.findall(data)
    if len(found) > 3 * MAX_MESH_FACES:
        raise MeshError(f"ASCII STL {str(path)!r} has more than {MAX_MESH_FACES} triangles")
    if not found or len(found) % 3:
        raise MeshError(
            f"ASCII STL {str(path)!r} has {len(found)} 'vertex x y z' lines; need a positive "
            "multiple of 3 (triangles)"
        )
    try:
        corners = np.array(found, dtype=float)
    except ValueError as exc:
        raise MeshError(f"ASCII STL {str(path)!r} has a non-numeric vertex: {exc}") from exc
    return _finite_corners(corners.reshape(-1, 3, 3), path)


def _finite_corners(corners: np.ndarray, path: Path) -> np.ndarray:
    bad = np.flatnonzero(~np.isfinite(corners).all(axis=(1, 2)))
    if bad.size:
        raise MeshError(f"STL {str(path)!r} triangle {bad[0]} has a non-finite coordinate")
    return corners


def _read_obj(text: str, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and fan-triangulated faces from OBJ text (``v`` and ``f`` records only)."""
    vertices: list[list[float]] = []
    faces: list[tuple[int, int, int]] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        parts = line.split("#", 1)[0].split()
        if not parts or parts[0] not in ("v", "f"):
            continue
        where = f"{str(path)!r} line {lineno}"
        if parts[0] == "v":
            vertices.append(_obj_vertex(parts[1:], where))
        else:
            idx = [_obj_index(tok, len(vertices), where) for tok in parts[1:]]
            if len(idx) < 3:
                raise MeshError(f"{where}: a face needs at least 3 vertices, got {len(idx)}")
            faces.extend((idx[0], idx[k], idx[k + 1]) for k in range(1, len(idx) - 1))
            if len(faces) > MAX_MESH_FACES:
                raise MeshError(f"OBJ {str(path)!r} has more than {MAX_MESH_FACES} triangles")
    if not faces:
        raise MeshError(f"OBJ {str(path)!r} has no 'f' (face) records")
    return np.array(vertices, dtype=float).reshape(-1, 3), np.array(faces, dtype=np.int64)


def _obj_vertex(fields: list[str], where: str) -> list[float]:
    try:
        xyz = [float(x) for x in fields[:3]]
    except ValueError as exc:
        raise MeshError(f"{where}: vertex coordinates must be numbers ({exc})") from exc
    if len(xyz) != 3 or not np.isfinite(xyz).all():
        raise MeshError(f"{where}: a vertex needs 3 finite coordinates, got {fields!r}")
    return xyz


def _obj_index(token: str, n_defined: int, where: str) -> int:
    """0-based vertex index from an OBJ face token ``i``, ``i/t``, ``i//n`` or ``i/t/n``."""
    try:
        i = int(token.split("/", 1)[0])
    except ValueError as exc:
        raise MeshError(f"{where}: face index {token!r} is not an integer") from exc
    k = i - 1 if i > 0 else n_defined + i  # OBJ is 1-based; negative counts back from the end
    if i == 0 or not 0 <= k < n_defined:
        raise MeshError(
            f"{where}: face index {i} refers to no vertex ({n_defined} defined so far; OBJ "
            "indices are 1-based, negative ones count back)"
        )
    return k
