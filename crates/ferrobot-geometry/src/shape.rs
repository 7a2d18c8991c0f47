//! The one shape type and what every crate asks of it: validation,
//! bounds, volume, signed distance, and the parry shape.

use std::sync::Arc;

use nalgebra::{Isometry3, Point3, Vector3};
use parry3d::math::{Pose, Rotation};
use parry3d::shape::SharedShape;

use crate::cloud::PointCloud;
use crate::error::{GeometryError, Result};
use crate::mesh::{Hull, Mesh};

/// A solid (or surface, or cloud) in its own frame.
///
/// One convention for every crate: parry's half sizes, cylinders and
/// capsules along z. Build from full sizes with [`Shape::cuboid_from_size`],
/// [`Shape::cylinder_from_length`] and [`Shape::capsule_from_length`].
#[derive(Debug, Clone)]
pub enum Shape {
    /// A box centred at the origin.
    Box {
        /// Half the edge lengths (m, > 0).
        half_extents: Vector3<f64>,
    },
    /// A sphere centred at the origin.
    Sphere {
        /// Radius (m, > 0).
        radius: f64,
    },
    /// A cylinder along z centred at the origin.
    Cylinder {
        /// Radius (m, > 0).
        radius: f64,
        /// Half the length along z (m, > 0).
        half_height: f64,
    },
    /// A capsule along z centred at the origin: the segment from
    /// `-half_height` to `half_height` swept by a ball of `radius` (total
    /// extent along z `2 (half_height + radius)`).
    Capsule {
        /// Radius (m, > 0).
        radius: f64,
        /// Half the length of the cylindrical part (m, >= 0).
        half_height: f64,
    },
    /// The convex hull of a set of points.
    ConvexHull(Arc<Hull>),
    /// A triangle mesh used as is: a solid if closed, else a surface (the
    /// simulator only accepts it on static objects).
    Mesh(Arc<Mesh>),
    /// A triangle mesh that the simulator splits into convex parts (V-HACD,
    /// as parry implements it) so that it can move; elsewhere it is the mesh.
    ConvexDecomposition(Arc<Mesh>),
    /// Points, each a ball of the cloud's radius (collision worlds only).
    PointCloud(Arc<PointCloud>),
}

/// How a parry shape represents a [`Shape::Mesh`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshAs {
    /// The triangles as they are.
    TriMesh,
    /// Their convex hull (robot links in the simulator and exact checks).
    ConvexHull,
}

/// The rotation taking parry's y-axis cylinders to z-axis cylinders.
pub fn y_to_z() -> Isometry3<f64> {
    Isometry3::rotation(Vector3::x() * std::f64::consts::FRAC_PI_2)
}

fn positive(what: &str, name: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(GeometryError::InvalidShape(format!(
            "{what}: {name} must be positive and finite, got {v}"
        )))
    }
}

impl Shape {
    /// A box of full edge lengths `size`.
    pub fn cuboid_from_size(size: Vector3<f64>) -> Self {
        Self::Box {
            half_extents: size / 2.0,
        }
    }

    /// A z-axis cylinder of full `length`.
    pub fn cylinder_from_length(radius: f64, length: f64) -> Self {
        Self::Cylinder {
            radius,
            half_height: length / 2.0,
        }
    }

    /// A z-axis capsule whose cylindrical part has full `length`.
    pub fn capsule_from_length(radius: f64, length: f64) -> Self {
        Self::Capsule {
            radius,
            half_height: length / 2.0,
        }
    }

