//! Pinhole cameras rendering depth, segmentation and flat-shaded RGB from
//! the scene's collision geometry by ray casting, rows in parallel.
//!
//! Camera frame: OpenCV (x right, y down, z forward). Depth is the z
//! coordinate of the hit in the camera frame (metres, `f32`), `+inf` where
//! no surface is hit; pixel (u, v) looks along ((u - cx)/fx, (v - cy)/fy, 1)
//! (pixel centres at integer coordinates, as in OpenCV).

use nalgebra::Isometry3;
use rapier3d::glamx::Mat3;
use rapier3d::math::{Pose, Vector};
use rapier3d::parry::query::Ray;
use rapier3d::prelude::SharedShape;
use rayon::prelude::*;

use crate::convert::{pose_is_finite, to_pose};
use crate::error::{Result, SimError};
use crate::hooks::seg_of;
use crate::world::World;

/// The camera model's intrinsics (image size, focal lengths, principal
/// point, depth units; one validation): `ferrobot-camera`'s. Rendered depth
/// is in metres (`depth_scale` 1).
pub use ferrobot_camera::Intrinsics;

/// What a camera is fixed to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraMount {
    /// The world frame.
    World,
    /// A robot link (robot index, model link index).
    Link {
        /// Robot index in the world.
        robot: usize,
        /// Link index in the robot's model.
        link: usize,
    },
}

/// A pinhole camera: intrinsics, pose (OpenCV frame) relative to its mount,
/// near and far clipping distances.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Intrinsics.
    pub intrinsics: Intrinsics,
    /// Pose of the OpenCV camera frame in the mount frame.
    pub pose: Isometry3<f64>,
    /// What the camera is fixed to.
    pub mount: CameraMount,
    /// Nearest depth seen (m).
    pub near: f64,
    /// Farthest depth seen (m).
    pub far: f64,
}

impl Camera {
    /// A world-fixed camera with near 0.01 m and far 100 m.
    pub fn new(intrinsics: Intrinsics, pose: Isometry3<f64>) -> Result<Self> {
        let c = Self {
            intrinsics,
            pose,
            mount: CameraMount::World,
            near: 0.01,
            far: 100.0,
        };
        c.validate()?;
        Ok(c)
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        self.intrinsics.validate()?;
        if !pose_is_finite(&self.pose) {
            return Err(SimError::NonFinite("camera pose is not finite".into()));
        }
        if !(self.near.is_finite() && self.near >= 0.0 && self.far > self.near) {
            return Err(SimError::InvalidArgument(format!(
                "camera clipping must satisfy 0 <= near < far, got near {} far {}",
                self.near, self.far
            )));
        }
        Ok(())
    }
}

/// A rendered image set (row-major, `height` rows of `width` pixels).
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Depth (m) along the optical axis; `+inf` where nothing is hit.
    pub depth: Vec<f32>,
    /// Segmentation id per pixel (0: nothing); see `World::labels`.
    pub segmentation: Vec<u32>,
    /// RGB bytes (3 per pixel), if asked for.
    pub rgb: Option<Vec<u8>>,
}

/// A collider placed in the camera frame, with its screen bounds.
struct Item {
    shape: SharedShape,
    pose: Pose,
    seg: u32,
    /// Inclusive pixel bounds (u0, u1, v0, v1).
    rect: (i64, i64, i64, i64),
    /// Camera-frame bounding box (for a quick slab test and front-to-back
    /// early exit); unused for half-spaces.
    mins: Vector,
    maxs: Vector,
    /// Half-space: outward normal and offset in the camera frame
    /// (points x with n.x <= d are inside).
    plane: Option<(Vector, f32)>,
    /// Analytic ray cast for common primitives (parry casts capsules and
    /// cylinders through GJK, ten times slower, and every cast through
    /// dynamic dispatch and a pose inversion).
    fast: Fast,
}

