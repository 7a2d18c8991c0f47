//! Joints: type, origin, axis, limits and mimic coupling.

use nalgebra::{Isometry3, Unit, Vector3};

/// The kinds of joint a model supports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Rotation about the axis, within position limits.
    Revolute,
    /// Rotation about the axis without position limits.
    Continuous,
    /// Translation along the axis.
    Prismatic,
    /// No motion.
    Fixed,
}

impl JointKind {
    /// The name used in URDF.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Revolute => "revolute",
            Self::Continuous => "continuous",
            Self::Prismatic => "prismatic",
            Self::Fixed => "fixed",
        }
    }

    /// Whether the joint moves (has a coordinate).
    pub fn is_movable(self) -> bool {
        self != Self::Fixed
    }

    /// Whether the joint rotates (revolute or continuous).
    pub fn is_rotational(self) -> bool {
        matches!(self, Self::Revolute | Self::Continuous)
    }
}

/// Position, velocity and effort limits of a joint.
///
/// Defaults where a URDF omits them: a continuous joint has position limits
/// `[-inf, inf]`; a `<limit>` without `velocity` or `effort` gives `inf`
/// ("no limit stated"); consumers such as the planner substitute their own
/// finite defaults where they need one. Fixed joints carry zeros.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimits {
    /// Lower position limit (rad or m).
    pub lower: f64,
    /// Upper position limit (rad or m).
    pub upper: f64,
    /// Velocity limit (rad/s or m/s).
    pub velocity: f64,
    /// Effort limit (N·m or N).
    pub effort: f64,
}

impl JointLimits {
    /// Limits of a joint that does not move.
    pub const FIXED: Self = Self {
        lower: 0.0,
        upper: 0.0,
        velocity: 0.0,
        effort: 0.0,
    };
}

/// A `<mimic>` element as written: this joint follows `joint`.
#[derive(Debug, Clone, PartialEq)]
pub struct Mimic {
    /// The joint followed.
    pub joint: String,
    /// `q = multiplier * q_joint + offset`; default 1.
    pub multiplier: f64,
    /// Default 0.
    pub offset: f64,
}

/// How a joint's coordinate is obtained from the model's DOF vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointCoupling {
    /// The joint does not move.
    Fixed,
    /// The joint is DOF number `dof` (an index into `dof_names`).
    Dof(usize),
    /// The joint follows DOF `dof`: `q = multiplier * q[dof] + offset`
    /// (chains of mimics are resolved to the independent DOF).
    Mimic {
        /// Index of the independent DOF followed.
        dof: usize,
        /// Gain.
        multiplier: f64,
        /// Offset (rad or m).
        offset: f64,
    },
}

impl JointCoupling {
    /// The joint coordinate for the DOF vector `q`, or `None` for a fixed joint.
    #[inline]
    pub fn position(&self, q: &[f64]) -> Option<f64> {
        match *self {
            Self::Fixed => None,
            Self::Dof(i) => Some(q[i]),
            Self::Mimic {
                dof,
                multiplier,
                offset,
            } => Some(multiplier * q[dof] + offset),
        }
    }

    /// The DOF that drives the joint and the gain `d q_joint / d q_dof`.
    #[inline]
    pub fn driver(&self) -> Option<(usize, f64)> {
        match *self {
            Self::Fixed => None,
            Self::Dof(i) => Some((i, 1.0)),
            Self::Mimic {
                dof, multiplier, ..
            } => Some((dof, multiplier)),
        }
    }
}

/// A joint of the kinematic tree.
#[derive(Debug, Clone)]
pub struct Joint {
    /// Name as in the URDF.
    pub name: String,
    /// Kind of motion.
    pub kind: JointKind,
    /// Index of the parent link in the model's `links`.
    pub parent: usize,
    /// Index of the child link in the model's `links`.
    pub child: usize,
    /// Pose of the joint frame in the parent link frame (at zero position).
    pub origin: Isometry3<f64>,
    /// Unit axis in the joint frame (meaningless for fixed joints).
    pub axis: Unit<Vector3<f64>>,
    /// Limits.
    pub limits: JointLimits,
    /// The `<mimic>` element as written, if any.
    pub mimic: Option<Mimic>,
    /// How the coordinate derives from the DOF vector.
    pub coupling: JointCoupling,
    /// Viscous damping from `<dynamics>` (N·m·s/rad or N·s/m), 0 if absent.
    pub damping: f64,
    /// Coulomb friction from `<dynamics>` (N·m or N), 0 if absent.
    pub friction: f64,
}

impl Joint {
    /// The transform from the parent link frame to the child link frame for
    /// joint coordinate `q` (ignored for fixed joints).
    #[inline]
    pub fn local_transform(&self, q: f64) -> Isometry3<f64> {
        match self.kind {
            JointKind::Fixed => self.origin,
            JointKind::Revolute | JointKind::Continuous => {
                self.origin * nalgebra::UnitQuaternion::from_axis_angle(&self.axis, q)
            }
            JointKind::Prismatic => {
                self.origin * nalgebra::Translation3::from(self.axis.into_inner() * q)
            }
        }
    }
}
