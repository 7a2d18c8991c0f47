//! Pinhole cameras rendering depth, segmentation and Lambert-shaded RGB
//! from the scene's collision geometry: boxes and convex polyhedra
//! rasterised into a depth buffer, curved primitives ray cast against it,
//! bands of rows in parallel.
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

/// A directional light (the sun, a distant lamp): parallel rays.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionalLight {
    /// Direction the light travels, world frame (any non-zero length;
    /// normalised when rendering). `[0, 0, -1]` shines straight down.
    pub direction: [f64; 3],
    /// Colour (linear RGB, each component in [0, 1]).
    pub color: [f64; 3],
    /// Intensity in [0, 10] (a surface facing the light receives
    /// `color * intensity`).
    pub intensity: f64,
}

/// How RGB images are shaded (Lambert): a pixel of a surface with albedo
/// `c` (the segmentation label's colour) and unit normal `n` seen along the
/// unit view ray `r` is
/// `255 * c * (ambient + headlight * |n·r| + Σ color_i * intensity_i * max(0, -n·l_i))`
/// per channel, saturating at 255, where `l_i` is light `i`'s unit direction
/// of travel. The default (ambient 0.35, headlight 0.65, no lights) is the
/// renderer's historical head-light shading. Depth and segmentation do not
/// depend on lighting.
#[derive(Debug, Clone, PartialEq)]
pub struct Lighting {
    /// Ambient term per channel, each in [0, 1].
    pub ambient: [f64; 3],
    /// Weight in [0, 1] of a light at the camera (shading by the angle
    /// between the surface and the view ray).
    pub headlight: f64,
    /// Directional lights (at most [`Lighting::MAX_LIGHTS`]).
    pub lights: Vec<DirectionalLight>,
}

impl Default for Lighting {
    fn default() -> Self {
        Self {
            ambient: [0.35; 3],
            headlight: 0.65,
            lights: Vec::new(),
        }
    }
}

impl Lighting {
    /// Most directional lights a scene may have.
    pub const MAX_LIGHTS: usize = 8;

    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<()> {
        let unit = |what: &str, v: f64| {
            if v.is_finite() && (0.0..=1.0).contains(&v) {
                Ok(())
            } else {
                Err(SimError::InvalidArgument(format!(
                    "lighting: {what} must be in [0, 1], got {v}"
                )))
            }
        };
        for v in self.ambient {
            unit("ambient", v)?;
        }
        unit("headlight", self.headlight)?;
        if self.lights.len() > Self::MAX_LIGHTS {
            return Err(SimError::InvalidArgument(format!(
                "lighting: at most {} directional lights, got {}",
                Self::MAX_LIGHTS,
                self.lights.len()
            )));
        }
        for (i, l) in self.lights.iter().enumerate() {
            let n2: f64 = l.direction.iter().map(|x| x * x).sum();
            if !(n2.is_finite() && n2 > 1e-18) {
                return Err(SimError::InvalidArgument(format!(
                    "lighting: light {i} direction must be finite and non-zero, got {:?}",
                    l.direction
                )));
            }
            for v in l.color {
                unit(&format!("light {i} color"), v)?;
            }
            if !(l.intensity.is_finite() && (0.0..=10.0).contains(&l.intensity)) {
                return Err(SimError::InvalidArgument(format!(
                    "lighting: light {i} intensity must be in [0, 10], got {}",
                    l.intensity
                )));
            }
        }
        Ok(())
    }
}

/// Rows rendered together (one rayon task).
const BAND: usize = 16;

/// A front face of a planar body (box or convex polyhedron) for
/// rasterisation: its plane in the camera frame, its polygon clipped to the
/// view frustum and projected to pixels.
struct RasterFace {
    /// Outward normal and offset (camera frame; the face is `n·x = d`).
    n: Vector,
    d: f32,
    seg: u32,
    /// Inclusive pixel rows covered.
    v0: usize,
    v1: usize,
    /// Range of the projected polygon in `RasterSetup::poly`.
    start: usize,
    len: usize,
}

/// A convex polygon clipped against the near plane and the four sides of
/// the frustum (widened by a pixel), in camera-frame coordinates (`f64`).
struct Clipper {
    /// Planes `a·x >= 0` (through the camera) and the near plane.
    sides: [[f64; 3]; 4],
    near: f64,
    a: Vec<[f64; 3]>,
    b: Vec<[f64; 3]>,
}