/// A primitive placed in the camera frame for analytic ray casts.
#[derive(Clone)]
enum Fast {
    /// Use parry.
    None,
    /// Capsule: segment end points and radius.
    Capsule(Vector, Vector, f32),
    /// Sphere: centre and radius.
    Ball(Vector, f32),
    /// Box: camera-to-local rotation, camera origin in the local frame, half extents.
    Cuboid(Mat3, Vector, Vector),
    /// Cylinder along local y: camera-to-local rotation, camera origin in
    /// the local frame, half height, radius.
    Cylinder(Mat3, Vector, f32, f32),
    /// Convex polyhedron (convex hulls, parts of convex decompositions):
    /// its face planes (outward normal n, offset d; inside is n·x <= d) in
    /// the camera frame. Parry casts these through GJK, which on thin hulls
    /// returned hits centimetres outside the shape (a phantom fin 4.5 cm
    /// above one of pybullet_data's random meshes).
    Convex(Vec<(Vector, f32)>),
}

impl Fast {
    fn of(shape: &dyn rapier3d::parry::shape::Shape, pose: &Pose) -> Self {
        let to_local = Mat3::from_quat(pose.rotation.inverse());
        let origin = to_local * -pose.translation;
        if let Some(c) = shape.as_capsule() {
            Self::Capsule(
                pose.transform_point(c.segment.a),
                pose.transform_point(c.segment.b),
                c.radius,
            )
        } else if let Some(b) = shape.as_ball() {
            Self::Ball(pose.translation, b.radius)
        } else if let Some(c) = shape.as_cuboid() {
            Self::Cuboid(to_local, origin, c.half_extents)
        } else if let Some(c) = shape.as_cylinder() {
            Self::Cylinder(to_local, origin, c.half_height, c.radius)
        } else if let Some(c) = shape.as_convex_polyhedron() {
            let adj = c.vertices_adj_to_face();
            Self::Convex(
                c.faces()
                    .iter()
                    .map(|f| {
                        let n = pose.rotation * f.normal;
                        let p = pose.transform_point(
                            c.points()[adj[f.first_vertex_or_edge as usize] as usize],
                        );
                        (n, n.dot(p))
                    })
                    .collect(),
            )
        } else {
            Self::None
        }
    }

    /// `Some(Some((t, normal)))` for a hit, `Some(None)` for a miss, `None`
    /// when the shape has no analytic cast.
    #[inline]
    fn cast(&self, dir: Vector) -> Option<Option<(f32, Vector)>> {
        Some(match *self {
            Self::Convex(ref planes) => ray_convex(dir, planes),
            Self::None => return None,
            Self::Capsule(pa, pb, r) => ray_capsule(dir, pa, pb, r),
            Self::Ball(c, r) => {
                let len = dir.length();
                let rd = dir / len;
                ray_sphere(rd, c, r).map(|t| (t / len, (rd * t - c).normalize_or_zero()))
            }
            Self::Cuboid(rot, o, he) => {
                let d = rot * dir;
                let inv = Vector::ONE / d;
                let t1 = (-he - o) * inv;
                let t2 = (he - o) * inv;
                let tmin_v = t1.min(t2);
                let tmin = tmin_v.max_element();
                let tmax = t1.max(t2).min_element();
                if tmin > tmax || tmin <= 0.0 {
                    None
                } else {
                    let axis = if tmin == tmin_v.x {
                        0
                    } else if tmin == tmin_v.y {
                        1
                    } else {
                        2
                    };
                    let mut n = Vector::ZERO;
                    n[axis] = -d[axis].signum();
                    Some((tmin, rot.transpose() * n))
                }
            }
            Self::Cylinder(rot, o, hh, r) => {
                ray_cylinder(rot * dir, o, hh, r).map(|(t, n)| (t, rot.transpose() * n))
            }
        })
    }
}

/// First intersection `t` (in units of `dir`, origin at the camera) of the
/// ray with the convex polyhedron `planes` (outward normal, offset), and
/// the outward normal there: the ray clipped by every face plane. `None`
/// when missed or when the camera is inside.
fn ray_convex(dir: Vector, planes: &[(Vector, f32)]) -> Option<(f32, Vector)> {
    let (mut t_in, mut t_out) = (f32::NEG_INFINITY, f32::INFINITY);
    let mut normal = Vector::ZERO;
    for &(n, d) in planes {
        let den = n.dot(dir);
        if den < 0.0 {
            let t = d / den;
            if t > t_in {
                t_in = t;
                normal = n;
            }
        } else if den > 0.0 {
            t_out = t_out.min(d / den);
        } else if d < 0.0 {
            return None;
        }
    }
    (t_in > 0.0 && t_in <= t_out).then_some((t_in, normal))
}

