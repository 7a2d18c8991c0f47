//! SRDF semantics on a model: validation, planning groups, named states.

use std::collections::BTreeSet;

use crate::error::{ModelError, Result};
use crate::model::RobotModel;
use crate::srdf::Srdf;

impl RobotModel {
    /// Checks that every name the SRDF uses exists in the model.
    pub(crate) fn validate_srdf(&self, srdf: &Srdf) -> Result<()> {
        let bad = |key: &str, what: String| Err(ModelError::srdf(srdf.location(key), what));
        for g in &srdf.groups {
            let key = format!("group:{}", g.name);
            for j in &g.joints {
                if !self.joint_index.contains_key(j) {
                    return bad(
                        &key,
                        format!(
                            "group '{}' names joint '{j}', which the URDF does not define",
                            g.name
                        ),
                    );
                }
            }
            for l in g
                .links
                .iter()
                .chain(g.chains.iter().flat_map(|(b, t)| [b, t]))
            {
                if !self.link_index.contains_key(l) {
                    return bad(
                        &key,
                        format!(
                            "group '{}' names link '{l}', which the URDF does not define",
                            g.name
                        ),
                    );
                }
            }
            for (base, tip) in &g.chains {
                let path = self.path_to(self.link_index[tip]);
                let b = self.link_index[base];
                if b != 0 && !path.iter().any(|&j| self.joints[j].child == b) {
                    return bad(
                        &key,
                        format!(
                            "group '{}': chain tip '{tip}' is not below base '{base}'",
                            g.name
                        ),
                    );
                }
            }
            for s in &g.subgroups {
                if srdf.group(s).is_none() {
                    return bad(
                        &key,
                        format!(
                            "group '{}' names subgroup '{s}', which is not defined",
                            g.name
                        ),
                    );
                }
            }
        }
        for s in &srdf.group_states {
            let key = format!("state:{}:{}", s.group, s.name);
            if srdf.group(&s.group).is_none() {
                return bad(
                    &key,
                    format!(
                        "state '{}' belongs to group '{}', which is not defined",
                        s.name, s.group
                    ),
                );
            }
            for j in s.values.keys() {
                if !self.joint_index.contains_key(j) {
                    return bad(
                        &key,
                        format!(
                            "state '{}' sets joint '{j}', which the URDF does not define",
                            s.name
                        ),
                    );
                }
            }
        }
        for p in &srdf.disabled_collisions {
            for l in [&p.link1, &p.link2] {
                if !self.link_index.contains_key(l) {
                    return bad(
                        &format!("pair:{}:{}", p.link1, p.link2),
                        format!(
                            "disable_collisions names link '{l}', which the URDF does not define"
                        ),
                    );
                }
            }
        }
        for e in &srdf.end_effectors {
            if !self.link_index.contains_key(&e.parent_link) {
                return Err(ModelError::srdf(
                    srdf.location(""),
                    format!(
                        "end effector '{}' names parent link '{}', which the URDF does not define",
                        e.name, e.parent_link
                    ),
                ));
            }
        }
        Ok(())
    }

    fn srdf_or_err(&self, what: &str) -> Result<&Srdf> {
        self.srdf.as_ref().ok_or_else(|| {
            ModelError::InvalidArgument(format!(
                "{what} needs an SRDF; load the model with srdf=..."
            ))
        })
    }

    /// Joint indices of SRDF group `name` (chains, joints, links' parent
    /// joints and subgroups), in model order.
    pub fn group_joints(&self, name: &str) -> Result<Vec<usize>> {
        let srdf = self.srdf_or_err("a named group")?;
        let mut out = BTreeSet::new();
        let mut todo = vec![name.to_string()];
        let mut seen = BTreeSet::new();
        while let Some(g) = todo.pop() {
            if !seen.insert(g.clone()) {
                continue;
            }
            let grp = srdf.group(&g).ok_or_else(|| {
                ModelError::unknown("group", &g, srdf.groups.iter().map(|g| g.name.as_str()))
            })?;
            for j in &grp.joints {
                out.insert(self.joint_index[j]);
            }
            for l in &grp.links {
                if let Some(j) = self.links[self.link_index[l]].parent_joint {
                    out.insert(j);
                }
            }
            for (base, tip) in &grp.chains {
                let to_base = self.path_to(self.link_index[base]);
                out.extend(
                    self.path_to(self.link_index[tip])
                        .into_iter()
                        .filter(|j| !to_base.contains(j)),
                );
            }
            todo.extend(grp.subgroups.iter().cloned());
        }
        Ok(out.into_iter().collect())
    }

    /// DOF indices of SRDF group `name` (mimic joints count as their driver).
    pub fn group_dof_indices(&self, name: &str) -> Result<Vec<usize>> {
        let mut dofs: Vec<usize> = self
            .group_joints(name)?
            .into_iter()
            .filter_map(|j| self.joints[j].coupling.driver().map(|(d, _)| d))
            .collect();
        dofs.sort_unstable();
        dofs.dedup();
        Ok(dofs)
    }

    /// Names of the SRDF groups.
    pub fn group_names(&self) -> Vec<String> {
        self.srdf
            .iter()
            .flat_map(|s| s.groups.iter().map(|g| g.name.clone()))
            .collect()
    }

    /// The full DOF vector of named state `name`: the state's joints set, the
    /// rest at the neutral configuration. With several states of that name,
    /// `group` picks one (default: the planning group's, else the first).
    pub fn named_state(&self, name: &str, group: Option<&str>) -> Result<Vec<f64>> {
        let srdf = self.srdf_or_err("a named state")?;
        let wanted = group.or(self.group_name.as_deref());
        let candidates: Vec<_> = srdf
            .group_states
            .iter()
            .filter(|s| s.name == name)
            .collect();
        let state = candidates
            .iter()
            .find(|s| Some(s.group.as_str()) == wanted)
            .or_else(|| {
                if group.is_none() {
                    candidates.first()
                } else {
                    None
                }
            })
            .ok_or_else(|| {
                ModelError::unknown(
                    "state",
                    &match group {
                        Some(g) => format!("{g}/{name}"),
                        None => name.to_string(),
                    },
                    srdf.group_states.iter().map(|s| s.name.as_str()),
                )
            })?;
        let mut q = self.neutral_configuration();
        for (joint, value) in &state.values {
            if let crate::joint::JointCoupling::Dof(d) =
                self.joints[self.joint_index[joint]].coupling
            {
                q[d] = *value;
            }
        }
        Ok(q)
    }

    /// Link pairs the SRDF disables for collision checking, as link indices
    /// (smaller first).
    pub fn disabled_collision_pairs(&self) -> Vec<(usize, usize, String)> {
        self.srdf
            .iter()
            .flat_map(|s| s.disabled_collisions.iter())
            .map(|p| {
                let (a, b) = (self.link_index[&p.link1], self.link_index[&p.link2]);
                (a.min(b), a.max(b), p.reason.clone())
            })
            .collect()
    }
}
