//! The robot's sphere model and the world compiled to flat `f32` data for
//! the lane kernel.
//!
//! Every movable joint is rotated so that it turns about (or slides along)
//! its local z axis: a joint with axis `a` becomes `A Rz(q) A^T` with
//! `A z = a`, and the trailing `A^T` is folded into what hangs below. Fixed
//! joints are folded away entirely. The lane forward kinematics then costs
//! one constant transform and a z rotation per movable joint.

use std::sync::Arc;

use ferrobot_model::{JointCoupling, JointKind, RobotModel};
use nalgebra::{Isometry3, Point3, Rotation3, UnitQuaternion, Vector3};
use wide::f32x8;

use crate::lanes::Lanes;

use crate::sphere::Sphere;
use crate::world::CollisionWorld;
use ferrobot_geometry::Shape;

/// A rigid transform as a row-major rotation and a translation, `f32`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame32 {
    /// Rotation, row-major.
    pub r: [f32; 9],
    /// Translation.
    pub t: [f32; 3],
}

impl Frame32 {
    /// From an `f64` isometry.
    pub fn from_iso(iso: &Isometry3<f64>) -> Self {
        let m = iso.rotation.to_rotation_matrix();
        let mut r = [0.0f32; 9];
        for i in 0..3 {
            for j in 0..3 {
                r[i * 3 + j] = m[(i, j)] as f32;
            }
        }
        let v = iso.translation.vector;
        Self {
            r,
            t: [v.x as f32, v.y as f32, v.z as f32],
        }
    }

    /// The rotation as a signed permutation, if it is one to within `1e-7`
    /// per entry (joint frames turned by multiples of 90 degrees, as in most
    /// URDFs): for each column `j`, the row `src[j]` of its one non-zero
    /// entry and that entry's sign.
    pub fn signed_permutation(&self) -> Option<([usize; 3], [f32; 3])> {
        let mut src = [0usize; 3];
        let mut sign = [0.0f32; 3];
        for j in 0..3 {
            let mut found = None;
            for l in 0..3 {
                let v = self.r[l * 3 + j];
                if (v.abs() - 1.0).abs() <= 1e-7 {
                    if found.is_some() {
                        return None;
                    }
                    found = Some((l, v.signum()));
                } else if v.abs() > 1e-7 {
                    return None;
                }
            }
            (src[j], sign[j]) = found?;
        }
        // A permutation: every row used once.
        if src[0] == src[1] || src[1] == src[2] || src[0] == src[2] {
            return None;
        }
        Some((src, sign))
    }
}

/// One movable joint of the lane forward kinematics.
#[derive(Debug, Clone)]
pub struct Step {
    /// Frame the joint hangs from (0 is the base frame).
    pub parent: usize,
    /// Constant transform from the parent frame to the joint frame.
    pub k: Frame32,
    /// Slides along z (true) or turns about z (false).
    pub prismatic: bool,
    /// Driving DOF; the joint coordinate is `gain * q[dof] + offset`.
    pub dof: usize,
    /// Mimic gain (1 for an independent joint).
    pub gain: f32,
    /// Mimic offset (0 for an independent joint).
    pub offset: f32,
    /// `k`'s rotation as a signed permutation (see
    /// [`Frame32::signed_permutation`]), which the forward kinematics
    /// applies by picking columns instead of a matrix product.
    pub perm: Option<([usize; 3], [f32; 3])>,
}

/// Eight steps side by side (lane `i` for the block's step `i`; padding
/// lanes read DOF 0 with gain 0, offset 0 and signs 1).
#[derive(Debug, Clone)]
pub struct StepBlock {
    /// Driving DOF per step.
    pub dofs: [usize; 8],
    /// Mimic gains.
    pub gain: f32x8,
    /// Mimic offsets.
    pub offset: f32x8,
    /// The signs a step's permutation gives columns 0 and 1 (1 for a step
    /// without one).
    pub signs: [f32x8; 2],
}

