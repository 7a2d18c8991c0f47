//! Exact (`f64`) signed distances of the sphere model to the world and to
//! itself, their gradient with respect to the configuration, and the list of
//! contacts that explains a collision.

use nalgebra::{Point3, Vector3};

use crate::checker::{CollisionChecker, Contact};
use crate::error::Result;
use crate::exact::confirm;
use crate::kernel::{Scratch, forward};
use crate::sphere::Sphere;

/// The result of [`CollisionChecker::distance`].
#[derive(Debug, Clone)]
pub struct Distance {
    /// Smallest signed distance (m) between a robot sphere and the world or
    /// between two robot spheres of a checked pair; negative when they
    /// overlap; `inf` when there is nothing to measure.
    pub distance: f64,
    /// Smallest distance to the world.
    pub world_distance: f64,
    /// Smallest distance between the spheres of checked robot bodies (the
    /// sphere model's, conservative: with exact self-collision checks,
    /// `in_collision` may be false while this is slightly negative).
    pub self_distance: f64,
    /// Gradient of `distance` with respect to `q` (num_dof values).
    pub gradient: Vec<f64>,
    /// The two sides of the closest pair (robot body, other).
    pub closest: Option<(String, String)>,
}

/// A robot sphere in the base frame with what it belongs to.
struct Placed {
    body: usize,
    link: usize,
    center: Point3<f64>,
    radius: f64,
}

impl CollisionChecker {
    fn body_name(&self, b: usize) -> String {
        let body = &self.robot.bodies[b];
        match &body.attached {
            Some(n) => format!("attached:{n}"),
            None => self.shared.model.links()[body.link].name.clone(),
        }
    }

    fn body_spheres(&self, b: usize) -> &[Sphere] {
        let body = &self.robot.bodies[b];
        match &body.attached {
            Some(n) => {
                &self
                    .attached
                    .iter()
                    .find(|a| &a.name == n)
                    .expect("attached body")
                    .spheres
            }
            None => &self.shared.spheres.links[body.link],
        }
    }

    fn placed(&self, q: &[f64]) -> Result<Vec<Placed>> {
        let poses = self.shared.model.fk_all(q)?;
        let mut out = Vec::new();
        for (b, body) in self.robot.bodies.iter().enumerate() {
            for s in self.body_spheres(b) {
                out.push(Placed {
                    body: b,
                    link: body.link,
                    center: poses[body.link] * s.center,
                    radius: s.radius,
                });
            }
        }
        Ok(out)
    }

    /// Velocity Jacobian (3 x num_dof, row-major) of a point fixed to `link`.
    fn point_jacobian(&self, q: &[f64], link: usize, p: &Point3<f64>) -> Result<Vec<f64>> {
        let n = self.shared.model.num_dof();
        let j = self.shared.model.jacobian(q, Some(link))?;
        let o = self.shared.model.fk(q, Some(link))?.translation.vector;
        let r = p.coords - o;
        let mut out = vec![0.0; 3 * n];
        for c in 0..n {
            let v = Vector3::new(j[c], j[n + c], j[2 * n + c]);
            let w = Vector3::new(j[3 * n + c], j[4 * n + c], j[5 * n + c]);
            let pv = v + w.cross(&r);
            for k in 0..3 {
                out[k * n + c] = pv[k];
            }
        }
        Ok(out)
    }