impl Clipper {
    fn new(intr: &Intrinsics, near: f64) -> Self {
        let (w, h) = (intr.width as f64, intr.height as f64);
        let l = (-1.0 - intr.cx) / intr.fx;
        let r = (w - intr.cx) / intr.fx;
        let t = (-1.0 - intr.cy) / intr.fy;
        let b = (h - intr.cy) / intr.fy;
        Self {
            sides: [
                [1.0, 0.0, -l],
                [-1.0, 0.0, r],
                [0.0, 1.0, -t],
                [0.0, -1.0, b],
            ],
            near,
            a: Vec::with_capacity(16),
            b: Vec::with_capacity(16),
        }
    }

    /// Clips the polygon in `self.a`; the result is left in `self.a`.
    /// Intersections are computed from the edge's end points in a canonical
    /// order, so that two faces sharing an edge get bit-identical clipped
    /// vertices (no cracks between them).
    fn clip(&mut self) {
        for k in 0..5 {
            let f = |p: &[f64; 3]| -> f64 {
                if k == 4 {
                    p[2] - self.near
                } else {
                    let s = self.sides[k];
                    s[0] * p[0] + s[1] * p[1] + s[2] * p[2]
                }
            };
            self.b.clear();
            let n = self.a.len();
            for i in 0..n {
                let p = self.a[i];
                let q = self.a[(i + 1) % n];
                let (fp, fq) = (f(&p), f(&q));
                if fp >= 0.0 {
                    self.b.push(p);
                }
                if (fp >= 0.0) != (fq >= 0.0) {
                    let (x, y, fx, fy) = if p < q {
                        (p, q, fp, fq)
                    } else {
                        (q, p, fq, fp)
                    };
                    let s = fx / (fx - fy);
                    self.b.push([
                        x[0] + s * (y[0] - x[0]),
                        x[1] + s * (y[1] - x[1]),
                        x[2] + s * (y[2] - x[2]),
                    ]);
                }
            }
            std::mem::swap(&mut self.a, &mut self.b);
            if self.a.len() < 3 {
                self.a.clear();
                return;
            }
        }
    }
}

/// The planar bodies' front faces, ready to rasterise.
struct RasterSetup {
    faces: Vec<RasterFace>,
    poly: Vec<(f64, f64)>,
}

impl RasterSetup {
    /// Adds the front faces of a convex body: `verts` in the camera frame,
    /// `faces` as (outward normal, offset, vertex loop).
    fn add_body<'a>(
        &mut self,
        clip: &mut Clipper,
        intr: &Intrinsics,
        verts: &[[f64; 3]],
        faces: impl Iterator<Item = (Vector, f32, &'a [u32])>,
        seg: u32,
    ) {
        for (n, d, lp) in faces {
            // Front faces only: the camera (origin) outside the face plane.
            if d.is_nan() || d >= 0.0 {
                continue;
            }
            clip.a.clear();
            clip.a.extend(lp.iter().map(|&i| verts[i as usize]));
            clip.clip();
            if clip.a.is_empty() {
                continue;
            }
            let start = self.poly.len();
            let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
            for p in &clip.a {
                let u = intr.fx * p[0] / p[2] + intr.cx;
                let v = intr.fy * p[1] / p[2] + intr.cy;
                y0 = y0.min(v);
                y1 = y1.max(v);
                self.poly.push((u, v));
            }
            // Rows v with y0 <= v < y1.
            let v0 = y0.ceil().max(0.0);
            let v1 = (y1.ceil() - 1.0).min(intr.height as f64 - 1.0);
            if v0.is_nan() || v1.is_nan() || v0 > v1 {
                self.poly.truncate(start);
                continue;
            }
            self.faces.push(RasterFace {
                n,
                d,
                seg,
                v0: v0 as usize,
                v1: v1 as usize,
                start,
                len: self.poly.len() - start,
            });
        }
    }
}

