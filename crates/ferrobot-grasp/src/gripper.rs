//! The parallel-jaw gripper's geometry and its collision test against a
//! cloud, in the gripper frame (x approach, y closing, z = x × y; origin at
//! the grasp translation, fingertips at x = depth).
//!
//! Each finger is a box x ∈ [depth - finger_depth, depth],
//! y ∈ [w/2, w/2 + finger_width] (and mirrored), |z| ≤ height/2; the palm is a
//! box of thickness `finger_width` behind the fingers spanning both; the
//! approach corridor is the palm's cross-section swept `approach_distance`
//! further back (the hand must get there). The closing region is the space
//! between the fingers.

use nalgebra::Vector3;

use crate::error::{Result, positive};

/// Dimensions of a parallel-jaw gripper as the detector models it, in
/// metres. The defaults describe the Franka Panda hand; for any gripper,
/// derive it from the one gripper description with [`Self::from_gripper`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GripperGeometry {
    /// Largest opening between the fingers' inner faces (Panda: 0.08).
    pub max_width: f64,
    /// Length of the fingers along the approach direction.
    pub finger_depth: f64,
    /// Thickness of each finger along the closing direction.
    pub finger_width: f64,
    /// Size of the fingers along z (perpendicular to approach and closing).
    pub height: f64,
    /// How far behind the palm the hand's path must be free.
    pub approach_distance: f64,
    /// Free space kept between the object and each finger when open
    /// (default 2 mm; 5 mm excluded many good grasps in the simulated
    /// evaluation, `benches/grasp_eval.py`).
    pub clearance: f64,
    /// Size of the hand's body (the housing the fingers slide in) along the
    /// closing axis (Panda: 0.208). The body is a box centred on the
    /// fingers, from the fingers' base back `palm_depth`; it is checked
    /// against the support plane (a hand whose housing would hit the table
    /// is rejected) and, with `DetectOptions::body_collision`, against
    /// every point of the cloud.
    pub palm_width: f64,
    /// Size of the hand's body along z (Panda: 0.063).
    pub palm_height: f64,
    /// Size of the hand's body along the approach (Panda: 0.092).
    pub palm_depth: f64,
}

impl Default for GripperGeometry {
    fn default() -> Self {
        Self {
            max_width: 0.08,
            finger_depth: 0.05,
            finger_width: 0.01,
            height: 0.02,
            approach_distance: 0.03,
            clearance: 0.002,
            palm_width: 0.208,
            palm_height: 0.063,
            palm_depth: 0.092,
        }
    }
}

/// How much the hand's solid parts are grown for collision against a cloud
/// of voxel centroids of size `voxel_size`: a centroid lies up to about half
/// a voxel and more from the surface it stands for.
pub fn body_margin(voxel_size: f64) -> f64 {
    0.75 * voxel_size
}

impl GripperGeometry {
    /// The detector's hand for `gripper` (the one gripper description,
    /// `ferrobot_model::Gripper`): its largest opening, finger and palm
    /// dimensions; approach distance and clearance keep their defaults.
    pub fn from_gripper(gripper: &ferrobot_model::Gripper) -> Self {
        let f = &gripper.fingers;
        Self {
            max_width: gripper.max_opening(),
            finger_depth: f.depth,
            finger_width: f.thickness,
            height: f.height,
            palm_width: f.palm_width,
            palm_height: f.palm_height,
            palm_depth: f.palm_depth,
            ..Self::default()
        }
    }
}

/// Where a point lies relative to a placed hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Region {
    /// Outside the hand and its closing region.
    Free,
    /// Between the fingers.
    Closing,
    /// Inside a finger, the palm or the approach corridor.
    Collision,
}

