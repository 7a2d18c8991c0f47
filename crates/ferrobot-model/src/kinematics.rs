//! Forward kinematics and Jacobians on a model: single, all links, batched.

use nalgebra::Isometry3;
use rayon::prelude::*;

use crate::error::{ModelError, Result};
use crate::model::RobotModel;

/// A pose as `[x, y, z, qw, qx, qy, qz]` with `qw >= 0`.
pub fn pose_to_array(pose: &Isometry3<f64>) -> [f64; 7] {
    let t = pose.translation.vector;
    let q = pose.rotation.coords; // (x, y, z, w)
    let s = if q[3] < 0.0 { -1.0 } else { 1.0 };
    [t.x, t.y, t.z, s * q[3], s * q[0], s * q[1], s * q[2]]
}

/// A pose as a row-major 4x4 homogeneous matrix.
pub fn pose_to_matrix(pose: &Isometry3<f64>) -> [f64; 16] {
    let m = pose.to_homogeneous();
    let mut out = [0.0; 16];
    for r in 0..4 {
        for c in 0..4 {
            out[r * 4 + c] = m[(r, c)];
        }
    }
    out
}

/// Configurations per rayon task in batched calls.
const BATCH_CHUNK: usize = 256;

impl RobotModel {
    /// Pose of `link` (default: the end effector) in the base frame.
    pub fn fk(&self, q: &[f64], link: Option<usize>) -> Result<Isometry3<f64>> {
        self.check_configuration("q", q)?;
        Ok(self.chain(link.unwrap_or(self.ee)).pose(q))
    }

    /// Pose of every link in the base frame, in link order.
    pub fn fk_all(&self, q: &[f64]) -> Result<Vec<Isometry3<f64>>> {
        self.check_configuration("q", q)?;
        let mut poses = Vec::with_capacity(self.links.len());
        poses.push(self.root_in_base);
        for joint in &self.joints {
            let local = joint.local_transform(joint.coupling.position(q).unwrap_or(0.0));
            poses.push(poses[joint.parent] * local);
        }
        Ok(poses)
    }

    /// Poses of `link` for `n` configurations stored row-major in `qs`
    /// (`n * num_dof` values), as `n * 7` values `[x, y, z, qw, qx, qy, qz]`.
    /// Runs on the rayon pool.
    pub fn fk_batch(&self, qs: &[f64], link: Option<usize>) -> Result<Vec<f64>> {
        let dof = self.num_dof();
        if dof == 0 || !qs.len().is_multiple_of(dof) {
            return Err(ModelError::Shape {
                what: "q".into(),
                expected: format!("(N, {dof})"),
                got: format!("{} values", qs.len()),
            });
        }
        crate::error::check_finite("q", qs)?;
        let mut out = vec![0.0; qs.len() / dof * 7];
        self.fk_batch_into(qs, link, &mut out);
        Ok(out)
    }

    /// [`RobotModel::fk_batch`] into `out` (`n * 7` values) for inputs the
    /// caller has already checked (whole rows, finite values).
    ///
    /// # Panics
    /// If `out.len() / 7 != qs.len() / num_dof`.
    pub fn fk_batch_into(&self, qs: &[f64], link: Option<usize>, out: &mut [f64]) {
        let dof = self.num_dof();
        let chain = self.chain(link.unwrap_or(self.ee));
        if dof == 0 {
            let pose = pose_to_array(&chain.pose(&[]));
            out.chunks_exact_mut(7)
                .for_each(|o| o.copy_from_slice(&pose));
            return;
        }
        assert_eq!(out.len() / 7, qs.len() / dof, "fk_batch_into: output size");
        out.par_chunks_mut(7 * BATCH_CHUNK)
            .zip(qs.par_chunks(dof * BATCH_CHUNK))
            .for_each(|(o, q)| {
                for (o, q) in o.chunks_exact_mut(7).zip(q.chunks_exact(dof)) {
                    o.copy_from_slice(&pose_to_array(&chain.pose(q)));
                }
            });
    }

    /// Geometric Jacobian (6 x num_dof, row-major; rows linear then angular)
    /// of the origin of `link` (default: the end effector), in the base frame.
    pub fn jacobian(&self, q: &[f64], link: Option<usize>) -> Result<Vec<f64>> {
        self.check_configuration("q", q)?;
        let mut out = vec![0.0; 6 * self.num_dof()];
        self.chain(link.unwrap_or(self.ee))
            .jacobian_into(q, self.num_dof(), &mut out);
        Ok(out)
    }
}
