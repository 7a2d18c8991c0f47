//! The allowed-collision matrix: link pairs never checked against each
//! other, from adjacency, rigid attachment and the SRDF. It only reads the
//! model, so it lives here (the simulator uses it to filter contacts); the
//! automatic analysis that samples configurations against a sphere model
//! (as MoveIt's setup assistant does) is `ferrobot_collision::AnalyzeCollisions`.

use std::collections::BTreeMap;

use crate::model::RobotModel;

/// Link pairs (link indices, smaller first) excluded from self-collision
/// checks, each with its reason.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AllowedCollisions {
    pairs: BTreeMap<(usize, usize), String>,
}

fn key(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

impl AllowedCollisions {
    /// Pairs joined by a joint (`Adjacent`), pairs that cannot move relative
    /// to each other (`Rigid`: only fixed joints between them), and the SRDF's
    /// `disable_collisions` pairs (with their reasons).
    pub fn from_model(model: &RobotModel) -> Self {
        let mut acm = Self::default();
        for j in model.joints() {
            acm.allow(j.parent, j.child, "Adjacent");
        }
        // Rigid groups: links joined only by fixed joints.
        let n = model.links().len();
        let mut group: Vec<usize> = (0..n).collect();
        for (l, link) in model.links().iter().enumerate() {
            if let Some(j) = link.parent_joint {
                let joint = &model.joints()[j];
                if !joint.kind.is_movable() {
                    group[l] = group[joint.parent];
                }
            }
        }
        for a in 0..n {
            for b in a + 1..n {
                if group[a] == group[b] && !acm.is_allowed(a, b) {
                    acm.allow(a, b, "Rigid");
                }
            }
        }
        for (a, b, reason) in model.disabled_collision_pairs() {
            acm.allow(a, b, if reason.is_empty() { "SRDF" } else { &reason });
        }
        acm
    }

    /// Excludes the pair `(a, b)`.
    pub fn allow(&mut self, a: usize, b: usize, reason: &str) {
        if a != b {
            self.pairs
                .entry(key(a, b))
                .or_insert_with(|| reason.to_string());
        }
    }

    /// Checks the pair `(a, b)` again.
    pub fn disallow(&mut self, a: usize, b: usize) {
        self.pairs.remove(&key(a, b));
    }

    /// Whether the pair is excluded.
    pub fn is_allowed(&self, a: usize, b: usize) -> bool {
        a == b || self.pairs.contains_key(&key(a, b))
    }

    /// The excluded pairs with their reasons.
    pub fn pairs(&self) -> impl Iterator<Item = (usize, usize, &str)> {
        self.pairs.iter().map(|(&(a, b), r)| (a, b, r.as_str()))
    }

    /// The pairs as SRDF `<disable_collisions>` elements (to save next to
    /// the robot; load them with the SRDF).
    pub fn to_srdf(&self, model: &RobotModel) -> String {
        let mut out = format!(
            "<?xml version=\"1.0\"?>\n<robot name=\"{}\">\n",
            model.name()
        );
        for (a, b, reason) in self.pairs() {
            out.push_str(&format!(
                "  <disable_collisions link1=\"{}\" link2=\"{}\" reason=\"{}\"/>\n",
                model.links()[a].name,
                model.links()[b].name,
                reason
            ));
        }
        out.push_str("</robot>\n");
        out
    }
}
