//! Reading SRDF (MoveIt's semantic robot description): planning groups,
//! named group states, end effectors and disabled collision pairs.

use std::collections::BTreeMap;

use crate::error::{ModelError, Result, SourceLocation};

/// A planning group as written: its parts are resolved against the model by
/// [`crate::RobotModel`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SrdfGroup {
    /// Group name.
    pub name: String,
    /// `<joint name>` entries.
    pub joints: Vec<String>,
    /// `<link name>` entries.
    pub links: Vec<String>,
    /// `<chain base_link tip_link>` entries.
    pub chains: Vec<(String, String)>,
    /// `<group name>` entries (subgroups).
    pub subgroups: Vec<String>,
}

/// A named joint configuration of a group (`<group_state>`).
#[derive(Debug, Clone, PartialEq)]
pub struct GroupState {
    /// State name, e.g. `ready`.
    pub name: String,
    /// The group it belongs to.
    pub group: String,
    /// Joint name to value.
    pub values: BTreeMap<String, f64>,
}

/// An `<end_effector>` element.
#[derive(Debug, Clone, PartialEq)]
pub struct EndEffector {
    /// Name.
    pub name: String,
    /// The link the end effector is attached to.
    pub parent_link: String,
    /// The group of the end effector's own joints.
    pub group: String,
    /// The group (arm) it is attached to, if given.
    pub parent_group: Option<String>,
}

/// A `<disable_collisions>` pair.
#[derive(Debug, Clone, PartialEq)]
pub struct DisabledPair {
    /// First link.
    pub link1: String,
    /// Second link.
    pub link2: String,
    /// Why (`Adjacent`, `Never`, `Default`, ...).
    pub reason: String,
}

/// The contents of an SRDF file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Srdf {
    /// Where it came from.
    pub source: String,
    /// Planning groups in file order.
    pub groups: Vec<SrdfGroup>,
    /// Named states in file order.
    pub group_states: Vec<GroupState>,
    /// End effectors.
    pub end_effectors: Vec<EndEffector>,
    /// Link pairs never checked for collision.
    pub disabled_collisions: Vec<DisabledPair>,
    /// Passive joints.
    pub passive_joints: Vec<String>,
    /// Line of each named element (`kind:name`), for later error messages.
    pub lines: BTreeMap<String, u32>,
}

