"""Mesh objects and clutter: object files, random piles on a table or in a bin, settling, instance masks.

Objects come from a folder of files: single-object URDFs (every collision of every link, meshes with their
``scale`` and primitives, placed by their origins and fixed joints; ``<inertial><mass>`` and
``<contact><lateral_friction>``; :func:`read_object_file`) and bare meshes (OBJ, STL, DAE) not referenced by a
URDF in the same folder. The default folders are PyPI ``pybullet``'s
``pybullet_data/random_urdfs`` (1,000 objects) and ``pybullet_data/objects``.

A :class:`ClutterSpec` is plain data drawn from a seed by :func:`random_clutter`: which files, at which
scale (the file's scale times a factor in ``scale_range``, then shrunk if its middle extent exceeds
``max_middle_extent`` so the hand's 8 cm opening fits), mass (the URDF's or ``density`` times the volume,
times a factor in ``mass_range``, then limited to 0.01-2 kg, the sampler's documented range), friction (the
URDF's ``lateral_friction``, else drawn in ``friction_range``) and drop pose (a random rotation
over a small disc or over the bin, stacked upward so objects land on each other). :func:`add_clutter` adds
a bin (four static walls on the table) and the objects to a :class:`ferrobot.World` as convex
decompositions (``World.add_mesh_file``: the decomposition is computed once per file, scale and
parameters) and steps until every object rests. Files that cannot be used (``ferrobot.errors.MeshError``,
e.g. non-manifold meshes) are left out and listed in ``ClutterSpec.skipped``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import _core
from .._tessellate import ROUND_SEGMENTS, primitive_mesh
from ..errors import InvalidArgumentError, MeshError, ModelError

__all__ = [
    "BinSpec",
    "ClutterObject",
    "ClutterSpec",
    "ObjectFile",
    "add_bin",
    "add_clutter",
    "default_object_folders",
    "find_object_files",
    "instance_masks",
    "random_clutter",
    "read_object_file",
    "settle",
]

MESH_SUFFIXES = (".obj", ".stl", ".dae")
#: Drawn per object: scale factor, mass factor, friction.
SCALE_RANGE = (0.85, 1.15)
MASS_RANGE = (0.7, 1.3)
FRICTION_RANGE = (0.7, 1.0)
#: Largest middle bounding-box extent (m) of a drawn object (the Panda hand opens 8 cm).
MAX_MIDDLE_EXTENT = 0.065
#: Density (kg/m^3) of bare meshes (no URDF mass).
DENSITY = 500.0
COLORS = [
    (0.85, 0.25, 0.20),
    (0.20, 0.55, 0.85),
    (0.95, 0.75, 0.15),
    (0.35, 0.75, 0.35),
    (0.65, 0.35, 0.80),
    (0.95, 0.50, 0.15),
    (0.30, 0.80, 0.80),
    (0.80, 0.40, 0.55),
]


@dataclass
class ObjectFile:
    """What a file says about an object: the mesh file, its scale (3,), mass (kg, None: from the density)
    and friction (None: drawn)."""

    source: str
    mesh: str
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    mass: float | None = None
    friction: float | None = None


@dataclass
class ClutterObject:
    """One object of a clutter scene; ``pose`` [x, y, z, qw, qx, qy, qz] is the drop pose of the mesh frame."""

    name: str
    source: str
    mesh: str
    scale: tuple[float, float, float]
    mass: float
    friction: float
    pose: list[float]
    color: tuple[float, float, float] = (0.6, 0.6, 0.6)


@dataclass
class BinSpec:
    """A bin on the table: inner size (x, y) and wall height and thickness (m), centred at ``center``."""

    center: tuple[float, float]
    inner: tuple[float, float] = (0.30, 0.24)
    height: float = 0.10
    thickness: float = 0.012

    def walls(self, table_top: float) -> list[tuple[str, tuple[float, float, float], list[float]]]:
        """(name, full size, pose) of the four walls."""
        cx, cy = self.center
        ix, iy = self.inner
        t, h = self.thickness, self.height
        z = table_top + h / 2
        return [
            ("bin_wall_x0", (t, iy + 2 * t, h), [cx - ix / 2 - t / 2, cy, z, 1, 0, 0, 0]),
            ("bin_wall_x1", (t, iy + 2 * t, h), [cx + ix / 2 + t / 2, cy, z, 1, 0, 0, 0]),
            ("bin_wall_y0", (ix, t, h), [cx, cy - iy / 2 - t / 2, z, 1, 0, 0, 0]),
            ("bin_wall_y1", (ix, t, h), [cx, cy + iy / 2 + t / 2, z, 1, 0, 0, 0]),
        ]


@dataclass
class ClutterSpec:
    """A clutter scene as plain data (JSON-serialisable via :meth:`to_dict`)."""

    seed: int
    table_top: float
    center: tuple[float, float]
    objects: list[ClutterObject]
    bin: BinSpec | None = None
    skipped: list[tuple[str, str]] = field(default_factory=list)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def default_object_folders() -> list[Path]:
    """``pybullet_data/random_urdfs`` and ``pybullet_data/objects`` (PyPI ``pybullet``)."""
    try:
        import pybullet_data
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise InvalidArgumentError(
            "objects: the default object set needs PyPI 'pybullet' (pip install pybullet); or pass a folder"
        ) from e
    root = Path(pybullet_data.getDataPath())
    return [root / "random_urdfs", root / "objects"]


def find_object_files(folders) -> list[Path]:
    """URDFs under ``folders`` (searched recursively), then bare meshes (OBJ, STL, DAE) in folders without a
    URDF. Raises ``InvalidArgumentError`` naming a folder that does not exist."""
    if isinstance(folders, (str, Path)):
        folders = [folders]
    out: list[Path] = []
    for folder in folders:
        folder = Path(folder)
        if not folder.is_dir():
            raise InvalidArgumentError(f"objects: '{folder}' is not a folder")
        urdfs = sorted(folder.rglob("*.urdf"))
        covered = {u.parent for u in urdfs}
        meshes = sorted(p for p in folder.rglob("*") if p.suffix.lower() in MESH_SUFFIXES and p.parent not in covered)
        out += urdfs + meshes
    return out


def _floats(text: str | None, n: int, what: str, path: Path) -> tuple[float, ...]:
    try:
        v = tuple(float(s) for s in (text or "").split())
    except ValueError:
        v = ()
    if len(v) != n or not all(math.isfinite(x) for x in v):
        raise MeshError(f"object file '{path}': {what} must be {n} finite numbers, got '{text}'")
    return v


def read_object_file(path) -> ObjectFile:
    """An object file as an :class:`ObjectFile`. Bare meshes (OBJ, STL, DAE) are used as they are. A URDF is
    read by the one URDF reader (:meth:`ferrobot.RobotModel.from_urdf_string`, its ``<visual>`` elements
    left out: an object's visuals are not used); every ``<collision>`` of every link counts, placed by its
    ``<origin>`` and the links' fixed joints. One collision mesh at the link's origin is used as it is (its
    file and ``scale``); anything else (primitives, several collisions, offsets, several links) becomes one
    generated OBJ in the object's frame, ``NAME-HASH.obj`` in the object cache (``$FERROBOT_CACHE_DIR/objects``,
    else ``~/.cache/ferrobot/objects``; boxes exact, round primitives inscribed polyhedra within 0.25 % of the
    radius). Mass: the links' ``<inertial><mass>`` summed; friction: the first ``<contact><lateral_friction>``.
    Raises ``MeshError`` naming the file when it cannot be used (unreadable, no collision geometry, movable
    joints)."""
    path = Path(path)
    if path.suffix.lower() in MESH_SUFFIXES:
        return ObjectFile(source=str(path), mesh=str(path))
    if path.suffix.lower() != ".urdf":
        raise MeshError(f"object file '{path}': expected a URDF, OBJ, STL or DAE file")
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as e:
        raise MeshError(f"object file '{path}': cannot read the URDF: {e}") from e
    for link in root.iter("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
    # package:// and relative names resolve against the URDF's folder and its parents (as a URDF file's do);
    # failing that, package://NAME/rest as rest in the URDF's folder (objects often ship that way).
    roots = [path.parent.resolve(), *path.parent.resolve().parents]
    try:
        model = _core.RobotModel.from_urdf_string(ET.tostring(root, encoding="unicode"), package_dirs=roots)
    except ModelError as first:
        renamed = False
        for mesh in root.iter("mesh"):
            name = mesh.get("filename", "")
            if name.startswith("package://") and "/" in name[len("package://") :]:
                mesh.set("filename", str(path.parent.resolve() / name[len("package://") :].split("/", 1)[1]))
                renamed = True
        if not renamed:
            raise MeshError(f"object file '{path}': {first}") from first
        try:
            model = _core.RobotModel.from_urdf_string(ET.tostring(root, encoding="unicode"), package_dirs=roots)
        except ModelError:
            raise MeshError(f"object file '{path}': {first}") from first
    if model.num_dof:
        raise MeshError(
            f"object file '{path}': an object must be one rigid body; movable joints {model.joint_names} "
            "(articulated objects are not supported)"
        )
    q0 = np.zeros(0)
    parts = [(model.fk(q0, link) @ g["origin"], g) for link in model.link_names for g in model.collision_geometry(link)]
    if not parts:
        raise MeshError(f"object file '{path}': no link has collision geometry")
    masses, friction = [], None
    for link in root.iter("link"):
        m = link.find("inertial/mass")
        if m is not None:
            masses.append(_floats(m.get("value"), 1, "mass", path)[0])
        fr = link.find("contact/lateral_friction")
        if fr is not None and friction is None:
            friction = _floats(fr.get("value"), 1, "lateral_friction", path)[0]
    mass = sum(masses) if masses and sum(masses) > 0 else None
    pose, g = parts[0]
    if len(parts) == 1 and g["type"] == "mesh" and np.allclose(pose, np.eye(4), rtol=0.0, atol=1e-12):
        scale = tuple(float(s) for s in g["scale"])
        return ObjectFile(source=str(path), mesh=str(g["path"]), scale=scale, mass=mass, friction=friction)  # type: ignore[arg-type]
    vertices, faces = _object_mesh(parts)
    mesh = _object_mesh_file(vertices, faces, path.stem)
    return ObjectFile(source=str(path), mesh=str(mesh), mass=mass, friction=friction)


def _object_mesh(parts) -> tuple[np.ndarray, np.ndarray]:
    """One triangle mesh (vertices, faces) of ``parts``: (4x4 pose in the object frame, collision geometry
    dict of :meth:`ferrobot.RobotModel.collision_geometry`) pairs; meshes scaled by their ``scale``."""
    vs, fs, n = [], [], 0
    for pose, g in parts:
        if g["type"] == "mesh":
            v = np.asarray(g["vertices"], dtype=np.float64) * np.asarray(g["scale"], dtype=np.float64)
            f = np.asarray(g["faces"], dtype=np.int64)
        elif g["type"] in ("box", "sphere", "cylinder", "capsule"):
            v, f = primitive_mesh(g, ROUND_SEGMENTS)
        else:
            raise MeshError(f"collision geometry '{g['type']}' is not a box, sphere, cylinder, capsule or mesh")
        pose = np.asarray(pose, dtype=np.float64)
        vs.append(v @ pose[:3, :3].T + pose[:3, 3])
        fs.append(f + n)
        n += len(v)
    return np.vstack(vs), np.vstack(fs)


def _cache_dir() -> Path:
    """The object cache: ``_core.cache_dir("objects")`` (the one folder rule, ``$FERROBOT_CACHE_DIR/objects``,
    else ``$XDG_CACHE_HOME/ferrobot/objects``, else ``~/.cache/ferrobot/objects``); with the disk cache off
    (``FERROBOT_CACHE_DIR=off``) a temporary folder of this process."""
    d = _core.cache_dir("objects")
    if d is not None:
        return Path(d)
    global _TEMP_CACHE
    if _TEMP_CACHE is None:
        _TEMP_CACHE = tempfile.mkdtemp(prefix="ferrobot-objects-")
    return Path(_TEMP_CACHE)


_TEMP_CACHE: str | None = None


def _object_mesh_file(vertices: np.ndarray, faces: np.ndarray, stem: str = "object") -> Path:
    """``vertices``/``faces`` written as an OBJ in the object cache (:func:`_cache_dir`), named ``STEM-HASH.obj``
    (``stem``: the source file's, so a later error about the mesh names its object; the hash of the content,
    so the same geometry gives the same file and its decomposition is cached once)."""
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    digest = hashlib.sha256(v.tobytes() + f.tobytes()).hexdigest()[:24]
    folder = _cache_dir()
    out = folder / f"{stem}-{digest}.obj"
    if out.is_file():
        return out
    try:
        folder.mkdir(parents=True, exist_ok=True)
        lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()]
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f.tolist()]
        tmp = folder / f".{digest}.{os.getpid()}.tmp"
        tmp.write_text("\n".join(lines) + "\n")
        tmp.replace(out)
    except OSError as e:
        raise MeshError(f"object cache '{folder}': cannot write the generated mesh: {e}") from e
    return out


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random unit quaternion (w, x, y, z)."""
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    return v @ r.T


