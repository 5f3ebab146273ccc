"""On-disk cache of convex decompositions, safe against kills and corruption.

An entry is one ``.npz`` file named by a key that hashes the mesh content, the
decomposition parameters and the CoACD version. Writes go to a temporary file
in the same folder and are moved into place with `os.replace`, so a killed
build leaves no entry at all. Each entry stores a SHA-256 of its arrays and its
metadata (the decomposition's coverage and key); an entry that fails to load, to
match its checksum or to name its own key is deleted and reported as a miss, so
the caller rebuilds it.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import trimesh

from manigrasp.errors import ConfigError

CACHE_FORMAT = 3  # 2: convex meshes are their own exact hull; 3: the checksum covers the metadata too (the
# entries of 2 are not read, nor deleted: a version of before that shares the cache keeps its own)

NAME_MAX = 64
"""Longest object name: names become file names in the cache."""
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def check_name(name: object) -> str:
    """`name` if it is a valid object name, else a one-line `ConfigError`.

    An object name is an identifier, as it becomes a file name in the cache: letters,
    digits, ``_``, ``-`` and ``.``, at most `NAME_MAX` characters, not starting with a dot
    or a dash (so no ``..``, no ``/``, no absolute path).
    """
    if not isinstance(name, str) or not name:
        raise ConfigError(f"object name {name!r}: expected a non-empty string")
    if len(name) > NAME_MAX:
        raise ConfigError(f"object name {name[:20]!r}... is {len(name)} characters long; at most {NAME_MAX}")
    if not _NAME.fullmatch(name):
        raise ConfigError(f"object name {name!r}: use only letters, digits, '_', '-' and '.', not starting with "
                          "'.' or '-' (names are file names in the cache)")
    return name


def name_from_path(path: str | Path) -> str:
    """A valid object name from a mesh file's stem (other characters become ``_``, cut to `NAME_MAX`)."""
    return name_from_text(Path(path).stem) or "mesh"


def name_from_text(text: str, length: int = NAME_MAX) -> str:
    """`text` made a valid object name: characters other than letters, digits, ``_``, ``-`` and ``.`` become ``_``,
    leading dots and dashes go, cut to `length`; "" if nothing is left."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", text).lstrip(".-")[:length]


def inside(root: Path, name: str) -> Path:
    """``root / name``, refused (`ConfigError`) unless it resolves to a direct child of `root`.

    Every cache path goes through here, so no object name can write outside the cache.
    """
    root = Path(root).resolve()
    path = (root / name).resolve()
    if path.parent != root or not name or "/" in name or "\\" in name:
        raise ConfigError(f"cache entry {name[:80]!r} would lie outside the cache {root}")
    return path


def mesh_digest(mesh: trimesh.Trimesh) -> str:
    """SHA-256 of a mesh's vertex and face arrays."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(mesh.vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    return h.hexdigest()


def cache_key(mesh: trimesh.Trimesh, params: dict, tool_version: str) -> str:
    """Key of a decomposition: mesh content + parameters + tool version."""
    payload = json.dumps({"mesh": mesh_digest(mesh), "params": params, "tool": tool_version,
                          "format": CACHE_FORMAT}, sort_keys=True)
    return hashlib.sha256(payload.encode()).hexdigest()[:32]


def _digest(arrays: dict[str, np.ndarray], meta: str) -> str:
    """SHA-256 of an entry: its arrays by name, then its metadata's JSON text."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        h.update(name.encode())
        h.update(np.ascontiguousarray(arrays[name]).tobytes())
    h.update(b"meta")
    h.update(meta.encode())
    return h.hexdigest()


class HullCache:
    """Convex hull lists stored under `root`, one file per key."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)

    def path(self, key: str) -> Path:
        """File of the entry `key` (it may not exist)."""
        return inside(self.root, f"{key}.npz")

    def get(self, key: str) -> tuple[list[trimesh.Trimesh], dict] | None:
        """The hulls and metadata stored under `key`, or None (missing or corrupted: deleted)."""
        path = self.path(key)
        if not path.exists():
            return None
        try:
            with np.load(path) as data:
                arrays = {name: data[name] for name in data.files if name not in ("checksum", "meta")}
                checksum = str(data["checksum"])
                text = str(data["meta"])
                meta = json.loads(text)
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, json.JSONDecodeError):
            path.unlink(missing_ok=True)
            return None
        if checksum != _digest(arrays, text) or not isinstance(meta, dict) or meta.get("key", key) != key:
            path.unlink(missing_ok=True)
            return None
        count = len(arrays) // 2
        hulls = [trimesh.Trimesh(arrays[f"v{i}"], arrays[f"f{i}"], process=False) for i in range(count)]
        return hulls, meta

    def put(self, key: str, hulls: list[trimesh.Trimesh], meta: dict) -> Path:
        """Store `hulls` and a JSON-able `meta` under `key` atomically; returns the entry's path."""
        arrays: dict[str, np.ndarray] = {}
        for i, hull in enumerate(hulls):
            arrays[f"v{i}"] = np.asarray(hull.vertices, dtype=np.float64)
            arrays[f"f{i}"] = np.asarray(hull.faces, dtype=np.int64)
        fd, tmp = tempfile.mkstemp(dir=self.root, prefix=f".{key}.", suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                text = json.dumps(meta)
                np.savez(f, checksum=np.array(_digest(arrays, text)), meta=np.array(text), **arrays)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, self.path(key))
        finally:
            Path(tmp).unlink(missing_ok=True)
        return self.path(key)
