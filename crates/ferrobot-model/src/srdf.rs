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
    /// What a lenient load skipped, one message per entry (`file:line:
    /// what; skipped`): elements missing a required attribute (a
    /// `group_state` without `group`), and, once resolved against a URDF,
    /// names the URDF lacks. Empty after a strict load.
    pub skipped: Vec<String>,
}

impl Srdf {
    /// Parses SRDF text strictly; `source` names it in errors. See
    /// [`Srdf::parse_with`].
    pub fn parse(text: &str, source: &str) -> Result<Self> {
        Self::parse_with(text, source, true)
    }

    /// Parses SRDF text; `source` names it in errors. Malformed XML, or a
    /// root other than `<robot>`, is always an error. An element that
    /// cannot be read (a `group_state` without `group`, a joint value that
    /// is not a number, a group defined twice, ...) is an error when
    /// `strict`, else it is skipped and listed in [`Srdf::skipped`], as
    /// MoveIt's srdfdom does.
    pub fn parse_with(text: &str, source: &str, strict: bool) -> Result<Self> {
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
            if let Err(e) = out.read_element(node, &line) {
                if strict {
                    return Err(e);
                }
                out.skipped.push(format!("{e}; skipped"));
            }
        }
        Ok(out)
    }

    /// Reads one top-level element into `self` (nothing is added on error).
    fn read_element(
        &mut self,
        node: roxmltree::Node,
        line: &dyn Fn(roxmltree::Node) -> u32,
    ) -> Result<()> {
        let source = self.source.clone();
        let loc = || SourceLocation::new(source.clone(), Some(line(node)));
        let attr = |n: roxmltree::Node, a: &str| -> Result<String> {
            n.attribute(a).map(str::to_string).ok_or_else(|| {
                let what = match n.attribute("name") {
                    Some(name) => format!("<{} name=\"{name}\">", n.tag_name().name()),
                    None => format!("<{}>", n.tag_name().name()),
                };
                ModelError::srdf(
                    SourceLocation::new(source.clone(), Some(line(n))),
                    format!("{what} needs a '{a}' attribute"),
                )
            })
        };
        match node.tag_name().name() {
            "group" => {
                let mut g = SrdfGroup {
                    name: attr(node, "name")?,
                    ..Default::default()
                };
                let mut passive = Vec::new();
                for c in node.children().filter(|n| n.is_element()) {
                    match c.tag_name().name() {
                        "joint" => g.joints.push(attr(c, "name")?),
                        "link" => g.links.push(attr(c, "name")?),
                        "chain" => g.chains.push((attr(c, "base_link")?, attr(c, "tip_link")?)),
                        "group" => g.subgroups.push(attr(c, "name")?),
                        "passive_joint" => passive.push(attr(c, "name")?),
                        // Other elements are not part of a group's definition.
                        _ => {}
                    }
                }
                if self.groups.iter().any(|o| o.name == g.name) {
                    return Err(ModelError::srdf(
                        loc(),
                        format!("group '{}' is defined twice", g.name),
                    ));
                }
                self.passive_joints.extend(passive);
                self.lines.insert(format!("group:{}", g.name), line(node));
                self.groups.push(g);
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
                                SourceLocation::new(source.clone(), Some(line(c))),
                                format!(
                                    "state '{}': joint '{joint}' has value '{raw}', not a finite number",
                                    s.name
                                ),
                            )
                        })?;
                    s.values.insert(joint, value);
                }
                self.lines
                    .insert(format!("state:{}:{}", s.group, s.name), line(node));
                self.group_states.push(s);
            }
            "end_effector" => {
                let e = EndEffector {
                    name: attr(node, "name")?,
                    parent_link: attr(node, "parent_link")?,
                    group: attr(node, "group")?,
                    parent_group: node.attribute("parent_group").map(str::to_string),
                };
                self.lines.insert(format!("ee:{}", e.name), line(node));
                self.end_effectors.push(e);
            }
            "disable_collisions" => {
                let pair = DisabledPair {
                    link1: attr(node, "link1")?,
                    link2: attr(node, "link2")?,
                    reason: node.attribute("reason").unwrap_or("").to_string(),
                };
                self.lines
                    .insert(format!("pair:{}:{}", pair.link1, pair.link2), line(node));
                self.disabled_collisions.push(pair);
            }
            "passive_joint" => self.passive_joints.push(attr(node, "name")?),
            // virtual_joint, link_sphere_approximation, enable_collisions, ...: not used.
            _ => {}
        }
        Ok(())
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

    #[test]
    fn lenient_parse_skips_unreadable_elements() {
        let text = "<robot name=\"r\">\n<group_state name=\"home\"><joint name=\"j\" value=\"0\"/></group_state>\n<group name=\"g\"><joint name=\"j\"/></group>\n<group name=\"g\"/>\n</robot>";
        let err = Srdf::parse(text, "x.srdf").unwrap_err().to_string();
        assert!(
            err.contains("x.srdf:2: <group_state name=\"home\"> needs a 'group'"),
            "{err}"
        );
        let s = Srdf::parse_with(text, "x.srdf", false).unwrap();
        assert!(s.group_states.is_empty());
        assert_eq!(s.groups.len(), 1);
        assert_eq!(s.skipped.len(), 2, "{:?}", s.skipped);
        assert!(s.skipped[1].starts_with("x.srdf:4: group 'g' is defined twice"));
    }
}
