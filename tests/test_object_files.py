"""Object files for clutter scenes (issue 18, deliverable 1): a URDF object is every ``<collision>`` of its
links, primitives included, placed by its ``<origin>`` and fixed joints; checked against hand formulas
(primitive volumes and surfaces), scipy's rotations for URDF ``rpy`` and the simulator (a generated box rests
on a face). A closed convex mesh is its own decomposition (one part)."""

from __future__ import annotations

import math
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

import ferrobot
from ferrobot._tessellate import primitive_mesh
from ferrobot.errors import InvalidArgumentError, MeshError
from ferrobot.pipeline import clutter, viewer

scipy_rotation = pytest.importorskip("scipy.spatial.transform").Rotation


def _closed_and_outward(v: np.ndarray, f: np.ndarray) -> float:
    """Asserts every edge is shared by two triangles; returns the signed enclosed volume."""
    edges: dict[tuple[int, int], int] = {}
    for t in f.tolist():
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            key = (min(a, b), max(a, b))
            edges[key] = edges.get(key, 0) + 1
    assert set(edges.values()) == {2}
    t = v[f]
    return float(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6.0)


def _urdf(path: Path, links: str, joints: str = "") -> Path:
    path.write_text(f'<?xml version="1.0"?>\n<robot name="obj">\n{links}\n{joints}\n</robot>\n')
    return path


def _link(name: str, collisions: str, mass: float | None = 0.2, friction: float | None = None) -> str:
    inertial = f'<inertial><mass value="{mass}"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'
    contact = f'<contact><lateral_friction value="{friction}"/></contact>' if friction is not None else ""
    return f'<link name="{name}">{contact}{inertial if mass is not None else ""}{collisions}</link>'


def _collision(geometry: str, xyz=(0, 0, 0), rpy=(0, 0, 0)) -> str:
    return (
        f'<collision><origin xyz="{" ".join(map(str, xyz))}" rpy="{" ".join(map(str, rpy))}"/>'
        f"<geometry>{geometry}</geometry></collision>"
    )


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("FERROBOT_CACHE_DIR", str(tmp_path / "cache"))


@pytest.mark.parametrize(
    ("geometry", "exact"),
    [
        ({"type": "box", "size": [0.05, 0.03, 0.02]}, 0.05 * 0.03 * 0.02),
        ({"type": "sphere", "radius": 0.04}, 4 / 3 * math.pi * 0.04**3),
        ({"type": "cylinder", "radius": 0.02, "length": 0.1}, math.pi * 0.02**2 * 0.1),
        ({"type": "capsule", "radius": 0.015, "length": 0.06}, math.pi * 0.015**2 * 0.06 + 4 / 3 * math.pi * 0.015**3),
    ],
)
@pytest.mark.parametrize("segments", [64, viewer.VIEW_SEGMENTS])
def test_primitive_meshes_match_hand_formulas(geometry, exact, segments):
    """The one tessellation (object files at 64 segments, the viewer at 20, whose back-face culling needs
    outward faces): closed, outward, vertices on the surface, faces within ~2 (1 - cos(pi / segments)) of it."""
    v, f = primitive_mesh(geometry, segments)
    volume = _closed_and_outward(v, f)
    if geometry["type"] == "box":
        assert volume == pytest.approx(exact, rel=1e-12)
        assert np.allclose(np.abs(v), np.asarray(geometry["size"]) / 2)
        return
    # Round shapes: vertices on the true surface, so the polyhedron lies inside the shape; every face plane
    # is at least r_in from the shape's core (its centre, axis segment), so the polyhedron holds the same
    # shape of radius r_in: exact(r_in) <= volume < exact(r), and r_in is within 2.05 (1 - cos(pi / segments))
    # of r (a quad of the latitude-longitude grid spans 2 pi / segments both ways; its triangles' circumradius
    # is about half its diagonal, so their planes sink r (pi / segments)^2 ~ 2 r (1 - cos(pi / segments)) in;
    # 0.25 % at 64 segments).
    r = geometry["radius"]
    h = geometry.get("length", 0.0) / 2
    t = v[f]
    normal = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    if geometry["type"] == "sphere":
        surface = np.abs(np.linalg.norm(v, axis=1) - r)
        core = np.zeros((len(f), 3))
    elif geometry["type"] == "cylinder":
        rho = np.linalg.norm(v[:, :2], axis=1)
        surface = np.minimum(np.abs(rho - r) + np.maximum(np.abs(v[:, 2]) - h, 0), np.abs(np.abs(v[:, 2]) - h))
        core = np.c_[np.zeros((len(f), 2)), np.clip(t[:, :, 2].mean(axis=1), -h, h)]
    else:
        axis = np.clip(v[:, 2], -h, h)
        surface = np.abs(np.linalg.norm(v - np.c_[0 * axis, 0 * axis, axis], axis=1) - r)
        # The face's nearest point of the axis segment: the end its normal points away from, or any.
        core = np.c_[np.zeros((len(f), 2)), np.where(normal[:, 2] > 0, h, np.where(normal[:, 2] < 0, -h, 0.0))]
    assert surface.max() < 1e-12
    plane_distance = np.einsum("ij,ij->i", t[:, 0] - core, normal)
    if geometry["type"] == "cylinder":
        caps = np.abs(normal[:, 2]) > 0.999
        assert np.allclose(plane_distance[caps], 0.0, atol=1e-12)  # the caps are exact (core on the cap)
        plane_distance = plane_distance[~caps]
    r_in = plane_distance.min()
    assert r * (1 - 2.05 * (1 - math.cos(math.pi / segments))) < r_in < r
    scaled = dict(geometry, radius=r_in)
    exact_in = {
        "sphere": 4 / 3 * math.pi * r_in**3,
        "cylinder": math.pi * r_in**2 * 2 * h,
        "capsule": math.pi * r_in**2 * 2 * h + 4 / 3 * math.pi * r_in**3,
    }[scaled["type"]]
    assert exact_in <= volume < exact


