//! The one shape convention checked against parry's own shapes (built
//! directly with parry's API, not through `Shape`) and hand formulas:
//! volumes, local AABBs and point distances of every primitive, a convex
//! hull and a shared mesh.

use std::f64::consts::PI;
use std::sync::Arc;

use ferrobot_geometry::{Hull, Mesh, MeshAs, Shape, TriMesh};
use nalgebra::{Isometry3, Point3, Vector3};
use parry3d::math::Vector as PVec;
use parry3d::shape::{Ball, Capsule, Cuboid, Cylinder, Shape as ParryShape};

fn pv(p: &Point3<f64>) -> PVec {
    PVec::new(p.x as f32, p.y as f32, p.z as f32)
}

/// A deterministic cloud of query points around the origin.
fn points() -> Vec<Point3<f64>> {
    let mut s = 0x2545_f491_4f6c_dd1d_u64;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..400)
        .map(|_| Point3::new(0.3 * rnd(), 0.3 * rnd(), 0.3 * rnd()))
        .collect()
}

/// parry's distance from `p` (shape frame of `shape`) to the shape placed at
/// `pose`; negative inside (parry's projection tells inside from outside).
fn parry_signed(shape: &dyn ParryShape, pose: &Isometry3<f64>, p: &Point3<f64>) -> f64 {
    let local = pose.inverse() * p;
    let proj = shape.project_local_point(pv(&local), false);
    let d = (local
        - Point3::new(
            proj.point.x as f64,
            proj.point.y as f64,
            proj.point.z as f64,
        ))
    .norm();
    if proj.is_inside { -d } else { d }
}

fn check_distances(shape: &Shape, reference: &dyn ParryShape, pose: &Isometry3<f64>) {
    for p in points() {
        let (d, _) = shape.signed_distance(&p);
        let want = parry_signed(reference, pose, &p);
        assert!(
            (d - want).abs() < 2e-6,
            "{} at {p:?}: {d} vs parry {want}",
            shape.kind()
        );
    }
}

fn parry_volume(s: &dyn ParryShape) -> f64 {
    s.mass_properties(1.0).mass() as f64
}

fn aabb_close(shape: &Shape, lo: [f64; 3], hi: [f64; 3]) {
    let (a, b) = shape.local_aabb();
    for k in 0..3 {
        assert!(
            (a[k] - lo[k]).abs() < 1e-6,
            "{}: min {a:?} vs {lo:?}",
            shape.kind()
        );
        assert!(
            (b[k] - hi[k]).abs() < 1e-6,
            "{}: max {b:?} vs {hi:?}",
            shape.kind()
        );
    }
}

fn parry_aabb(s: &dyn ParryShape, pose: &Isometry3<f64>) -> ([f64; 3], [f64; 3]) {
    let b = s.compute_aabb(&ferrobot_geometry::shape::to_pose(pose));
    (
        [b.mins.x as f64, b.mins.y as f64, b.mins.z as f64],
        [b.maxs.x as f64, b.maxs.y as f64, b.maxs.z as f64],
    )
}

#[test]
fn box_matches_parry_and_hand_formulas() {
    let h = Vector3::new(0.1, 0.05, 0.2);
    let s = Shape::cuboid_from_size(h * 2.0);
    assert!(matches!(s, Shape::Box { half_extents } if half_extents == h));
    let reference = Cuboid::new(PVec::new(0.1, 0.05, 0.2));
    let id = Isometry3::identity();
    assert!((s.volume().unwrap() - 8.0 * h.x * h.y * h.z).abs() < 1e-12);
    assert!((s.volume().unwrap() - parry_volume(&reference)).abs() < 1e-6);
    let (lo, hi) = parry_aabb(&reference, &id);
    aabb_close(&s, lo, hi);
    check_distances(&s, &reference, &id);
    // Through to_parry: the same parry shape at the identity.
    let (ps, pose) = s.to_parry(MeshAs::TriMesh).unwrap();
    assert_eq!(pose, id);
    assert!((parry_volume(ps.as_ref()) - parry_volume(&reference)).abs() < 1e-7);
}

#[test]
fn sphere_matches_parry_and_hand_formulas() {
    let s = Shape::Sphere { radius: 0.12 };
    let reference = Ball::new(0.12);
    assert!((s.volume().unwrap() - 4.0 / 3.0 * PI * 0.12f64.powi(3)).abs() < 1e-12);
    assert!((s.volume().unwrap() - parry_volume(&reference)).abs() < 1e-6);
    aabb_close(&s, [-0.12; 3], [0.12; 3]);
    check_distances(&s, &reference, &Isometry3::identity());
}