    /// A short name of the kind of shape.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Box { .. } => "box",
            Self::Sphere { .. } => "sphere",
            Self::Cylinder { .. } => "cylinder",
            Self::Capsule { .. } => "capsule",
            Self::ConvexHull(_) => "convex_hull",
            Self::Mesh(_) => "mesh",
            Self::ConvexDecomposition(_) => "convex_decomposition",
            Self::PointCloud(_) => "pointcloud",
        }
    }

    /// The one validation of a shape's sizes: lengths positive and finite
    /// (a capsule's cylindrical part may be empty). Sizes are reported as
    /// full lengths (`box size`, `cylinder length`), as users give them.
    /// Meshes, hulls and clouds are checked when they are built.
    pub fn validate(&self, what: &str) -> Result<()> {
        match self {
            Self::Box { half_extents } => half_extents
                .iter()
                .try_for_each(|&h| positive(what, "box size", 2.0 * h)),
            Self::Sphere { radius } => positive(what, "sphere radius", *radius),
            Self::Cylinder {
                radius,
                half_height,
            } => positive(what, "cylinder radius", *radius).and(positive(
                what,
                "cylinder length",
                2.0 * half_height,
            )),
            Self::Capsule {
                radius,
                half_height,
            } => {
                positive(what, "capsule radius", *radius)?;
                if half_height.is_finite() && *half_height >= 0.0 {
                    Ok(())
                } else {
                    Err(GeometryError::InvalidShape(format!(
                        "{what}: capsule length must be finite and >= 0, got {}",
                        2.0 * half_height
                    )))
                }
            }
            Self::ConvexHull(_)
            | Self::Mesh(_)
            | Self::ConvexDecomposition(_)
            | Self::PointCloud(_) => Ok(()),
        }
    }

    /// Radius of a ball around the shape's origin holding the whole shape.
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Self::Box { half_extents } => half_extents.norm(),
            Self::Sphere { radius } => *radius,
            Self::Cylinder {
                radius,
                half_height,
            } => radius.hypot(*half_height),
            Self::Capsule {
                radius,
                half_height,
            } => radius + half_height,
            Self::ConvexHull(h) => h.surface().bounding_radius(),
            Self::Mesh(m) | Self::ConvexDecomposition(m) => m.bounding_radius(),
            Self::PointCloud(c) => c.bounding_radius(),
        }
    }

    /// The axis-aligned bounding box in the shape frame, `(min, max)`.
    pub fn local_aabb(&self) -> (Point3<f64>, Point3<f64>) {
        let sym = |h: Vector3<f64>| (Point3::from(-h), Point3::from(h));
        let of_points = |pts: &mut dyn Iterator<Item = Point3<f64>>, pad: f64| {
            let mut lo = Point3::from(Vector3::repeat(f64::INFINITY));
            let mut hi = Point3::from(Vector3::repeat(f64::NEG_INFINITY));
            for p in pts {
                lo = lo.inf(&p);
                hi = hi.sup(&p);
            }
            let pad = Vector3::repeat(pad);
            (lo - pad, hi + pad)
        };
        match self {
            Self::Box { half_extents } => sym(*half_extents),
            Self::Sphere { radius } => sym(Vector3::repeat(*radius)),
            Self::Cylinder {
                radius,
                half_height,
            } => sym(Vector3::new(*radius, *radius, *half_height)),
            Self::Capsule {
                radius,
                half_height,
            } => sym(Vector3::new(*radius, *radius, half_height + radius)),
            Self::ConvexHull(h) => of_points(&mut h.points().iter().copied(), 0.0),
            Self::Mesh(m) | Self::ConvexDecomposition(m) => of_points(&mut m.vertices(), 0.0),
            Self::PointCloud(c) => of_points(&mut c.points().iter().copied(), c.radius()),
        }
    }

    /// The enclosed volume (m³): closed forms for primitives, parry's for a
    /// hull and a decomposition; None for a mesh used as a surface and for
    /// a cloud.
    pub fn volume(&self) -> Option<f64> {
        use std::f64::consts::PI;
        Some(match self {
            Self::Box { half_extents: h } => 8.0 * h.x * h.y * h.z,
            Self::Sphere { radius: r } => 4.0 / 3.0 * PI * r.powi(3),
            Self::Cylinder {
                radius: r,
                half_height: h,
            } => PI * r * r * 2.0 * h,
            Self::Capsule {
                radius: r,
                half_height: h,
            } => PI * r * r * 2.0 * h + 4.0 / 3.0 * PI * r.powi(3),
            Self::ConvexHull(_) | Self::ConvexDecomposition(_) => {
                let s = self.to_shared_shape(MeshAs::TriMesh).ok()?;
                s.mass_properties(1.0).mass() as f64
            }
            Self::Mesh(_) | Self::PointCloud(_) => return None,
        })
    }

    /// Signed distance from `p` (shape frame) to the surface (negative
    /// inside) and the unit direction in which it grows fastest.
    pub fn signed_distance(&self, p: &Point3<f64>) -> (f64, Vector3<f64>) {
        match self {
            Self::Box { half_extents } => box_sdf(p, half_extents),
            Self::Sphere { radius } => {
                let n = p.coords.norm();
                let dir = if n > 1e-12 {
                    p.coords / n
                } else {
                    Vector3::z()
                };
                (n - radius, dir)
            }
            Self::Cylinder {
                radius,
                half_height,
            } => cylinder_sdf(p, *radius, *half_height),
            Self::Capsule {
                radius,
                half_height,
            } => {
                let z = p.z.clamp(-half_height, *half_height);
                let d = p.coords - Vector3::new(0.0, 0.0, z);
                let n = d.norm();
                let dir = if n > 1e-12 { d / n } else { Vector3::x() };
                (n - radius, dir)
            }
            Self::ConvexHull(h) => h.surface().signed_distance(p),
            Self::Mesh(m) | Self::ConvexDecomposition(m) => m.signed_distance(p),
            Self::PointCloud(c) => c.signed_distance(p),
        }
    }

    /// The parry shape (single precision) and its pose in the shape frame
    /// (parry's cylinders run along y: a cylinder comes with the rotation
    /// taking y to z). Sizes are validated first.
    pub fn to_parry(&self, meshes: MeshAs) -> Result<(SharedShape, Isometry3<f64>)> {
        self.validate("shape")?;
        let id = Isometry3::identity();
        Ok(match self {
            Self::Box { half_extents: h } => {
                (SharedShape::cuboid(h.x as f32, h.y as f32, h.z as f32), id)
            }
            Self::Sphere { radius } => (SharedShape::ball(*radius as f32), id),
            Self::Cylinder {
                radius,
                half_height,
            } => (
                SharedShape::cylinder(*half_height as f32, *radius as f32),
                y_to_z(),
            ),
            Self::Capsule {
                radius,
                half_height,
            } => (
                SharedShape::capsule_z(*half_height as f32, *radius as f32),
                id,
            ),
            Self::ConvexHull(h) => (h.parry_shape().clone(), id),
            Self::Mesh(m) => match meshes {
                MeshAs::TriMesh => (
                    SharedShape::trimesh(m.parry_vertices(), m.triangles().to_vec()).map_err(
                        |e| GeometryError::InvalidShape(format!("invalid triangle mesh: {e}")),
                    )?,
                    id,
                ),
                MeshAs::ConvexHull => (
                    SharedShape::convex_hull(&m.parry_vertices()).ok_or_else(|| {
                        GeometryError::InvalidShape(format!(
                            "the convex hull of the mesh's {} vertices is degenerate",
                            m.data().vertices.len()
                        ))
                    })?,
                    id,
                ),
            },
            Self::ConvexDecomposition(m) => (m.convex_decomposition()?.clone(), id),
            Self::PointCloud(_) => {
                return Err(GeometryError::InvalidShape(
                    "a point cloud has no parry shape".into(),
                ));
            }
        })
    }

    /// [`Shape::to_parry`] as one shape in the shape frame (a cylinder is
    /// wrapped in a one-part compound carrying its rotation).
    pub fn to_shared_shape(&self, meshes: MeshAs) -> Result<SharedShape> {
        let (s, pose) = self.to_parry(meshes)?;
        if pose == Isometry3::identity() {
            Ok(s)
        } else {
            Ok(SharedShape::compound(vec![(to_pose(&pose), s)]))
        }
    }
}