def test_urdf_primitive_with_origin_is_placed_by_rpy_and_xyz(tmp_path):
    xyz, rpy, size = (0.01, -0.02, 0.03), (0.3, -0.2, 1.1), (0.04, 0.025, 0.015)
    geometry = f'<box size="{" ".join(map(str, size))}"/>'
    path = _urdf(tmp_path / "brick.urdf", _link("brick", _collision(geometry, xyz, rpy), mass=0.07, friction=0.8))
    of = clutter.read_object_file(path)
    assert (of.mass, of.friction, of.source) == (0.07, 0.8, str(path))
    info = ferrobot.load_mesh(of.mesh)
    # URDF rpy: fixed-axis roll, pitch, yaw (extrinsic x-y-z).
    rot = scipy_rotation.from_euler("xyz", rpy).as_matrix()
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * np.asarray(size) / 2
    expected = corners @ rot.T + np.asarray(xyz)
    got = np.asarray(info.vertices)
    assert len(got) == 8
    assert np.abs(got[:, None, :] - expected[None]).max(axis=2).min(axis=1).max() < 1e-7  # f32 vertices
    assert info.volume == pytest.approx(np.prod(size), rel=1e-5)
    assert len(info.parts) == 1, "a box is its own decomposition"


def test_multi_link_urdf_keeps_every_collision(tmp_path):
    """Two links joined by a fixed joint, three collisions (a box and a cylinder on one link, a sphere on the
    other): all three shells are in the object, where the joint and origins put them."""
    links = _link(
        "a",
        _collision('<box size="0.04 0.04 0.02"/>')
        + _collision('<cylinder radius="0.01" length="0.06"/>', xyz=(0.0, 0.0, 0.04)),
        mass=0.1,
    ) + _link("b", _collision('<sphere radius="0.015"/>'), mass=0.05)
    joint = '<joint name="j" type="fixed"><parent link="a"/><child link="b"/><origin xyz="0.08 0 0"/></joint>'
    of = clutter.read_object_file(_urdf(tmp_path / "three.urdf", links, joint))
    assert of.mass == pytest.approx(0.15)
    info = ferrobot.load_mesh(of.mesh)
    v = np.asarray(info.vertices)
    lo, hi = v.min(axis=0), v.max(axis=0)
    assert lo == pytest.approx([-0.02, -0.02, -0.015], abs=1e-7)
    assert hi == pytest.approx([0.08 + 0.015, 0.02, 0.07], abs=1e-7)
    pieces = 0.04 * 0.04 * 0.02 + math.pi * 0.01**2 * 0.06 + 4 / 3 * math.pi * 0.015**3
    # The cylinder stands on the box (z 0.01-0.07): the shells touch, the volumes add.
    solid = _closed_and_outward(np.asarray(info.vertices, dtype=np.float64), np.asarray(info.faces))
    assert 0.99 * pieces < solid < 1.0001 * pieces
    assert info.volume >= 0.999 * solid  # the convex parts cover the solid
    assert len(info.parts) >= 2


def test_single_mesh_at_its_origin_is_used_as_it_is(tmp_path):
    """The common case (pybullet_data's random_urdfs): the mesh file itself with the URDF's scale, so its
    decomposition is cached per file; a visual mesh that does not exist does not matter."""
    v, f = primitive_mesh({"type": "box", "size": [1.0, 2.0, 3.0]})
    mesh = tmp_path / "m.obj"
    mesh.write_text(
        "".join(f"v {a} {b} {c}\n" for a, b, c in v) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f)
    )
    visual = '<visual><geometry><mesh filename="missing_visual.obj"/></geometry></visual>'
    link = _link("o", visual + _collision('<mesh filename="m.obj" scale="0.01 0.02 0.03"/>'), mass=0.3)
    of = clutter.read_object_file(_urdf(tmp_path / "o.urdf", link))
    assert Path(of.mesh) == mesh.resolve()
    assert of.scale == (0.01, 0.02, 0.03)