impl StepBlock {
    /// The block of up to eight `steps`.
    fn new(steps: &[Step]) -> Self {
        let lanes = |f: &dyn Fn(&Step) -> f32, pad: f32| {
            f32x8::new(std::array::from_fn(|i| steps.get(i).map_or(pad, f)))
        };
        Self {
            dofs: std::array::from_fn(|i| steps.get(i).map_or(0, |s| s.dof)),
            gain: lanes(&|s| s.gain, 0.0),
            offset: lanes(&|s| s.offset, 0.0),
            signs: [0, 1].map(|j| lanes(&|s| s.perm.map_or(1.0, |(_, sign)| sign[j]), 1.0)),
        }
    }
}

/// A body of the sphere model: a link (or an attached object) whose spheres
/// move with one lane frame.
#[derive(Debug, Clone)]
pub struct Body {
    /// Model link the body moves with.
    pub link: usize,
    /// Attached object name, or None for a robot link.
    pub attached: Option<String>,
    /// Frame index the spheres are expressed in.
    pub frame: usize,
    /// First sphere in the flat sphere arrays.
    pub first: usize,
    /// Number of spheres.
    pub count: usize,
    /// Bounding sphere centre (frame coordinates) and radius.
    pub bound: ([f32; 3], f32),
    /// First pack of eight spheres in [`CompiledRobot::packs`].
    pub first_pack: usize,
    /// Number of packs.
    pub pack_count: usize,
    /// A sphere (base frame: centre, radius) that holds the bounding sphere
    /// in every configuration (infinite radius below a prismatic joint):
    /// obstacles outside it can never touch the body.
    pub sweep: ([f32; 3], f32),
}

/// Eight spheres of one body side by side (structure of arrays), for the
/// single-configuration kernel whose SIMD lanes hold spheres. A body whose
/// sphere count is not a multiple of eight repeats its last sphere, so every
/// lane is a real sphere and no mask is needed.
#[derive(Debug, Clone, Copy)]
pub struct SpherePack {
    /// Centres x, y, z in the body's frame.
    pub c: [f32x8; 3],
    /// Radii.
    pub r: f32x8,
}

/// The robot's spheres, compiled.
#[derive(Debug, Clone)]
pub struct CompiledRobot {
    /// Number of DOFs of the model.
    pub num_dof: usize,
    /// Movable joints in tree order; step `i` makes frame `i + 1`.
    pub steps: Vec<Step>,
    /// The steps in blocks of eight, lane `i` of block `b` describing step
    /// `8 b + i`, for the one-configuration kinematics
    /// ([`crate::kernel::forward_cols`]). Derived from `steps` by
    /// [`CompiledRobot::new`].
    pub step_blocks: Vec<StepBlock>,
    /// Bodies with spheres.
    pub bodies: Vec<Body>,
    /// Sphere centres in their body's frame.
    pub centers: Vec<[f32; 3]>,
    /// Sphere radii.
    pub radii: Vec<f32>,
    /// The same spheres in packs of eight per body.
    pub packs: Vec<SpherePack>,
    /// Exact geometry of each body (robot links with collision geometry),
    /// for confirming self-collisions.
    pub exact: Vec<Option<crate::exact::ExactBody>>,
    /// Body pairs checked for self-collision (body indices).
    pub pairs: Vec<(usize, usize)>,
    /// Sum of the two bounding radii of each pair (aligned with `pairs`).
    pub pair_reach: Vec<f32>,
    /// Joint-space clearance maps of the pairs (aligned with `pairs`, or
    /// empty): set by the checker, used by the single-configuration kernel.
    pub pair_maps: Vec<Option<std::sync::Arc<crate::pair_map::PairMap>>>,
    /// The colliding cells of `pair_maps`, one map per pair of DOFs
    /// ([`crate::pair_map::collide_maps`]): set with them by the checker,
    /// used by the single-configuration kernel.
    pub collide_maps: Vec<crate::pair_map::PairMap>,
    /// For each model link: its lane frame and the constant transform from
    /// that frame to the link frame (`link = frame * correction`).
    pub link_frames: Vec<(usize, Isometry3<f64>)>,
    /// For each lane frame: a point fixed in the base frame, a distance the
    /// frame's origin never exceeds from it, and the frame's rotation when
    /// that is `K Rz(q)` with constant `K` (frames turning about a joint
    /// fixed to the base), for [`Body::sweep`].
    frame_reach: Vec<(Vector3<f64>, f64, Option<Rotation3<f64>>)>,
}