/// First hit of `o + t d` (local frame) with a capped cylinder along y;
/// `None` when missed or when `o` is inside.
fn ray_cylinder(d: Vector, o: Vector, hh: f32, r: f32) -> Option<(f32, Vector)> {
    if o.x * o.x + o.z * o.z <= r * r && o.y.abs() <= hh {
        return None;
    }
    let mut best: Option<(f32, Vector)> = None;
    let a = d.x * d.x + d.z * d.z;
    if a > 1e-12 {
        let b = o.x * d.x + o.z * d.z;
        let c = o.x * o.x + o.z * o.z - r * r;
        let h = b * b - a * c;
        if h >= 0.0 {
            let t = (-b - h.sqrt()) / a;
            let y = o.y + t * d.y;
            if t > 0.0 && y.abs() <= hh {
                best = Some((t, Vector::new(o.x + t * d.x, 0.0, o.z + t * d.z) / r));
            }
        }
    }
    if d.y != 0.0 {
        let cap = if d.y > 0.0 { -hh } else { hh };
        let t = (cap - o.y) / d.y;
        let x = o.x + t * d.x;
        let z = o.z + t * d.z;
        if t > 0.0 && x * x + z * z <= r * r && best.is_none_or(|(tb, _)| t < tb) {
            best = Some((t, Vector::new(0.0, cap.signum(), 0.0)));
        }
    }
    best
}

/// First intersection `t` (in units of `dir`, origin at the camera) of the
/// ray with a capsule, and the outward normal there; `None` when missed or
/// when the camera is inside.
fn ray_capsule(dir: Vector, pa: Vector, pb: Vector, r: f32) -> Option<(f32, Vector)> {
    let len = dir.length();
    let rd = dir / len;
    let ba = pb - pa;
    let oa = -pa;
    let baba = ba.dot(ba);
    let bard = ba.dot(rd);
    let baoa = ba.dot(oa);
    let rdoa = rd.dot(oa);
    let oaoa = oa.dot(oa);
    let a = baba - bard * bard;
    if a > 1e-12 * baba.max(1e-12) {
        let b = baba * rdoa - baoa * bard;
        let c = baba * oaoa - baoa * baoa - r * r * baba;
        let h = b * b - a * c;
        if h < 0.0 {
            return None;
        }
        let t = (-b - h.sqrt()) / a;
        let y = baoa + t * bard;
        if y > 0.0 && y < baba {
            if t <= 0.0 {
                return None;
            }
            let p = rd * t;
            let axis_point = pa + ba * (y / baba);
            return Some((t / len, (p - axis_point).normalize_or_zero()));
        }
        let centre = if y <= 0.0 { pa } else { pb };
        return ray_sphere(rd, centre, r).map(|t| (t / len, (rd * t - centre).normalize_or_zero()));
    }
    // Ray along the axis: the nearer cap decides.
    let ta = ray_sphere(rd, pa, r);
    let tb = ray_sphere(rd, pb, r);
    let (t, c) = match (ta, tb) {
        (Some(x), Some(y)) if x <= y => (x, pa),
        (Some(_), Some(y)) => (y, pb),
        (Some(x), None) => (x, pa),
        (None, Some(y)) => (y, pb),
        (None, None) => return None,
    };
    Some((t / len, (rd * t - c).normalize_or_zero()))
}

/// Entry distance along the unit ray `rd` (from the origin) into a sphere.
fn ray_sphere(rd: Vector, centre: Vector, r: f32) -> Option<f32> {
    let b = rd.dot(centre);
    let c = centre.dot(centre) - r * r;
    let h = b * b - c;
    if h < 0.0 || c < 0.0 {
        return None;
    }
    let t = b - h.sqrt();
    (t > 0.0).then_some(t)
}

/// Entry parameter of the ray `t dir` (origin at the camera) into the box,
/// if it enters before `tmax`.
#[inline]
fn slab(inv: Vector, mins: Vector, maxs: Vector, tmax: f32) -> bool {
    let t1 = mins * inv;
    let t2 = maxs * inv;
    let tmin = t1.min(t2).max_element().max(0.0);
    let tout = t1.max(t2).min_element().min(tmax);
    tmin <= tout
}

