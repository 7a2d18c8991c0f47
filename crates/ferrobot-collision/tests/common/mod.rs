//! Helpers shared by the collision crate's integration tests: the robots in
//! `../shared`, random configurations and nalgebra-to-parry poses.

#![allow(dead_code)] // each test file uses a part

use std::path::PathBuf;
use std::sync::Arc;

use ferrobot_collision::{AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres};
use ferrobot_model::{LoadOptions, RobotModel, Shape, SrdfSource};
use nalgebra::Isometry3;
use parry3d::math::{Pose, Rot3, Vector};
use parry3d::shape::ConvexPolyhedron;
use rand::{Rng, SeedableRng, rngs::StdRng};

/// A path in the `shared` folder beside the checkout.
pub fn shared(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared")
        .join(rel)
}

/// The MotionBenchMaker Panda (mesh URDF + SRDF), its spherized model and
/// its allowed-collision matrix.
pub fn mbm_panda() -> (Arc<RobotModel>, RobotSpheres, AllowedCollisions) {
    let model = RobotModel::from_urdf_file(
        shared("robots/panda/panda.urdf"),
        &LoadOptions {
            srdf: Some(SrdfSource::File(shared("robots/panda/panda.srdf"))),
            ee_link: Some("panda_hand".into()),
            ..Default::default()
        },
    )
    .unwrap();
    let spheres =
        RobotSpheres::from_spherized_urdf(&model, shared("robots/panda/panda_spherized.urdf"))
            .unwrap();
    let acm = AllowedCollisions::from_model(&model);
    (Arc::new(model), spheres, acm)
}

/// A configuration drawn uniformly within the joint limits.
pub fn random_q(model: &RobotModel, rng: &mut StdRng) -> Vec<f64> {
    model
        .lower_limits()
        .iter()
        .zip(model.upper_limits())
        .map(|(l, h)| rng.random_range(*l..h))
        .collect()
}

/// A parry (f32) pose from an nalgebra isometry.
pub fn to_pose(iso: &Isometry3<f64>) -> Pose {
    let t = iso.translation.vector;
    let q = iso.rotation.coords; // x, y, z, w
    Pose::from_parts(
        Vector::new(t.x as f32, t.y as f32, t.z as f32),
        Rot3::from_xyzw(q[0] as f32, q[1] as f32, q[2] as f32, q[3] as f32),
    )
}

/// The MotionBenchMaker Panda's checker in `scene` (a path below `shared`)
/// with `margin`; then `n` random configurations (seeded) checked one at a
/// time `passes` times over (caches such as the world grid fill during the
/// first pass), each answer asserted equal to the batch kernel's. Returns
/// the checker and the batch answers.
pub fn assert_single_matches_batch(
    scene: &str,
    margin: f64,
    seed: u64,
    n: usize,
    passes: usize,
) -> (CollisionChecker, Vec<bool>) {
    let (model, spheres, acm) = mbm_panda();
    let world = CollisionWorld::from_moveit_scene(shared(scene)).unwrap();
    let mut checker = CollisionChecker::new(model.clone(), spheres, acm, world).unwrap();
    checker.set_margin(margin).unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    let qs: Vec<f64> = (0..n).flat_map(|_| random_q(&model, &mut rng)).collect();
    let batch = checker.in_collision_batch(&qs).unwrap();
    for _ in 0..passes {
        for (i, q) in qs.chunks(model.num_dof()).enumerate() {
            assert_eq!(checker.in_collision(q).unwrap(), batch[i], "{scene} {q:?}");
        }
    }
    (checker, batch)
}

/// Each link's meshes as parry convex polyhedra in the link frame.
pub fn hulls(model: &RobotModel) -> Vec<Vec<(Isometry3<f64>, ConvexPolyhedron)>> {
    model
        .links()
        .iter()
        .map(|link| {
            link.collisions
                .iter()
                .map(|g| match &g.shape {
                    Shape::Mesh(mesh) => {
                        let pts: Vec<Vector> = mesh
                            .vertices()
                            .map(|p| Vector::new(p.x as f32, p.y as f32, p.z as f32))
                            .collect();
                        (g.origin, ConvexPolyhedron::from_convex_hull(&pts).unwrap())
                    }
                    _ => panic!("the MotionBenchMaker Panda has mesh collision geometry"),
                })
                .collect()
        })
        .collect()
}

/// Obstacles scattered around the arm (clear of the base link, which would
/// make every configuration collide): `n` boxes, spheres, cylinders and, with
/// `kinds == 4`, capsules in turn, at random poses with centres in
/// `[-half_span, half_span]²` x `z`, and half-sizes drawn from `size`. The
/// crowded worlds of the grid and certification tests.
pub fn scattered_world(
    seed: u64,
    n: usize,
    half_span: f64,
    z: std::ops::Range<f64>,
    size: std::ops::Range<f64>,
    kinds: usize,
) -> CollisionWorld {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut world = CollisionWorld::new();
    for i in 0..n {
        let p = loop {
            let p: [f64; 3] = [
                rng.random_range(-half_span..half_span),
                rng.random_range(-half_span..half_span),
                rng.random_range(z.clone()),
            ];
            if p[0].hypot(p[1]) > 0.35 {
                break p;
            }
        };
        let h = nalgebra::Vector3::new(
            rng.random_range(size.clone()),
            rng.random_range(size.clone()),
            rng.random_range(size.clone()),
        );
        let rot = nalgebra::UnitQuaternion::from_euler_angles(
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
        );
        let pose = Isometry3::from_parts(nalgebra::Translation3::new(p[0], p[1], p[2]), rot);
        let shape = match i % kinds {
            0 => Shape::Box { half_extents: h },
            1 => Shape::Sphere { radius: h.x },
            2 => Shape::Cylinder {
                radius: h.x,
                half_height: h.y,
            },
            _ => Shape::Capsule {
                radius: h.x,
                half_height: h.y,
            },
        };
        world
            .add(&format!("o{i}"), pose, vec![(shape, Isometry3::identity())])
            .unwrap();
    }
    world
}
