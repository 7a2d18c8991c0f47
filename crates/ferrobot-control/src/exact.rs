//! Exact clearance between the robot's link geometry and the world, with
//! parry: link primitives exactly, link meshes as their convex hulls (which
//! contain them, so a contact is never missed); world boxes, spheres,
//! cylinders and capsules exactly. Distances are lower bounds exact to
//! ~0.01 % (a separating plane along GJK's direction, cylinders as
//! circumscribed prisms: see `convex_distance_lower`), never more than the
//! true distance. For judging controllers (benchmarks, tests) independently
//! of the sphere model they steer by, and for certifying motions the sphere
//! model is too coarse for (`object_clearances`).

use std::sync::Arc;

use ferrobot_collision::CollisionWorld;
use ferrobot_geometry::MeshAs;
use ferrobot_model::{RobotModel, Shape};
use nalgebra::{Isometry3, Point3, Vector3};
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

/// Sides of the prism that stands in for a cylinder in distance queries.
const CYLINDER_SIDES: usize = 64;

/// A cylinder along z as the prism circumscribed about it (its
/// [`CYLINDER_SIDES`]-gon's edges touch the circle, so the prism holds the
/// cylinder and reaches at most `radius (1 / cos(pi / n) - 1)`, 0.12 % of
/// the radius, beyond it). parry's GJK distance between a round cylinder and
/// a box can stop millimetres short of converging (measured: 31.35 mm for a
/// true 29.93 mm, radius 3.5 cm), which would overstate a clearance; against
/// a polytope GJK terminates exactly, and the prism errs on the safe side.
fn cylinder_prism(radius: f64, half_height: f64) -> Option<SharedShape> {
    let n = CYLINDER_SIDES;
    let r = radius / (std::f64::consts::PI / n as f64).cos();
    let mut pts = Vec::with_capacity(2 * n);
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        for z in [-half_height, half_height] {
            pts.push(Vector::new(
                (r * a.cos()) as f32,
                (r * a.sin()) as f32,
                z as f32,
            ));
        }
    }
    SharedShape::convex_hull(&pts)
}

/// A shape for parry's distance queries: cylinders as their circumscribed
/// prisms ([`cylinder_prism`]), the rest as [`Shape::to_parry`] makes them.
fn distance_shape(shape: &Shape, meshes: MeshAs) -> Option<(SharedShape, Isometry3<f64>)> {
    match shape {
        Shape::Cylinder {
            radius,
            half_height,
        } => Some((
            cylinder_prism(*radius, *half_height)?,
            Isometry3::identity(),
        )),
        _ => shape.to_parry(meshes).ok(),
    }
}

/// A link shape for parry (meshes as their convex hulls, which contain
/// them; cylinders as circumscribed prisms); None when parry cannot
/// represent it.
fn link_shape(shape: &Shape) -> Option<(SharedShape, Isometry3<f64>)> {
    distance_shape(shape, MeshAs::ConvexHull)
}

/// A world shape for parry: primitives only (meshes, hulls and clouds are
/// left to the sphere model's distance queries).
pub(crate) fn world_shape(shape: &Shape) -> Option<(SharedShape, Isometry3<f64>)> {
    match shape {
        Shape::Box { .. }
        | Shape::Sphere { .. }
        | Shape::Cylinder { .. }
        | Shape::Capsule { .. } => distance_shape(shape, MeshAs::TriMesh),
        _ => None,
    }
}

/// A world shape for parry in exact object-by-object queries: primitives
/// exactly, convex hulls as they are, a convex decomposition as its convex
/// parts (a link inside the object touches a part), other meshes as their
/// triangles; None for point clouds.
fn world_shape_exact(shape: &Shape) -> Option<(SharedShape, Isometry3<f64>)> {
    match shape {
        Shape::PointCloud(_) => None,
        _ => distance_shape(shape, MeshAs::TriMesh),
    }
}