impl World {
    /// World pose of `camera`'s OpenCV frame.
    pub fn camera_pose(&self, camera: &Camera) -> Result<Isometry3<f64>> {
        Ok(match camera.mount {
            CameraMount::World => camera.pose,
            CameraMount::Link { robot, link } => {
                let r = self.robot(robot)?;
                if link >= r.model().links().len() {
                    return Err(SimError::UnknownName(format!(
                        "camera mount: robot '{}' has no link {link}",
                        r.name()
                    )));
                }
                r.link_pose(&self.state, link) * camera.pose
            }
        })
    }

    /// Renders depth and segmentation (and RGB when `rgb`) from `camera`.
    pub fn render(&self, camera: &Camera, rgb: bool) -> Result<Frame> {
        camera.validate()?;
        let intr = camera.intrinsics;
        let (w, h) = (intr.width, intr.height);
        let cam_world = to_pose(&self.camera_pose(camera)?);
        let world_cam = cam_world.inverse();
        let near = camera.near as f32;
        let far = camera.far as f32;
        let full = (0, w as i64 - 1, 0, h as i64 - 1);
        let mut items = Vec::new();
        for (_, c) in self.state.colliders.iter() {
            if !c.is_enabled() {
                continue;
            }
            // From the parent body: collider poses are only synced during a
            // step, and a teleport (set_joint_positions, set_object_pose)
            // moves the bodies at once.
            let world_pose = match (c.parent(), c.position_wrt_parent()) {
                (Some(b), Some(rel)) => match self.state.bodies.get(b) {
                    Some(body) => *body.position() * *rel,
                    None => *c.position(),
                },
                _ => *c.position(),
            };
            let pose = world_cam * world_pose;
            let seg = seg_of(c.user_data);
            let shape = c.shared_shape().clone();
            if let Some(hs) = shape.as_halfspace() {
                let n = pose.rotation * hs.normal;
                let d = n.dot(pose.translation);
                items.push(Item {
                    shape,
                    pose,
                    seg,
                    rect: full,
                    mins: Vector::splat(f32::NEG_INFINITY),
                    maxs: Vector::splat(f32::INFINITY),
                    plane: Some((n, d)),
                    fast: Fast::None,
                });
                continue;
            }
            // Compounds (cylinders along z, convex decompositions) become
            // one item per part: tighter bounds, analytic casts.
            let parts: Vec<(Pose, SharedShape)> = match shape.as_compound() {
                Some(comp) => comp
                    .shapes()
                    .iter()
                    .map(|(p, s)| (pose * *p, s.clone()))
                    .collect(),
                None => vec![(pose, shape)],
            };
            for (pose, shape) in parts {
                let aabb = shape.compute_aabb(&pose);
                let rect = if aabb.maxs.z <= near || aabb.mins.z >= far {
                    None
                } else if aabb.mins.z <= near {
                    Some(full)
                } else {
                    let (mut u0, mut u1, mut v0, mut v1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
                    for corner in aabb.vertices() {
                        let z = corner.z as f64;
                        let u = intr.fx * corner.x as f64 / z + intr.cx;
                        let v = intr.fy * corner.y as f64 / z + intr.cy;
                        u0 = u0.min(u);
                        u1 = u1.max(u);
                        v0 = v0.min(v);
                        v1 = v1.max(v);
                    }
                    let r = (
                        (u0.floor() as i64).max(0),
                        (u1.ceil() as i64).min(w as i64 - 1),
                        (v0.floor() as i64).max(0),
                        (v1.ceil() as i64).min(h as i64 - 1),
                    );
                    (r.0 <= r.1 && r.2 <= r.3).then_some(r)
                };
                if let Some(rect) = rect {
                    let fast = Fast::of(shape.as_ref(), &pose);
                    items.push(Item {
                        shape,
                        pose,
                        seg,
                        rect,
                        mins: aabb.mins,
                        maxs: aabb.maxs,
                        plane: None,
                        fast,
                    });
                }
            }
        }
        // Half-spaces first (analytic), then bodies front to back so that a
        // pixel stops at the first box farther than its nearest hit.
        items.sort_by(|a, b| {
            (a.plane.is_none(), a.mins.z)
                .partial_cmp(&(b.plane.is_none(), b.mins.z))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let colors: Vec<[f32; 3]> = {
            let max = self.labels().iter().map(|l| l.id).max().unwrap_or(0) as usize;
            let mut c = vec![[0.0f32; 3]; max + 1];
            for l in self.labels() {
                c[l.id as usize] = l.color;
            }
            c
        };
        let mut depth = vec![f32::INFINITY; w * h];
        let mut seg = vec![0u32; w * h];
        let mut rgb_buf = if rgb {
            vec![0u8; 3 * w * h]
        } else {
            Vec::new()
        };
        let (fx, fy, cx, cy) = (intr.fx, intr.fy, intr.cx, intr.cy);
        let render_row = |v: usize, drow: &mut [f32], srow: &mut [u32], crow: &mut [u8]| {
            let vi = v as i64;
            let cands: Vec<&Item> = items
                .iter()
                .filter(|it| it.rect.2 <= vi && vi <= it.rect.3)
                .collect();
            if cands.is_empty() {
                return;
            }
            let dy = ((v as f64 - cy) / fy) as f32;
            for u in 0..w {
                let ui = u as i64;
                let dir = Vector::new(((u as f64 - cx) / fx) as f32, dy, 1.0);
                let ray = Ray::new(Vector::ZERO, dir);
                // Depth equals the ray parameter because dir.z == 1.
                let mut best = far;
                let mut hit: Option<&Item> = None;
                let inv = Vector::ONE / dir;
                for it in &cands {
                    if let Some((n, d)) = it.plane {
                        // Ray t*dir enters n.x <= d where n.(t dir) = d from outside.
                        let nd = n.dot(dir);
                        if d < 0.0 && nd < 0.0 {
                            let t = d / nd;
                            if t >= near && t < best {
                                best = t;
                                hit = Some(it);
                            }
                        } else if d >= 0.0 && near < best {
                            // The camera is inside the half-space.
                            best = near;
                            hit = Some(it);
                        }
                        continue;
                    }
                    if it.mins.z >= best {
                        break;
                    }
                    if ui < it.rect.0 || ui > it.rect.1 || !slab(inv, it.mins, it.maxs, best) {
                        continue;
                    }
                    let t = match it.fast.cast(dir) {
                        Some(hit) => hit.map(|(t, _)| t),
                        None => it.shape.cast_ray(&it.pose, &ray, best, true),
                    };
                    if let Some(t) = t
                        && t >= near
                        && t < best
                    {
                        best = t;
                        hit = Some(it);
                    }
                }
                if let Some(it) = hit {
                    drow[u] = best;
                    srow[u] = it.seg;
                    if !crow.is_empty() {
                        let normal = match (it.plane, it.fast.cast(dir)) {
                            (Some((n, _)), _) => Some(n),
                            (_, Some(hit)) => hit.map(|(_, n)| n),
                            _ => it
                                .shape
                                .cast_ray_and_get_normal(&it.pose, &ray, best * 1.001 + 1e-4, true)
                                .map(|i| i.normal),
                        };
                        let shade = normal.map_or(1.0, |n| {
                            0.35 + 0.65 * n.normalize_or_zero().dot(dir.normalize()).abs()
                        });
                        let c = colors.get(it.seg as usize).copied().unwrap_or([1.0; 3]);
                        for k in 0..3 {
                            crow[3 * u + k] = (c[k] * shade * 255.0).clamp(0.0, 255.0) as u8;
                        }
                    }
                }
            }
        };
        if rgb {
            depth
                .par_chunks_mut(w)
                .zip(seg.par_chunks_mut(w))
                .zip(rgb_buf.par_chunks_mut(3 * w))
                .enumerate()
                .for_each(|(v, ((d, s), c))| render_row(v, d, s, c));
        } else {
            depth
                .par_chunks_mut(w)
                .zip(seg.par_chunks_mut(w))
                .enumerate()
                .for_each(|(v, (d, s))| render_row(v, d, s, &mut []));
        }
        Ok(Frame {
            width: w,
            height: h,
            depth,
            segmentation: seg,
            rgb: rgb.then_some(rgb_buf),
        })
    }
}
