//! Contact filtering of robot links by the model's allowed-collision matrix.

use std::collections::HashSet;

use rapier3d::prelude::{PairFilterContext, PhysicsHooks, SolverFlags};

/// Encodes a collider's identity in its `user_data`: bits 0..32 the
/// segmentation id, bits 32..64 the robot index + 1 (0: not a robot), bits
/// 64..96 the model link index.
pub fn user_data(seg: u32, robot: Option<usize>, link: usize) -> u128 {
    let r = robot.map_or(0, |r| r as u128 + 1);
    (seg as u128) | (r << 32) | ((link as u128) << 64)
}

/// The segmentation id stored by [`user_data`].
pub fn seg_of(data: u128) -> u32 {
    (data & 0xffff_ffff) as u32
}

/// The (robot, link) stored by [`user_data`], if the collider is a robot's.
pub fn robot_link_of(data: u128) -> Option<(usize, usize)> {
    let r = ((data >> 32) & 0xffff_ffff) as usize;
    (r > 0).then(|| (r - 1, ((data >> 64) & 0xffff_ffff) as usize))
}

/// Filters contacts between two links of one robot whose pair the robot's
/// allowed-collision matrix excludes (adjacent, rigidly attached or SRDF
/// disabled pairs). Other pairs collide normally.
#[derive(Debug, Clone, Default)]
pub struct LinkFilter {
    /// Excluded (robot, link a, link b) with a < b.
    pub allowed: HashSet<(usize, usize, usize)>,
}

impl PhysicsHooks for LinkFilter {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        let c1 = &context.colliders[context.collider1];
        let c2 = &context.colliders[context.collider2];
        if let (Some((r1, l1)), Some((r2, l2))) =
            (robot_link_of(c1.user_data), robot_link_of(c2.user_data))
            && r1 == r2
            && (l1 == l2 || self.allowed.contains(&(r1, l1.min(l2), l1.max(l2))))
        {
            return None;
        }
        Some(SolverFlags::COMPUTE_RIGID_IMPULSES)
    }
}