/// The pixel columns `[u0, u1)` of row `v` inside the convex polygon `poly`
/// (pixel centres with `x_left <= u < x_right`; each edge's crossing is
/// computed from its end points in a canonical order, so neighbouring faces
/// share it exactly).
#[inline]
fn span(poly: &[(f64, f64)], v: f64, w: usize) -> (usize, usize) {
    let (mut xl, mut xr) = (f64::INFINITY, f64::NEG_INFINITY);
    let n = poly.len();
    for i in 0..n {
        let (p, q) = (poly[i], poly[(i + 1) % n]);
        let (p, q) = if p.1 < q.1 || (p.1 == q.1 && p.0 < q.0) {
            (p, q)
        } else {
            (q, p)
        };
        if p.1 <= v && v < q.1 {
            let x = p.0 + (v - p.1) * (q.0 - p.0) / (q.1 - p.1);
            xl = xl.min(x);
            xr = xr.max(x);
        }
    }
    if xl.is_nan() || xr.is_nan() || xl >= xr {
        return (0, 0);
    }
    let u0 = xl.ceil().clamp(0.0, w as f64) as usize;
    let u1 = xr.ceil().clamp(0.0, w as f64) as usize;
    (u0, u1)
}

/// A box face: outward normal, offset, corner loop.
type BoxFace = (Vector, f32, [u32; 4]);