impl GripperGeometry {
    /// Checks every dimension is positive and finite (clearance and approach
    /// distance may be 0).
    pub fn validate(&self) -> Result<()> {
        positive("gripper max_width", self.max_width)?;
        positive("gripper finger_depth", self.finger_depth)?;
        positive("gripper finger_width", self.finger_width)?;
        positive("gripper height", self.height)?;
        positive("gripper palm_width", self.palm_width)?;
        positive("gripper palm_height", self.palm_height)?;
        positive("gripper palm_depth", self.palm_depth)?;
        for (what, v) in [
            ("gripper approach_distance", self.approach_distance),
            ("gripper clearance", self.clearance),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(crate::GraspError::InvalidArgument(format!(
                    "{what} must be finite and >= 0, got {v}"
                )));
            }
        }
        Ok(())
    }

    /// Classifies the point `p` (gripper frame of a hand at the origin whose
    /// fingers are centred on y = `yc`, open to `width`, fingertips at
    /// x = `depth`), with the solid parts grown by `margin` on every side
    /// (points stand for voxels; the closing region is not grown).
    pub fn region(&self, p: &Vector3<f64>, depth: f64, width: f64, yc: f64, margin: f64) -> Region {
        let y = p.y - yc;
        let half = width / 2.0;
        let base = depth - self.finger_depth;
        if p.z.abs() <= self.height / 2.0
            && p.x >= base + margin
            && p.x <= depth
            && y.abs() < half - margin
        {
            return Region::Closing;
        }
        if p.z.abs() > self.height / 2.0 + margin
            || p.x > depth + margin
            || y.abs() > half + self.finger_width + margin
            || p.x < base - self.finger_width - self.approach_distance - margin
        {
            return Region::Free;
        }
        if p.x < base + margin || y.abs() >= half - margin {
            return Region::Collision;
        }
        // Between the fingers but beyond the closing region's z extent.
        Region::Free
    }

    /// Whether any of `points` (gripper frame) is inside the hand grown by `margin`.
    pub fn collides(
        &self,
        points: &[Vector3<f64>],
        depth: f64,
        width: f64,
        yc: f64,
        margin: f64,
    ) -> bool {
        points
            .iter()
            .any(|p| self.region(p, depth, width, yc, margin) == Region::Collision)
    }

    /// Whether any of `points` is [`Region::Collision`] for this hand, and
    /// how many are [`Region::Closing`] (the count is complete only when
    /// there is no collision): [`Self::region`] restated without branches
    /// and checked in blocks, which is what the hand search runs per hand.
    ///
    /// A point collides when it is inside the hand's outer box (grown by
    /// `margin`) and either behind the fingers' base + `margin` or within
    /// `margin` of a finger's inner face or beyond it; a closing-region
    /// point satisfies neither, so the two tests never overlap.
    pub fn collision_and_closing(
        &self,
        points: &[Vector3<f64>],
        depth: f64,
        width: f64,
        yc: f64,
        margin: f64,
    ) -> (bool, usize) {
        let half = width / 2.0;
        let base = depth - self.finger_depth;
        let hz = self.height / 2.0;
        let back = base - self.finger_width - self.approach_distance - margin;
        let outer_y = half + self.finger_width + margin;
        let mut closing = 0usize;
        for block in points.chunks(32) {
            let mut hit = false;
            for p in block {
                let y = (p.y - yc).abs();
                let z = p.z.abs();
                let outer =
                    (z <= hz + margin) & (p.x <= depth + margin) & (y <= outer_y) & (p.x >= back);
                let solid = (p.x < base + margin) | (y >= half - margin);
                hit |= outer & solid;
                let inside =
                    (z <= hz) & (p.x >= base + margin) & (p.x <= depth) & (y < half - margin);
                closing += usize::from(inside);
            }
            if hit {
                return (true, closing);
            }
        }
        (false, closing)
    }

    /// [`Self::collision_and_closing`] on points stored one array per axis
    /// (`xs`, `ys`, `zs`, equal lengths): the same tests in the same blocks
    /// of 32, in a loop the compiler vectorises.
    #[allow(clippy::too_many_arguments)]
    pub fn collision_and_closing_xyz(
        &self,
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        depth: f64,
        width: f64,
        yc: f64,
        margin: f64,
    ) -> (bool, usize) {
        let half = width / 2.0;
        let base = depth - self.finger_depth;
        let hz = self.height / 2.0;
        let back = base - self.finger_width - self.approach_distance - margin;
        let outer_y = half + self.finger_width + margin;
        let (hz_out, x_out, x_solid, y_solid) =
            (hz + margin, depth + margin, base + margin, half - margin);
        let mut closing = 0usize;
        for ((bx, by), bz) in xs.chunks(32).zip(ys.chunks(32)).zip(zs.chunks(32)) {
            let mut hit = false;
            let mut inside_n = 0usize;
            for ((&x, &y), &z) in bx.iter().zip(by).zip(bz) {
                let y = (y - yc).abs();
                let z = z.abs();
                let outer = (z <= hz_out) & (x <= x_out) & (y <= outer_y) & (x >= back);
                let solid = (x < x_solid) | (y >= y_solid);
                hit |= outer & solid;
                let inside = (z <= hz) & (x >= x_solid) & (x <= depth) & (y < y_solid);
                inside_n += usize::from(inside);
            }
            closing += inside_n;
            if hit {
                return (true, closing);
            }
        }
        (false, closing)
    }

    /// The hand's solid boxes as (min, max) corners in the gripper frame:
    /// left finger, right finger, and palm with the approach corridor.
    pub fn boxes(&self, depth: f64, width: f64, yc: f64) -> [(Vector3<f64>, Vector3<f64>); 3] {
        let half = width / 2.0;
        let outer = half + self.finger_width;
        let hz = self.height / 2.0;
        let base = depth - self.finger_depth;
        let back = base - self.finger_width - self.approach_distance;
        [
            (
                Vector3::new(base, yc - outer, -hz),
                Vector3::new(depth, yc - half, hz),
            ),
            (
                Vector3::new(base, yc + half, -hz),
                Vector3::new(depth, yc + outer, hz),
            ),
            (
                Vector3::new(back, yc - outer, -hz),
                Vector3::new(base, yc + outer, hz),
            ),
        ]
    }

    /// The hand's body as a (min, max) box in the gripper frame: centred on
    /// the fingers (y = `yc`, z = 0), from the fingers' base
    /// (x = `depth` - `finger_depth`) back by `palm_depth`.
    pub fn body_box(&self, depth: f64, yc: f64) -> (Vector3<f64>, Vector3<f64>) {
        let base = depth - self.finger_depth;
        let (hy, hz) = (self.palm_width / 2.0, self.palm_height / 2.0);
        (
            Vector3::new(base - self.palm_depth, yc - hy, -hz),
            Vector3::new(base, yc + hy, hz),
        )
    }

    /// Radius of a ball around the grasp origin that holds the whole hand
    /// (at any opening and centring used by the search) for depths up to
    /// `max_depth`.
    pub fn reach(&self, max_depth: f64) -> f64 {
        let back = self.finger_depth + self.finger_width + self.approach_distance;
        let x = max_depth.abs().max(back);
        let y = self.max_width + self.finger_width;
        (x * x + y * y + self.height * self.height / 4.0).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_from_the_gripper_description() {
        let panda = GripperGeometry::from_gripper(&ferrobot_model::Gripper::panda_hand());
        assert_eq!(panda, GripperGeometry::default());
        let g = GripperGeometry::from_gripper(&ferrobot_model::Gripper::robotiq_2f85());
        assert!((g.max_width - 0.085).abs() < 2e-4);
        g.validate().unwrap();
    }

    #[test]
    fn regions() {
        let g = GripperGeometry::default();
        let r = |x, y, z| g.region(&Vector3::new(x, y, z), 0.02, 0.06, 0.0, 0.0);
        assert_eq!(r(0.0, 0.0, 0.0), Region::Closing);
        assert_eq!(r(0.0, 0.035, 0.0), Region::Collision);
        assert_eq!(r(0.0, 0.045, 0.0), Region::Free);
        assert_eq!(r(0.03, 0.0, 0.0), Region::Free);
        assert_eq!(r(-0.035, 0.0, 0.0), Region::Collision); // palm
        assert_eq!(r(-0.07, 0.0, 0.0), Region::Collision); // corridor
        assert_eq!(r(-0.1, 0.0, 0.0), Region::Free);
        assert_eq!(r(0.0, 0.0, 0.011), Region::Free);
    }

    #[test]
    fn block_test_agrees_with_regions() {
        // Points on a grid through and around a hand, including the
        // regions' boundaries: the block test must give what region() gives.
        let g = GripperGeometry::default();
        let (depth, width, yc, m) = (0.03, 0.05, 0.004, 0.00375);
        let mut pts = Vec::new();
        for i in -70..=25 {
            for j in -40..=40 {
                for k in -8..=8 {
                    pts.push(Vector3::new(
                        0.0025 * i as f64,
                        yc + 0.0025 * j as f64,
                        0.0017 * k as f64,
                    ));
                }
            }
        }
        let mut all_closing = 0;
        for p in &pts {
            let r = g.region(p, depth, width, yc, m);
            let (hit, closing) =
                g.collision_and_closing(std::slice::from_ref(p), depth, width, yc, m);
            assert_eq!(hit, r == Region::Collision, "{p:?} {r:?}");
            assert_eq!(closing == 1, r == Region::Closing, "{p:?} {r:?}");
            all_closing += closing;
        }
        let free: Vec<_> = pts
            .iter()
            .copied()
            .filter(|p| g.region(p, depth, width, yc, m) != Region::Collision)
            .collect();
        assert_eq!(
            g.collision_and_closing(&free, depth, width, yc, m),
            (false, all_closing)
        );
        assert!(g.collision_and_closing(&pts, depth, width, yc, m).0);
        // The per-axis variant: the same verdict and count point by point
        // and over every prefix length around the blocks of 32 (the count
        // returned with a collision is that of the blocks read so far).
        let axis = |v: &[Vector3<f64>], k: usize| v.iter().map(|p| p[k]).collect::<Vec<f64>>();
        for p in &pts {
            let one = std::slice::from_ref(p);
            assert_eq!(
                g.collision_and_closing_xyz(&[p.x], &[p.y], &[p.z], depth, width, yc, m),
                g.collision_and_closing(one, depth, width, yc, m),
                "{p:?}"
            );
        }
        for v in [&free, &pts] {
            let (xs, ys, zs) = (axis(v, 0), axis(v, 1), axis(v, 2));
            for len in [0, 1, 31, 32, 33, 64, 65, 1000, v.len()] {
                let len = len.min(v.len());
                assert_eq!(
                    g.collision_and_closing_xyz(
                        &xs[..len],
                        &ys[..len],
                        &zs[..len],
                        depth,
                        width,
                        yc,
                        m
                    ),
                    g.collision_and_closing(&v[..len], depth, width, yc, m),
                    "{len}"
                );
            }
        }
    }
}
