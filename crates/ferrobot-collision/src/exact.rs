//! Exact link geometry for confirming self-collisions found by spheres.
//!
//! A conservative sphere model covers each link with some protrusion (a few
//! millimetres to centimetres beyond the surface), so two links that come
//! close, such as the Panda's link 5 and link 7 in its `ready` pose, can
//! have overlapping spheres while their geometry is apart. Self-collision
//! is therefore decided in two stages: spheres first (fast, never missing a
//! contact of the covered geometry), then, for the lanes where two robot
//! links' spheres overlap, the links' collision geometry itself with parry:
//! primitives exactly, meshes as their convex hulls (which contain them, so
//! the second stage cannot miss a contact either). World collisions stay
//! sphere-only. Attached objects have no exact shape: spheres decide.

use ferrobot_model::{Link, Shape};
use nalgebra::{Isometry3, Point3, Rotation3, UnitQuaternion};
use parry3d::math::{Pose, Rot3, Vector};
use parry3d::query::{distance, intersection_test};
use parry3d::shape::{Ball, Capsule, ConvexPolyhedron, Cuboid, Cylinder, SharedShape};

use crate::kernel::LaneFrame;
use crate::lanes::Lanes;

/// The collision geometry of one link: parts with their poses in the
/// body's lane frame.
#[derive(Clone)]
pub struct ExactBody {
    parts: Vec<(Isometry3<f64>, SharedShape)>,
}

impl std::fmt::Debug for ExactBody {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ExactBody({} parts)", self.parts.len())
    }
}

fn vector(p: &Point3<f64>) -> Vector {
    Vector::new(p.x as f32, p.y as f32, p.z as f32)
}

fn pose(iso: &Isometry3<f64>) -> Pose {
    let t = iso.translation.vector;
    let q = iso.rotation.coords; // x, y, z, w
    Pose::from_parts(
        Vector::new(t.x as f32, t.y as f32, t.z as f32),
        Rot3::from_xyzw(q[0] as f32, q[1] as f32, q[2] as f32, q[3] as f32),
    )
}

impl ExactBody {
    /// The collision geometry of `link`, posed by `corr` (link frame in the
    /// lane frame). None if the link has no collision geometry or a part
    /// cannot be represented (a degenerate mesh): spheres alone decide.
    pub fn of_link(link: &Link, corr: &Isometry3<f64>) -> Option<Self> {
        let mut parts = Vec::new();
        for g in &link.collisions {
            let at = corr * g.origin;
            let shape = match &g.shape {
                Shape::Box { half_extents: h } => {
                    SharedShape::new(Cuboid::new(Vector::new(h.x as f32, h.y as f32, h.z as f32)))
                }
                Shape::Sphere { radius } => SharedShape::new(Ball::new(*radius as f32)),
                Shape::Cylinder { radius, length } => {
                    // parry's cylinders run along y, URDF's along z.
                    let turn = UnitQuaternion::from_axis_angle(
                        &nalgebra::Vector3::x_axis(),
                        std::f64::consts::FRAC_PI_2,
                    );
                    parts.push((
                        at * turn,
                        SharedShape::new(Cylinder::new((*length / 2.0) as f32, *radius as f32)),
                    ));
                    continue;
                }
                Shape::Capsule { radius, length } => SharedShape::new(Capsule::new(
                    Vector::new(0.0, 0.0, (-length / 2.0) as f32),
                    Vector::new(0.0, 0.0, (length / 2.0) as f32),
                    *radius as f32,
                )),
                Shape::Mesh { scale, mesh, .. } => {
                    let pts: Vec<Vector> = mesh
                        .vertices
                        .iter()
                        .map(|v| vector(&Point3::from(v.coords.component_mul(scale))))
                        .collect();
                    SharedShape::new(ConvexPolyhedron::from_convex_hull(&pts)?)
                }
            };
            parts.push((at, shape));
        }
        (!parts.is_empty()).then_some(Self { parts })
    }
}

/// The pose of lane `i` of a lane frame.
fn lane_pose<L: Lanes>(f: &LaneFrame<L>, i: usize) -> Isometry3<f64> {
    let v = |k: usize| f[k].lane(i) as f64;
    let m = nalgebra::Matrix3::new(v(0), v(1), v(2), v(3), v(4), v(5), v(6), v(7), v(8));
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m));
    Isometry3::from_parts(nalgebra::Translation3::new(v(9), v(10), v(11)), rot)
}

/// Of the lanes in `lanes`, those where the exact geometry of bodies `a`
/// and `b` (lane frames `fa`, `fb`) is closer than `margin` (or touches).
/// Lanes whose geometry parry cannot compare stay set (conservative).
pub fn confirm<L: Lanes>(
    a: &ExactBody,
    b: &ExactBody,
    fa: &LaneFrame<L>,
    fb: &LaneFrame<L>,
    lanes: u32,
    margin: f32,
) -> u32 {
    let mut out = 0;
    let mut bits = lanes;
    while bits != 0 {
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let (pa, pb) = (lane_pose(fa, i), lane_pose(fb, i));
        let hit = a.parts.iter().any(|(ia, sa)| {
            let wa = pose(&(pa * ia));
            b.parts.iter().any(|(ib, sb)| {
                let wb = pose(&(pb * ib));
                if margin > 0.0 {
                    distance(&wa, sa.as_ref(), &wb, sb.as_ref())
                        .map_or(true, |d| d.distance < margin)
                } else {
                    intersection_test(&wa, sa.as_ref(), &wb, sb.as_ref())
                        .map_or(true, |r| r.intersecting)
                }
            })
        });
        if hit {
            out |= 1 << i;
        }
    }
    out
}
