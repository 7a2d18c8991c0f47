//! Conservativeness of the automatic sphere model: every configuration in
//! which the exact link geometry (the Panda's collision meshes as parry
//! triangle meshes) intersects a MotionBenchMaker scene primitive is
//! reported in collision by the sphere checker.

mod common;

use common::{shared, to_pose};

use std::sync::Arc;

use ferrobot_collision::spherize::{SpherizeOptions, spherize_robot};
use ferrobot_collision::{
    AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres, Shape,
};
use ferrobot_model::{LoadOptions, RobotModel};
use nalgebra::{UnitQuaternion, Vector3};
use parry3d::math::{Pose, Vector};
use parry3d::query::intersection_test;
use parry3d::shape::{Ball, Cuboid, Cylinder, SharedShape, TriMesh};
use rand::{Rng, SeedableRng, rngs::StdRng};

#[test]
fn automatic_spheres_never_miss_an_exact_collision_in_any_scene() {
    let model = Arc::new(
        RobotModel::from_urdf_file(shared("robots/panda/panda.urdf"), &LoadOptions::default())
            .unwrap(),
    );
    let options = SpherizeOptions {
        total_budget: Some(59),
        ..SpherizeOptions::default()
    };
    let (links, _) = spherize_robot(&model, &options).unwrap();
    let spheres = RobotSpheres::new(&model, links).unwrap();
    assert!(spheres.count() <= 59, "{}", spheres.count());

    // Exact link geometry: each collision mesh as a triangle mesh in the link frame.
    let hulls: Vec<Vec<TriMesh>> = model
        .links()
        .iter()
        .map(|link| {
            link.collisions
                .iter()
                .filter_map(|g| match &g.shape {
                    Shape::Mesh(mesh) => {
                        let pts: Vec<Vector> = mesh
                            .vertices()
                            .map(|v| {
                                let p = g.origin * v;
                                Vector::new(p.x as f32, p.y as f32, p.z as f32)
                            })
                            .collect();
                        TriMesh::new(pts, mesh.triangles().to_vec()).ok()
                    }
                    _ => None,
                })
                .collect()
        })
        .collect();

    let mut rng = StdRng::seed_from_u64(3);
    let (mut exact_hits, mut checked) = (0, 0);
    for scene in ["table_pick_panda", "bookshelf_small_panda"] {
        for id in 1..=100 {
            let world = CollisionWorld::from_moveit_scene(shared(&format!(
                "bench/mbm/{scene}/scene{id:04}.yaml"
            )))
            .unwrap();
            let parts: Vec<(SharedShape, Pose)> = world
                .objects()
                .iter()
                .flat_map(|o| o.parts.iter().map(move |(s, local)| (s, o.pose * local)))
                .map(|(s, pose)| match s {
                    Shape::Box { half_extents } => (
                        SharedShape::new(Cuboid::new(Vector::new(
                            half_extents.x as f32,
                            half_extents.y as f32,
                            half_extents.z as f32,
                        ))),
                        to_pose(&pose),
                    ),
                    // parry's cylinder runs along y; ours along z.
                    Shape::Cylinder {
                        radius,
                        half_height,
                    } => (
                        SharedShape::new(Cylinder::new(*half_height as f32, *radius as f32)),
                        to_pose(
                            &(pose
                                * UnitQuaternion::from_axis_angle(
                                    &Vector3::x_axis(),
                                    std::f64::consts::FRAC_PI_2,
                                )),
                        ),
                    ),
                    Shape::Sphere { radius } => {
                        (SharedShape::new(Ball::new(*radius as f32)), to_pose(&pose))
                    }
                    other => panic!("unexpected scene shape {}", other.kind()),
                })
                .collect();
            let checker = CollisionChecker::new(
                model.clone(),
                spheres.clone(),
                AllowedCollisions::from_model(&model),
                world,
            )
            .unwrap();
            for _ in 0..25 {
                let q: Vec<f64> = model
                    .lower_limits()
                    .iter()
                    .zip(model.upper_limits())
                    .map(|(l, h)| rng.random_range(*l..h))
                    .collect();
                let poses = model.fk_all(&q).unwrap();
                let exact = hulls.iter().enumerate().any(|(l, hs)| {
                    let lp = to_pose(&poses[l]);
                    hs.iter().any(|h| {
                        parts.iter().any(|(s, p)| {
                            intersection_test(&lp, h, p, s.as_ref())
                                .unwrap()
                                .intersecting
                        })
                    })
                });
                checked += 1;
                if exact {
                    exact_hits += 1;
                    assert!(
                        checker.in_collision(&q).unwrap(),
                        "{scene} scene {id}: exact geometry collides, spheres say free at {q:?}"
                    );
                }
            }
        }
    }
    assert!(exact_hits > 200, "{exact_hits} of {checked}");
}