def random_clutter(
    seed: int,
    num_objects: int = 8,
    objects=None,
    *,
    bin: bool = False,
    table_top: float = 0.40,
    center: tuple[float, float] = (0.55, 0.0),
    scale_range: tuple[float, float] = SCALE_RANGE,
    mass_range: tuple[float, float] = MASS_RANGE,
    friction_range: tuple[float, float] = FRICTION_RANGE,
    max_middle_extent: float = MAX_MIDDLE_EXTENT,
    density: float = DENSITY,
) -> ClutterSpec:
    """A random pile of ``num_objects`` (1-30) objects drawn from ``objects`` (a folder, a list of folders or
    a list of files; default :func:`default_object_folders`), dropped over a disc of radius growing with the
    count (touching, partly stacked) or over the bin's floor. Deterministic in ``seed``."""
    if not 1 <= int(num_objects) <= 30:
        raise InvalidArgumentError(f"num_objects: expected 1 to 30, got {num_objects}")
    for name, (lo, hi), low in (
        ("scale_range", scale_range, 0.0),
        ("mass_range", mass_range, 0.0),
        ("friction_range", friction_range, -1e-12),
    ):
        if not (math.isfinite(lo) and math.isfinite(hi) and low < lo <= hi):
            raise InvalidArgumentError(f"{name}: expected 0 < low <= high (finite), got {(lo, hi)}")
    if not 0.01 <= max_middle_extent <= 1.0:
        raise InvalidArgumentError(f"max_middle_extent: expected 0.01 to 1 m, got {max_middle_extent}")
    if not 1.0 <= density <= 1e5:
        raise InvalidArgumentError(f"density: expected 1 to 1e5 kg/m^3, got {density}")
    if objects is None:
        files = find_object_files(default_object_folders())
    elif isinstance(objects, (str, Path)):
        files = find_object_files(objects)
    else:
        files = [Path(p) for p in objects]
        if files and all(p.is_dir() for p in files):
            files = find_object_files(files)
    if not files:
        raise InvalidArgumentError(f"objects: no URDF, OBJ, STL or DAE file found in {objects}")
    rng = np.random.default_rng(seed)
    bin_spec = BinSpec(center=center) if bin else None
    chosen: list[ClutterObject] = []
    skipped: list[tuple[str, str]] = []
    order = rng.permutation(len(files))
    k = 0
    top = table_top + 0.02
    n = int(num_objects)
    radius = 0.03 + 0.012 * n
    for idx in order:
        if len(chosen) == n:
            break
        path = files[int(idx)]
        try:
            of = read_object_file(path)
            base = np.asarray(of.scale, dtype=np.float64)
            factor = rng.uniform(*scale_range)
            info = _core.load_mesh(of.mesh, base * factor)
            ext = np.sort(info.vertices.max(axis=0) - info.vertices.min(axis=0))
            if ext[1] > max_middle_extent:
                factor *= max_middle_extent / ext[1]
                info = _core.load_mesh(of.mesh, base * factor)
        except MeshError as e:
            skipped.append((str(path), str(e)))
            continue
        scale = base * factor
        mass = (of.mass if of.mass is not None else density * info.volume) * rng.uniform(*mass_range)
        mass = float(min(max(mass, 0.01), 2.0))
        friction = float(rng.uniform(*friction_range)) if of.friction is None else float(of.friction)
        q = _random_rotation(rng)
        verts = _rotate(q, info.vertices)
        centre = 0.5 * (verts.max(axis=0) + verts.min(axis=0))
        if bin_spec is not None:
            ix, iy = bin_spec.inner
            half = 0.5 * (verts.max(axis=0) - verts.min(axis=0))
            x = center[0] + rng.uniform(-1, 1) * max(ix / 2 - half[0] - 0.01, 0.0)
            y = center[1] + rng.uniform(-1, 1) * max(iy / 2 - half[1] - 0.01, 0.0)
        else:
            r, a = radius * math.sqrt(rng.uniform()), rng.uniform(-math.pi, math.pi)
            x, y = center[0] + r * math.cos(a), center[1] + r * math.sin(a)
        z = top - verts[:, 2].min() + 0.005
        top = z + verts[:, 2].max() + 0.005
        pos = np.array([x, y, z]) - np.array([centre[0], centre[1], 0.0])
        chosen.append(
            ClutterObject(
                name=f"obj_{k}_{Path(of.source).stem}",
                source=of.source,
                mesh=of.mesh,
                scale=tuple(float(s) for s in scale),  # type: ignore[arg-type]
                mass=mass,
                friction=friction,
                pose=[*map(float, pos), *map(float, q)],
                color=COLORS[k % len(COLORS)],
            )
        )
        k += 1
    if len(chosen) < n:
        raise InvalidArgumentError(
            f"objects: only {len(chosen)} of the {n} objects asked for could be loaded "
            f"({len(skipped)} files skipped, first: {skipped[:1]})"
        )
    return ClutterSpec(seed=seed, table_top=table_top, center=center, objects=chosen, bin=bin_spec, skipped=skipped)


