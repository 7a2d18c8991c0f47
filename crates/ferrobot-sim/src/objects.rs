//! Rigid objects: shapes, materials and how they become Rapier colliders.

use nalgebra::{Isometry3, Point3, Vector3};
use rapier3d::prelude::{ColliderBuilder, SharedShape};

use crate::error::{Result, SimError, check_finite};

/// The shape of a rigid object, in its own frame.
#[derive(Debug, Clone)]
pub enum ObjectShape {
    /// A box centred at the origin.
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
    /// A capsule along z: a cylinder of `length` with hemispherical caps.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Length of the cylindrical part (m).
        length: f64,
    },
    /// The convex hull of a set of points.
    ConvexHull {
        /// The points (m).
        points: Vec<Point3<f64>>,
    },
    /// A triangle mesh split into convex parts (V-HACD, as parry implements it).
    ConvexDecomposition {
        /// Vertices (m).
        vertices: Vec<Point3<f64>>,
        /// Triangles (indices into `vertices`).
        triangles: Vec<[u32; 3]>,
    },
    /// A triangle mesh used as is: static objects only (a dynamic body
    /// needs a volume, use a hull or a decomposition).
    TriMesh {
        /// Vertices (m).
        vertices: Vec<Point3<f64>>,
        /// Triangles (indices into `vertices`).
        triangles: Vec<[u32; 3]>,
    },
}

/// Everything that describes an object to add to a world.
#[derive(Debug, Clone)]
pub struct ObjectDesc {
    /// Unique name in the world.
    pub name: String,
    /// Shape.
    pub shape: ObjectShape,
    /// Initial pose in the world.
    pub pose: Isometry3<f64>,
    /// Mass (kg) of a dynamic object; ignored for static objects.
    pub mass: f64,
    /// Coulomb friction coefficient.
    pub friction: f64,
    /// Restitution (0: no bounce, 1: elastic).
    pub restitution: f64,
    /// Whether the object never moves.
    pub is_static: bool,
    /// Flat RGB colour (0..1) used by cameras.
    pub color: [f64; 3],
}

impl ObjectDesc {
    /// A dynamic 1 kg object with friction 0.5, no restitution, grey.
    pub fn new(name: impl Into<String>, shape: ObjectShape, pose: Isometry3<f64>) -> Self {
        Self {
            name: name.into(),
            shape,
            pose,
            mass: 1.0,
            friction: 0.5,
            restitution: 0.0,
            is_static: false,
            color: [0.6, 0.6, 0.6],
        }
    }

    /// Checks every field and returns a clear error for the first bad one.
    pub fn validate(&self) -> Result<()> {
        let n = &self.name;
        if n.is_empty() {
            return Err(SimError::InvalidArgument(
                "object name must not be empty".into(),
            ));
        }
        if !crate::convert::pose_is_finite(&self.pose) {
            return Err(SimError::NonFinite(format!(
                "object '{n}': pose is not finite"
            )));
        }
        check_finite(&format!("object '{n}': mass"), &[self.mass])?;
        check_finite(&format!("object '{n}': friction"), &[self.friction])?;
        check_finite(&format!("object '{n}': restitution"), &[self.restitution])?;
        if !self.is_static && self.mass <= 0.0 {
            return Err(SimError::InvalidArgument(format!(
                "object '{n}': mass must be > 0 for a dynamic object, got {}",
                self.mass
            )));
        }
        if self.friction < 0.0 {
            return Err(SimError::InvalidArgument(format!(
                "object '{n}': friction must be >= 0, got {}",
                self.friction
            )));
        }
        if !(0.0..=1.0).contains(&self.restitution) {
            return Err(SimError::InvalidArgument(format!(
                "object '{n}': restitution must be in [0, 1], got {}",
                self.restitution
            )));
        }
        if self.color.iter().any(|c| !(0.0..=1.0).contains(c)) {
            return Err(SimError::InvalidArgument(format!(
                "object '{n}': colour components must be in [0, 1]"
            )));
        }
        if matches!(self.shape, ObjectShape::TriMesh { .. }) && !self.is_static {
            return Err(SimError::InvalidArgument(format!(
                "object '{n}': a raw triangle mesh can only be static; use a convex hull or a convex decomposition for a dynamic object"
            )));
        }
        Ok(())
    }
}

