//! Rigid objects: shapes, materials and how they become Rapier colliders.

use ferrobot_geometry::{MeshAs, Shape};
use nalgebra::Isometry3;
use rapier3d::prelude::{ColliderBuilder, SharedShape};

use crate::error::{Result, SimError, check_finite};

/// Everything that describes an object to add to a world.
#[derive(Debug, Clone)]
pub struct ObjectDesc {
    /// Unique name in the world.
    pub name: String,
    /// Shape (the one geometry vocabulary; a [`Shape::Mesh`] only on a
    /// static object, a point cloud never).
    pub shape: Shape,
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
    pub fn new(name: impl Into<String>, shape: Shape, pose: Isometry3<f64>) -> Self {
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
        if matches!(self.shape, Shape::Mesh(_)) && !self.is_static {
            return Err(SimError::InvalidArgument(format!(
                "object '{n}': a raw triangle mesh can only be static; use a convex hull or a convex decomposition for a dynamic object"
            )));
        }
        Ok(())
    }
}

/// The Rapier shape of an object's [`Shape`] (meshes as triangle meshes,
/// cylinders wrapped with their y-to-z rotation), validated; `what` names
/// the object in errors.
pub fn shared_shape(shape: &Shape, what: &str) -> Result<SharedShape> {
    shape.validate(what).map_err(crate::error::geometry_err)?;
    shape
        .to_shared_shape(MeshAs::TriMesh)
        .map_err(|e| crate::error::geometry_err(e).context(what))
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
