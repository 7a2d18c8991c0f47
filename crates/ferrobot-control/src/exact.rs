//! Exact clearance between the robot's link geometry and the world, with
//! parry: link primitives exactly, link meshes as their convex hulls (which
//! contain them, so a contact is never missed); world boxes, spheres,
//! cylinders and capsules exactly. For judging controllers (benchmarks,
//! tests) independently of the sphere model they steer by.

use std::sync::Arc;

use ferrobot_collision::CollisionWorld;
use ferrobot_geometry::MeshAs;
use ferrobot_model::{RobotModel, Shape};
use nalgebra::Isometry3;
use parry3d::math::{Pose, Rot3, Vector};
use parry3d::shape::SharedShape;

use crate::error::{ControlError, Result};

fn to_pose(iso: &Isometry3<f64>) -> Pose {
    let t = iso.translation.vector;
    let r = iso.rotation.coords; // x, y, z, w
    Pose::from_parts(
        Vector::new(t.x as f32, t.y as f32, t.z as f32),
        Rot3::from_xyzw(r[0] as f32, r[1] as f32, r[2] as f32, r[3] as f32).normalize(),
    )
}

/// A link shape for parry (meshes as their convex hulls, which contain
/// them); None when parry cannot represent it.
fn link_shape(shape: &Shape) -> Option<(SharedShape, Isometry3<f64>)> {
    shape.to_parry(MeshAs::ConvexHull).ok()
}

/// A world shape for parry: primitives only (meshes, hulls and clouds are
/// left to the sphere model's distance queries).
fn world_shape(shape: &Shape) -> Option<(SharedShape, Isometry3<f64>)> {
    match shape {
        Shape::Box { .. }
        | Shape::Sphere { .. }
        | Shape::Cylinder { .. }
        | Shape::Capsule { .. } => shape.to_parry(MeshAs::TriMesh).ok(),
        _ => None,
    }
}

/// The closest pair found by [`LinkClearance::clearance`].
#[derive(Debug, Clone, PartialEq)]
pub struct Clearance {
    /// Smallest distance (m) between a link's geometry and a world shape;
    /// 0 when they touch or overlap; `inf` with no geometry to compare.
    pub distance: f64,
    /// The link and the world object of the closest pair.
    pub closest: Option<(String, String)>,
}

/// Exact link geometry of a robot, for clearance queries against worlds of
/// primitives.
#[derive(Debug, Clone)]
pub struct LinkClearance {
    model: Arc<RobotModel>,
    /// Per link: shapes and their poses in the link frame.
    links: Vec<Vec<(SharedShape, Isometry3<f64>)>>,
}

impl LinkClearance {
    /// The collision geometry of every link of `model` (meshes as convex hulls).
    pub fn new(model: Arc<RobotModel>) -> Result<Self> {
        let mut links = Vec::new();
        for link in model.links() {
            let mut parts = Vec::new();
            for g in &link.collisions {
                let (s, fix) = link_shape(&g.shape).ok_or_else(|| {
                    ControlError::InvalidArgument(format!(
                        "link '{}': cannot make a convex hull of its mesh",
                        link.name
                    ))
                })?;
                parts.push((s, g.origin * fix));
            }
            links.push(parts);
        }
        Ok(Self { model, links })
    }

    /// Smallest distance between the links (at `q`) and the objects of
    /// `world`. Meshes and point clouds in the world are refused.
    pub fn clearance(&self, q: &[f64], world: &CollisionWorld) -> Result<Clearance> {
        let poses = self.model.fk_all(q)?;
        let mut obstacles = Vec::new();
        for obj in world.objects() {
            for (shape, local) in &obj.parts {
                let (s, fix) = world_shape(shape).ok_or_else(|| {
                    ControlError::InvalidArgument(format!(
                        "world object '{}': exact clearance supports boxes, spheres, cylinders and capsules, not {}",
                        obj.name,
                        shape.kind()
                    ))
                })?;
                obstacles.push((obj.name.as_str(), s, to_pose(&(obj.pose * local * fix))));
            }
        }
        let mut best = Clearance {
            distance: f64::INFINITY,
            closest: None,
        };
        for (l, parts) in self.links.iter().enumerate() {
            for (s, local) in parts {
                let pose = to_pose(&(poses[l] * local));
                for (name, o, opose) in &obstacles {
                    let d = parry3d::query::distance(&pose, s.as_ref(), opose, o.as_ref())
                        .map_err(|_| {
                            ControlError::InvalidArgument(format!(
                                "parry cannot measure link '{}' against '{name}'",
                                self.model.links()[l].name
                            ))
                        })?
                        .distance as f64;
                    if d < best.distance {
                        best = Clearance {
                            distance: d,
                            closest: Some((self.model.links()[l].name.clone(), name.to_string())),
                        };
                    }
                }
            }
        }
        Ok(best)
    }

    /// Distance (m) between the geometry of links `a` and `b` at the link
    /// poses `poses` (base frame, one per link); `None` when either link
    /// has no geometry or parry cannot measure the pair.
    pub fn link_pair_distance(&self, poses: &[Isometry3<f64>], a: usize, b: usize) -> Option<f64> {
        let mut best: Option<f64> = None;
        for (sa, la) in self.links.get(a)? {
            let pa = to_pose(&(poses[a] * la));
            for (sb, lb) in self.links.get(b)? {
                let pb = to_pose(&(poses[b] * lb));
                let d = parry3d::query::distance(&pa, sa.as_ref(), &pb, sb.as_ref()).ok()?;
                let d = d.distance as f64;
                best = Some(best.map_or(d, |x: f64| x.min(d)));
            }
        }
        best
    }

    /// Smallest distance at `q` between the geometry of the link pairs
    /// `pairs` (link indices; typically [`crate::Core::self_link_pairs`],
    /// the pairs the allowed-collision matrix checks): an exact judge of
    /// self-contact, independent of the sphere model. `closest` names the
    /// two links.
    pub fn self_clearance(&self, q: &[f64], pairs: &[(usize, usize)]) -> Result<Clearance> {
        let poses = self.model.fk_all(q)?;
        let n = self.links.len();
        let mut best = Clearance {
            distance: f64::INFINITY,
            closest: None,
        };
        for &(a, b) in pairs {
            if a >= n || b >= n {
                return Err(ControlError::InvalidArgument(format!(
                    "link pair ({a}, {b}): the robot has {n} links"
                )));
            }
            for (sa, la) in &self.links[a] {
                let pa = to_pose(&(poses[a] * la));
                for (sb, lb) in &self.links[b] {
                    let pb = to_pose(&(poses[b] * lb));
                    let d = parry3d::query::distance(&pa, sa.as_ref(), &pb, sb.as_ref())
                        .map_err(|_| {
                            ControlError::InvalidArgument(format!(
                                "parry cannot measure link '{}' against link '{}'",
                                self.model.links()[a].name,
                                self.model.links()[b].name
                            ))
                        })?
                        .distance as f64;
                    if d < best.distance {
                        best = Clearance {
                            distance: d,
                            closest: Some((
                                self.model.links()[a].name.clone(),
                                self.model.links()[b].name.clone(),
                            )),
                        };
                    }
                }
            }
        }
        Ok(best)
    }
}
