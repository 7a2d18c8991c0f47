//! Collision and visual geometry attached to links.

use nalgebra::Isometry3;

pub use ferrobot_geometry::Shape;

/// A shape placed in a link frame (a URDF `<collision>` or `<visual>`).
#[derive(Debug, Clone)]
pub struct Geometry {
    /// The element's `name` attribute, if any.
    pub name: Option<String>,
    /// Pose of the shape in the link frame.
    pub origin: Isometry3<f64>,
    /// The shape.
    pub shape: Shape,
    /// RGBA colour of a visual's material, if given.
    pub rgba: Option<[f64; 4]>,
}

/// Mass properties of a link (URDF `<inertial>`).
#[derive(Debug, Clone, PartialEq)]
pub struct Inertial {
    /// Pose of the centre of mass frame in the link frame.
    pub origin: Isometry3<f64>,
    /// Mass (kg).
    pub mass: f64,
    /// Inertia tensor about the centre of mass in the inertial frame
    /// (row-major 3x3, kg·m²).
    pub inertia: [[f64; 3]; 3],
}

impl Default for Inertial {
    fn default() -> Self {
        Self {
            origin: Isometry3::identity(),
            mass: 0.0,
            inertia: [[0.0; 3]; 3],
        }
    }
}