/// A rotation taking z to `axis`.
fn z_to(axis: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(&Vector3::z(), axis).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    })
}

impl CompiledRobot {
    /// The exact geometry of every link of `model` (see [`crate::exact`]),
    /// posed in its lane frame, for [`CompiledRobot::new`]. Building it
    /// takes convex hulls: do it once per model.
    pub fn exact_bodies(model: &RobotModel) -> Vec<Option<crate::exact::ExactBody>> {
        let kin = Self::new(model, &[], &[], &[], |_, _| false);
        model
            .links()
            .iter()
            .zip(&kin.link_frames)
            .map(|(link, (_, corr))| crate::exact::ExactBody::of_link(link, corr))
            .collect()
    }

    /// Compiles the kinematics of `model` and attaches `spheres` (per link,
    /// link frame) plus extra bodies `(link, name, spheres in link frame)`.
    /// `exact` holds the exact geometry per link from
    /// [`CompiledRobot::exact_bodies`] (empty: spheres alone decide
    /// self-collision). `pairs` lists the body pairs to check for
    /// self-collision, as a predicate over (link or attached name)
    /// identities.
    pub fn new(
        model: &RobotModel,
        link_spheres: &[Vec<Sphere>],
        attached: &[(usize, String, Vec<Sphere>)],
        exact: &[Option<crate::exact::ExactBody>],
        check_pair: impl Fn(&Body, &Body) -> bool,
    ) -> Self {
        let n = model.links().len();
        let mut link_frames: Vec<(usize, Isometry3<f64>)> = vec![(0, Isometry3::identity()); n];
        // Base frame 0 is the identity; the root link sits at root_in_base.
        let root_in_base = {
            let base_path = model.path_to(model.base_link());
            base_path
                .iter()
                .fold(Isometry3::identity(), |acc, &j| {
                    acc * model.joints()[j].origin
                })
                .inverse()
        };
        link_frames[0] = (0, root_in_base);
        let mut steps = Vec::new();
        // Frame 0 is the base: fixed, identity rotation.
        let mut frame_reach = vec![(Vector3::zeros(), 0.0, Some(Rotation3::identity()))];
        for joint in model.joints() {
            let (pframe, pcorr) = link_frames[joint.parent];
            let through = pcorr * joint.origin;
            match (joint.kind, joint.coupling) {
                (JointKind::Fixed, _) | (_, JointCoupling::Fixed) => {
                    link_frames[joint.child] = (pframe, through)
                }
                (kind, coupling) => {
                    let a = z_to(&joint.axis);
                    let k = through * a;
                    // Where the new frame's origin can go: a frame of
                    // constant rotation places it exactly; one turning about
                    // z fixes the z part of the offset; otherwise the
                    // offset's length adds to the parent's reach.
                    let t = k.translation.vector;
                    let (anchor, reach, rot) = &frame_reach[pframe];
                    let (anchor, reach) = match rot {
                        Some(r) if *reach == 0.0 && pframe == 0 => (anchor + r * t, 0.0),
                        Some(r) if *reach == 0.0 => {
                            (anchor + r * Vector3::new(0.0, 0.0, t.z), t.x.hypot(t.y))
                        }
                        _ => (*anchor, reach + t.norm()),
                    };
                    let reach = if kind == JointKind::Prismatic {
                        f64::INFINITY
                    } else {
                        reach
                    };
                    let turn = (pframe == 0).then(|| k.rotation.to_rotation_matrix());
                    frame_reach.push((anchor, reach, turn));
                    let (dof, gain, offset) = match coupling {
                        JointCoupling::Dof(d) => (d, 1.0, 0.0),
                        JointCoupling::Mimic {
                            dof,
                            multiplier,
                            offset,
                        } => (dof, multiplier, offset),
                        JointCoupling::Fixed => unreachable!(),
                    };
                    let k = Frame32::from_iso(&k);
                    steps.push(Step {
                        parent: pframe,
                        perm: k.signed_permutation(),
                        k,
                        prismatic: kind == JointKind::Prismatic,
                        dof,
                        gain: gain as f32,
                        offset: offset as f32,
                    });
                    link_frames[joint.child] = (
                        steps.len(),
                        Isometry3::from_parts(Default::default(), a.inverse()),
                    );
                }
            }
        }
        let step_blocks = steps.chunks(8).map(StepBlock::new).collect();
        let mut robot = Self {
            num_dof: model.num_dof(),
            steps,
            step_blocks,
            bodies: Vec::new(),
            centers: Vec::new(),
            radii: Vec::new(),
            packs: Vec::new(),
            exact: Vec::new(),
            pairs: Vec::new(),
            pair_reach: Vec::new(),
            pair_maps: Vec::new(),
            collide_maps: Vec::new(),
            link_frames,
            frame_reach,
        };
        for (l, spheres) in link_spheres.iter().enumerate() {
            robot.push_body(l, None, spheres, exact.get(l).cloned().flatten());
        }
        for (l, name, spheres) in attached {
            robot.push_body(*l, Some(name.clone()), spheres, None);
        }
        for a in 0..robot.bodies.len() {
            for b in a + 1..robot.bodies.len() {
                if check_pair(&robot.bodies[a], &robot.bodies[b]) {
                    robot.pairs.push((a, b));
                    robot
                        .pair_reach
                        .push(robot.bodies[a].bound.1 + robot.bodies[b].bound.1);
                }
            }
        }
        robot
    }