/// A lower bound (m) on the distance between convex shapes `a` at `pa` and
/// `b` at `pb`, within 0.01 % of it in practice: GJK's closest points give a
/// direction `n`, and no two points of the shapes are closer than the gap
/// between `a`'s support along `n` and `b`'s along `-n` (a separating
/// plane). parry's GJK alone can stop short of the minimum (measured: a
/// prism against a box with parallel faces, 31.26 mm for a true 29.93 mm),
/// which would overstate a clearance; the plane's gap never does. None when
/// either shape is not convex.
fn convex_distance_lower(
    a: &dyn parry3d::shape::Shape,
    pa: &Pose,
    b: &dyn parry3d::shape::Shape,
    pb: &Pose,
) -> Option<f64> {
    let sa = a.as_support_map()?;
    let sb = b.as_support_map()?;
    let c = parry3d::query::contact(pa, a, pb, b, 1.0e3).ok()??;
    if c.dist <= 0.0 {
        return Some(0.0);
    }
    let n = c.normal1;
    let top_a = sa.support_point(pa, n).dot(n);
    let bottom_b = sb.support_point(pb, -n).dot(n);
    Some(f64::from(bottom_b - top_a).clamp(0.0, f64::from(c.dist)))
}

/// A lower bound (m) on the distance between the convex shape `a` at `pa`
/// and `b` at `pb`, which may be a compound of convex parts or a triangle
/// mesh (a surface: the least over its triangles); see
/// [`convex_distance_lower`]. None when parry cannot measure the pair.
fn distance_lower(
    a: &dyn parry3d::shape::Shape,
    pa: &Pose,
    b: &dyn parry3d::shape::Shape,
    pb: &Pose,
) -> Option<f64> {
    if let Some(compound) = b.as_compound() {
        let mut best = f64::INFINITY;
        for (local, part) in compound.shapes() {
            best = best.min(distance_lower(a, pa, part.as_ref(), &(*pb * *local))?);
        }
        return Some(best);
    }
    if let Some(mesh) = b.as_trimesh() {
        let mut best = f64::INFINITY;
        for tri in mesh.triangles() {
            best = best.min(convex_distance_lower(a, pa, &tri, pb)?);
        }
        return Some(best);
    }
    convex_distance_lower(a, pa, b, pb)
}

/// The clearance of one world object: see [`LinkClearance::object_clearances`].
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectClearance {
    /// The world object's name.
    pub object: String,
    /// Smallest distance (m) between the object and any link's geometry; 0
    /// when they touch or overlap; `inf` when no link has geometry.
    pub distance: f64,
    /// The link of the closest pair (None when no link has geometry).
    pub link: Option<String>,
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

/// The closest points of two convex shapes (or of the deepest
/// penetration), base frame: see [`LinkClearance::link_pair_contact`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExactContact {
    /// Signed distance (m): negative when the shapes overlap (minus the
    /// penetration depth).
    pub distance: f64,
    /// Point on the first shape.
    pub point_a: Point3<f64>,
    /// Point on the second shape.
    pub point_b: Point3<f64>,
    /// Unit normal pointing from the first shape towards the second: moving
    /// the first shape along `-normal` increases the distance.
    pub normal: Vector3<f64>,
}

fn to_point(v: Vector) -> Point3<f64> {
    Point3::new(v.x as f64, v.y as f64, v.z as f64)
}

fn to_vector(v: Vector) -> Vector3<f64> {
    Vector3::new(v.x as f64, v.y as f64, v.z as f64)
}

