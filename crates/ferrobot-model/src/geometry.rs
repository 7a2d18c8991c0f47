//! Collision and visual geometry attached to links.

use std::path::PathBuf;
use std::sync::Arc;

use nalgebra::{Isometry3, Vector3};

use crate::mesh::TriMesh;

/// A geometric shape, in its own frame.
#[derive(Debug, Clone)]
pub enum Shape {
    /// An axis-aligned box centred at the origin.
    Box {
        /// Half the edge lengths (m).
        half_extents: Vector3<f64>,
    },
    /// A sphere centred at the origin.
    Sphere {
        /// Radius (m).
        radius: f64,
    },
    /// A cylinder along z centred at the origin.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Full length along z (m).
        length: f64,
    },
    /// A capsule along z centred at the origin: a cylinder of `length` with
    /// hemispherical caps (total extent `length + 2 radius`).
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Length of the cylindrical part (m).
        length: f64,
    },
    /// A triangle mesh loaded from a file.
    Mesh {
        /// The filename as written in the URDF.
        filename: String,
        /// The file it resolved to.
        path: PathBuf,
        /// Per-axis scale applied to the vertices.
        scale: Vector3<f64>,
        /// The mesh as loaded (unscaled); shared between uses of one file.
        mesh: Arc<TriMesh>,
    },
}

impl Shape {
    /// The URDF element name of the shape.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Box { .. } => "box",
            Self::Sphere { .. } => "sphere",
            Self::Cylinder { .. } => "cylinder",
            Self::Capsule { .. } => "capsule",
            Self::Mesh { .. } => "mesh",
        }
    }
}

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