    fn push_body(
        &mut self,
        link: usize,
        attached: Option<String>,
        spheres: &[Sphere],
        exact: Option<crate::exact::ExactBody>,
    ) {
        if spheres.is_empty() {
            return;
        }
        let (frame, corr) = self.link_frames[link];
        let in_frame: Vec<Sphere> = spheres
            .iter()
            .map(|s| Sphere::new(corr * s.center, s.radius))
            .collect();
        let b = Sphere::bounding(&in_frame).expect("non-empty");
        let first = self.centers.len();
        for s in &in_frame {
            self.centers
                .push([s.center.x as f32, s.center.y as f32, s.center.z as f32]);
            self.radii.push(s.radius as f32);
        }
        self.exact.push(exact);
        let first_pack = self.packs.len();
        let count = in_frame.len();
        for chunk in 0..count.div_ceil(8) {
            // Lanes past the last sphere repeat it.
            let k = |lane: usize| first + (chunk * 8 + lane).min(count - 1);
            let coord = |axis: usize| f32x8::from_fn(|lane| self.centers[k(lane)][axis]);
            let pack = SpherePack {
                c: [coord(0), coord(1), coord(2)],
                r: f32x8::from_fn(|lane| self.radii[k(lane)]),
            };
            self.packs.push(pack);
        }
        let sweep = {
            let (anchor, reach, rot) = &self.frame_reach[frame];
            let c = b.center.coords;
            let (anchor, reach) = match rot {
                Some(r) if *reach == 0.0 && frame == 0 => (anchor + r * c, 0.0),
                Some(r) if *reach == 0.0 => {
                    (anchor + r * Vector3::new(0.0, 0.0, c.z), c.x.hypot(c.y))
                }
                _ => (*anchor, reach + c.norm()),
            };
            // Padded for the f32 lane arithmetic.
            let radius = (reach + b.radius) * (1.0 + 1e-5) + 1e-4;
            (
                [anchor.x as f32, anchor.y as f32, anchor.z as f32],
                radius as f32,
            )
        };
        self.bodies.push(Body {
            sweep,
            link,
            attached,
            frame,
            first,
            count,
            bound: (
                [b.center.x as f32, b.center.y as f32, b.center.z as f32],
                b.radius as f32,
            ),
            first_pack,
            pack_count: count.div_ceil(8),
        });
    }

