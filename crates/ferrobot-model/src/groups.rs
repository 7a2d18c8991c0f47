//! SRDF semantics on a model: validation, planning groups, named states.

use std::collections::BTreeSet;

use crate::error::{ModelError, Result};
use crate::model::RobotModel;
use crate::srdf::Srdf;

impl RobotModel {
    /// Checks every name the SRDF uses against the model. With `strict`,
    /// the first unknown name is an error. Otherwise, as MoveIt's srdfdom
    /// does, what names something the URDF lacks is dropped and listed in
    /// [`Srdf::skipped`]: a group's unknown joints, links and chains (a
    /// group left empty goes too), subgroups that are not (or no longer)
    /// defined, a state's unknown joints (a state of an unknown group goes
    /// whole), `disable_collisions` pairs naming unknown links, end effectors
    /// attached to unknown links, unknown passive joints.
    pub(crate) fn resolve_srdf(&self, srdf: &mut Srdf, strict: bool) -> Result<()> {
        let mut skipped = Vec::new();
        let mut issue = |srdf: &Srdf, key: &str, what: String| -> Result<()> {
            let location = srdf.location(key);
            if strict {
                return Err(ModelError::srdf(location, what));
            }
            skipped.push(format!("{location}: {what}; skipped"));
            Ok(())
        };
        let mut groups = std::mem::take(&mut srdf.groups);
        for g in &mut groups {
            let key = format!("group:{}", g.name);
            let was_empty = g.joints.is_empty()
                && g.links.is_empty()
                && g.chains.is_empty()
                && g.subgroups.is_empty();
            let mut joints = Vec::new();
            for j in std::mem::take(&mut g.joints) {
                if self.joint_index.contains_key(&j) {
                    joints.push(j);
                } else {
                    let what = format!(
                        "group '{}' names joint '{j}', which the URDF does not define",
                        g.name
                    );
                    issue(srdf, &key, what)?;
                }
            }
            g.joints = joints;
            let mut links = Vec::new();
            for l in std::mem::take(&mut g.links) {
                if self.link_index.contains_key(&l) {
                    links.push(l);
                } else {
                    let what = format!(
                        "group '{}' names link '{l}', which the URDF does not define",
                        g.name
                    );
                    issue(srdf, &key, what)?;
                }
            }
            g.links = links;
            let mut chains = Vec::new();
            for (base, tip) in std::mem::take(&mut g.chains) {
                if let Some(l) = [&base, &tip]
                    .into_iter()
                    .find(|l| !self.link_index.contains_key(l.as_str()))
                {
                    let what = format!(
                        "group '{}' names link '{l}', which the URDF does not define",
                        g.name
                    );
                    issue(srdf, &key, what)?;
                    continue;
                }
                let path = self.path_to(self.link_index[&tip]);
                let b = self.link_index[&base];
                if b != 0 && !path.iter().any(|&j| self.joints[j].child == b) {
                    let what = format!(
                        "group '{}': chain tip '{tip}' is not below base '{base}'",
                        g.name
                    );
                    issue(srdf, &key, what)?;
                    continue;
                }
                chains.push((base, tip));
            }
            g.chains = chains;
            let empty = g.joints.is_empty()
                && g.links.is_empty()
                && g.chains.is_empty()
                && g.subgroups.is_empty();
            if empty && !was_empty {
                let what = format!("group '{}' names nothing the URDF defines", g.name);
                issue(srdf, &key, what)?;
                g.name.clear();
            }
        }
        groups.retain(|g| !g.name.is_empty());
        // Subgroups: drop references to undefined groups, and groups left
        // with nothing, until nothing changes.
        loop {
            let names: BTreeSet<String> = groups.iter().map(|g| g.name.clone()).collect();
            let mut changed = false;
            for g in &mut groups {
                let key = format!("group:{}", g.name);
                let before = g.subgroups.len();
                let mut kept = Vec::new();
                for s in std::mem::take(&mut g.subgroups) {
                    if names.contains(&s) {
                        kept.push(s);
                    } else {
                        let what = format!(
                            "group '{}' names subgroup '{s}', which is not defined",
                            g.name
                        );
                        issue(srdf, &key, what)?;
                    }
                }
                g.subgroups = kept;
                if g.subgroups.len() != before
                    && g.joints.is_empty()
                    && g.links.is_empty()
                    && g.chains.is_empty()
                    && g.subgroups.is_empty()
                {
                    let what = format!("group '{}' names nothing the URDF defines", g.name);
                    issue(srdf, &key, what)?;
                    g.name.clear();
                    changed = true;
                }
            }
            groups.retain(|g| !g.name.is_empty());
            if !changed {
                break;
            }
        }
        srdf.groups = groups;

        let mut states = std::mem::take(&mut srdf.group_states);
        for s in &mut states {
            let key = format!("state:{}:{}", s.group, s.name);
            if srdf.group(&s.group).is_none() {
                let what = format!(
                    "state '{}' belongs to group '{}', which is not defined",
                    s.name, s.group
                );
                issue(srdf, &key, what)?;
                s.name.clear();
                continue;
            }
            let unknown: Vec<String> = s
                .values
                .keys()
                .filter(|j| !self.joint_index.contains_key(*j))
                .cloned()
                .collect();
            for j in unknown {
                let what = format!(
                    "state '{}' sets joint '{j}', which the URDF does not define",
                    s.name
                );
                issue(srdf, &key, what)?;
                s.values.remove(&j);
            }
        }
        states.retain(|s| !s.name.is_empty());
        srdf.group_states = states;

        let mut pairs = Vec::new();
        for p in std::mem::take(&mut srdf.disabled_collisions) {
            let key = format!("pair:{}:{}", p.link1, p.link2);
            if let Some(l) = [&p.link1, &p.link2]
                .into_iter()
                .find(|l| !self.link_index.contains_key(l.as_str()))
            {
                let what =
                    format!("disable_collisions names link '{l}', which the URDF does not define");
                issue(srdf, &key, what)?;
            } else {
                pairs.push(p);
            }
        }
        srdf.disabled_collisions = pairs;

        let mut ees = Vec::new();
        for e in std::mem::take(&mut srdf.end_effectors) {
            if self.link_index.contains_key(&e.parent_link) {
                ees.push(e);
            } else {
                let what = format!(
                    "end effector '{}' names parent link '{}', which the URDF does not define",
                    e.name, e.parent_link
                );
                issue(srdf, &format!("ee:{}", e.name), what)?;
            }
        }
        srdf.end_effectors = ees;

        let mut passive = Vec::new();
        for j in std::mem::take(&mut srdf.passive_joints) {
            if self.joint_index.contains_key(&j) {
                passive.push(j);
            } else {
                let what = format!("passive joint '{j}' is a joint the URDF does not define");
                issue(srdf, "", what)?;
            }
        }
        srdf.passive_joints = passive;
        srdf.skipped.extend(skipped);
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
