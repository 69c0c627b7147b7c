"""Ground truth for the printed-link collision model: the carved meshes themselves.

Independent of ``handarm.collision``: each carved link mesh (``handarm.carve``) is placed by
the URDF frames (``handarm.joint_frames``), python-fcl tests every non-adjacent pair, and a
reported contact is confirmed by the volume of the manifold3d intersection of the two placed
solids. Used by the tests and by ``benchmarks/bench_collision_model.py``.
"""

from __future__ import annotations

import itertools

import fcl
import numpy as np

import handarm
from handarm.carve.properties import to_trimesh

#: The 15 non-adjacent link pairs (adjacent pairs are governed by the joint limits).
PAIRS = tuple((a, b) for a, b in itertools.combinations(range(7), 2) if b - a > 1)


class MeshArm:
    """The carved links of a design as fcl objects, placeable at any configuration."""

    def __init__(self, design, carving=None, resolution_deg: float = 1.0):
        self.design = design
        self.carving = carving or handarm.carve.carve(design, resolution_deg)
        self.solids = [link.solid for link in self.carving.links]  # mm, link frames
        self.models = []
        self.meshes = []
        for solid in self.solids:
            mesh = to_trimesh(solid)
            self.meshes.append(mesh)
            model = fcl.BVHModel()
            model.beginModel(len(mesh.vertices), len(mesh.faces))
            model.addSubModel(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64))
            model.endModel()
            self.models.append(model)

    def transforms(self, q) -> np.ndarray:
        """(7, 4, 4) placement of each link frame in the base frame, millimetres."""
        frames = handarm.joint_frames(self.design, np.asarray(q, float))
        out = np.empty((7, 4, 4))
        out[0] = np.eye(4)
        out[1:] = frames[:6]
        out[:, :3, 3] *= 1000.0
        return out

    def contacts(self, q, pairs=PAIRS) -> list[tuple[int, int]]:
        """Pairs whose meshes touch or overlap (fcl) at configuration q."""
        tf = self.transforms(q)
        objs = [
            fcl.CollisionObject(m, fcl.Transform(t[:3, :3], t[:3, 3]))
            for m, t in zip(self.models, tf, strict=True)
        ]
        request = fcl.CollisionRequest()
        hits = []
        for a, b in pairs:
            result = fcl.CollisionResult()
            if fcl.collide(objs[a], objs[b], request, result):
                hits.append((a, b))
        return hits

    def overlap_volume(self, q, a: int, b: int) -> float:
        """Volume (mm^3) of the intersection of links a and b placed at q (manifold3d)."""
        tf = self.transforms(q)
        sa = self.solids[a].transform(tf[a][:3, :4].tolist())
        sb = self.solids[b].transform(tf[b][:3, :4].tolist())
        return float((sa ^ sb).volume())

    def colliding(self, q, min_volume: float = 1.0) -> list[tuple[int, int, float]]:
        """Pairs that overlap by more than ``min_volume`` mm^3, with their volumes."""
        out = []
        for a, b in self.contacts(q):
            v = self.overlap_volume(q, a, b)
            if v > min_volume:
                out.append((a, b, v))
        return out