def test_generated_files_are_cached_by_content(tmp_path):
    link = _link("o", _collision('<cylinder radius="0.02" length="0.05"/>', xyz=(0, 0, 0.01)))
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    a = clutter.read_object_file(_urdf(tmp_path / "one" / "can.urdf", link))
    b = clutter.read_object_file(_urdf(tmp_path / "two" / "can.urdf", link))
    assert a.mesh == b.mesh
    assert Path(a.mesh).parent == tmp_path / "cache" / "objects"
    assert Path(a.mesh).name.startswith("can-")


def test_a_generated_mesh_too_big_is_named_after_its_object(tmp_path):
    """The generated OBJ carries the source's name, so the size check's error names the object."""
    link = _link("o", _collision('<box size="1e9 1 1"/>', xyz=(0, 0, 0.5)))
    of = clutter.read_object_file(_urdf(tmp_path / "slab.urdf", link))
    with pytest.raises(MeshError, match=r"slab-[0-9a-f]+\.obj.*huge"):
        ferrobot.load_mesh(of.mesh)


@pytest.mark.parametrize(
    ("links", "joints", "match"),
    [
        (_link("o", ""), "", "no link has collision geometry"),
        (
            _link("a", _collision('<box size="0.1 0.1 0.1"/>')) + _link("b", _collision('<sphere radius="0.02"/>')),
            '<joint name="hinge" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>',
            "movable joints",
        ),
        (_link("o", _collision('<mesh filename="nowhere.obj"/>')), "", "nowhere.obj"),
        (_link("o", _collision('<box size="0.1 0.1 0.1"/>', xyz=("nan", 0, 0))), "", "not finite"),
        (_link("o", _collision('<box size="-0.1 0.1 0.1"/>')), "", "box size must be positive"),
        (_link("o", _collision('<cylinder radius="0.02"/>')), "", "length"),
    ],
)
def test_unusable_urdf_objects_raise_naming_the_file(tmp_path, links, joints, match):
    path = _urdf(tmp_path / "bad.urdf", links, joints)
    with pytest.raises(MeshError, match=match) as e:
        clutter.read_object_file(path)
    assert str(path) in str(e.value)


def test_pybullet_data_primitive_objects_load():
    pybullet_data = pytest.importorskip("pybullet_data")
    root = Path(pybullet_data.getDataPath())
    for rel, extent in (
        ("cube_small.urdf", [0.05, 0.05, 0.05]),
        ("lego/lego.urdf", [0.032, 0.032, 0.023]),
        ("jenga/jenga.urdf", [0.15, 0.05, 0.03]),
        ("domino/domino.urdf", [0.00635, 0.0254, 0.0508]),
    ):
        of = clutter.read_object_file(root / rel)
        info = ferrobot.load_mesh(of.mesh, of.scale)
        v = np.asarray(info.vertices)
        assert np.sort(v.max(axis=0) - v.min(axis=0)) == pytest.approx(sorted(extent), abs=1e-6), rel
        assert len(info.parts) == 1, rel


def test_a_generated_box_rests_on_a_face_in_a_clutter_scene(tmp_path):
    """A folder of primitive-only URDFs makes a clutter scene; after settling, each box rests on a face: its
    lowest vertex is at the table, and its height above the table is one of its edge lengths."""
    folder = tmp_path / "objects"
    folder.mkdir()
    sizes = [(0.05, 0.03, 0.02), (0.04, 0.04, 0.025), (0.06, 0.02, 0.02)]
    for i, s in enumerate(sizes):
        _urdf(folder / f"box{i}.urdf", _link("o", _collision(f'<box size="{s[0]} {s[1]} {s[2]}"/>'), mass=0.1))
    spec = clutter.random_clutter(4, 3, folder, center=(0.0, 0.0), scale_range=(1.0, 1.0))
    w = ferrobot.World(dt=1 / 240)
    w.add_box("table", [1.0, 1.0, spec.table_top], [0, 0, spec.table_top / 2, 1, 0, 0, 0], fixed=True)
    # Spread them out so each lands alone.
    for k, o in enumerate(spec.objects):
        o.pose[:2] = [-0.2 + 0.2 * k, 0.0]
    names = clutter.add_clutter(w, spec)
    for name, o in zip(names, spec.objects, strict=True):
        pose = w.get_object_pose(name)
        v = np.asarray(ferrobot.load_mesh(o.mesh, o.scale).vertices)
        world_v = v @ pose[:3, :3].T + pose[:3, 3]
        low, high = world_v[:, 2].min(), world_v[:, 2].max()
        size = sorted(float(x) for x in np.ptp(v, axis=0))
        assert low == pytest.approx(spec.table_top, abs=2e-3), name
        assert min(abs((high - low) - s) for s in size) < 2e-3, (name, high - low, size)


