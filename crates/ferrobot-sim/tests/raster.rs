//! The rasterising renderer against independent references: the per-pixel
//! ray caster on the same scenes (the robot's convex hulls, boxes, hulls,
//! curved primitives, near-plane clipping) and an analytic ray-box
//! intersection written here in f64.

use std::sync::Arc;

use ferrobot_camera::look_at;
use ferrobot_sim::camera::{Camera, CameraMount, Intrinsics};
use ferrobot_sim::{Frame, ObjectDesc, RobotOptions, Shape, World, WorldConfig};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.f()
    }
}

fn random_scene(rng: &mut Rng) -> (World, usize) {
    let mut w = World::new(WorldConfig::default()).unwrap();
    let model = Arc::new(ferrobot_model::robots::panda().unwrap());
    let mut opts = RobotOptions::new("panda");
    let q0 = [0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785, 0.04];
    opts.q = Some(q0.iter().map(|q| q + rng.range(-0.4, 0.4)).collect());
    opts.q.as_mut().unwrap()[7] = 0.03;
    let r = w.add_robot(model, &opts).unwrap();
    let pose = |rng: &mut Rng| {
        Isometry3::from_parts(
            Translation3::new(
                rng.range(0.3, 0.7),
                rng.range(-0.3, 0.3),
                rng.range(0.03, 0.3),
            ),
            UnitQuaternion::from_euler_angles(
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
            ),
        )
    };
    let hull: Vec<Point3<f64>> = (0..30)
        .map(|_| {
            Point3::new(
                rng.range(-0.04, 0.04),
                rng.range(-0.03, 0.03),
                rng.range(-0.02, 0.02),
            )
        })
        .collect();
    let shapes = vec![
        Shape::Box {
            half_extents: Vector3::new(0.03, 0.05, 0.02),
        },
        Shape::Box {
            half_extents: Vector3::new(0.2, 0.3, 0.01),
        },
        Shape::Sphere { radius: 0.03 },
        Shape::cylinder_from_length(0.025, 0.1),
        Shape::capsule_from_length(0.02, 0.08),
        Shape::ConvexHull(Arc::new(ferrobot_geometry::Hull::new(hull).unwrap())),
    ];
    for (i, s) in shapes.into_iter().enumerate() {
        let mut d = ObjectDesc::new(format!("o{i}"), s, pose(rng));
        d.is_static = true;
        w.add_object(d).unwrap();
    }
    (w, r)
}

/// Depth equal within 1e-4 relative on pixels both renderers hit;
/// segmentation (and hit / no hit) identical except on silhouette pixels
/// (a pixel whose 8 neighbours in the reference do not all share its
/// label), and those at most 1 % of the image.
fn compare(got: &Frame, want: &Frame, what: &str) -> usize {
    let (w, h) = (want.width, want.height);
    let mut edge_diffs = 0;
    let mut both = 0;
    for v in 0..h {
        for u in 0..w {
            let i = v * w + u;
            let (a, b) = (got.depth[i], want.depth[i]);
            let same_label =
                got.segmentation[i] == want.segmentation[i] && a.is_finite() == b.is_finite();
            if same_label && a.is_finite() {
                both += 1;
                assert!(
                    (a - b).abs() <= 1e-4 * b + 1e-6,
                    "{what}: pixel ({u}, {v}) depth {a} vs reference {b}"
                );
                continue;
            }
            if same_label {
                continue;
            }
            let mut edge = false;
            for dv in -1i64..=1 {
                for du in -1i64..=1 {
                    let (x, y) = (u as i64 + du, v as i64 + dv);
                    if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
                        let j = y as usize * w + x as usize;
                        edge |= want.segmentation[j] != want.segmentation[i]
                            || want.depth[j].is_finite() != b.is_finite();
                    }
                }
            }
            assert!(
                edge,
                "{what}: pixel ({u}, {v}) label {} (depth {a}) vs reference {} (depth {b}) away from any silhouette",
                got.segmentation[i], want.segmentation[i]
            );
            edge_diffs += 1;
        }
    }
    assert!(
        edge_diffs * 100 <= w * h,
        "{what}: {edge_diffs} silhouette pixels differ"
    );
    both
}

