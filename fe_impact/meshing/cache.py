"""What the tooth-pair builders reuse: mesh keys and the files stored under them.

A mesh is stored with a summary (``tca.json``, ``two_pair.json``) that holds its
key (:func:`mesh_key`); a build with ``reuse`` returns the stored files if the
key matches (:func:`cached_summary`) and meshes again otherwise. A stage's
sector solids are reused too: :mod:`fe_impact.meshing.solids`.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict
from pathlib import Path

from fe_impact.gears.pairanalysis import PairSpec

#: Version of what a mesh of a given gear set and spec holds; part of every mesh key,
#: so a change of how the solids or the mesh are made invalidates the caches.
#: 2: corner meshes' loft stations keep half a fine step from the fine window
#: (pairgeometry._stations_through); 4: the face-gear flank continued smoothly beyond
#: the face's ends (_FaceFlank.angle; 3 continued it along its tangent without end);
#: 5: the keys hash every field of the spec (before, ``contact = "flank"`` and
#: ``refinement = 1`` were left out) and two-pair meshes carry the format too.
MESH_FORMAT = 5


def mesh_key(gearset, spec: PairSpec, **kind) -> str:
    """Deterministic hash (16 hex digits) of the gear set, every field of ``spec``,
    :data:`MESH_FORMAT` and ``kind`` (e.g. ``two_pair=1``: another builder's meshes)."""
    payload = json.dumps(
        {"gearset": asdict(gearset), "spec": asdict(spec), "format": MESH_FORMAT, **kind},
        sort_keys=True, default=repr,
    )
    return hashlib.sha256(payload.encode()).hexdigest()[:16]


def cached_summary(files: tuple[Path, ...], summary: Path, key: str) -> dict | None:
    """The stored ``summary`` (JSON) if every one of ``files`` exists and the summary
    was written for ``key`` with its mesh's statistics; else None."""
    if not all(p.is_file() for p in (*files, summary)):
        return None
    try:
        data = json.loads(summary.read_text())
    except (OSError, json.JSONDecodeError):
        return None
    return data if data.get("key") == key and data.get("mesh") else None
