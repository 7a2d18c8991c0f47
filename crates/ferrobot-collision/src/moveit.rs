//! Reading MoveIt planning scenes (YAML): `world.collision_objects` with
//! primitives (box, sphere, cylinder, cone rejected), meshes, their poses and
//! an optional object pose. Quaternions in that format are `x, y, z, w`.

use std::path::Path;

use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde_yaml::Value;

use crate::error::{CollisionError, Result};
use crate::world::CollisionWorld;
use ferrobot_geometry::Shape;

fn err(location: &str, message: impl Into<String>) -> CollisionError {
    CollisionError::File {
        location: location.to_string(),
        message: message.into(),
    }
}

fn floats(v: &Value, n: usize, loc: &str, what: &str) -> Result<Vec<f64>> {
    let seq = v
        .as_sequence()
        .ok_or_else(|| err(loc, format!("{what}: expected a list of {n} numbers")))?;
    let out: Vec<f64> = seq
        .iter()
        .map(|x| {
            x.as_f64()
                .ok_or_else(|| err(loc, format!("{what}: '{x:?}' is not a number")))
        })
        .collect::<Result<_>>()?;
    if out.len() != n {
        return Err(err(
            loc,
            format!("{what}: expected {n} numbers, got {}", out.len()),
        ));
    }
    if out.iter().any(|x| !x.is_finite()) {
        return Err(err(loc, format!("{what}: non-finite value")));
    }
    Ok(out)
}

/// A `geometry_msgs/Pose` (`position`, `orientation` x, y, z, w); missing
/// fields default to identity.
fn pose(v: Option<&Value>, loc: &str) -> Result<Isometry3<f64>> {
    let Some(v) = v else {
        return Ok(Isometry3::identity());
    };
    let p = match v.get("position") {
        Some(p) => floats(p, 3, loc, "position")?,
        None => vec![0.0; 3],
    };
    let q = match v.get("orientation") {
        Some(q) => floats(q, 4, loc, "orientation (x, y, z, w)")?,
        None => vec![0.0, 0.0, 0.0, 1.0],
    };
    let quat = Quaternion::new(q[3], q[0], q[1], q[2]);
    if quat.norm() < 1e-9 {
        return Err(err(loc, "orientation: zero quaternion"));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(p[0], p[1], p[2]),
        UnitQuaternion::from_quaternion(quat),
    ))
}

fn primitive(v: &Value, loc: &str) -> Result<Shape> {
    let kind = v
        .get("type")
        .and_then(Value::as_str)
        .ok_or_else(|| err(loc, "primitive without a 'type'"))?;
    let dims = |n: usize| -> Result<Vec<f64>> {
        let d = floats(
            v.get("dimensions")
                .ok_or_else(|| err(loc, format!("{kind} without 'dimensions'")))?,
            n,
            loc,
            &format!("{kind} dimensions"),
        )?;
        if let Some(bad) = d.iter().find(|x| **x <= 0.0) {
            return Err(err(
                loc,
                format!("{kind} dimensions must be positive, got {bad}"),
            ));
        }
        Ok(d)
    };
    Ok(match kind {
        "box" => {
            let d = dims(3)?;
            Shape::Box {
                half_extents: Vector3::new(d[0], d[1], d[2]) / 2.0,
            }
        }
        "sphere" => Shape::Sphere {
            radius: dims(1)?[0],
        },
        // shape_msgs/SolidPrimitive: CYLINDER_HEIGHT = 0, CYLINDER_RADIUS = 1.
        "cylinder" => {
            let d = dims(2)?;
            Shape::Cylinder {
                radius: d[1],
                half_height: d[0] / 2.0,
            }
        }
        other => {
            return Err(err(
                loc,
                format!(
                    "unknown or unsupported primitive type '{other}' (supported: box, sphere, cylinder)"
                ),
            ));
        }
    })
}

fn mesh(v: &Value, loc: &str) -> Result<Shape> {
    let verts = v
        .get("vertices")
        .and_then(Value::as_sequence)
        .ok_or_else(|| err(loc, "mesh without 'vertices'"))?;
    let tris = v
        .get("triangles")
        .and_then(Value::as_sequence)
        .ok_or_else(|| err(loc, "mesh without 'triangles'"))?;
    let vertices = verts
        .iter()
        .map(|p| {
            let xyz = match p {
                Value::Sequence(_) => floats(p, 3, loc, "mesh vertex")?,
                _ => ["x", "y", "z"]
                    .iter()
                    .map(|k| {
                        p.get(k)
                            .and_then(Value::as_f64)
                            .ok_or_else(|| err(loc, "mesh vertex needs x, y, z"))
                    })
                    .collect::<Result<_>>()?,
            };
            Ok(Point3::new(xyz[0], xyz[1], xyz[2]))
        })
        .collect::<Result<Vec<_>>>()?;
    let triangles = tris
        .iter()
        .map(|t| {
            let idx = t.get("vertex_indices").unwrap_or(t);
            let ids = floats(idx, 3, loc, "triangle vertex_indices")?;
            // Indices must be whole numbers naming a vertex: a negative or
            // fractional index was silently cast before.
            let mut out = [0u32; 3];
            for (o, &id) in out.iter_mut().zip(&ids) {
                if !(id.fract() == 0.0 && id >= 0.0 && id < vertices.len() as f64) {
                    return Err(err(
                        loc,
                        format!(
                            "triangle vertex index {id} is not an integer in [0, {})",
                            vertices.len()
                        ),
                    ));
                }
                *o = id as u32;
            }
            Ok(out)
        })
        .collect::<Result<Vec<_>>>()?;
    let m = ferrobot_geometry::Mesh::new(vertices, triangles)
        .and_then(|m| m.query_ready().map(|()| m))
        .map_err(|e| err(loc, e.to_string()))?;
    Ok(Shape::Mesh(std::sync::Arc::new(m)))
}