#[test]
fn raster_matches_the_ray_caster() {
    let mut rng = Rng(7);
    let mut compared = 0;
    for scene in 0..4 {
        let (world, robot) = random_scene(&mut rng);
        let hand = world
            .robot(robot)
            .unwrap()
            .model()
            .link("panda_hand")
            .unwrap();
        let mut cams = vec![];
        for _ in 0..3 {
            let eye = Point3::new(
                rng.range(0.9, 1.5),
                rng.range(-0.8, 0.8),
                rng.range(0.3, 1.2),
            );
            let target = Point3::new(
                rng.range(0.3, 0.6),
                rng.range(-0.2, 0.2),
                rng.range(0.0, 0.3),
            );
            let pose = look_at(&eye, &target, &Vector3::z()).unwrap();
            cams.push(Camera::new(Intrinsics::from_fov(160, 120, 1.0).unwrap(), pose).unwrap());
        }
        // On the hand, close to the fingers (near-plane clipping of the
        // finger hulls happens here).
        let mut wrist = Camera::new(
            Intrinsics::from_fov(120, 90, 1.4).unwrap(),
            look_at(
                &Point3::new(0.06, 0.0, 0.03),
                &Point3::new(0.0, 0.0, 0.14),
                &Vector3::x(),
            )
            .unwrap(),
        )
        .unwrap();
        wrist.mount = CameraMount::Link { robot, link: hand };
        wrist.near = 0.05;
        cams.push(wrist);
        // Inside the large thin box's thickness range, grazing it.
        let mut low = cams[0].clone();
        low.near = 0.3;
        cams.push(low);
        for (k, cam) in cams.iter().enumerate() {
            for rgb in [false, true] {
                let got = world.render(cam, rgb).unwrap();
                let want = world.render_ray_cast(cam, rgb).unwrap();
                compared += compare(&got, &want, &format!("scene {scene} camera {k}"));
                if rgb {
                    // Shading from the same normals: equal but at silhouettes.
                    let (a, b) = (got.rgb.unwrap(), want.rgb.unwrap());
                    let same = (0..a.len() / 3)
                        .filter(|p| a[3 * p..3 * p + 3] == b[3 * p..3 * p + 3])
                        .count();
                    assert!(
                        same * 100 >= 98 * (a.len() / 3),
                        "scene {scene} camera {k}: {same} equal"
                    );
                }
            }
        }
    }
    assert!(compared > 100_000, "{compared} pixels compared");
}

/// A rotated box in front of the camera against a ray-box slab test
/// written here (f64): same hits, depth within 1e-5 relative.
#[test]
fn box_depth_is_analytic() {
    let mut w = World::new(WorldConfig {
        ground: false,
        ..WorldConfig::default()
    })
    .unwrap();
    let he = Vector3::new(0.1, 0.15, 0.05);
    let bpose = Isometry3::from_parts(
        Translation3::new(0.05, -0.02, 0.0),
        UnitQuaternion::from_euler_angles(0.3, -0.5, 0.9),
    );
    let mut d = ObjectDesc::new("b", Shape::Box { half_extents: he }, bpose);
    d.is_static = true;
    w.add_object(d).unwrap();
    let eye = Point3::new(0.6, 0.4, 0.5);
    let pose = look_at(&eye, &Point3::origin(), &Vector3::z()).unwrap();
    let intr = Intrinsics::from_fov(200, 150, 0.8).unwrap();
    let frame = w.render(&Camera::new(intr, pose).unwrap(), false).unwrap();
    let (mut hits, mut diffs) = (0, 0);
    for v in 0..150 {
        for u in 0..200 {
            let dc = Vector3::new(
                (u as f64 - intr.cx) / intr.fx,
                (v as f64 - intr.cy) / intr.fy,
                1.0,
            );
            // Ray in the box frame.
            let o = bpose.inverse() * eye;
            let dl = bpose.rotation.inverse() * (pose.rotation * dc);
            let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
            for k in 0..3 {
                let (a, b) = ((-he[k] - o[k]) / dl[k], (he[k] - o[k]) / dl[k]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
            let got = frame.depth[v * 200 + u] as f64;
            let inside = t0 <= t1 && t0 > 0.0;
            // 1e-9 of margin: pixels exactly on an edge may go either way.
            let margin = (t1 - t0).abs() < 1e-6;
            if inside != got.is_finite() {
                assert!(margin, "pixel ({u}, {v}): hit {inside} vs rendered {got}");
                diffs += 1;
                continue;
            }
            if inside {
                hits += 1;
                // t is the depth since dc.z == 1.
                assert!(
                    (got - t0).abs() < 1e-5 * t0,
                    "pixel ({u}, {v}): {got} vs {t0}"
                );
            }
        }
    }
    assert!(hits > 3000, "{hits}");
    assert!(diffs < 10, "{diffs}");
}