def add_bin(world, spec: BinSpec, table_top: float) -> list[str]:
    """Adds the bin's four walls (static boxes) to ``world``; returns their names."""
    names = []
    for name, size, pose in spec.walls(table_top):
        world.add_box(name, size, pose, fixed=True, friction=0.6, color=(0.45, 0.47, 0.52))
        names.append(name)
    return names


def settle(world, names, *, max_seconds: float = 4.0, speed: float = 2e-3) -> float:
    """Steps ``world`` until every object in ``names`` moves slower than ``speed`` (m/s and rad/s) over
    0.25 s, or ``max_seconds`` pass; returns the simulated seconds stepped."""
    dt = world.dt
    chunk = max(1, int(round(0.25 / dt)))
    t = 0.0
    while t < max_seconds:
        world.step(chunk)
        t += chunk * dt
        fast = False
        for n in names:
            lin, ang = world.get_object_velocity(n)
            if np.linalg.norm(lin) > speed or np.linalg.norm(ang) > speed:
                fast = True
                break
        if not fast:
            break
    return t


def add_clutter(world, spec: ClutterSpec, *, drop_steps: int | None = None, settle_seconds: float = 4.0) -> list[str]:
    """Adds ``spec``'s bin and objects to ``world`` (objects as convex decompositions, added one by one
    with ``drop_steps`` steps between drops, default 0.1 s) and settles them (:func:`settle`); returns the
    object names. The table is the caller's (its top at ``spec.table_top``)."""
    if spec.bin is not None:
        add_bin(world, spec.bin, spec.table_top)
    steps = int(round(0.1 / world.dt)) if drop_steps is None else int(drop_steps)
    names = []
    for o in spec.objects:
        world.add_mesh_file(o.name, o.mesh, o.pose, scale=o.scale, mass=o.mass, friction=o.friction, color=o.color)
        names.append(o.name)
        if steps:
            world.step(steps)
    settle(world, names, max_seconds=settle_seconds)
    return names


def instance_masks(segmentation, world, names=None) -> dict[str, np.ndarray]:
    """Per-object boolean masks (H, W) from a segmentation image of ``world``'s camera: one per object in
    ``names`` (default every object with a pixel). Objects out of view get an all-False mask."""
    seg = np.asarray(segmentation)
    labels = {name: i for i, name in world.segmentation_labels.items()}
    if names is None:
        present = set(np.unique(seg).tolist())
        names = [n for n, i in labels.items() if i in present and "/" not in n and n != "ground"]
    out = {}
    for n in names:
        if n not in labels:
            raise InvalidArgumentError(f"names: the world has no object '{n}'")
        out[n] = seg == labels[n]
    return out