def test_folder_of_mixed_objects_is_copied_and_loads(tmp_path):
    """pybullet_data's top-level objects with primitive collisions and meshes side by side: all load."""
    pybullet_data = pytest.importorskip("pybullet_data")
    root = Path(pybullet_data.getDataPath())
    folder = tmp_path / "mixed"
    folder.mkdir()
    for rel in ("cube_small.urdf", "duck_vhacd.urdf", "duck_vhacd.obj", "lego/lego.urdf", "lego/lego.obj"):
        shutil.copy(root / rel, folder / Path(rel).name)
    spec = clutter.random_clutter(0, 3, folder)
    assert spec.skipped == []
    assert len(spec.objects) == 3


def test_package_uris_resolve_in_ros_and_flat_layouts(tmp_path):
    """``package://NAME/meshes/m.obj`` from ``NAME/urdf/o.urdf`` (a ROS package), and ``package://ANY/m.obj``
    with the mesh beside the URDF (how object files are often shipped)."""
    v, f = primitive_mesh({"type": "box", "size": [1.0, 1.0, 1.0]})
    obj = "\n".join([f"v {a} {b} {c}" for a, b, c in v] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]) + "\n"
    ros = tmp_path / "mypkg"
    (ros / "urdf").mkdir(parents=True)
    (ros / "meshes").mkdir()
    (ros / "meshes" / "m.obj").write_text(obj)
    link = _link("o", _collision('<mesh filename="package://mypkg/meshes/m.obj" scale="0.03 0.03 0.03"/>'))
    of = clutter.read_object_file(_urdf(ros / "urdf" / "o.urdf", link))
    assert Path(of.mesh) == (ros / "meshes" / "m.obj").resolve()
    flat = tmp_path / "flat"
    flat.mkdir()
    (flat / "m.obj").write_text(obj)
    link = _link("o", _collision('<mesh filename="package://elsewhere/m.obj" scale="0.03 0.03 0.03"/>'))
    of = clutter.read_object_file(_urdf(flat / "o.urdf", link))
    assert Path(of.mesh) == (flat / "m.obj").resolve()


@pytest.mark.parametrize(
    ("env", "expected"),
    [
        ({"FERROBOT_CACHE_DIR": "/c", "XDG_CACHE_HOME": "/x", "HOME": "/h"}, "/c/{kind}"),
        ({"FERROBOT_CACHE_DIR": "", "XDG_CACHE_HOME": "/x", "HOME": "/h"}, "/x/ferrobot/{kind}"),
        ({"XDG_CACHE_HOME": "", "HOME": "/h"}, "/h/.cache/ferrobot/{kind}"),
        ({"FERROBOT_CACHE_DIR": "off", "XDG_CACHE_HOME": "/x", "HOME": "/h"}, None),
        ({"HOME": ""}, None),
    ],
)
def test_one_cache_folder_rule_for_spheres_and_objects(monkeypatch, tmp_path, env, expected):
    """The documented rule (README): $FERROBOT_CACHE_DIR, else $XDG_CACHE_HOME/ferrobot, else
    ~/.cache/ferrobot, a subfolder per kind, empty variables unset, ``off`` no disk cache; the object cache
    falls back to a temporary folder of the process."""
    for k in ("FERROBOT_CACHE_DIR", "XDG_CACHE_HOME", "HOME"):
        monkeypatch.delenv(k, raising=False)
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    for kind in ("spheres", "objects"):
        got = ferrobot._core.cache_dir(kind)
        assert (None if got is None else str(got)) == (None if expected is None else expected.format(kind=kind))
    folder = clutter._cache_dir()
    if expected is None:
        assert folder.is_dir() and Path(tempfile.gettempdir()) in folder.parents
    else:
        assert folder == Path(expected.format(kind="objects"))
    with pytest.raises(InvalidArgumentError, match="kind"):
        ferrobot._core.cache_dir("../objects")


@pytest.mark.parametrize("segments", [0, 2, 6, -4])
def test_tessellation_refuses_segments_that_are_not_a_multiple_of_four(segments):
    with pytest.raises(InvalidArgumentError, match="segments"):
        primitive_mesh({"type": "sphere", "radius": 0.01}, segments)
    with pytest.raises(InvalidArgumentError, match="'cone'"):
        primitive_mesh({"type": "cone", "radius": 0.01})