    /// Number of lane frames (base frame included).
    pub fn num_frames(&self) -> usize {
        self.steps.len() + 1
    }
}

/// A primitive obstacle in the world frame, in `f32`.
#[derive(Debug, Clone, Copy)]
pub enum Prim {
    /// Sphere: centre, radius.
    Sphere {
        /// Centre.
        c: [f32; 3],
        /// Radius.
        r: f32,
    },
    /// Box: centre, rotation rows of the world-to-box rotation, half extents.
    Box {
        /// Centre.
        c: [f32; 3],
        /// World-to-box rotation, row-major.
        rt: [f32; 9],
        /// Half extents.
        h: [f32; 3],
    },
    /// Cylinder: centre, unit axis, radius, half length.
    Cylinder {
        /// Centre.
        c: [f32; 3],
        /// Unit axis.
        a: [f32; 3],
        /// Radius.
        r: f32,
        /// Half length.
        h: f32,
    },
    /// Capsule: centre, unit axis, radius, half segment length.
    Capsule {
        /// Centre.
        c: [f32; 3],
        /// Unit axis.
        a: [f32; 3],
        /// Radius.
        r: f32,
        /// Half segment length.
        h: f32,
    },
    /// Mesh or point cloud: exact `f64` query per configuration.
    Complex,
}

/// One obstacle of the compiled world.
#[derive(Debug, Clone)]
pub struct Obstacle {
    /// The primitive.
    pub prim: Prim,
    /// Bounding sphere centre (world).
    pub bound_c: [f32; 3],
    /// Bounding sphere radius.
    pub bound_r: f32,
    /// World object index.
    pub object: usize,
    /// For complex shapes: the shape and its world pose.
    pub complex: Option<(Shape, Isometry3<f64>)>,
}

/// The world compiled for the kernel.
#[derive(Debug, Clone, Default)]
pub struct CompiledWorld {
    /// Obstacles (one per object part).
    pub obstacles: Vec<Obstacle>,
    /// World revision it was compiled from.
    pub revision: u64,
    /// Object names by index.
    pub names: Arc<Vec<String>>,
    /// Obstacle bounding spheres eight at a time: x, y, z, radius (padding
    /// entries lie far away with radius 0).
    pub bound_soa: Vec<[wide::f32x8; 4]>,
}

fn p32(p: &Point3<f64>) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

impl CompiledWorld {
    /// Compiles every part of every object of `world`.
    pub fn new(world: &CollisionWorld) -> Self {
        Self::with_mask(world, |_| true)
    }