impl Srdf {
    /// Parses SRDF text; `source` names it in errors.
    pub fn parse(text: &str, source: &str) -> Result<Self> {
        crate::xml::check_limits(text)
            .map_err(|e| ModelError::srdf(SourceLocation::new(source, e.line), e.message))?;
        let doc = roxmltree::Document::parse(text).map_err(|e| {
            ModelError::srdf(
                SourceLocation::new(source, Some(e.pos().row)),
                format!("malformed XML: {e}"),
            )
        })?;
        let root = doc.root_element();
        let lines = crate::xml::LineIndex::new(text);
        let line = |n: roxmltree::Node| lines.line_of(n);
        if root.tag_name().name() != "robot" {
            return Err(ModelError::srdf(
                SourceLocation::new(source, Some(line(root))),
                format!(
                    "the root element is <{}>, an SRDF needs <robot>",
                    root.tag_name().name()
                ),
            ));
        }
        let mut out = Srdf {
            source: source.to_string(),
            ..Default::default()
        };
        for node in root.children().filter(|n| n.is_element()) {
            let loc = || SourceLocation::new(source, Some(line(node)));
            let attr = |n: roxmltree::Node, a: &str| -> Result<String> {
                n.attribute(a).map(str::to_string).ok_or_else(|| {
                    ModelError::srdf(
                        SourceLocation::new(source, Some(line(n))),
                        format!("<{}> needs a '{a}' attribute", n.tag_name().name()),
                    )
                })
            };
            match node.tag_name().name() {
                "group" => {
                    let mut g = SrdfGroup {
                        name: attr(node, "name")?,
                        ..Default::default()
                    };
                    for c in node.children().filter(|n| n.is_element()) {
                        match c.tag_name().name() {
                            "joint" => g.joints.push(attr(c, "name")?),
                            "link" => g.links.push(attr(c, "name")?),
                            "chain" => g.chains.push((attr(c, "base_link")?, attr(c, "tip_link")?)),
                            "group" => g.subgroups.push(attr(c, "name")?),
                            "passive_joint" => out.passive_joints.push(attr(c, "name")?),
                            // Other elements are not part of a group's definition.
                            _ => {}
                        }
                    }
                    if out.groups.iter().any(|o| o.name == g.name) {
                        return Err(ModelError::srdf(
                            loc(),
                            format!("group '{}' is defined twice", g.name),
                        ));
                    }
                    out.lines.insert(format!("group:{}", g.name), line(node));
                    out.groups.push(g);
                }
                "group_state" => {
                    let mut s = GroupState {
                        name: attr(node, "name")?,
                        group: attr(node, "group")?,
                        values: BTreeMap::new(),
                    };
                    for c in node.children().filter(|n| n.tag_name().name() == "joint") {
                        let joint = attr(c, "name")?;
                        let raw = attr(c, "value")?;
                        let value: f64 = raw
                            .split_whitespace()
                            .next()
                            .and_then(|v| v.parse().ok())
                            .filter(|v: &f64| v.is_finite())
                            .ok_or_else(|| {
                                ModelError::srdf(
                                    SourceLocation::new(source, Some(line(c))),
                                    format!("state '{}': joint '{joint}' has value '{raw}', not a finite number", s.name),
                                )
                            })?;
                        s.values.insert(joint, value);
                    }
                    out.lines
                        .insert(format!("state:{}:{}", s.group, s.name), line(node));
                    out.group_states.push(s);
                }
                "end_effector" => out.end_effectors.push(EndEffector {
                    name: attr(node, "name")?,
                    parent_link: attr(node, "parent_link")?,
                    group: attr(node, "group")?,
                    parent_group: node.attribute("parent_group").map(str::to_string),
                }),
                "disable_collisions" => {
                    let pair = DisabledPair {
                        link1: attr(node, "link1")?,
                        link2: attr(node, "link2")?,
                        reason: node.attribute("reason").unwrap_or("").to_string(),
                    };
                    out.lines
                        .insert(format!("pair:{}:{}", pair.link1, pair.link2), line(node));
                    out.disabled_collisions.push(pair);
                }
                "passive_joint" => out.passive_joints.push(attr(node, "name")?),
                // virtual_joint, link_sphere_approximation, enable_collisions, ...: not used.
                _ => {}
            }
        }
        Ok(out)
    }

    /// The group named `name`.
    pub fn group(&self, name: &str) -> Option<&SrdfGroup> {
        self.groups.iter().find(|g| g.name == name)
    }

    /// Location of a recorded element for error messages.
    pub fn location(&self, key: &str) -> SourceLocation {
        SourceLocation::new(self.source.clone(), self.lines.get(key).copied())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_groups_states_and_pairs() {
        let text = r#"<robot name="r">
  <group name="arm"><chain base_link="a" tip_link="c"/></group>
  <group name="hand"><link name="f"/><joint name="j"/></group>
  <group_state name="home" group="arm"><joint name="j1" value="0.5"/></group_state>
  <end_effector name="ee" parent_link="c" group="hand" parent_group="arm"/>
  <disable_collisions link1="a" link2="b" reason="Adjacent"/>
</robot>"#;
        let s = Srdf::parse(text, "<test>").unwrap();
        assert_eq!(s.groups.len(), 2);
        assert_eq!(
            s.group("arm").unwrap().chains,
            vec![("a".into(), "c".into())]
        );
        assert_eq!(s.group_states[0].values["j1"], 0.5);
        assert_eq!(s.end_effectors[0].parent_link, "c");
        assert_eq!(s.disabled_collisions[0].reason, "Adjacent");
        assert_eq!(s.lines["pair:a:b"], 6);
    }

    #[test]
    fn reports_line_of_bad_value() {
        let text = "<robot name=\"r\">\n<group_state name=\"s\" group=\"g\">\n<joint name=\"j\" value=\"abc\"/>\n</group_state></robot>";
        let err = Srdf::parse(text, "x.srdf").unwrap_err().to_string();
        assert!(err.starts_with("x.srdf:3:"), "{err}");
    }
}
