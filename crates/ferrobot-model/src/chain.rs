//! A compiled kinematic chain: the movable joints from the base to one link,
//! with fixed transforms folded in, for fast forward kinematics and Jacobians.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::joint::{Joint, JointKind};

/// One movable joint of a chain.
#[derive(Debug, Clone)]
struct Segment {
    /// Transform from the previous segment's moving frame to this joint's
    /// frame (fixed joints and the joint origin folded together).
    pre: Isometry3<f64>,
    /// Unit axis in the joint frame.
    axis: Vector3<f64>,
    /// Translation (true) or rotation (false) along/about the axis.
    prismatic: bool,
    /// Driving DOF and mimic gain/offset: `q_joint = gain * q[dof] + offset`.
    dof: usize,
    gain: f64,
    offset: f64,
}

/// The pose of one link as a function of the DOF vector.
#[derive(Debug, Clone)]
pub struct KinematicChain {
    segments: Vec<Segment>,
    tip: Isometry3<f64>,
}

impl KinematicChain {
    /// Compiles the chain through `path` (joint indices from the root to the
    /// link, in order), with `prefix` applied first (e.g. the inverse of the
    /// base link's pose, to express the result in the base frame).
    pub fn compile(joints: &[Joint], path: &[usize], prefix: Isometry3<f64>) -> Self {
        let mut segments = Vec::new();
        let mut pending = prefix;
        for &j in path {
            let joint = &joints[j];
            match (joint.kind, joint.coupling.driver()) {
                (JointKind::Fixed, _) | (_, None) => pending *= joint.origin,
                (kind, Some((dof, gain))) => {
                    let offset = match joint.coupling {
                        crate::joint::JointCoupling::Mimic { offset, .. } => offset,
                        _ => 0.0,
                    };
                    segments.push(Segment {
                        pre: pending * joint.origin,
                        axis: joint.axis.into_inner(),
                        prismatic: kind == JointKind::Prismatic,
                        dof,
                        gain,
                        offset,
                    });
                    pending = Isometry3::identity();
                }
            }
        }
        Self {
            segments,
            tip: pending,
        }
    }

    /// Number of movable joints along the chain.
    pub fn len(&self) -> usize {
        self.segments.len()
    }

    /// Whether the link is fixed to the base (no movable joint on the way).
    pub fn is_empty(&self) -> bool {
        self.segments.is_empty()
    }

    /// The DOFs that move the link (with repeats for mimic joints).
    pub fn dofs(&self) -> impl Iterator<Item = usize> + '_ {
        self.segments.iter().map(|s| s.dof)
    }

    /// Pose of the link for the DOF vector `q` (which must be long enough).
    #[inline]
    pub fn pose(&self, q: &[f64]) -> Isometry3<f64> {
        let mut rot = UnitQuaternion::identity();
        let mut pos = Vector3::zeros();
        for s in &self.segments {
            pos += rot * s.pre.translation.vector;
            rot *= s.pre.rotation;
            let qj = s.gain * q[s.dof] + s.offset;
            if s.prismatic {
                pos += rot * (s.axis * qj);
            } else {
                let (sin, cos) = (0.5 * qj).sin_cos();
                let v = s.axis * sin;
                rot *= UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(cos, v.x, v.y, v.z));
            }
        }
        pos += rot * self.tip.translation.vector;
        rot *= self.tip.rotation;
        Isometry3::from_parts(Translation3::from(pos), rot)
    }

    /// Geometric Jacobian of the link origin in the base frame, written into
    /// `out` as a row-major 6 x `num_dof` matrix (rows: linear x, y, z, then
    /// angular x, y, z), which must hold zeros on entry. Returns the pose.
    pub fn jacobian_into(&self, q: &[f64], num_dof: usize, out: &mut [f64]) -> Isometry3<f64> {
        // Joint frames first (position and world axis), then the tip.
        let mut rot = UnitQuaternion::identity();
        let mut pos = Vector3::zeros();
        // Joint frames on the stack for chains of up to 32 joints (no
        // allocation in IK loops), on the heap beyond.
        let n = self.segments.len();
        let mut stack = [(Vector3::zeros(), Vector3::zeros()); 32];
        let mut heap = Vec::new();
        let frames: &mut [(Vector3<f64>, Vector3<f64>)] = if n <= stack.len() {
            &mut stack[..n]
        } else {
            heap.resize(n, (Vector3::zeros(), Vector3::zeros()));
            &mut heap
        };
        for (s, frame) in self.segments.iter().zip(frames.iter_mut()) {
            pos += rot * s.pre.translation.vector;
            rot *= s.pre.rotation;
            *frame = (pos, rot * s.axis);
            let qj = s.gain * q[s.dof] + s.offset;
            if s.prismatic {
                pos += rot * (s.axis * qj);
            } else {
                // The unit axis' half-angle quaternion, as in `pose` (no
                // norm or division: `from_scaled_axis` up to rounding).
                let (sin, cos) = (0.5 * qj).sin_cos();
                let v = s.axis * sin;
                rot *= UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(cos, v.x, v.y, v.z));
            }
        }
        pos += rot * self.tip.translation.vector;
        rot *= self.tip.rotation;
        for (s, (origin, z)) in self.segments.iter().zip(frames.iter()) {
            let (lin, ang) = if s.prismatic {
                (*z, Vector3::zeros())
            } else {
                (z.cross(&(pos - origin)), *z)
            };
            for r in 0..3 {
                out[r * num_dof + s.dof] += s.gain * lin[r];
                out[(r + 3) * num_dof + s.dof] += s.gain * ang[r];
            }
        }
        Isometry3::from_parts(Translation3::from(pos), rot)
    }
}