    /// Compiles every part of the objects of `world` for which
    /// `enabled(object index)` holds (the others are ignored by every
    /// query; obstacle `object` indices still index `world.objects()`).
    pub fn with_mask(world: &CollisionWorld, enabled: impl Fn(usize) -> bool) -> Self {
        let mut obstacles = Vec::new();
        for (i, obj) in world.objects().iter().enumerate() {
            if !enabled(i) {
                continue;
            }
            for (shape, local) in &obj.parts {
                let pose = obj.pose * local;
                let c = p32(&Point3::from(pose.translation.vector));
                let axis = pose.rotation * Vector3::z();
                let a = [axis.x as f32, axis.y as f32, axis.z as f32];
                let prim = match shape {
                    Shape::Sphere { radius } => Prim::Sphere {
                        c,
                        r: *radius as f32,
                    },
                    Shape::Box { half_extents } => {
                        let m: Rotation3<f64> = pose.rotation.inverse().to_rotation_matrix();
                        let mut rt = [0.0f32; 9];
                        for r in 0..3 {
                            for col in 0..3 {
                                rt[r * 3 + col] = m[(r, col)] as f32;
                            }
                        }
                        Prim::Box {
                            c,
                            rt,
                            h: [
                                half_extents.x as f32,
                                half_extents.y as f32,
                                half_extents.z as f32,
                            ],
                        }
                    }
                    Shape::Cylinder {
                        radius,
                        half_height,
                    } => Prim::Cylinder {
                        c,
                        a,
                        r: *radius as f32,
                        h: *half_height as f32,
                    },
                    Shape::Capsule {
                        radius,
                        half_height,
                    } => Prim::Capsule {
                        c,
                        a,
                        r: *radius as f32,
                        h: *half_height as f32,
                    },
                    Shape::ConvexHull(_)
                    | Shape::Mesh(_)
                    | Shape::ConvexDecomposition(_)
                    | Shape::PointCloud(_) => Prim::Complex,
                };
                let complex = matches!(prim, Prim::Complex).then(|| (shape.clone(), pose));
                obstacles.push(Obstacle {
                    prim,
                    bound_c: c,
                    // Rounded up so the f32 bound never excludes a true hit.
                    bound_r: (shape.bounding_radius() * (1.0 + 1e-6) + 1e-6) as f32,
                    object: i,
                    complex,
                });
            }
        }
        let bound_soa = obstacles
            .chunks(8)
            .map(|c| {
                let get = |f: &dyn Fn(&Obstacle) -> f32, pad: f32| {
                    wide::f32x8::new(std::array::from_fn(|i| c.get(i).map_or(pad, f)))
                };
                [
                    get(&|o| o.bound_c[0], 1e18),
                    get(&|o| o.bound_c[1], 1e18),
                    get(&|o| o.bound_c[2], 1e18),
                    get(&|o| o.bound_r, 0.0),
                ]
            })
            .collect();
        Self {
            obstacles,
            bound_soa,
            revision: world.revision(),
            names: Arc::new(world.objects().iter().map(|o| o.name.clone()).collect()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{Scratch, apply, forward};

    /// Every body's bounding sphere stays inside its sweep sphere, for
    /// configurations within and far beyond the joint limits.
    #[test]
    fn sweep_holds_the_bounding_sphere() {
        let model = ferrobot_model::robots::panda().unwrap();
        let spheres: Vec<Vec<Sphere>> = (0..model.links().len())
            .map(|l| {
                vec![Sphere::new(
                    Point3::new(0.05, -0.02, 0.1 + 0.01 * l as f64),
                    0.04,
                )]
            })
            .collect();
        let robot = CompiledRobot::new(&model, &spheres, &[], &[], |_, _| false);
        let mut scratch = Scratch::<f32>::new(&robot);
        let (mut finite, mut worst) = (0, f32::INFINITY);
        for k in 0..2000 {
            // Prismatic joints may run anywhere: bodies below them sweep
            // an infinite sphere.
            let q: Vec<f32> = (0..model.num_dof())
                .map(|d| ((k * 7 + d * 13) % 97) as f32 / 97.0 * 12.0 - 6.0)
                .collect();
            forward(&robot, &q, &mut scratch);
            for b in &robot.bodies {
                let c = apply(&scratch.frames()[b.frame], &b.bound.0);
                let (s, r) = b.sweep;
                let d =
                    ((c[0] - s[0]).powi(2) + (c[1] - s[1]).powi(2) + (c[2] - s[2]).powi(2)).sqrt();
                assert!(
                    d + b.bound.1 <= r,
                    "body of link {}: {d} + {} > {r}",
                    b.link,
                    b.bound.1
                );
                if r.is_finite() {
                    finite += 1;
                    worst = worst.min(r - d - b.bound.1);
                }
            }
        }
        assert!(finite > 10_000, "{finite}");
        // Tight somewhere: the slack of the closest approach is small.
        assert!(worst < 0.05, "{worst}");
    }
}
