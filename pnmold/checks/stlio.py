"""Read exported STL files exactly as the printer gets them: nothing repaired.

STL stores every triangle with its own three corners, so topology has to be rebuilt by
welding corners whose coordinates are bit-for-bit equal (no tolerance). No faces are
removed, flipped or added: a hole or an inverted face in the file stays in the mesh.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from pnmold.errors import ExportError


def load_stl(path: str | Path) -> trimesh.Trimesh:
    """The STL at ``path`` as a trimesh with exactly-equal corners welded."""
    path = Path(path)
    if not path.is_file():
        raise ExportError(str(path), "no such STL file")
    try:
        raw = trimesh.load(path, file_type="stl", process=False, force="mesh")
    except Exception as err:
        raise ExportError(str(path), f"not a readable STL: {err}") from err
    corners = np.asarray(raw.vertices)[np.asarray(raw.faces)].reshape(-1, 3)
    unique, inverse = np.unique(corners, axis=0, return_inverse=True)
    return trimesh.Trimesh(unique, inverse.reshape(-1, 3), process=False, validate=False)
