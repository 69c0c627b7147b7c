"""Obstacles around the arm: boxes, spheres, capsules and meshes, and the arm's clearance to them.

A ``Scene`` holds convex obstacles in the base (handle) frame, or in a world frame that
``Scene.in_handle_frame`` maps into the handle frame given the handle's pose. The arm is
represented by its printed-link envelopes (``handarm.collision``), each slab stadium covered
by a capsule; the gap between a capsule and an obstacle is exact (``handarm._scene``). Meshes
are represented by the oriented bounding box of each of their bodies: conservative, and
stated so; give several boxes (or several mesh bodies) for a closer fit.

A scene file (TOML)::

    frame = "handle"            # or "world": obstacles are then placed by a handle pose
    [[box]]
    size = [0.06, 0.06, 0.06]    # m
    position = [0.12, 0.0, 0.0]  # m, the box's centre
    rpy = [0.0, 0.0, 0.3]        # rad, optional
    [[sphere]]
    radius = 0.02
    position = [0.0, 0.15, 0.05]
    [[capsule]]
    radius = 0.01
    ends = [[0.1, -0.1, 0.0], [0.1, 0.1, 0.0]]
    [[mesh]]
    file = "fixture.stl"         # relative to the scene file
    units = "mm"                 # or "m"
    position = [0.0, 0.0, 0.0]   # optional pose of the mesh
    rpy = [0.0, 0.0, 0.0]
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from pathlib import Path

import numpy as np

from handarm._io import not_a_file
from handarm.design import ArmDesign

__all__ = ["Scene", "rpy_matrix", "scene_gaps", "scene_free"]

_FRAMES = ("handle", "world")
_KEYS = {
    "box": {"size", "position", "rpy", "name"},
    "sphere": {"radius", "position", "name"},
    "capsule": {"radius", "ends", "name"},
    "mesh": {"file", "units", "position", "rpy", "name"},
}
#: Largest coordinate or size accepted (m): a scene is around a handheld arm.
_MAX = 100.0


def rpy_matrix(rpy) -> np.ndarray:
    """Rotation matrix Rz(yaw) Ry(pitch) Rx(roll) of roll, pitch, yaw (rad), as in URDF."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _vector(value, n: int, field: str, *, positive: bool = False) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{field}: expected {n} numbers, got {value!r}") from None
    if arr.shape != (n,) or isinstance(value, str):
        raise ValueError(f"{field}: expected {n} numbers, got {value!r}")
    if not np.all(np.isfinite(arr)) or np.any(np.abs(arr) > _MAX):
        raise ValueError(f"{field}: expected finite numbers within +-{_MAX:g} m, got {value!r}")
    if positive and np.any(arr <= 0):
        raise ValueError(f"{field}: expected positive numbers, got {value!r}")
    return arr