/// Deepest flow-collection nesting (`[` and `{`) a scene may have. MoveIt
/// scenes nest three levels (a list of vertex triples); serde_yaml refuses
/// more than 128 levels anyway, but only after libyaml has scanned the whole
/// document, which takes time quadratic in the nesting depth (5,000 levels:
/// about 0.1 s per document). The scan below is linear and runs first.
pub const MAX_FLOW_DEPTH: usize = 64;

/// The line of the first flow collection nested deeper than `max`, if any.
/// `[` and `{` count where a flow collection can begin: inside another one,
/// or in block context as a value (first on the line, or after `:`, `-` or
/// `?`); quoted scalars and comments are skipped. A `[` inside a block
/// plain scalar (`name: a[1]`) does not count.
fn flow_too_deep(text: &str, max: usize) -> Option<usize> {
    #[derive(PartialEq)]
    enum In {
        Plain,
        Single,
        Double,
        Comment,
    }
    let b = text.as_bytes();
    let (mut depth, mut line) = (0usize, 1usize);
    let mut state = In::Plain;
    // The last non-blank byte on this line outside quotes (b'\n' at a line
    // start), and whether the byte before the current one was blank.
    let mut last = b'\n';
    let mut blank_before = true;
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c == b'\n' {
            line += 1;
        }
        match state {
            In::Comment => {
                if c == b'\n' {
                    state = In::Plain;
                }
            }
            In::Single => {
                if c == b'\'' {
                    if b.get(i + 1) == Some(&b'\'') {
                        i += 1;
                    } else {
                        state = In::Plain;
                        last = c;
                    }
                }
            }
            In::Double => {
                if c == b'\\' {
                    if b.get(i + 1) == Some(&b'\n') {
                        line += 1;
                    }
                    i += 1;
                } else if c == b'"' {
                    state = In::Plain;
                    last = c;
                }
            }
            In::Plain => {
                let value_start = depth > 0 || matches!(last, b'\n' | b':' | b'-' | b'?');
                match c {
                    b'\n' => last = b'\n',
                    b' ' | b'\t' | b'\r' => {}
                    b'#' if blank_before => state = In::Comment,
                    b'\'' | b'"' if value_start || matches!(last, b',' | b'[' | b'{') => {
                        state = if c == b'"' { In::Double } else { In::Single };
                    }
                    b'[' | b'{' if value_start => {
                        depth += 1;
                        if depth > max {
                            return Some(line);
                        }
                        last = c;
                    }
                    b']' | b'}' if depth > 0 => {
                        depth -= 1;
                        last = c;
                    }
                    _ => last = c,
                }
            }
        }
        blank_before = matches!(c, b' ' | b'\t' | b'\r' | b'\n');
        i += 1;
    }
    None
}

impl CollisionWorld {
    /// Reads a MoveIt planning-scene YAML file.
    pub fn from_moveit_scene(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path)
            .map_err(|e| err(&path.display().to_string(), e.to_string()))?;
        Self::from_moveit_scene_str(&text, &path.display().to_string())
    }

    /// Reads MoveIt planning-scene YAML text; `source` names it in errors.
    pub fn from_moveit_scene_str(text: &str, source: &str) -> Result<Self> {
        if let Some(line) = flow_too_deep(text, MAX_FLOW_DEPTH) {
            return Err(err(
                &format!("{source}:{line}"),
                format!(
                    "flow collections ([...], {{...}}) nested more than {MAX_FLOW_DEPTH} levels deep"
                ),
            ));
        }
        let doc: Value =
            serde_yaml::from_str(text).map_err(|e| err(source, format!("invalid YAML: {e}")))?;
        let mut world = CollisionWorld::new();
        let Some(objects) = doc.get("world").and_then(|w| w.get("collision_objects")) else {
            return Ok(world);
        };
        let objects = objects
            .as_sequence()
            .ok_or_else(|| err(source, "world.collision_objects is not a list"))?;
        for (i, obj) in objects.iter().enumerate() {
            let id = obj
                .get("id")
                .and_then(Value::as_str)
                .map(str::to_string)
                .unwrap_or_else(|| format!("object{i}"));
            let loc = format!("{source}: collision object '{id}'");
            if let Some(op) = obj.get("operation") {
                let ok =
                    matches!(op.as_str(), Some("add") | Some("append")) || op.as_i64() == Some(0);
                if !ok {
                    return Err(err(
                        &loc,
                        format!("operation {op:?} is not supported in a scene file"),
                    ));
                }
            }
            let object_pose = pose(obj.get("pose"), &loc)?;
            let mut parts = Vec::new();
            for (shapes_key, poses_key, is_mesh) in [
                ("primitives", "primitive_poses", false),
                ("meshes", "mesh_poses", true),
            ] {
                let Some(shapes) = obj.get(shapes_key).and_then(Value::as_sequence) else {
                    continue;
                };
                let poses = obj.get(poses_key).and_then(Value::as_sequence);
                if poses.is_some_and(|p| p.len() != shapes.len()) {
                    return Err(err(
                        &loc,
                        format!(
                            "{} {shapes_key} but a different number of {poses_key}",
                            shapes.len()
                        ),
                    ));
                }
                for (k, s) in shapes.iter().enumerate() {
                    let shape = if is_mesh {
                        mesh(s, &loc)?
                    } else {
                        primitive(s, &loc)?
                    };
                    parts.push((shape, pose(poses.and_then(|p| p.get(k)), &loc)?));
                }
            }
            if parts.is_empty() {
                continue;
            }
            world
                .add(&id, object_pose, parts)
                .map_err(|e| err(&loc, e.to_string()))?;
        }
        Ok(world)
    }
}