fn positive(what: &str, v: f64) -> Result<f32> {
    if v.is_finite() && v > 0.0 {
        Ok(v as f32)
    } else {
        Err(SimError::InvalidArgument(format!(
            "{what} must be finite and > 0, got {v}"
        )))
    }
}

fn points(what: &str, p: &[Point3<f64>]) -> Result<Vec<rapier3d::math::Vector>> {
    if p.iter().any(|v| !v.coords.iter().all(|c| c.is_finite())) {
        return Err(SimError::NonFinite(format!("{what}: non-finite vertex")));
    }
    Ok(p.iter()
        .map(|v| rapier3d::math::Vector::new(v.x as f32, v.y as f32, v.z as f32))
        .collect())
}

fn check_triangles(what: &str, n: usize, t: &[[u32; 3]]) -> Result<()> {
    if t.is_empty() {
        return Err(SimError::InvalidArgument(format!("{what}: no triangles")));
    }
    if t.iter().flatten().any(|&i| i as usize >= n) {
        return Err(SimError::InvalidArgument(format!(
            "{what}: a triangle refers to a vertex that does not exist ({n} vertices)"
        )));
    }
    Ok(())
}

impl ObjectShape {
    /// The shape as a parry shared shape (validated).
    pub fn to_shared_shape(&self, what: &str) -> Result<SharedShape> {
        Ok(match self {
            Self::Box { half_extents: h } => SharedShape::cuboid(
                positive(&format!("{what}: box half extent x"), h.x)?,
                positive(&format!("{what}: box half extent y"), h.y)?,
                positive(&format!("{what}: box half extent z"), h.z)?,
            ),
            Self::Sphere { radius } => {
                SharedShape::ball(positive(&format!("{what}: sphere radius"), *radius)?)
            }
            Self::Cylinder { radius, length } => {
                // parry's cylinder is along y: rotate it to z through a compound.
                let r = positive(&format!("{what}: cylinder radius"), *radius)?;
                let l = positive(&format!("{what}: cylinder length"), *length)?;
                SharedShape::compound(vec![(y_to_z(), SharedShape::cylinder(l / 2.0, r))])
            }
            Self::Capsule { radius, length } => {
                let r = positive(&format!("{what}: capsule radius"), *radius)?;
                if !(length.is_finite() && *length >= 0.0) {
                    return Err(SimError::InvalidArgument(format!(
                        "{what}: capsule length must be finite and >= 0, got {length}"
                    )));
                }
                SharedShape::capsule_z(*length as f32 / 2.0, r)
            }
            Self::ConvexHull { points: p } => {
                let pts = points(what, p)?;
                SharedShape::convex_hull(&pts).ok_or_else(|| {
                    SimError::InvalidArgument(format!(
                        "{what}: the convex hull of {} points is degenerate (flat or fewer than 4 points)",
                        p.len()
                    ))
                })?
            }
            Self::ConvexDecomposition {
                vertices,
                triangles,
            } => {
                let v = points(what, vertices)?;
                check_triangles(what, v.len(), triangles)?;
                SharedShape::convex_decomposition(&v, triangles)
            }
            Self::TriMesh {
                vertices,
                triangles,
            } => {
                let v = points(what, vertices)?;
                check_triangles(what, v.len(), triangles)?;
                SharedShape::trimesh(v, triangles.clone()).map_err(|e| {
                    SimError::InvalidArgument(format!("{what}: invalid triangle mesh: {e}"))
                })?
            }
        })
    }
}

/// The rotation taking parry's y-axis cylinders to z-axis cylinders.
pub(crate) fn y_to_z() -> rapier3d::math::Pose {
    rapier3d::math::Pose::from_rotation(rapier3d::math::Rotation::from_rotation_x(
        std::f32::consts::FRAC_PI_2,
    ))
}

/// A collider builder for `shape` with the material of `desc` (mass set
/// through the density so that the collider carries the whole mass).
pub(crate) fn collider_for(desc: &ObjectDesc, shape: SharedShape) -> Result<ColliderBuilder> {
    let mut b = ColliderBuilder::new(shape.clone())
        .friction(desc.friction as f32)
        .restitution(desc.restitution as f32);
    if !desc.is_static {
        let volume = shape.mass_properties(1.0).mass();
        if !(volume.is_finite() && volume > 0.0) {
            return Err(SimError::InvalidArgument(format!(
                "object '{}': the shape has no volume, it cannot be dynamic",
                desc.name
            )));
        }
        b = b.density(desc.mass as f32 / volume);
    }
    Ok(b)
}