#[test]
fn cylinder_is_along_z_with_half_height() {
    // Full length 0.3 at the boundary is half height 0.15 inside.
    let s = Shape::cylinder_from_length(0.08, 0.3);
    assert!(matches!(s, Shape::Cylinder { half_height, .. } if half_height == 0.15));
    // parry's cylinder runs along y: rotate it to z.
    let reference = Cylinder::new(0.15, 0.08);
    let y_to_z = Isometry3::rotation(Vector3::x() * PI / 2.0);
    assert!((s.volume().unwrap() - PI * 0.08 * 0.08 * 0.3).abs() < 1e-12);
    assert!((s.volume().unwrap() - parry_volume(&reference)).abs() < 1e-6);
    let (lo, hi) = parry_aabb(&reference, &y_to_z);
    aabb_close(&s, lo, hi);
    aabb_close(&s, [-0.08, -0.08, -0.15], [0.08, 0.08, 0.15]);
    check_distances(&s, &reference, &y_to_z);
    // to_parry places parry's cylinder with that same rotation.
    let (ps, pose) = s.to_parry(MeshAs::TriMesh).unwrap();
    for p in points() {
        let a = parry_signed(ps.as_ref(), &pose, &p);
        let b = s.signed_distance(&p).0;
        assert!((a - b).abs() < 2e-6, "{p:?}: {a} vs {b}");
    }
    // The one-shape form (a compound carrying the rotation) has the same volume.
    let shared = s.to_shared_shape(MeshAs::TriMesh).unwrap();
    assert!((parry_volume(shared.as_ref()) - parry_volume(&reference)).abs() < 1e-6);
}

#[test]
fn capsule_is_along_z_with_half_height() {
    let s = Shape::capsule_from_length(0.05, 0.2);
    let reference = Capsule::new_z(0.1, 0.05);
    let r: f64 = 0.05;
    let want = PI * r * r * 0.2 + 4.0 / 3.0 * PI * r.powi(3);
    assert!((s.volume().unwrap() - want).abs() < 1e-12);
    assert!((s.volume().unwrap() - parry_volume(&reference)).abs() < 1e-6);
    aabb_close(&s, [-0.05, -0.05, -0.15], [0.05, 0.05, 0.15]);
    let (lo, hi) = parry_aabb(&reference, &Isometry3::identity());
    aabb_close(&s, lo, hi);
    check_distances(&s, &reference, &Isometry3::identity());
    // A capsule with an empty cylindrical part is a ball.
    assert!(Shape::capsule_from_length(0.05, 0.0).validate("c").is_ok());
}

/// A cube of half side `h` about the origin, as vertices and outward triangles.
fn cube(h: f64) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
    let m = TriMesh::cuboid(Point3::origin(), Vector3::repeat(h));
    (m.vertices, m.triangles)
}

#[test]
fn hull_and_mesh_of_a_cube_match_the_box() {
    let (v, t) = cube(0.1);
    let boxed = Cuboid::new(PVec::new(0.1, 0.1, 0.1));
    let id = Isometry3::identity();
    let hull = Shape::ConvexHull(Arc::new(Hull::new(v.clone()).unwrap()));
    assert!((hull.volume().unwrap() - 0.008).abs() < 1e-6);
    aabb_close(&hull, [-0.1; 3], [0.1; 3]);
    check_distances(&hull, &boxed, &id);
    let mesh = Shape::Mesh(Arc::new(Mesh::new(v.clone(), t.clone()).unwrap()));
    assert!(mesh.volume().is_none(), "a mesh used as is is a surface");
    assert!(matches!(&mesh, Shape::Mesh(m) if m.is_closed()));
    check_distances(&mesh, &boxed, &id);
    assert!((mesh.bounding_radius() - 0.1 * 3f64.sqrt()).abs() < 1e-12);
    // Non-finite hulls and bad meshes are errors, not shapes.
    assert!(Hull::new(vec![Point3::new(f64::NAN, 0.0, 0.0); 4]).is_err());
    assert!(Mesh::new(v.clone(), vec![[0, 1, 8]]).is_err());
    assert!(Mesh::new(v, vec![]).is_err());
}

#[test]
fn shared_scaled_mesh_is_not_copied() {
    let (v, t) = cube(0.5);
    let data = Arc::new(TriMesh {
        vertices: v,
        triangles: t,
    });
    let a = Mesh::from_shared(data.clone(), Vector3::new(0.2, 0.2, 0.2), None);
    let b = Mesh::from_shared(data.clone(), Vector3::new(0.4, 0.2, 0.2), None);
    assert!(Arc::ptr_eq(a.data(), b.data()));
    let sa = Shape::Mesh(Arc::new(a));
    // Scale 0.2 of a 0.5 cube is the 0.1 cube.
    check_distances(
        &sa,
        &Cuboid::new(PVec::new(0.1, 0.1, 0.1)),
        &Isometry3::identity(),
    );
    aabb_close(
        &Shape::Mesh(Arc::new(b)),
        [-0.2, -0.1, -0.1],
        [0.2, 0.1, 0.1],
    );
    // Cloning the shape shares the mesh (and the BVH built once).
    let c = sa.clone();
    let (Shape::Mesh(x), Shape::Mesh(y)) = (&sa, &c) else {
        unreachable!()
    };
    assert!(Arc::ptr_eq(x, y));
}

#[test]
fn validation_names_full_sizes() {
    let e = Shape::cuboid_from_size(Vector3::new(0.1, -0.1, 0.1))
        .validate("b")
        .unwrap_err()
        .to_string();
    assert!(e.contains("box size must be positive"), "{e}");
    let e = Shape::cylinder_from_length(0.1, f64::NAN)
        .validate("c")
        .unwrap_err()
        .to_string();
    assert!(e.contains("cylinder length"), "{e}");
    assert!(Shape::Sphere { radius: 0.0 }.validate("s").is_err());
    assert!(
        Shape::Sphere { radius: -1.0 }
            .to_parry(MeshAs::TriMesh)
            .is_err()
    );
}