def _number(value, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{field}: expected a number, got {value!r}")
    if not (math.isfinite(value) and 0 < value <= _MAX):
        raise ValueError(f"{field}: expected a positive length up to {_MAX:g} m, got {value!r}")
    return float(value)


@dataclasses.dataclass(frozen=True, eq=False)  # holds arrays: identity equality
class Scene:
    """Convex obstacles (SI units), packed as the kernels read them.

    Attributes
    ----------
    obstacles : ndarray, shape (m, 16)
        One row per obstacle (see ``handarm._scene``): kind 0 sphere (centre, radius),
        1 capsule (two ends, radius), 2 box (centre, rotation, half extents).
    names : tuple of str
        A name per obstacle, for messages ("box 1", or the ``name`` given).
    frame : str
        ``"handle"``: coordinates are in the arm's base frame; ``"world"``: use
        ``in_handle_frame`` with the handle's pose first.
    """

    obstacles: np.ndarray
    names: tuple[str, ...]
    frame: str = "handle"

    def __post_init__(self):
        obs = np.asarray(self.obstacles, dtype=float).reshape(-1, 16)
        if self.frame not in _FRAMES:
            raise ValueError(f"frame: expected one of {list(_FRAMES)}, got {self.frame!r}")
        if len(self.names) != len(obs):
            raise ValueError(f"names: expected {len(obs)} names, got {len(self.names)}")
        obs.flags.writeable = False
        object.__setattr__(self, "obstacles", np.ascontiguousarray(obs))

    def __len__(self) -> int:
        return len(self.obstacles)

    @classmethod
    def empty(cls, frame: str = "handle") -> Scene:
        """A scene with no obstacles (add them with ``with_box`` and its siblings)."""
        return cls(np.zeros((0, 16)), (), frame)

    def with_sphere(self, position, radius: float, name: str | None = None) -> Scene:
        """A copy with a sphere added (m)."""
        row = np.zeros(16)
        row[0], row[1:4], row[4] = (
            0,
            _vector(position, 3, "sphere.position"),
            _number(radius, "sphere.radius"),
        )
        return self._add(row, name or f"sphere {len(self) + 1}")

    def with_capsule(self, end0, end1, radius: float, name: str | None = None) -> Scene:
        """A copy with a capsule (segment end0-end1 grown by radius, m) added."""
        row = np.zeros(16)
        row[0] = 1
        row[1:4] = _vector(end0, 3, "capsule.ends[0]")
        row[4:7] = _vector(end1, 3, "capsule.ends[1]")
        row[7] = _number(radius, "capsule.radius")
        return self._add(row, name or f"capsule {len(self) + 1}")

    def with_box(self, size, position, rpy=(0.0, 0.0, 0.0), name: str | None = None) -> Scene:
        """A copy with a box (edge lengths ``size``, centre ``position``, m; ``rpy``, rad)."""
        row = np.zeros(16)
        row[0] = 2
        row[1:4] = _vector(position, 3, "box.position")
        row[4:13] = rpy_matrix(_vector(rpy, 3, "box.rpy")).reshape(-1)
        row[13:16] = 0.5 * _vector(size, 3, "box.size", positive=True)
        return self._add(row, name or f"box {len(self) + 1}")

    def with_mesh(
        self, path, units: str = "m", position=(0, 0, 0), rpy=(0, 0, 0), name=None
    ) -> Scene:
        """A copy with the oriented bounding box of each body of a mesh file (STL, OBJ, ...)."""
        import trimesh

        scale = {"m": 1.0, "mm": 1e-3}.get(units)
        if scale is None:
            raise ValueError(f"mesh.units: expected 'm' or 'mm', got {units!r}")
        path = Path(path)
        if not path.is_file():
            raise ValueError(f"mesh.file: {not_a_file(path)}")
        try:
            mesh = trimesh.load(path, force="mesh")
        except Exception as exc:  # trimesh raises many kinds for unreadable files
            raise ValueError(f"mesh.file: cannot read {str(path)!r}: {exc}") from None
        if len(mesh.vertices) == 0:
            raise ValueError(f"mesh.file: {str(path)!r} holds no geometry")
        pose = np.eye(4)
        pose[:3, :3] = rpy_matrix(_vector(rpy, 3, "mesh.rpy"))
        pose[:3, 3] = _vector(position, 3, "mesh.position")
        mesh.apply_scale(scale)
        mesh.apply_transform(pose)
        scene = self
        bodies = mesh.split(only_watertight=False) or [mesh]
        for k, body in enumerate(bodies):
            obb = body.bounding_box_oriented
            t = np.asarray(obb.primitive.transform)
            ext = np.maximum(np.asarray(obb.primitive.extents, float), 1e-9)
            label = name or path.name
            scene = scene._add_box_matrix(
                ext, t, f"{label} body {k + 1}" if len(bodies) > 1 else label
            )
        return scene

    def _add_box_matrix(self, size, transform, name) -> Scene:
        row = np.zeros(16)
        row[0] = 2
        row[1:4] = transform[:3, 3]
        row[4:13] = transform[:3, :3].reshape(-1)
        row[13:16] = 0.5 * np.asarray(size, float)
        return self._add(row, name)

    def _add(self, row, name: str) -> Scene:
        return Scene(np.vstack([self.obstacles, row[None]]), self.names + (str(name),), self.frame)

    def in_handle_frame(self, handle_pose) -> Scene:
        """The scene in the handle frame, given the handle's pose in the world (4x4)."""
        t = np.asarray(handle_pose, dtype=float)
        if t.shape != (4, 4) or not np.all(np.isfinite(t)):
            raise ValueError("handle_pose: expected a finite 4x4 matrix")
        rot = t[:3, :3]
        if not np.allclose(rot @ rot.T, np.eye(3), atol=1e-9) or np.linalg.det(rot) < 0:
            raise ValueError("handle_pose: its rotation part is not a rotation")
        inv = np.linalg.inv(t)
        obs = self.obstacles.copy()
        for row in obs:
            kind = int(row[0])
            pts = [row[1:4]] if kind != 1 else [row[1:4], row[4:7]]
            moved = [inv[:3, :3] @ p + inv[:3, 3] for p in pts]
            row[1:4] = moved[0]
            if kind == 1:
                row[4:7] = moved[1]
            if kind == 2:
                row[4:13] = (inv[:3, :3] @ row[4:13].reshape(3, 3)).reshape(-1)
        return Scene(obs, self.names, "handle")

    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> Scene:
        """Load a scene file (see the module doc); bad entries name their field."""
        path = Path(path)
        if not path.is_file():
            raise ValueError(f"scene: {not_a_file(path)}")
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise ValueError(f"scene: {path.name} is not valid TOML: {exc}") from None
        return cls.from_dict(data, base=path.parent)

    @classmethod
    def from_dict(cls, data: dict, base: str | os.PathLike[str] = ".") -> Scene:
        """A scene from the contents of a scene file (``base``: where mesh paths start)."""
        unknown = set(data) - set(_KEYS) - {"frame"}
        if unknown:
            raise ValueError(
                f"scene: unknown key {sorted(unknown)[0]!r} (expected frame, {', '.join(_KEYS)})"
            )
        scene = cls.empty(data.get("frame", "handle"))
        for kind, keys in _KEYS.items():
            entries = data.get(kind, [])
            if not isinstance(entries, list) or not all(isinstance(x, dict) for x in entries):
                raise ValueError(f"{kind}: expected a list of tables ([[{kind}]])")
            for i, entry in enumerate(entries):
                field = f"{kind}[{i}]"
                extra = set(entry) - keys
                if extra:
                    raise ValueError(f"{field}: unknown key {sorted(extra)[0]!r}")
                for need in keys - {"rpy", "name", "units", "position"} | (
                    {"position"} if kind in ("box", "sphere") else set()
                ):
                    if need not in entry:
                        raise ValueError(f"{field}.{need}: missing")
                name = str(entry.get("name", f"{kind} {i + 1}"))
                try:
                    if kind == "box":
                        scene = scene.with_box(
                            entry["size"], entry["position"], entry.get("rpy", (0, 0, 0)), name
                        )
                    elif kind == "sphere":
                        scene = scene.with_sphere(entry["position"], entry["radius"], name)
                    elif kind == "capsule":
                        ends = entry["ends"]
                        if not (isinstance(ends, list) and len(ends) == 2):
                            raise ValueError("ends: expected two points")
                        scene = scene.with_capsule(ends[0], ends[1], entry["radius"], name)
                    else:
                        scene = scene.with_mesh(
                            Path(base) / str(entry["file"]),
                            entry.get("units", "m"),
                            entry.get("position", (0, 0, 0)),
                            entry.get("rpy", (0, 0, 0)),
                            entry.get("name"),
                        )
                except ValueError as exc:
                    msg = str(exc)
                    msg = msg.split(".", 1)[1] if msg.startswith(f"{kind}.") else msg
                    raise ValueError(f"{field}.{msg}") from None
        return scene


def _kernel_args(design: ArmDesign):
    from handarm.collision import envelopes, kernel_coefficients

    env = envelopes(design)
    return env.pi, env.pf, env.pieces_count, kernel_coefficients(design)


def _check_scene(scene) -> Scene:
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a handarm.scene.Scene, got {type(scene).__name__}")
    if scene.frame != "handle":
        raise ValueError("scene: its frame is 'world'; place it with scene.in_handle_frame(pose)")
    return scene


def scene_gaps(design: ArmDesign, q, scene: Scene, clearance: float = 0.0) -> np.ndarray:
    """Smallest gap (m) between the printed arm and each obstacle, shape (..., m).

    Negative where the arm's envelope comes within ``clearance`` of the obstacle (the gap is
    measured to the capsules covering the envelope pieces, so it is conservative).
    """
    from handarm import _scene
    from handarm._checks import check_joints

    scene = _check_scene(scene)
    if not (
        isinstance(clearance, (int, float)) and math.isfinite(clearance) and 0 <= clearance <= 1
    ):
        raise ValueError(f"clearance: expected a distance in [0, 1] m, got {clearance!r}")
    q = check_joints(q)
    flat = np.ascontiguousarray(q.reshape(-1, 6))
    out = np.empty((len(flat), len(scene)))
    if len(scene):
        pi, pf, n, _ = _kernel_args(design)
        _scene.gaps_many(flat, design.lengths, pi, pf, n, scene.obstacles, float(clearance), out)
    return out.reshape(q.shape[:-1] + (len(scene),))


def scene_free(design: ArmDesign, q, scene: Scene, clearance: float = 0.0) -> np.ndarray:
    """Whether the printed arm keeps ``clearance`` from every obstacle, shape (...,) bool."""
    return np.all(scene_gaps(design, q, scene, clearance) >= 0.0, axis=-1)
