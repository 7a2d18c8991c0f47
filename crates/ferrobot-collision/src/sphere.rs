//! Spheres and the sphere model of a robot (spheres per link, link frame).

use nalgebra::{Point3, Vector3};

/// A sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre (m), in the frame of whatever holds the sphere.
    pub center: Point3<f64>,
    /// Radius (m), positive.
    pub radius: f64,
}

impl Sphere {
    /// A sphere at `center` with `radius`.
    pub fn new(center: Point3<f64>, radius: f64) -> Self {
        Self { center, radius }
    }

    /// The smallest sphere holding all of `spheres` (not minimal in general:
    /// centred on the bounding box centre, radius grown to hold every sphere).
    pub fn bounding(spheres: &[Sphere]) -> Option<Sphere> {
        let first = spheres.first()?;
        let mut lo = first.center.coords - Vector3::repeat(first.radius);
        let mut hi = first.center.coords + Vector3::repeat(first.radius);
        for s in spheres {
            lo = lo.inf(&(s.center.coords - Vector3::repeat(s.radius)));
            hi = hi.sup(&(s.center.coords + Vector3::repeat(s.radius)));
        }
        let center = Point3::from((lo + hi) * 0.5);
        let radius = spheres
            .iter()
            .map(|s| (s.center - center).norm() + s.radius)
            .fold(0.0, f64::max);
        Some(Sphere { center, radius })
    }
}