/// The eight corners (camera frame) and six faces of a box.
fn box_faces(pose: &Pose, he: Vector) -> ([[f64; 3]; 8], [BoxFace; 6]) {
    let mut verts = [[0.0; 3]; 8];
    for (i, v) in verts.iter_mut().enumerate() {
        let s = |b: usize| if i & b != 0 { 1.0 } else { -1.0 };
        let p = pose.transform_point(Vector::new(s(1) * he.x, s(2) * he.y, s(4) * he.z));
        *v = [p.x as f64, p.y as f64, p.z as f64];
    }
    let t = pose.translation;
    let (tx, ty, tz) = (t.x as f64, t.y as f64, t.z as f64);
    let face = |axis: usize, sign: f32, lp: [u32; 4]| {
        let mut a = Vector::ZERO;
        a[axis] = sign;
        let n = pose.rotation * a;
        // Offset from the face centre (not a far corner): accurate for the
        // 2 km ground box.
        let c = pose.rotation * (a * he[axis]);
        let d = n.x as f64 * (tx + c.x as f64)
            + n.y as f64 * (ty + c.y as f64)
            + n.z as f64 * (tz + c.z as f64);
        (n, d as f32, lp)
    };
    // Corner i has x = +he.x when bit 1 is set, y when bit 2, z when bit 4.
    let faces = [
        face(0, -1.0, [0, 2, 6, 4]),
        face(0, 1.0, [1, 5, 7, 3]),
        face(1, -1.0, [0, 4, 5, 1]),
        face(1, 1.0, [2, 3, 7, 6]),
        face(2, -1.0, [0, 1, 3, 2]),
        face(2, 1.0, [4, 6, 7, 5]),
    ];
    (verts, faces)
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

    /// The lighting RGB images are shaded with.
    pub fn lighting(&self) -> &Lighting {
        &self.lighting
    }

    /// Sets the lighting (checked; the previous lighting is kept on error).
    pub fn set_lighting(&mut self, lighting: Lighting) -> Result<()> {
        lighting.validate()?;
        self.lighting = lighting;
        Ok(())
    }

    /// Renders depth and segmentation (and RGB when `rgb`) from `camera`.
    ///
    /// Boxes and convex polyhedra (robot links' hulls, objects' hulls and
    /// convex decompositions, the ground and tables) are rasterised: their
    /// front faces, clipped to the view frustum, are scan-converted into a
    /// depth buffer, each pixel's depth computed from the face's plane
    /// along the pixel's ray (the ray cast's own formula). Curved
    /// primitives (spheres, capsules, cylinders), half-spaces and other
    /// shapes are ray cast analytically per pixel against that buffer.
    pub fn render(&self, camera: &Camera, rgb: bool) -> Result<Frame> {
        self.render_impl(camera, rgb, true)
    }

    /// The same image as [`World::render`], every shape ray cast per pixel
    /// (no rasterisation): the slower reference the rasteriser is tested
    /// against.
    pub fn render_ray_cast(&self, camera: &Camera, rgb: bool) -> Result<Frame> {
        self.render_impl(camera, rgb, false)
    }

    fn render_impl(&self, camera: &Camera, rgb: bool, raster: bool) -> Result<Frame> {
        camera.validate()?;
        let intr = camera.intrinsics;
        let (w, h) = (intr.width, intr.height);
        let cam_world = to_pose(&self.camera_pose(camera)?);
        let world_cam = cam_world.inverse();
        let near = camera.near as f32;
        let far = camera.far as f32;
        let full = (0, w as i64 - 1, 0, h as i64 - 1);
        let mut items = Vec::new();
        let mut setup = RasterSetup {
            faces: Vec::new(),
            poly: Vec::new(),
        };
        let mut clipper = Clipper::new(&intr, camera.near);
        let mut hull_verts: Vec<[f64; 3]> = Vec::new();
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
                // Bounding-volume culling: behind the camera or beyond far.
                if aabb.maxs.z <= near || aabb.mins.z >= far {
                    continue;
                }
                if raster {
                    if let Some(b) = shape.as_cuboid() {
                        let (verts, faces) = box_faces(&pose, b.half_extents);
                        setup.add_body(
                            &mut clipper,
                            &intr,
                            &verts,
                            faces.iter().map(|(n, d, lp)| (*n, *d, &lp[..])),
                            seg,
                        );
                        continue;
                    }
                    if let Some(cp) = shape.as_convex_polyhedron() {
                        hull_verts.clear();
                        hull_verts.extend(cp.points().iter().map(|p| {
                            let q = pose.transform_point(*p);
                            [q.x as f64, q.y as f64, q.z as f64]
                        }));
                        let adj = cp.vertices_adj_to_face();
                        // The face planes exactly as the ray cast computes them.
                        let faces = cp.faces().iter().map(|f| {
                            let n = pose.rotation * f.normal;
                            let first = f.first_vertex_or_edge as usize;
                            let lp = &adj[first..first + f.num_vertices_or_edges as usize];
                            let p = pose.transform_point(cp.points()[lp[0] as usize]);
                            (n, n.dot(p), lp)
                        });
                        setup.add_body(&mut clipper, &intr, &hull_verts, faces, seg);
                        continue;
                    }
                }
                let rect = if aabb.mins.z <= near {
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
            // Albedo times 255 per label.
            let mut c = vec![[0.0f32; 3]; max + 1];
            for l in self.labels() {
                c[l.id as usize] = l.color.map(|x| x * 255.0);
            }
            c
        };
        // Lights in the camera frame, colour times intensity.
        let lt = &self.lighting;
        let ambient = lt.ambient.map(|x| x as f32);
        let headlight = lt.headlight as f32;
        let lights: Vec<(Vector, [f32; 3])> = lt
            .lights
            .iter()
            .map(|l| {
                let dw = nalgebra::Vector3::from(l.direction).normalize();
                let dc = world_cam.rotation * Vector::new(dw.x as f32, dw.y as f32, dw.z as f32);
                (dc, l.color.map(|c| (c * l.intensity) as f32))
            })
            .collect();
        let (fx, fy, cx, cy) = (intr.fx, intr.fy, intr.cx, intr.cy);
        let dxs: Vec<f32> = (0..w).map(|u| ((u as f64 - cx) / fx) as f32).collect();
        let mut depth = vec![f32::INFINITY; w * h];
        let mut seg = vec![0u32; w * h];
        let mut rgb_buf = if rgb {
            vec![0u8; 3 * w * h]
        } else {
            Vec::new()
        };
        let setup = &setup;
        let render_band = |band: usize, dband: &mut [f32], sband: &mut [u32], cband: &mut [u8]| {
            let rows = dband.len() / w;
            let first = band * BAND;
            let last = first + rows - 1;
            let faces: Vec<&RasterFace> = setup
                .faces
                .iter()
                .filter(|f| f.v0 <= last && f.v1 >= first)
                .collect();
            // Hit normals (camera frame, unit length or zero when unknown)
            // of the current row, for shading; written wherever a hit is.
            let mut normals = if cband.is_empty() {
                Vec::new()
            } else {
                vec![Vector::ZERO; w]
            };
            for r in 0..rows {
                let v = first + r;
                let drow = &mut dband[r * w..(r + 1) * w];
                let srow = &mut sband[r * w..(r + 1) * w];
                let dy = ((v as f64 - cy) / fy) as f32;
                drow.fill(far);
                // Rasterised faces into the row's depth buffer.
                for f in &faces {
                    if v < f.v0 || v > f.v1 {
                        continue;
                    }
                    let (u0, u1) = span(&setup.poly[f.start..f.start + f.len], v as f64, w);
                    for u in u0..u1 {
                        let t = f.d / f.n.dot(Vector::new(dxs[u], dy, 1.0));
                        if t >= near && t < drow[u] {
                            drow[u] = t;
                            srow[u] = f.seg;
                            if !normals.is_empty() {
                                normals[u] = f.n;
                            }
                        }
                    }
                }
                // Ray-cast items against it.
                let vi = v as i64;
                let cands: Vec<&Item> = items
                    .iter()
                    .filter(|it| it.rect.2 <= vi && vi <= it.rect.3)
                    .collect();
                if !cands.is_empty() {
                    // Only the columns some candidate covers.
                    let ua = cands.iter().map(|it| it.rect.0).min().unwrap_or(0).max(0) as usize;
                    let ub = cands.iter().map(|it| it.rect.1).max().unwrap_or(0).max(0) as usize;
                    for u in ua..=ub.min(w - 1) {
                        let ui = u as i64;
                        let dir = Vector::new(dxs[u], dy, 1.0);
                        // Depth equals the ray parameter because dir.z == 1.
                        let mut best = drow[u];
                        let mut hit: Option<(&Item, Option<Vector>)> = None;
                        let inv = Vector::ONE / dir;
                        for it in &cands {
                            if let Some((n, d)) = it.plane {
                                // Ray t*dir enters n.x <= d where n.(t dir) = d from outside.
                                let nd = n.dot(dir);
                                if d < 0.0 && nd < 0.0 {
                                    let t = d / nd;
                                    if t >= near && t < best {
                                        best = t;
                                        hit = Some((it, Some(n)));
                                    }
                                } else if d >= 0.0 && near < best {
                                    // The camera is inside the half-space.
                                    best = near;
                                    hit = Some((it, Some(n)));
                                }
                                continue;
                            }
                            if it.mins.z >= best {
                                break;
                            }
                            if ui < it.rect.0
                                || ui > it.rect.1
                                || !slab(inv, it.mins, it.maxs, best)
                            {
                                continue;
                            }
                            let t = match it.fast.cast(dir) {
                                Some(h) => h,
                                None => {
                                    let ray = Ray::new(Vector::ZERO, dir);
                                    it.shape
                                        .cast_ray_and_get_normal(&it.pose, &ray, best, true)
                                        .map(|i| (i.time_of_impact, i.normal))
                                }
                            };
                            if let Some((t, n)) = t
                                && t >= near
                                && t < best
                            {
                                best = t;
                                hit = Some((it, Some(n)));
                            }
                        }
                        if let Some((it, n)) = hit {
                            drow[u] = best;
                            srow[u] = it.seg;
                            if !normals.is_empty() {
                                normals[u] = n.unwrap_or(Vector::ZERO);
                            }
                        }
                    }
                }
                for d in drow.iter_mut() {
                    if *d >= far {
                        *d = f32::INFINITY;
                    }
                }
                if cband.is_empty() {
                    continue;
                }
                let crow = &mut cband[3 * r * w..3 * (r + 1) * w];
                let dy2 = dy * dy + 1.0;
                for u in 0..w {
                    if drow[u].is_infinite() {
                        continue;
                    }
                    let n = normals[u];
                    let head = if n == Vector::ZERO {
                        1.0
                    } else {
                        let view = Vector::new(dxs[u], dy, 1.0);
                        n.dot(view).abs() / (dxs[u] * dxs[u] + dy2).sqrt()
                    };
                    let mut shade = [
                        ambient[0] + headlight * head,
                        ambient[1] + headlight * head,
                        ambient[2] + headlight * head,
                    ];
                    for (l, c) in &lights {
                        let lambert = (-n.dot(*l)).max(0.0);
                        for k in 0..3 {
                            shade[k] += c[k] * lambert;
                        }
                    }
                    let c = colors.get(srow[u] as usize).copied().unwrap_or([255.0; 3]);
                    for k in 0..3 {
                        crow[3 * u + k] = (c[k] * shade[k]).clamp(0.0, 255.0) as u8;
                    }
                }
            }
        };
        if rgb {
            depth
                .par_chunks_mut(BAND * w)
                .zip(seg.par_chunks_mut(BAND * w))
                .zip(rgb_buf.par_chunks_mut(3 * BAND * w))
                .enumerate()
                .for_each(|(b, ((d, s), c))| render_band(b, d, s, c));
        } else {
            depth
                .par_chunks_mut(BAND * w)
                .zip(seg.par_chunks_mut(BAND * w))
                .enumerate()
                .for_each(|(b, (d, s))| render_band(b, d, s, &mut []));
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
