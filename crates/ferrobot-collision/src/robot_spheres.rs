//! The sphere model of a robot: spheres per link in the link frame, from a
//! spherized URDF, cuRobo's YAML map, the automatic spherizer, or a file
//! saved earlier (cuRobo's YAML format).

use std::collections::BTreeMap;
use std::path::Path;

use ferrobot_model::{LoadOptions, RobotModel, Shape};
use nalgebra::Point3;
use serde_yaml::Value;

use crate::error::{CollisionError, Result};
use crate::sphere::Sphere;

/// Spheres per link, indexed like `model.links()`, in each link's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotSpheres {
    /// Spheres of each link.
    pub links: Vec<Vec<Sphere>>,
}

fn file_err(location: impl Into<String>, message: impl Into<String>) -> CollisionError {
    CollisionError::File {
        location: location.into(),
        message: message.into(),
    }
}

fn check_sphere(where_: &str, s: &Sphere) -> Result<()> {
    if !(s.radius.is_finite() && s.radius > 0.0 && s.center.coords.iter().all(|c| c.is_finite())) {
        return Err(CollisionError::InvalidShape(format!(
            "{where_}: sphere at {:?} with radius {} (radius must be positive, values finite)",
            s.center.coords.as_slice(),
            s.radius
        )));
    }
    Ok(())
}

impl RobotSpheres {
    /// Spheres given per link, checked against the model.
    pub fn new(model: &RobotModel, links: Vec<Vec<Sphere>>) -> Result<Self> {
        if links.len() != model.links().len() {
            return Err(CollisionError::InvalidArgument(format!(
                "sphere model has {} links, the robot {}",
                links.len(),
                model.links().len()
            )));
        }
        for (l, spheres) in links.iter().enumerate() {
            for s in spheres {
                check_sphere(&format!("link '{}'", model.links()[l].name), s)?;
            }
        }
        // A link with collision geometry but no sphere would never collide:
        // collision checking silently switched off for it.
        let bare: Vec<&str> = model
            .links()
            .iter()
            .zip(&links)
            .filter(|(link, s)| !link.collisions.is_empty() && s.is_empty())
            .map(|(link, _)| link.name.as_str())
            .collect();
        if !bare.is_empty() {
            return Err(CollisionError::InvalidArgument(format!(
                "sphere model has no sphere on link(s) with collision geometry: {}",
                bare.join(", ")
            )));
        }
        if links.iter().all(Vec::is_empty) {
            return Err(CollisionError::InvalidArgument(format!(
                "sphere model of robot '{}' has no sphere at all (the robot has no collision geometry): every configuration would be collision-free",
                model.name()
            )));
        }
        Ok(Self { links })
    }

    /// Takes the sphere collision elements of a spherized URDF (a copy of
    /// the robot whose collision geometry is spheres) and maps them onto
    /// `model`'s links by name. Other collision shapes in that file are an
    /// error: a sphere model must be made of spheres.
    pub fn from_spherized_urdf(model: &RobotModel, path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let sph = RobotModel::from_urdf_file(path, &LoadOptions::default())?;
        let mut links = vec![Vec::new(); model.links().len()];
        for link in sph.links() {
            let Ok(l) = model.link(&link.name) else {
                if link.collisions.is_empty() {
                    continue;
                }
                return Err(file_err(
                    path.display().to_string(),
                    format!(
                        "link '{}' has spheres but the robot has no such link",
                        link.name
                    ),
                ));
            };
            for g in &link.collisions {
                let Shape::Sphere { radius } = g.shape else {
                    return Err(file_err(
                        path.display().to_string(),
                        format!(
                            "link '{}' has a {} collision element; only spheres are allowed",
                            link.name,
                            g.shape.kind()
                        ),
                    ));
                };
                links[l].push(Sphere::new(
                    Point3::from(g.origin.translation.vector),
                    radius,
                ));
            }
        }
        Self::new(model, links)
    }

    /// Reads cuRobo's map `{link: [{center: [x, y, z], radius: r}, ...]}`,
    /// at the top level or under a `collision_spheres` key.
    pub fn from_curobo_yaml(model: &RobotModel, text: &str, source: &str) -> Result<Self> {
        let doc: Value = serde_yaml::from_str(text)
            .map_err(|e| file_err(source, format!("invalid YAML: {e}")))?;
        let map = doc.get("collision_spheres").unwrap_or(&doc);
        let map = map
            .as_mapping()
            .ok_or_else(|| file_err(source, "expected a map of link name to a list of spheres"))?;
        let mut links = vec![Vec::new(); model.links().len()];
        for (name, list) in map {
            let name = name
                .as_str()
                .ok_or_else(|| file_err(source, "link names must be strings"))?;
            let l = model
                .link(name)
                .map_err(|e| file_err(source, e.to_string()))?;
            let list = list.as_sequence().ok_or_else(|| {
                file_err(source, format!("link '{name}': expected a list of spheres"))
            })?;
            for (k, s) in list.iter().enumerate() {
                let loc = format!("{source}: link '{name}' sphere {k}");
                let center: Vec<f64> = s
                    .get("center")
                    .and_then(Value::as_sequence)
                    .map(|c| c.iter().filter_map(Value::as_f64).collect())
                    .ok_or_else(|| file_err(&loc, "needs 'center: [x, y, z]'"))?;
                let radius = s
                    .get("radius")
                    .and_then(Value::as_f64)
                    .ok_or_else(|| file_err(&loc, "needs 'radius'"))?;
                if center.len() != 3 {
                    return Err(file_err(&loc, "center needs 3 numbers"));
                }
                let sphere = Sphere::new(Point3::new(center[0], center[1], center[2]), radius);
                check_sphere(&loc, &sphere)?;
                links[l].push(sphere);
            }
        }
        Self::new(model, links)
    }

    /// Reads a file written by [`RobotSpheres::to_curobo_yaml`] (or cuRobo's).
    pub fn load(model: &RobotModel, path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path)
            .map_err(|e| file_err(path.display().to_string(), e.to_string()))?;
        Self::from_curobo_yaml(model, &text, &path.display().to_string())
    }

    /// cuRobo's YAML form, under a `collision_spheres` key.
    pub fn to_curobo_yaml(&self, model: &RobotModel) -> String {
        let mut out = String::from("collision_spheres:\n");
        let named: BTreeMap<usize, &Vec<Sphere>> = self
            .links
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.is_empty())
            .collect();
        for (l, spheres) in named {
            out.push_str(&format!("  {}:\n", model.links()[l].name));
            for s in spheres {
                out.push_str(&format!(
                    "    - center: [{:?}, {:?}, {:?}]\n      radius: {:?}\n",
                    s.center.x, s.center.y, s.center.z, s.radius
                ));
            }
        }
        out
    }

    /// Writes [`RobotSpheres::to_curobo_yaml`] to `path`.
    pub fn save(&self, model: &RobotModel, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        std::fs::write(path, self.to_curobo_yaml(model))
            .map_err(|e| file_err(path.display().to_string(), e.to_string()))
    }

    /// Total number of spheres.
    pub fn count(&self) -> usize {
        self.links.iter().map(Vec::len).sum()
    }

    /// One sphere per link holding all its spheres (None for links without).
    pub fn bounding_spheres(&self) -> Vec<Option<Sphere>> {
        self.links.iter().map(|s| Sphere::bounding(s)).collect()
    }
}