    /// Signed distance of the robot to the world and to itself, with its
    /// gradient with respect to `q` (the gradient of the closest pair).
    pub fn distance(&self, q: &[f64]) -> Result<Distance> {
        self.shared.model.check_configuration("q", q)?;
        let placed = self.placed(q)?;
        let n = self.shared.model.num_dof();
        let mut world = (f64::INFINITY, None::<(usize, Vector3<f64>, usize)>);
        let enabled = self.enabled_mask();
        for (i, s) in placed.iter().enumerate() {
            if let Some((d, dir, obj)) = self.world.signed_distance_where(&s.center, |k| enabled[k])
            {
                let d = d - s.radius;
                if d < world.0 {
                    world = (d, Some((i, dir, obj)));
                }
            }
        }
        let mut own = (f64::INFINITY, None::<(usize, usize, Vector3<f64>)>);
        for &(a, b) in &self.robot.pairs {
            for (i, sa) in placed.iter().enumerate().filter(|(_, s)| s.body == a) {
                for (j, sb) in placed.iter().enumerate().filter(|(_, s)| s.body == b) {
                    let d = sa.center - sb.center;
                    let len = d.norm();
                    let dist = len - sa.radius - sb.radius;
                    if dist < own.0 {
                        let dir = if len > 1e-12 { d / len } else { Vector3::z() };
                        own = (dist, Some((i, j, dir)));
                    }
                }
            }
        }
        let mut gradient = vec![0.0; n];
        let closest = if world.0 <= own.0 {
            match world.1 {
                None => None,
                Some((i, dir, obj)) => {
                    let s = &placed[i];
                    let jp = self.point_jacobian(q, s.link, &s.center)?;
                    for (c, g) in gradient.iter_mut().enumerate() {
                        *g = dir.x * jp[c] + dir.y * jp[n + c] + dir.z * jp[2 * n + c];
                    }
                    Some((
                        self.body_name(s.body),
                        self.world.objects()[obj].name.clone(),
                    ))
                }
            }
        } else {
            match own.1 {
                None => None,
                Some((i, j, dir)) => {
                    let (a, b) = (&placed[i], &placed[j]);
                    let ja = self.point_jacobian(q, a.link, &a.center)?;
                    let jb = self.point_jacobian(q, b.link, &b.center)?;
                    for (c, g) in gradient.iter_mut().enumerate() {
                        *g = (0..3)
                            .map(|k| dir[k] * (ja[k * n + c] - jb[k * n + c]))
                            .sum();
                    }
                    Some((self.body_name(a.body), self.body_name(b.body)))
                }
            }
        };
        Ok(Distance {
            distance: world.0.min(own.0),
            world_distance: world.0,
            self_distance: own.0,
            gradient,
            closest,
        })
    }

    /// Every colliding (body, object) and (body, body) pair at `q` with the
    /// deepest penetration, deepest first: the explanation of a collision.
    /// Depths are those of the sphere model. A robot pair whose spheres
    /// overlap is listed only when the checker reports it too, i.e. when
    /// the links' exact geometry confirms the contact (see
    /// [`crate::exact`]); so the list is empty when
    /// [`CollisionChecker::in_collision`] is false and not empty when it is
    /// true (up to `f32` rounding for contacts that exactly touch).
    pub fn contacts(&self, q: &[f64]) -> Result<Vec<Contact>> {
        self.shared.model.check_configuration("q", q)?;
        let placed = self.placed(q)?;
        let mut found: Vec<Contact> = Vec::new();
        let mut record = |body: String, other: String, self_collision: bool, depth: f64| {
            if let Some(c) = found
                .iter_mut()
                .find(|c| c.body == body && c.other == other)
            {
                c.depth = c.depth.max(depth);
            } else {
                found.push(Contact {
                    body,
                    other,
                    self_collision,
                    depth,
                });
            }
        };
        let enabled = self.enabled_mask();
        for s in &placed {
            for (obj, _) in self
                .world
                .objects()
                .iter()
                .zip(&enabled)
                .filter(|(_, on)| **on)
            {
                for (shape, local) in &obj.parts {
                    let pose = obj.pose * local;
                    let (d, _) = shape.signed_distance(&pose.inverse_transform_point(&s.center));
                    let depth = s.radius + self.margin - d;
                    if depth > 0.0 {
                        record(self.body_name(s.body), obj.name.clone(), false, depth);
                    }
                }
            }
        }
        // Self-collisions as the checker decides them: spheres overlap, and
        // where both links have exact geometry, that geometry confirms it
        // (on the same f32 lane frames as the kernel).
        let q32: Vec<f32> = q.iter().map(|&v| v as f32).collect();
        let mut lanes = Scratch::<f32>::new(&self.robot);
        forward(&self.robot, &q32, &mut lanes);
        for &(a, b) in &self.robot.pairs {
            let mut deepest = f64::NEG_INFINITY;
            for sa in placed.iter().filter(|s| s.body == a) {
                for sb in placed.iter().filter(|s| s.body == b) {
                    let depth =
                        sa.radius + sb.radius + self.margin - (sa.center - sb.center).norm();
                    deepest = deepest.max(depth);
                }
            }
            if deepest <= 0.0 {
                continue;
            }
            if let (Some(ea), Some(eb)) = (&self.robot.exact[a], &self.robot.exact[b]) {
                let frames = lanes.frames();
                let (fa, fb) = (
                    &frames[self.robot.bodies[a].frame],
                    &frames[self.robot.bodies[b].frame],
                );
                if confirm(ea, eb, fa, fb, 1, self.margin as f32) == 0 {
                    continue;
                }
            }
            record(self.body_name(a), self.body_name(b), true, deepest);
        }
        found.sort_by(|a, b| b.depth.total_cmp(&a.depth));
        Ok(found)
    }
}
