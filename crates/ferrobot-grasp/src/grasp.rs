//! Grasps and groups of grasps in graspnetAPI's layout.

use nalgebra::{Matrix3, Vector3};

use crate::error::{GraspError, Result};

/// Number of columns of a grasp row:
/// `[score, width, height, depth, rotation (9, row-major), translation (3), object_id]`.
pub const GRASP_COLUMNS: usize = 17;

/// One parallel-jaw grasp. The rotation's columns are the gripper's axes
/// (x approach, y closing, z = x × y) in the cloud's frame; a point `p` of
/// the gripper frame is at `rotation * p + translation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grasp {
    /// Quality in (0, 1]; higher is better.
    pub score: f64,
    /// Opening between the fingers, metres.
    pub width: f64,
    /// Finger size along z, metres.
    pub height: f64,
    /// How far the fingertips reach beyond the translation along x, metres.
    pub depth: f64,
    /// Gripper orientation (columns: approach, closing, z).
    pub rotation: Matrix3<f64>,
    /// Grasp centre.
    pub translation: Vector3<f64>,
    /// Segmentation id of the grasped object; -1 when unknown.
    pub object_id: i32,
}

impl Grasp {
    /// The 17-value row of this grasp.
    pub fn to_row(&self) -> [f64; GRASP_COLUMNS] {
        let mut r = [0.0; GRASP_COLUMNS];
        r[0] = self.score;
        r[1] = self.width;
        r[2] = self.height;
        r[3] = self.depth;
        for i in 0..3 {
            for j in 0..3 {
                r[4 + 3 * i + j] = self.rotation[(i, j)];
            }
            r[13 + i] = self.translation[i];
        }
        r[16] = f64::from(self.object_id);
        r
    }

    /// A grasp from a 17-value row (the rotation is taken as given).
    pub fn from_row(r: &[f64]) -> Result<Self> {
        if r.len() != GRASP_COLUMNS {
            return Err(GraspError::Shape(format!(
                "grasp row: expected {GRASP_COLUMNS} values, got {}",
                r.len()
            )));
        }
        if let Some(i) = r.iter().position(|v| !v.is_finite()) {
            return Err(GraspError::NonFinite(format!(
                "grasp row: non-finite value at column {i}"
            )));
        }
        Ok(Self {
            score: r[0],
            width: r[1],
            height: r[2],
            depth: r[3],
            rotation: Matrix3::from_fn(|i, j| r[4 + 3 * i + j]),
            translation: Vector3::new(r[13], r[14], r[15]),
            object_id: r[16].round() as i32,
        })
    }
}

/// An ordered collection of grasps.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GraspGroup {
    /// The grasps.
    pub grasps: Vec<Grasp>,
}

impl GraspGroup {
    /// Number of grasps.
    pub fn len(&self) -> usize {
        self.grasps.len()
    }

    /// Whether there are no grasps.
    pub fn is_empty(&self) -> bool {
        self.grasps.is_empty()
    }

    /// Sorts by score, best first (stable).
    pub fn sort_by_score(&mut self) {
        self.grasps.sort_by(|a, b| b.score.total_cmp(&a.score));
    }

    /// Rows of 17 values, concatenated (row-major `(len, 17)`).
    pub fn to_array(&self) -> Vec<f64> {
        self.grasps.iter().flat_map(|g| g.to_row()).collect()
    }

    /// A group from row-major `(n, 17)` values.
    pub fn from_array(values: &[f64]) -> Result<Self> {
        if !values.len().is_multiple_of(GRASP_COLUMNS) {
            return Err(GraspError::Shape(format!(
                "grasp array: {} values is not a multiple of {GRASP_COLUMNS}",
                values.len()
            )));
        }
        let grasps = values
            .chunks(GRASP_COLUMNS)
            .map(Grasp::from_row)
            .collect::<Result<_>>()?;
        Ok(Self { grasps })
    }
}
