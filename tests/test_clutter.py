"""Mesh objects and clutter (issue 18): the convex decomposition covers the mesh (surface samples inside the
parts, volumes between the mesh's and its hull's, all computed with numpy/scipy from the mesh itself), bad
mesh files raise ``MeshError`` naming the file, settled piles rest still for 10,000 steps, no returned grasp
puts the Panda hand's collision meshes into the cloud or the bin, and clearing counts match the simulator."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import ferrobot
from ferrobot.errors import InvalidArgumentError, MeshError
from ferrobot.pipeline import clutter
from ferrobot.transforms import pose_to_matrix

scipy_spatial = pytest.importorskip("scipy.spatial")

BENCHES = Path(__file__).resolve().parents[1] / "benches"
sys.path.insert(0, str(BENCHES))
import make_objects  # noqa: E402


def write_obj(path: Path, v, f) -> Path:
    make_objects.write_obj(path, np.asarray(v, dtype=float), np.asarray(f))
    return path


def cube(edge=1.0):
    v, f = make_objects._box([-edge / 2] * 3, [edge / 2] * 3)
    return v, f


def mesh_volume(v, f) -> float:
    t = v[f]
    return float(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6.0)


def surface_samples(v, f, n, rng):
    t = v[f]
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    idx = rng.choice(len(f), size=n, p=area / area.sum())
    r1, r2 = rng.uniform(size=(2, n))
    s = np.sqrt(r1)
    a, b, c = t[idx, 0], t[idx, 1], t[idx, 2]
    return (1 - s)[:, None] * a + (s * (1 - r2))[:, None] * b + (s * r2)[:, None] * c


@pytest.fixture(scope="module")
def objects_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("objects")
    rng = np.random.default_rng(7)
    for i in range(10):
        kind = make_objects.KINDS[i % len(make_objects.KINDS)]
        v, f = kind(rng)
        make_objects.write_obj(d / f"{i:02d}_{kind.__name__}.obj", v, f)
    return d


@pytest.mark.parametrize("kind", ["ring", "bent_tube", "dumbbell", "l_shape", "superellipsoid"])
def test_decomposition_covers_the_mesh(tmp_path, kind):
    rng = np.random.default_rng(3)
    v, f = getattr(make_objects, kind)(rng)
    path = write_obj(tmp_path / f"{kind}.obj", v, f)
    info = ferrobot.load_mesh(path)
    assert np.allclose(info.vertices[info.faces], v[f], atol=1e-6)
    assert info.closed and len(info.vertices) == len(v)
    hulls = [scipy_spatial.ConvexHull(pv) for pv, _ in info.parts]
    # The reported volume is the parts' (scipy's hulls of the parts' vertices).
    # (parry's volumes of the parts differ from scipy's hulls of the same vertices by up to 3.5% here.)
    assert info.volume == pytest.approx(sum(h.volume for h in hulls), rel=0.05)
    # Every surface point of the mesh lies in (or on) a part: 2,000 area-weighted samples.
    pts = surface_samples(v, f, 2000, rng)
    size = np.ptp(v, axis=0).max()
    depth = np.full(len(pts), np.inf)
    for h in hulls:
        depth = np.minimum(depth, (pts @ h.equations[:, :3].T + h.equations[:, 3]).max(axis=1))
    assert (depth <= 1e-5 * max(size, 1.0) + 2e-6).all(), f"{(depth > 2e-6).sum()} samples outside every part"
    # Volumes: at least the mesh's (the union of overlapping parts counts overlaps once at most per part) and
    # at most its convex hull's plus the overlaps; concave shapes keep their concavity.
    mesh_vol = mesh_volume(v, f)
    hull_vol = scipy_spatial.ConvexHull(v).volume
    if kind not in ("l_shape", "dumbbell"):  # those two are overlapping closed parts: mesh_vol over-counts
        assert info.volume >= 0.95 * min(mesh_vol, hull_vol)
    if kind in ("ring", "bent_tube"):
        assert mesh_vol > 0 and info.volume < 0.75 * hull_vol
        assert info.volume < 1.3 * mesh_vol


def test_pybullet_objects_decompose_and_cover(tmp_path):
    pybullet_data = pytest.importorskip("pybullet_data")
    root = Path(pybullet_data.getDataPath())
    # pybullet_data's mug collision mesh has 48 edges shared by more than two triangles: rejected, named.
    with pytest.raises(MeshError, match="mug_col.obj.*non-manifold"):
        ferrobot.load_mesh(clutter.read_object_file(root / "objects" / "mug.urdf").mesh)
    for urdf in (root / "random_urdfs" / "000" / "000.urdf", root / "random_urdfs" / "001" / "001.urdf"):
        of = clutter.read_object_file(urdf)
        info = ferrobot.load_mesh(of.mesh, of.scale)
        assert len(info.parts) >= 1
        pts = surface_samples(info.vertices, info.faces, 1000, np.random.default_rng(0))
        depth = np.full(len(pts), np.inf)
        for pv, _ in info.parts:
            h = scipy_spatial.ConvexHull(pv)
            depth = np.minimum(depth, (pts @ h.equations[:, :3].T + h.equations[:, 3]).max(axis=1))
        assert (depth <= 1e-5).all()


def test_decomposition_is_cached_per_file_and_scale(tmp_path):
    path = write_obj(tmp_path / "ring.obj", *make_objects.ring(np.random.default_rng(1)))
    a = ferrobot.load_mesh(path, 1.0)
    b = ferrobot.load_mesh(path, 1.0)
    c = ferrobot.load_mesh(path, 0.5)
    assert [p[0].tolist() for p in a.parts] == [p[0].tolist() for p in b.parts]
    assert c.volume == pytest.approx(a.volume / 8, rel=0.05)


def test_bad_mesh_files_raise_naming_the_file(tmp_path):
    cases = {}
    (tmp_path / "empty.obj").write_text("")
    cases["empty.obj"] = None
    (tmp_path / "text.stl").write_text("this is not a mesh at all\n" * 20)
    cases["text.stl"] = None
    (tmp_path / "words.obj").write_text("hello world\nv a b c\n")
    cases["words.obj"] = None
    v, f = cube(0.05)
    flat = v.copy()
    flat[:, 2] = 0.0
    write_obj(tmp_path / "flat.obj", flat, f)
    cases["flat.obj"] = "degenerate"
    fin_v = np.vstack([v, [[0.0, -0.1, -0.025]]])
    fin_f = np.vstack([f, [[0, 1, 8]]])
    write_obj(tmp_path / "fin.obj", fin_v, fin_f)
    cases["fin.obj"] = "non-manifold"
    write_obj(tmp_path / "big.obj", *cube(50.0))
    cases["big.obj"] = "huge"
    (tmp_path / "mesh.ply").write_text("ply\n")
    cases["mesh.ply"] = "unsupported"
    cases["missing.obj"] = "cannot read"
    for name, word in cases.items():
        with pytest.raises(MeshError) as e:
            ferrobot.load_mesh(tmp_path / name)
        assert name in str(e.value)
        if word:
            assert word in str(e.value)
        w = ferrobot.World()
        with pytest.raises(MeshError, match=name.replace(".", r"\.")):
            w.add_mesh_file("o", tmp_path / name)
        assert w.object_names == []
    good = write_obj(tmp_path / "cube.obj", *cube(0.05))
    with pytest.raises(InvalidArgumentError, match="scale"):
        ferrobot.load_mesh(good, -1.0)
    with pytest.raises(InvalidArgumentError, match="resolution"):
        ferrobot.load_mesh(good, resolution=2)
    with pytest.raises(InvalidArgumentError, match="mass or density"):
        ferrobot.World().add_mesh_file("o", good, mass=1.0, density=500.0)


def test_mesh_file_objects_mass_density_and_static_trimesh(tmp_path):
    path = write_obj(tmp_path / "cube.obj", *cube(0.1))
    w = ferrobot.World(dt=1 / 240)
    w.add_mesh_file("ground_block", path, [0, 0, 0.05, 1, 0, 0, 0], scale=[4.0, 4.0, 1.0], fixed=True)
    w.add_mesh_file("box", path, [0, 0, 0.2, 1, 0, 0, 0], density=1000.0)
    w.step(240)
    # Rests on the static triangle mesh (top at 0.1 m): centre at 0.15 m.
    assert w.get_object_pose("box")[2, 3] == pytest.approx(0.15, abs=3e-3)


def _table_world(spec):
    w = ferrobot.World(dt=1 / 240)
    w.add_box("table", [1.0, 1.0, spec.table_top], [*spec.center, spec.table_top / 2, 1, 0, 0, 0], fixed=True)
    return w


_BENT_TUBE_2CM = pytest.mark.xfail(
    strict=True,
    reason="known: a 2 cm bent tube (tube ~2 mm thick) still moves: its hull is still rolling after the 4 s "
    "settle (it then sleeps, 12 mm away), its decomposition rocks at ~2 rad/s even without contact recycling",
)


@pytest.mark.parametrize("approximation", ["convex_hull", "convex_decomposition"])
@pytest.mark.parametrize(
    ("kind", "size", "mass"),
    [
        *[
            (k, s, m)
            for k in ("superellipsoid", "dumbbell", "ring")
            for s, m in ((0.02, 0.05), (0.04, 0.1), (0.06, 0.3), (0.1, 1.0))
        ],
        pytest.param("bent_tube", 0.02, 0.05, marks=_BENT_TUBE_2CM),
        *[("bent_tube", s, m) for s, m in ((0.04, 0.1), (0.06, 0.3), (0.1, 1.0))],
    ],
)
def test_single_small_mesh_object_rests_still_on_the_table(kind, size, mass, approximation):
    """One object alone on a table box, sizes 2-10 cm and masses 0.05-1 kg: after settling (4 s) it stays
    within 0.5 mm and 1 degree over 10,000 steps (a rigid body resting on a rigid table has nothing to move
    it). Before the contact-recycling and clustering settings of ``World`` (BENCHMARKS.md, "Small mesh objects
    at rest"), a 4 cm 0.1 kg superellipsoid hull rocked at 1-3 rad/s for ever and decompositions crept by cm."""
    rng = np.random.default_rng(3)
    v, f = getattr(make_objects, kind)(rng)
    v = (v - v.mean(axis=0)) * (size / np.ptp(v, axis=0).max())
    w = ferrobot.World(dt=1 / 240)
    w.add_box("table", [1.0, 1.0, 0.4], [0, 0, 0.2, 1, 0, 0, 0], fixed=True)
    w.add_mesh("o", v, f, [0, 0, 0.4 + size / 2 + 0.005, 1, 0, 0, 0], approximation=approximation, mass=mass)
    w.step(960)
    before = w.get_object_pose("o")
    assert before[2, 3] > 0.4, "fell through the table"
    w.step(10_000)
    after = w.get_object_pose("o")
    assert np.linalg.norm(after[:3, 3] - before[:3, 3]) < 5e-4
    cos = (np.trace(before[:3, :3].T @ after[:3, :3]) - 1) / 2
    assert np.degrees(np.arccos(np.clip(cos, -1, 1))) < 1.0


_MADE_PILE = pytest.mark.xfail(
    strict=True,
    reason="known: in this pile of light rounded meshes a 0.11 kg superellipsoid decomposition keeps rocking (it does "
    "so alone on the table too: contact clustering is off, so this is not its deduplication) and moves ~5 mm; "
    "about half of the made/pybullet_data piles in benches/pile_rest.py have not settled after 10 s "
    "(BENCHMARKS.md, 'Piles at rest')",
)


@pytest.fixture(scope="module")
def heldout_dir(tmp_path_factory):
    import heldout_objects

    d = tmp_path_factory.mktemp("heldout")
    heldout_objects.generate(d, per_kind=3)
    return d


@pytest.mark.parametrize(
    ("object_set", "seed", "count"),
    [
        ("made", 2, 6),
        pytest.param("made", 1, 6, marks=_MADE_PILE),
        ("pybullet", 2, 8),
        ("pybullet", 3, 12),
        ("heldout", 2, 8),
        ("heldout", 3, 8),
    ],
)
def test_settled_clutter_rests_still_for_10000_steps(object_set, seed, count, objects_dir, heldout_dir):
    """Piles of 6-12 objects (this module's rounded meshes, pybullet_data's objects, the held-out set of
    ``benches/heldout_objects.py``), touching and partly stacked: once settled (every object slower than
    2 mm/s and 2 mrad/s over 0.25 s), no object moves more than 2 mm or turns more than 2 degrees over
    10,000 steps (41.7 s): resting rigid bodies have nothing to move them (BENCHMARKS.md, "Piles at rest")."""
    if object_set == "pybullet":
        pytest.importorskip("pybullet_data")
    objects = {"made": objects_dir, "pybullet": None, "heldout": heldout_dir}[object_set]
    spec = clutter.random_clutter(seed, count, objects, center=(0.0, 0.0))
    w = _table_world(spec)
    names = clutter.add_clutter(w, spec)
    assert clutter.settle(w, names, max_seconds=6.0) < 6.0, "the pile did not settle within 10 s"
    before = {n: w.get_object_pose(n) for n in names}
    # On the table (an object's frame may lie off its mesh, e.g. a URDF origin, hence the 10 cm: this catches
    # an object through or off the table).
    assert all(p[2, 3] > spec.table_top - 0.1 for p in before.values())
    w.step(10_000)
    for n in names:
        after = w.get_object_pose(n)
        assert np.linalg.norm(after[:3, 3] - before[n][:3, 3]) < 2e-3, n
        cos = (np.trace(before[n][:3, :3].T @ after[:3, :3]) - 1) / 2
        assert np.degrees(np.arccos(np.clip(cos, -1, 1))) < 2.0, n


def test_instance_masks_match_segmentation_ids(objects_dir):
    spec = clutter.random_clutter(2, 5, objects_dir, bin=True, center=(0.0, 0.0))
    w = _table_world(spec)
    names = clutter.add_clutter(w, spec)
    assert {"bin_wall_x0", "bin_wall_y1"} <= set(w.object_names)
    cam = ferrobot.Camera(w, 160, 120, 130.0, pose=ferrobot.look_at([0.4, 0, 1.0], [0, 0, 0.4]))
    seg = cam.render(rgb=False).segmentation
    masks = clutter.instance_masks(seg, w, names)
    ids = {n: i for i, n in w.segmentation_labels.items()}
    for n, m in masks.items():
        assert m.sum() == (seg == ids[n]).sum()
    assert sum(m.any() for m in masks.values()) >= 3
    assert not np.logical_and(masks[names[0]], masks[names[1]]).any()


def _hand_hulls():
    pybullet_data = pytest.importorskip("pybullet_data")
    import grasp_eval as ge

    d = Path(pybullet_data.getDataPath()) / "franka_panda" / "meshes" / "collision"
    return ge, scipy_spatial.ConvexHull(ge.read_obj(d / "hand.obj")), ge.read_obj(d / "finger.obj")


def test_no_returned_grasp_collides_with_the_cloud_or_the_bin(objects_dir):
    ge, hand_hull, finger_v = _hand_hulls()
    spec = clutter.random_clutter(3, 8, objects_dir, bin=True, center=(0.0, 0.0))
    w = _table_world(spec)
    names = clutter.add_clutter(w, spec)
    cam_pose = np.asarray(ferrobot.look_at([0.35, 0, 1.0], [0, 0, 0.4]))
    cam = ferrobot.Camera(w, 640, 480, 525.0, pose=cam_pose)
    frame = cam.render(rgb=False)
    ids = [i for i, n in w.segmentation_labels.items() if n in names]
    seg = np.where(np.isin(frame.segmentation, ids), frame.segmentation, 0).astype(np.int32)
    depth = np.where(np.isfinite(frame.depth), frame.depth, 0.0)
    down = tuple(cam_pose[:3, :3].T @ np.array([0.0, 0.0, -1.0]))
    gg = ferrobot.grasp.detect_from_rgbd(
        depth, 525.0, 525.0, 319.5, 239.5, scale=1.0, mask=seg, approach_direction=down
    )
    assert len(gg) > 0
    world_gg = gg.transform(ferrobot.grasp.camera_to_world(cam_pose, "opencv"))
    pts_cam, _ = ferrobot.camera.backproject(depth, ferrobot.camera.Intrinsics(640, 480, 525.0, 525.0, 319.5, 239.5))
    cloud = pts_cam @ cam_pose[:3, :3].T + cam_pose[:3, 3]
    # The bin walls, sampled every 2 mm on their surfaces (an independent model of the walls).
    wall_pts = []
    for _, size, pose in spec.bin.walls(spec.table_top):
        s = np.asarray(size)
        g = [np.arange(-si / 2, si / 2 + 1e-9, 0.002) for si in s]
        grid = np.stack(np.meshgrid(*g, indexing="ij"), -1).reshape(-1, 3)
        on_face = (np.abs(np.abs(grid) - s / 2) < 1e-3).any(axis=1)
        wall_pts.append(grid[on_face] + np.asarray(pose[:3]))
    walls = np.vstack(wall_pts)
    hands = ge.hand_poses(world_gg)
    tol = 0.003  # points may sit up to 3 mm inside the meshes (depth quantisation, rounded finger pads)
    for k, hand in enumerate(hands):
        half = world_gg.widths[k] / 2
        parts = [(hand, hand_hull)]
        for sign in (1.0, -1.0):
            f = np.eye(4)
            f[:3, :3] = np.diag([sign, sign, 1.0])
            f[:3, 3] = [0.0, sign * half, 0.0584]
            parts.append((hand @ f, scipy_spatial.ConvexHull(finger_v)))
        for pi, (pose, hull) in enumerate(parts):
            for what, pts in (("cloud", cloud), ("bin", walls)):
                local = (pts - pose[:3, 3]) @ pose[:3, :3]
                inside = (local @ hull.equations[:, :3].T + hull.equations[:, 3]).max(axis=1) < -tol
                assert not inside.any(), (
                    f"grasp {k}: {inside.sum()} {what} points inside the hand (part {pi}, e.g. "
                    f"{np.round(local[inside][:3], 4).tolist()} in its frame)"
                )


def test_clearing_counts_match_the_simulator(objects_dir, tmp_path):
    pytest.importorskip("pybullet_data")
    import clutter as bench  # benches/clutter.py

    _, hand_model = bench.ge.hand_files(tmp_path)
    spec = clutter.random_clutter(4, 3, objects_dir, table_top=bench.TABLE_TOP, center=bench.CENTER)
    rec = bench.run_scene(spec, hand_model, None, {})
    assert rec["objects"] == 3
    assert rec["removed"] + rec["remaining"] + rec["lost"] == 3
    removed = [n for a in rec["attempts"] for n in a.get("removed", [])]
    assert len(removed) == len(set(removed)) == rec["removed"]
    for a in rec["attempts"]:
        assert a["ferrobot"]["success"] == bool(a.get("removed"))
        assert set(a.get("removed", [])) == set(a["ferrobot"].get("lifted", [])) if a["ferrobot"]["success"] else True
    # The objects left are those the final simulator state holds on the table.
    final = rec["final_state"]
    assert len(final) == rec["remaining"]
    w = ferrobot.World(dt=bench.DT)
    w.add_box("table", [2, 2, bench.TABLE_TOP], [0, 0, bench.TABLE_TOP / 2, 1, 0, 0, 0], fixed=True)
    for o in spec.objects:
        if o.name in final:
            w.add_mesh_file(o.name, o.mesh, final[o.name], scale=o.scale, mass=o.mass)
    w.step(240)
    for n in final:
        assert w.get_object_pose(n)[2, 3] > bench.TABLE_TOP - 0.01
    assert not set(final) & set(removed)


def test_demo_clutter_arguments_are_checked(capsys):
    from ferrobot import cli

    assert cli.main(["demo", "--objects", "/no/such/folder"]) == 2
    assert "--clutter" in capsys.readouterr().err
    assert cli.main(["demo", "--clutter", "40"]) == 2
    assert "between 1 and 15" in capsys.readouterr().err
    assert cli.main(["demo", "--clutter", "3", "--objects", "/no/such/folder"]) == 2
    assert "/no/such/folder" in capsys.readouterr().err


def test_clutter_scene_is_a_pick_place_scene(objects_dir):
    from ferrobot.pipeline import build_world, clutter_scene

    spec = clutter_scene(5, 4, objects_dir, bin=True)
    assert spec.target == spec.objects[-1].name and all(o.kind == "mesh" for o in spec.objects)
    world, _robot, _camera = build_world(spec)
    assert {o.name for o in spec.objects} | {"bin_wall_x0"} <= set(world.object_names)
    with pytest.raises(InvalidArgumentError, match="no object 'nope'"):
        clutter_scene(5, 4, objects_dir, target="nope")


def test_planner_world_gets_mesh_file_objects(tmp_path):
    from ferrobot.pipeline.scene import HOME

    model = ferrobot.robots.panda()
    path = write_obj(tmp_path / "cube.obj", *cube(0.04))
    hand = model.fk(HOME, "panda_hand")[:3, 3]
    for dz, expected in ((0.0, True), (0.3, False)):
        w = ferrobot.World(ground=False, gravity=[0, 0, 0])
        w.add_mesh_file("cube", path, [hand[0], hand[1], hand[2] + dz, 1, 0, 0, 0])
        planner = ferrobot.Planner(model)
        planner.update_world(w, base_pose=[0, 0, 0, 1, 0, 0, 0])
        assert planner.in_collision(HOME) is expected


@pytest.mark.parametrize("in_bin", [False, True], ids=["table", "bin"])
def test_clearing_episode_removes_objects_in_the_simulator(objects_dir, tmp_path, in_bin):
    """A whole clearing episode (3 objects): every object counted as removed was, in the simulator, held
    between the fingers at least 8 cm above where it rested, and every object left rests on the table (in the
    bin) when its final state is simulated again in a fresh world with the bin."""
    pytest.importorskip("pybullet_data")
    import clutter as bench  # benches/clutter.py

    _, hand_model = bench.ge.hand_files(tmp_path)
    spec = clutter.random_clutter(5, 3, objects_dir, bin=in_bin, table_top=bench.TABLE_TOP, center=bench.CENTER)
    rec = bench.run_scene(spec, hand_model, None, {})
    assert rec["objects"] == 3 and rec["attempts"]
    assert rec["removed"] >= 1, [a["ferrobot"] for a in rec["attempts"]]
    assert rec["removed"] + len(rec["final_state"]) + rec["lost"] == 3
    for a in rec["attempts"]:
        for n, pose in a.get("removed_poses", {}).items():
            z0 = a["settled"][n][2]
            assert pose[2] - z0 >= bench.ge.MIN_RISE
            # In the hand: the object's origin near the fingers (the fingertips' centre is TCP_OFFSET = 11.2 cm
            # along the hand's z axis; objects are at most 6.5 cm across their middle extent).
            hand = pose_to_matrix(a["hand_final"]["pose"])
            local = hand[:3, :3].T @ (np.asarray(pose[:3]) - hand[:3, 3])
            assert np.linalg.norm(local[:2]) < 0.1 and 0.03 < local[2] < 0.2, local
            assert a["hand_final"]["opening"] > bench.ge.MIN_OPENING
    # The objects left rest on the table, inside the bin's walls if there is one.
    w = ferrobot.World(dt=bench.DT)
    w.add_box("table", [2, 2, bench.TABLE_TOP], [0, 0, bench.TABLE_TOP / 2, 1, 0, 0, 0], fixed=True)
    if spec.bin is not None:
        clutter.add_bin(w, spec.bin, bench.TABLE_TOP)
    removed = {n for a in rec["attempts"] for n in a.get("removed", [])}
    assert not removed & set(rec["final_state"])
    for o in spec.objects:
        if o.name in rec["final_state"]:
            w.add_mesh_file(o.name, o.mesh, rec["final_state"][o.name], scale=o.scale, mass=o.mass)
    w.step(240)
    for n in rec["final_state"]:
        p = w.get_object_pose(n)[:3, 3]
        assert p[2] > bench.TABLE_TOP - 0.01
        if spec.bin is not None:
            assert abs(p[0] - spec.bin.center[0]) < spec.bin.inner[0] / 2
            assert abs(p[1] - spec.bin.center[1]) < spec.bin.inner[1] / 2
