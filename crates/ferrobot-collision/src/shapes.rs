//! Obstacle shapes and exact signed distances from a point to each of them.

use std::sync::Arc;

use nalgebra::{Point3, Vector3};

use crate::cloud::PointCloud;
use crate::trimesh::MeshShape;

/// The shape of a world object, in its own frame.
#[derive(Debug, Clone)]
pub enum ObstacleShape {
    /// Box centred at the origin.
    Box {
        /// Half edge lengths (m).
        half_extents: Vector3<f64>,
    },
    /// Sphere centred at the origin.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// Cylinder along z centred at the origin.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Half of the length along z (m).
        half_length: f64,
    },
    /// Capsule along z centred at the origin (segment of `2 half_length`).
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Half of the segment length (m).
        half_length: f64,
    },
    /// Triangle mesh with a BVH.
    Mesh(Arc<MeshShape>),
    /// Point cloud with a kd-tree; each point is a ball of the cloud's radius.
    PointCloud(Arc<PointCloud>),
}

impl ObstacleShape {
    /// A short name of the kind of shape.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Box { .. } => "box",
            Self::Sphere { .. } => "sphere",
            Self::Cylinder { .. } => "cylinder",
            Self::Capsule { .. } => "capsule",
            Self::Mesh(_) => "mesh",
            Self::PointCloud(_) => "pointcloud",
        }
    }

    /// Radius of a ball around the shape's origin holding the whole shape.
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Self::Box { half_extents } => half_extents.norm(),
            Self::Sphere { radius } => *radius,
            Self::Cylinder {
                radius,
                half_length,
            } => radius.hypot(*half_length),
            Self::Capsule {
                radius,
                half_length,
            } => radius + half_length,
            Self::Mesh(m) => m.bounding_radius(),
            Self::PointCloud(c) => c.bounding_radius(),
        }
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
                half_length,
            } => cylinder_sdf(p, *radius, *half_length),
            Self::Capsule {
                radius,
                half_length,
            } => {
                let z = p.z.clamp(-half_length, *half_length);
                let d = p.coords - Vector3::new(0.0, 0.0, z);
                let n = d.norm();
                let dir = if n > 1e-12 { d / n } else { Vector3::x() };
                (n - radius, dir)
            }
            Self::Mesh(m) => m.signed_distance(p),
            Self::PointCloud(c) => c.signed_distance(p),
        }
    }
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
pub fn cylinder_sdf(p: &Point3<f64>, radius: f64, half_length: f64) -> (f64, Vector3<f64>) {
    let rho = p.x.hypot(p.y);
    let radial = if rho > 1e-12 {
        Vector3::new(p.x / rho, p.y / rho, 0.0)
    } else {
        Vector3::x()
    };
    let axial = Vector3::new(0.0, 0.0, if p.z >= 0.0 { 1.0 } else { -1.0 });
    let dr = rho - radius;
    let dz = p.z.abs() - half_length;
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