/// Closest (or deepest) contact between shape `a` at `pa` and `b` at `pb`
/// within `prediction` (m), base frame.
pub(crate) fn shape_contact(
    a: &SharedShape,
    pa: &Isometry3<f64>,
    b: &SharedShape,
    pb: &Isometry3<f64>,
    prediction: f64,
) -> Option<ExactContact> {
    let c = parry3d::query::contact(
        &to_pose(pa),
        a.as_ref(),
        &to_pose(pb),
        b.as_ref(),
        prediction as f32,
    )
    .ok()??;
    Some(ExactContact {
        distance: c.dist as f64,
        point_a: to_point(c.point1),
        point_b: to_point(c.point2),
        normal: to_vector(c.normal1),
    })
}

/// Exact link geometry of a robot, for clearance queries against worlds of
/// primitives.
#[derive(Debug, Clone)]
pub struct LinkClearance {
    model: Arc<RobotModel>,
    /// Per link: shapes and their poses in the link frame.
    links: Vec<Vec<(SharedShape, Isometry3<f64>)>>,
    /// Per link: a ball holding all its shapes (centre in the link frame,
    /// radius), None without geometry: the broad phase of the contact queries.
    bounds: Vec<Option<(Point3<f64>, f64)>>,
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
        let bounds = links
            .iter()
            .map(|parts| {
                // A ball about the mean of the parts' bounding-ball centres
                // holding every part's bounding ball.
                if parts.is_empty() {
                    return None;
                }
                let balls: Vec<(Point3<f64>, f64)> = parts
                    .iter()
                    .map(|(s, local)| {
                        let b = s.compute_local_bounding_sphere();
                        (local * to_point(b.center()), b.radius() as f64)
                    })
                    .collect();
                let c = balls
                    .iter()
                    .fold(Vector3::zeros(), |acc, (p, _)| acc + p.coords)
                    / balls.len() as f64;
                let r = balls
                    .iter()
                    .map(|(p, r)| (p.coords - c).norm() + r)
                    .fold(0.0, f64::max);
                Some((Point3::from(c), r * (1.0 + 1e-6) + 1e-6))
            })
            .collect();
        Ok(Self {
            model,
            links,
            bounds,
        })
    }

    /// Whether link `l` has collision geometry.
    pub fn has_geometry(&self, l: usize) -> bool {
        self.links.get(l).is_some_and(|p| !p.is_empty())
    }

    /// A ball holding link `l`'s geometry: centre in the link frame, radius
    /// (m); None without geometry.
    pub fn bound(&self, l: usize) -> Option<(Point3<f64>, f64)> {
        self.bounds.get(l).copied().flatten()
    }

    /// The closest points between the geometry of links `a` and `b` at the
    /// link poses `poses` (base frame, one per link), or their deepest
    /// penetration, when they are within `prediction` (m) of each other;
    /// None when farther or when either link has no geometry. The normal
    /// points from `a` to `b`.
    pub fn link_pair_contact(
        &self,
        poses: &[Isometry3<f64>],
        a: usize,
        b: usize,
        prediction: f64,
    ) -> Option<ExactContact> {
        let mut best: Option<ExactContact> = None;
        for (sa, la) in self.links.get(a)? {
            let pa = poses[a] * la;
            for (sb, lb) in self.links.get(b)? {
                let pb = poses[b] * lb;
                if let Some(c) = shape_contact(sa, &pa, sb, &pb, prediction)
                    && best.is_none_or(|x| c.distance < x.distance)
                {
                    best = Some(c);
                }
            }
        }
        best
    }

    /// The closest points between link `l`'s geometry (at `pose`, base
    /// frame) and the shape `other` at `other_pose` within `prediction` (m),
    /// as [`LinkClearance::link_pair_contact`] (the link is the first shape).
    pub fn link_shape_contact(
        &self,
        l: usize,
        pose: &Isometry3<f64>,
        other: &SharedShape,
        other_pose: &Isometry3<f64>,
        prediction: f64,
    ) -> Option<ExactContact> {
        let mut best: Option<ExactContact> = None;
        for (s, local) in self.links.get(l)? {
            if let Some(c) = shape_contact(s, &(pose * local), other, other_pose, prediction)
                && best.is_none_or(|x| c.distance < x.distance)
            {
                best = Some(c);
            }
        }
        best
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
                    let d =
                        distance_lower(s.as_ref(), &pose, o.as_ref(), opose).ok_or_else(|| {
                            ControlError::InvalidArgument(format!(
                                "parry cannot measure link '{}' against '{name}'",
                                self.model.links()[l].name
                            ))
                        })?;
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
                let d = distance_lower(sa.as_ref(), &pa, sb.as_ref(), &pb)?;
                best = Some(best.map_or(d, |x: f64| x.min(d)));
            }
        }
        best
    }

    /// Per object of `world` (every object, or those named in `objects`,
    /// in the world's order): the smallest distance at `q` between its
    /// shapes and the links' geometry (parry; link meshes as their convex
    /// hulls, which contain them; cylinders as circumscribed prisms; world
    /// primitives and hulls as they are, convex decompositions part by part,
    /// other meshes by their triangles), as a lower bound that is exact to
    /// ~0.01 % ([`convex_distance_lower`]): never more than the true
    /// distance. A judge of contacts the sphere model reports, where a
    /// few millimetres matter (a hand between the walls of a bin). Errors:
    /// a name in `objects` the world does not hold, a point cloud, or a
    /// configuration of the wrong length.
    pub fn object_clearances(
        &self,
        q: &[f64],
        world: &CollisionWorld,
        objects: Option<&[String]>,
    ) -> Result<Vec<ObjectClearance>> {
        if let Some(names) = objects {
            for n in names {
                if !world.objects().iter().any(|o| &o.name == n) {
                    return Err(ControlError::UnknownName(format!(
                        "objects: the world has no object '{n}'"
                    )));
                }
            }
        }
        let poses = self.model.fk_all(q)?;
        let mut out = Vec::new();
        for obj in world.objects() {
            if objects.is_some_and(|names| !names.iter().any(|n| n == &obj.name)) {
                continue;
            }
            let mut best = ObjectClearance {
                object: obj.name.clone(),
                distance: f64::INFINITY,
                link: None,
            };
            for (shape, local) in &obj.parts {
                let (s, fix) = world_shape_exact(shape).ok_or_else(|| {
                    ControlError::InvalidArgument(format!(
                        "world object '{}': exact clearance does not measure {}",
                        obj.name,
                        shape.kind()
                    ))
                })?;
                let oiso = obj.pose * local * fix;
                let opose = to_pose(&oiso);
                let ob = s.compute_local_bounding_sphere();
                let ocentre = oiso * to_point(ob.center());
                for (l, parts) in self.links.iter().enumerate() {
                    // Broad phase: a link whose bounding ball is farther than
                    // the best distance so far cannot be closer.
                    if let Some((c, r)) = self.bounds[l] {
                        let gap = (poses[l] * c - ocentre).norm() - r - ob.radius() as f64;
                        if gap > best.distance {
                            continue;
                        }
                    }
                    for (ls, llocal) in parts {
                        let lpose = to_pose(&(poses[l] * llocal));
                        let d = distance_lower(ls.as_ref(), &lpose, s.as_ref(), &opose)
                            .ok_or_else(|| {
                                ControlError::InvalidArgument(format!(
                                    "parry cannot measure link '{}' against '{}'",
                                    self.model.links()[l].name,
                                    obj.name
                                ))
                            })?;
                        if d < best.distance {
                            best.distance = d;
                            best.link = Some(self.model.links()[l].name.clone());
                        }
                    }
                }
            }
            out.push(best);
        }
        Ok(out)
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
                    let d =
                        distance_lower(sa.as_ref(), &pa, sb.as_ref(), &pb).ok_or_else(|| {
                            ControlError::InvalidArgument(format!(
                                "parry cannot measure link '{}' against link '{}'",
                                self.model.links()[a].name,
                                self.model.links()[b].name
                            ))
                        })?;
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