/// A double-precision pose as parry's single-precision one.
pub fn to_pose(iso: &Isometry3<f64>) -> Pose {
    let t = iso.translation.vector;
    let r = iso.rotation.coords; // x, y, z, w
    Pose::from_parts(
        parry3d::math::Vector::new(t.x as f32, t.y as f32, t.z as f32),
        Rotation::from_xyzw(r[0] as f32, r[1] as f32, r[2] as f32, r[3] as f32).normalize(),
    )
}

/// Signed distance to a box of half extents `h` centred at the origin.
pub fn box_sdf(p: &Point3<f64>, h: &Vector3<f64>) -> (f64, Vector3<f64>) {
    let q = p.coords.abs() - h;
    let outside = q.sup(&Vector3::zeros());
    let out_len = outside.norm();
    if out_len > 0.0 {
        let dir = Vector3::new(
            outside.x * p.x.signum(),
            outside.y * p.y.signum(),
            outside.z * p.z.signum(),
        ) / out_len;
        (out_len, dir)
    } else {
        let (axis, depth) = (0..3)
            .map(|i| (i, q[i]))
            .fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
        let mut dir = Vector3::zeros();
        dir[axis] = if p[axis] >= 0.0 { 1.0 } else { -1.0 };
        (depth, dir)
    }
}

/// Signed distance to a z-axis cylinder centred at the origin.
pub fn cylinder_sdf(p: &Point3<f64>, radius: f64, half_height: f64) -> (f64, Vector3<f64>) {
    let rho = p.x.hypot(p.y);
    let radial = if rho > 1e-12 {
        Vector3::new(p.x / rho, p.y / rho, 0.0)
    } else {
        Vector3::x()
    };
    let axial = Vector3::new(0.0, 0.0, if p.z >= 0.0 { 1.0 } else { -1.0 });
    let dr = rho - radius;
    let dz = p.z.abs() - half_height;
    if dr > 0.0 && dz > 0.0 {
        let n = dr.hypot(dz);
        (n, (radial * dr + axial * dz) / n)
    } else if dr > dz {
        (dr, radial)
    } else {
        (dz, axial)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_distances_are_analytic() {
        let h = Vector3::new(1.0, 2.0, 3.0);
        let (d, g) = box_sdf(&Point3::new(2.0, 0.0, 0.0), &h);
        assert_eq!((d, g), (1.0, Vector3::x()));
        let (d, _) = box_sdf(&Point3::new(2.0, 3.0, 0.0), &h);
        assert!((d - 2f64.sqrt()).abs() < 1e-12);
        let (d, g) = box_sdf(&Point3::new(0.0, 0.0, -2.5), &h);
        assert_eq!((d, g), (-0.5, -Vector3::z()));
    }

    #[test]
    fn cylinder_distances_are_analytic() {
        let (d, _) = cylinder_sdf(&Point3::new(3.0, 0.0, 0.0), 1.0, 2.0);
        assert_eq!(d, 2.0);
        let (d, _) = cylinder_sdf(&Point3::new(0.0, 0.0, 1.5), 1.0, 2.0);
        assert_eq!(d, -0.5);
        let (d, _) = cylinder_sdf(&Point3::new(4.0, 0.0, 6.0), 1.0, 2.0);
        assert_eq!(d, 5.0);
    }
}
