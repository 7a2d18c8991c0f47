//! Exact link geometry for confirming self-collisions found by spheres.
//!
//! A conservative sphere model covers each link with some protrusion (a few
//! millimetres to centimetres beyond the surface), so two links that come
//! close, such as the Panda's link 5 and link 7 in its `ready` pose, can
//! have overlapping spheres while their geometry is apart. Self-collision
//! is therefore decided in two stages: spheres first (fast, never missing a
//! contact of the covered geometry), then, for the lanes where two robot
//! links' spheres overlap, the links' collision geometry itself: primitives
//! exactly, meshes as their convex hulls (which contain them, so the second
//! stage cannot miss a contact either). World collisions stay sphere-only.
//! Attached objects have no exact shape: spheres decide.
//!
//! Where a mesh's hull is too coarse (some point of the hull's surface lies
//! more than [`HULL_EXCESS`] from the mesh, e.g. the UR3's upper arm, whose
//! hull fills the hollow of its shoulder), a contact of the hulls is
//! re-decided on the mesh itself (`refine`): its triangles (parry's
//! `TriMesh` and its BVH, traversed together with the other part's) against
//! the other part's triangles (its mesh, or its hull's faces), with exact
//! triangle-triangle distances. The surfaces are apart only if no triangle
//! pair is within the margin; the solids are then apart unless one lies
//! inside the other, which is ruled out by the hull's planes (a mesh in a
//! hull) or when one hull reaches further than the other along one of 26
//! directions, and otherwise reported as a contact. Against a primitive
//! (box, sphere, cylinder, capsule) the hulls' verdict stands. So the mesh
//! stage only turns a hull contact into "free" when the surfaces are apart
//! and neither solid can hold the other: it stays conservative with respect
//! to the mesh, also for meshes that are not closed. No decomposition is
//! computed, so nothing needs caching: building the BVH and measuring the
//! hull's excess take milliseconds per link. Two things keep deep contacts
//! cheap: such parts get inscribed spheres too (step 2 below), centred
//! where the mesh's generalized winding number is at least
//! `INSIDE_WINDING` in absolute value (inside; closed meshes give 0 or
//! ±1) and not reaching its surface, so an overlap of two inscribed spheres
//! decides a contact without GJK or triangles; and each part remembers the
//! triangle pair that touched last for each other part (a hint tested
//! first: consecutive checks along a motion touch at the same place), which
//! changes the time, never the answer. Before the triangles, a refined
//! part's witness points (its inscribed spheres' centres and mesh vertices
//! spread over it) are tested against the other part's solid: one inside is
//! a contact the triangles would confirm too, found without the traversal.
//!
//! The second stage is cheap because most lanes never reach GJK:
//!
//! 1. Each part carries an oriented bounding box (in its lane frame, padded
//!    for `f32` rounding). For every pair of parts the separating-axis test
//!    of the two boxes runs on all lanes at once; disjoint boxes mean
//!    disjoint parts, so those lanes are free without further work.
//! 2. Each part also carries a few spheres inscribed in it (shrunk for
//!    rounding). Where an inscribed sphere of one part overlaps one of the
//!    other, the parts certainly touch: those lanes collide without GJK.
//! 3. The remaining lanes run parry's GJK on the pair. The relative pose of
//!    the two parts is built from the lane frames' rotation matrices in
//!    `f32` (no `f64` isometries), and convex hulls answer support queries
//!    with an eight-wide scan of their vertices.
//!
//! Every step only uses the lane's own `f32` values, so the scalar and the
//! eight-lane kernels answer identically.

use std::sync::Arc;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering::Relaxed};

use ferrobot_model::{Link, Shape};
use nalgebra::{Isometry3, Matrix3, Point3, SymmetricEigen, UnitQuaternion, Vector3};
use parry3d::bounding_volume::BoundingVolume;
use parry3d::math::{Mat3, Pose, Rot3, Vector};
use parry3d::query::ClosestPoints;
use parry3d::query::PointQuery;
use parry3d::query::details::{
    closest_points_support_map_support_map, intersection_test_support_map_support_map,
};
use parry3d::shape::{Ball, Capsule, Cuboid, Cylinder, SupportMap, TriMesh};

use crate::compiled::Frame32;
use crate::kernel::LaneFrame;
use crate::lanes::Lanes;
use wide::f32x8;

/// Counters of the exact stage per pair of parts (feature `exact-stats`,
/// for the probes in `benches/` only: they take a lock, so no normal build
/// has them).
#[cfg(feature = "exact-stats")]
pub mod stats {
    use std::collections::HashMap;
    use std::sync::Mutex;

    /// What the exact stage did for one pair of parts.
    #[derive(Debug, Default, Clone, Copy)]
    pub struct PairStats {
        /// Lanes whose boxes overlap (cheap step).
        pub boxes: u64,
        /// Of those, lanes decided by inscribed spheres.
        pub inner: u64,
        /// GJK calls.
        pub gjk: u64,
        /// GJK calls that found the hulls in contact.
        pub gjk_hit: u64,
        /// Mesh refinements.
        pub refine: u64,
        /// Refinements that confirmed the contact.
        pub refine_hit: u64,
        /// Refinements decided by the hint, the containment test, a
        /// witness point, a triangle pair found by the traversal,
        /// `may_hold`; apart.
        pub by: [u64; 6],
        /// Triangle pairs tested (`touch`) in refinements.
        pub touch_tests: u64,
        /// Time spent in refinements (ns).
        pub refine_ns: u64,
        /// Time spent in GJK (ns).
        pub gjk_ns: u64,
    }

    type Table = HashMap<(u32, u32), PairStats>;
    static STATS: Mutex<Option<Table>> = Mutex::new(None);
    static NAMES: Mutex<Option<HashMap<u32, String>>> = Mutex::new(None);

    pub(crate) fn name(uid: u32, name: String) {
        NAMES
            .lock()
            .unwrap()
            .get_or_insert_with(HashMap::new)
            .insert(uid, name);
    }

    pub(crate) fn add(a: u32, b: u32, f: impl FnOnce(&mut PairStats)) {
        let mut s = STATS.lock().unwrap();
        f(s.get_or_insert_with(HashMap::new)
            .entry((a, b))
            .or_default());
    }

    /// Every pair's counters since the last call (part names as
    /// `link#part`), and resets them.
    pub fn take() -> Vec<(String, String, PairStats)> {
        let table = STATS.lock().unwrap().take().unwrap_or_default();
        let names = NAMES.lock().unwrap();
        let name = |u: u32| {
            names
                .as_ref()
                .and_then(|n| n.get(&u).cloned())
                .unwrap_or_else(|| format!("part{u}"))
        };
        let mut out: Vec<_> = table
            .into_iter()
            .map(|((a, b), s)| (name(a), name(b), s))
            .collect();
        out.sort_by(|x, y| (&x.0, &x.1).cmp(&(&y.0, &y.1)));
        out
    }
}

/// Padding (m) added to every box half extent, far above the `f32`
/// rounding of the lane arithmetic at robot scale (about 1e-7 m).
const BOX_PAD: f64 = 1e-5;
/// A mesh part whose convex hull's surface lies further than this (m) from
/// the mesh somewhere (the hull-to-mesh Hausdorff distance, measured at the
/// centroid and edge midpoints of every hull face) keeps its triangles, and
/// hull contacts are re-decided on them (`refine`). Below it the hull is
/// at most this much larger than the mesh and decides alone.
pub const HULL_EXCESS: f64 = 2e-3;
/// Triangles closer than this (m, plus the margin) count as touching in
/// [`refine`]: far above the `f32` rounding of the relative pose and of
/// GJK on robot-sized parts, so rounding never turns a contact into a gap.
const TOUCH: f32 = 1e-5;
/// Added to the absolute rotation entries of the separating-axis test, so
/// nearly parallel edges never produce a false separating axis.
const AXIS_EPS: f32 = 1e-5;

/// A convex hull: its vertices eight at a time (structure of arrays) for
/// support queries, and its face planes.
#[derive(Debug)]
struct Hull {
    /// Vertices x, y, z, eight per pack (the last vertex repeats).
    packs: Vec<[f32x8; 3]>,
    /// Face planes `(n, d)`, outward unit `n`: inside is `n . p <= d`.
    planes: Vec<(Vector3<f64>, f64)>,
    /// The same planes in `f32`, `[nx, ny, nz, d]`, for [`witness_inside`].
    planes32: Vec<[f32; 4]>,
    /// Vertices.
    points: Vec<Vector>,
    /// Triangles of the hull's surface (three vertices each).
    faces: Vec<[Vector; 3]>,
}

impl Hull {
    fn new(pts: &[Vector]) -> Option<Self> {
        let (raw, tris) = parry3d::transformation::try_convex_hull(pts).ok()?;
        if tris.len() < 4 {
            return None;
        }
        // The vertices the triangles use.
        let mut used = vec![false; raw.len()];
        tris.iter().flatten().for_each(|&v| used[v as usize] = true);
        let points: Vec<Vector> = raw
            .iter()
            .zip(&used)
            .filter_map(|(p, &u)| u.then_some(*p))
            .collect();
        let p64 = |p: &Vector| Vector3::new(p.x as f64, p.y as f64, p.z as f64);
        let inside = points.iter().fold(Vector3::zeros(), |a, p| a + p64(p)) / points.len() as f64;
        let planes: Vec<(Vector3<f64>, f64)> = tris
            .iter()
            .filter_map(|t| {
                let [a, b, c] = t.map(|v| p64(&raw[v as usize]));
                let n = (b - a).cross(&(c - a)).try_normalize(1e-12)?;
                let n = if n.dot(&(inside - a)) > 0.0 { -n } else { n };
                Some((n, n.dot(&a)))
            })
            .collect();
        let planes32 = planes
            .iter()
            .map(|(n, d)| [n.x as f32, n.y as f32, n.z as f32, *d as f32])
            .collect();
        let faces = tris.iter().map(|t| t.map(|v| raw[v as usize])).collect();
        let packs = points
            .chunks(8)
            .map(|c| {
                let get = |k: usize, axis: usize| c[k.min(c.len() - 1)][axis];
                [0, 1, 2].map(|axis| f32x8::new(std::array::from_fn(|k| get(k, axis))))
            })
            .collect();
        Some(Self {
            packs,
            planes,
            planes32,
            points,
            faces,
        })
    }

    /// The vertex furthest along `dir` (the first one on ties).
    #[inline]
    fn support(&self, dir: Vector) -> Vector {
        let d = [dir.x, dir.y, dir.z].map(f32x8::splat);
        let mut best = f32x8::splat(f32::NEG_INFINITY);
        let mut at = f32x8::splat(0.0);
        let mut index = f32x8::new([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
        for p in &self.packs {
            let v = p[0] * d[0] + p[1] * d[1] + p[2] * d[2];
            let better = best.simd_lt(v);
            best = better.select(v, best);
            at = better.select(index, at);
            index += f32x8::splat(8.0);
        }
        let (best, at) = (best.to_array(), at.to_array());
        let mut k = 0;
        for i in 1..8 {
            if best[i] > best[k] || (best[i] == best[k] && at[i] < at[k]) {
                k = i;
            }
        }
        self.points[at[k] as usize]
    }
}

/// A convex part shape.
#[derive(Debug, Clone)]
enum Convex {
    Ball(Ball),
    Cuboid(Cuboid),
    Cylinder(Cylinder),
    Capsule(Capsule),
    Hull(Arc<Hull>),
}

impl Convex {
    /// How deep local point `p` lies inside the shape (negative outside,
    /// a lower bound of the distance to the surface for hulls).
    fn depth(&self, p: &Vector3<f64>) -> f64 {
        match self {
            Convex::Ball(b) => b.radius as f64 - p.norm(),
            Convex::Cuboid(c) => (0..3)
                .map(|i| c.half_extents[i] as f64 - p[i].abs())
                .fold(f64::INFINITY, f64::min),
            Convex::Cylinder(c) => {
                (c.radius as f64 - p.x.hypot(p.z)).min(c.half_height as f64 - p.y.abs())
            }
            Convex::Capsule(c) => {
                let (a, b) = (c.segment.a, c.segment.b);
                let a = Vector3::new(a.x as f64, a.y as f64, a.z as f64);
                let ab = Vector3::new(b.x as f64, b.y as f64, b.z as f64) - a;
                let t = ((p - a).dot(&ab) / ab.norm_squared().max(1e-30)).clamp(0.0, 1.0);
                c.radius as f64 - (p - a - ab * t).norm()
            }
            Convex::Hull(h) => h
                .planes
                .iter()
                .map(|(n, d)| d - n.dot(p))
                .fold(f64::INFINITY, f64::min),
        }
    }
}

impl SupportMap for Convex {
    #[inline]
    fn local_support_point(&self, dir: Vector) -> Vector {
        match self {
            Convex::Ball(s) => s.local_support_point(dir),
            Convex::Cuboid(s) => s.local_support_point(dir),
            Convex::Cylinder(s) => s.local_support_point(dir),
            Convex::Capsule(s) => s.local_support_point(dir),
            Convex::Hull(h) => h.support(dir),
        }
    }
}

/// Whether the convex shapes `sa` and `sb` (`sb`'s pose in `sa`'s frame:
/// `pos12`) come closer than `margin` (> 0), never answering "no" for
/// shapes that do. parry's GJK distance can stop short of the minimum and
/// overstate it by millimetres (a cylinder against a box with parallel
/// faces: 31.35 mm for a true 29.93 mm), which would let a pair within the
/// margin pass; here the distance is the gap between the two shapes'
/// support points along GJK's direction (a separating plane: never more
/// than the true distance), and touching or overlapping shapes always count.
fn within_margin(pos12: &Pose, sa: &Convex, sb: &Convex, margin: f32) -> bool {
    if intersection_test_support_map_support_map(pos12, sa, sb) {
        return true;
    }
    match closest_points_support_map_support_map(pos12, sa, sb, f32::MAX) {
        ClosestPoints::WithinMargin(p1, p2) => {
            let n = *pos12 * p2 - p1;
            let len = n.length();
            // Closest points that coincide (or a NaN length): touching.
            if len.is_nan() || len <= 1e-9 {
                return true;
            }
            let n = n / len;
            let top_a = sa.local_support_point(n).dot(n);
            let dir_b = pos12.rotation.inverse() * -n;
            let bottom_b = (*pos12 * sb.local_support_point(dir_b)).dot(n);
            bottom_b - top_a < margin
        }
        // GJK found them intersecting after all, or could not tell.
        _ => true,
    }
}

/// An oriented box in the lane frame.
#[derive(Debug, Clone, Copy)]
struct Obb {
    /// Centre.
    c: [f32; 3],
    /// Unit axes, one per row.
    u: [f32; 9],
    /// Half extents (padded).
    h: [f32; 3],
}

impl Obb {
    /// The box with axes `axes` (columns, in the lane frame) that holds
    /// `points` (lane frame).
    fn fit(points: &[Point3<f64>], axes: &Matrix3<f64>) -> (Self, f64) {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for p in points {
            let l = axes.transpose() * p.coords;
            lo = lo.inf(&l);
            hi = hi.sup(&l);
        }
        let c = axes * ((lo + hi) / 2.0);
        let h = (hi - lo) / 2.0;
        (Self::new(c, axes, &h), h.x * h.y * h.z)
    }

    fn new(c: Vector3<f64>, axes: &Matrix3<f64>, h: &Vector3<f64>) -> Self {
        let mut u = [0.0f32; 9];
        for k in 0..3 {
            for r in 0..3 {
                u[k * 3 + r] = axes[(r, k)] as f32;
            }
        }
        Self {
            c: [c.x as f32, c.y as f32, c.z as f32],
            u,
            h: h.map(|v| (v * (1.0 + 1e-6) + BOX_PAD) as f32).into(),
        }
    }
}

/// One convex part of a link: pose in the lane frame, bounding box, shape.
#[derive(Debug, Clone)]
struct Part {
    pose: Frame32,
    obb: Obb,
    shape: Convex,
    /// Spheres inside the shape (lane frame: centre, radius): two parts
    /// whose inner spheres overlap certainly touch, without GJK.
    inner: Vec<([f32; 3], f32)>,
    /// The same spheres eight to a pack (x, y, z, radius lanes; padding
    /// lanes NaN, which never overlap), for the one-lane test.
    inner_packs: Vec<[f32x8; 4]>,
    /// The mesh itself (part frame), where its hull is too coarse
    /// ([`HULL_EXCESS`]): hull contacts are re-decided on it.
    fine: Option<Arc<TriMesh>>,
    /// Identifies the part in other parts' [`Part::hint`]s.
    uid: u32,
    /// The last triangle pair [`refine`] found touching, as the other
    /// part's `uid` (high 20 bits) and the two triangle indices (22 bits
    /// each): tested first by the next `refine` of the same pair (a hint
    /// only: the answer is the same without it).
    hint: Arc<AtomicU64>,
    /// The hull's faces as a mesh (hull parts without `fine`), standing
    /// for the part when the other part of a pair keeps its mesh.
    hull_faces: Option<Arc<TriMesh>>,
    /// Points of the solid of a part that keeps its mesh (part frame,
    /// eight per pack, the last repeated): its inscribed spheres' centres
    /// and mesh vertices spread over the surface. One of them inside the
    /// other part's hull is a contact ([`witness_inside`]), found before
    /// the triangle traversal. Empty for other parts.
    witness: Vec<[f32x8; 3]>,
    /// The inscribed spheres in the part frame (centre, radius shrunk by
    /// [`TOUCH`]), for [`witness_inside`] against a part that keeps its
    /// mesh.
    inner_local: Vec<[f32; 4]>,
    /// How far the shape reaches along each of [`directions26`] (part
    /// frame): `local_support_point(d).dot(d)`, the outer side of
    /// [`may_hold`], computed once.
    reach26: [f32; 26],
}

/// The 26 unit directions of [`may_hold`]: every (x, y, z) in {-1, 0, 1}^3
/// but the origin, normalised, in lexicographic order.
fn directions26() -> [Vector; 26] {
    let mut out = [Vector::ZERO; 26];
    let mut k = 0;
    for x in -1i8..=1 {
        for y in -1i8..=1 {
            for z in -1i8..=1 {
                if (x, y, z) == (0, 0, 0) {
                    continue;
                }
                out[k] = Vector::new(x as f32, y as f32, z as f32).normalize();
                k += 1;
            }
        }
    }
    out
}

/// At most this many inner spheres per part.
const INNER: usize = 16;
/// At most this many candidate inner spheres of a mesh part are tested
/// for lying inside the mesh ([`winding_number`]).
const INNER_TESTS: usize = 48;
/// A point whose winding number about a mesh is at least this (in
/// absolute value) is inside it. A closed mesh gives exactly 0 outside and
/// ±1 inside; small holes change it by their solid angle over 4π.
const INSIDE_WINDING: f64 = 0.9;
/// The bits of a part's `uid` kept in hints.
const UID_MASK: u64 = (1 << 20) - 1;
/// The bits of a triangle index kept in hints.
const TRI_MASK: u64 = (1 << 22) - 1;
/// The next part `uid`.
static NEXT_UID: AtomicU32 = AtomicU32::new(0);

/// The generalized winding number of mesh `m` about point `p` (mesh
/// frame): the triangles' signed solid angles over 4π (Van Oosterom and
/// Strackee's formula), 1 or -1 inside a closed mesh (by its orientation),
/// 0 outside.
fn winding_number(m: &TriMesh, p: &Vector3<f64>) -> f64 {
    let v = |q: Vector| Vector3::new(q.x as f64, q.y as f64, q.z as f64) - p;
    let mut sum = 0.0;
    for t in m.triangles() {
        let (a, b, c) = (v(t.a), v(t.b), v(t.c));
        let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
        let det = a.dot(&b.cross(&c));
        let den = la * lb * lc + a.dot(&b) * lc + b.dot(&c) * la + c.dot(&a) * lb;
        sum += 2.0 * det.atan2(den);
    }
    sum / (4.0 * std::f64::consts::PI)
}

impl Part {
    fn new(pose: Isometry3<f64>, obb: Obb, shape: Convex, fine: Option<Arc<TriMesh>>) -> Self {
        let mut part = Self {
            pose: Frame32::from_iso(&pose),
            obb,
            shape,
            inner: Vec::new(),
            inner_packs: Vec::new(),
            hull_faces: None,
            fine,
            uid: NEXT_UID.fetch_add(1, Relaxed) & UID_MASK as u32,
            hint: Arc::new(AtomicU64::new(u64::MAX)),
            reach26: [0.0; 26],
            witness: Vec::new(),
            inner_local: Vec::new(),
        };
        let dirs = directions26();
        part.reach26 =
            std::array::from_fn(|k| part.shape.local_support_point(dirs[k]).dot(dirs[k]));
        if let (Convex::Hull(h), None) = (&part.shape, &part.fine) {
            let v: Vec<Vector> = h.faces.iter().flatten().copied().collect();
            let t: Vec<[u32; 3]> = (0..h.faces.len() as u32)
                .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
                .collect();
            part.hull_faces = TriMesh::new(v, t).ok().map(Arc::new);
        }
        // Candidates on a grid over the box, largest inscribed first, kept
        // when not mostly inside one already kept.
        let n = 13;
        let mut cands: Vec<(Vector3<f64>, f64)> = Vec::new();
        let axes = |k: usize| {
            Vector3::new(
                obb.u[k * 3] as f64,
                obb.u[k * 3 + 1] as f64,
                obb.u[k * 3 + 2] as f64,
            )
        };
        let c0 = Vector3::new(obb.c[0] as f64, obb.c[1] as f64, obb.c[2] as f64);
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let f = |x: usize, h: f32| (2.0 * x as f64 / (n - 1) as f64 - 1.0) * h as f64;
                    let p = c0
                        + axes(0) * f(i, obb.h[0])
                        + axes(1) * f(j, obb.h[1])
                        + axes(2) * f(k, obb.h[2]);
                    let local = pose.inverse_transform_point(&Point3::from(p));
                    // Shrunk for f32 rounding: inner spheres must be inside.
                    let mut r = part.shape.depth(&local.coords) - BOX_PAD;
                    if let (Some(m), true) = (&part.fine, r > 0.0) {
                        // Within the hull: the distance to the mesh's
                        // surface (whether inside the mesh is tested
                        // below, for the spheres kept).
                        let l = Vector::new(local.x as f32, local.y as f32, local.z as f32);
                        let proj = m.project_local_point(l, false);
                        r = r.min((proj.point - l).length() as f64 - BOX_PAD);
                    }
                    if r > 0.0 {
                        cands.push((p, r));
                    }
                }
            }
        }
        cands.sort_by(|a, b| b.1.total_cmp(&a.1));
        let mut kept: Vec<(Vector3<f64>, f64)> = Vec::new();
        let mut tested = 0;
        for (p, r) in cands {
            if kept.len() == INNER || kept.first().is_some_and(|k| r < 0.2 * k.1) {
                break;
            }
            if kept.iter().all(|(q, s)| (p - q).norm() > 0.7 * s.max(r)) {
                if let Some(m) = &part.fine {
                    // A mesh part: only centres inside the mesh (the
                    // sphere then lies inside, as it does not reach the
                    // surface). Bounded work per part.
                    if tested == INNER_TESTS {
                        break;
                    }
                    tested += 1;
                    let local = pose.inverse_transform_point(&Point3::from(p));
                    if winding_number(m, &local.coords).abs() < INSIDE_WINDING {
                        continue;
                    }
                }
                kept.push((p, r));
            }
        }
        part.inner = kept
            .into_iter()
            .map(|(p, r)| ([p.x as f32, p.y as f32, p.z as f32], r as f32))
            .collect();
        part.inner_packs = part
            .inner
            .chunks(8)
            .map(|chunk| {
                let lane = |k: usize| {
                    f32x8::new(std::array::from_fn(|i| {
                        chunk
                            .get(i)
                            .map_or(f32::NAN, |(c, r)| if k < 3 { c[k] } else { *r })
                    }))
                };
                [lane(0), lane(1), lane(2), lane(3)]
            })
            .collect();
        let to_part = pose.inverse();
        part.inner_local = part
            .inner
            .iter()
            .map(|(c, r)| {
                let p = to_part * Point3::new(c[0] as f64, c[1] as f64, c[2] as f64);
                [p.x as f32, p.y as f32, p.z as f32, r - TOUCH]
            })
            .filter(|s| s[3] > 0.0)
            .collect();
        if let Some(m) = &part.fine {
            let mut pts: Vec<Vector> = part
                .inner
                .iter()
                .map(|(c, _)| {
                    let p = to_part * Point3::new(c[0] as f64, c[1] as f64, c[2] as f64);
                    Vector::new(p.x as f32, p.y as f32, p.z as f32)
                })
                .collect();
            pts.extend(spread_vertices(m, WITNESS_VERTICES));
            part.witness = pts
                .chunks(8)
                .map(|c| {
                    let get = |k: usize, axis: usize| c[k.min(c.len() - 1)][axis];
                    [0, 1, 2].map(|axis| f32x8::new(std::array::from_fn(|k| get(k, axis))))
                })
                .collect();
        }
        part
    }
}

/// At most this many mesh vertices among a part's [`Part::witness`] points
/// (spread over the mesh, in the order of the farthest-point sampling).
const WITNESS_VERTICES: usize = 256;
/// Of a part's [`Part::witness`] points, at most this many packs of eight
/// are tested against the inscribed spheres of a part that keeps its mesh
/// (its inscribed spheres' centres and the 48 most spread vertices): every
/// pack costs a test against every sphere there, while against a hull's
/// planes a pack is usually dismissed by its first planes, so there all of
/// them are tested.
const WITNESS_PACKS_VS_SPHERES: usize = 8;

/// Up to `n` vertices of mesh `m` (those its triangles use), spread over
/// it: farthest-point sampling from the first.
fn spread_vertices(m: &TriMesh, n: usize) -> Vec<Vector> {
    let mut used = vec![false; m.vertices().len()];
    m.indices()
        .iter()
        .flatten()
        .for_each(|&v| used[v as usize] = true);
    let verts: Vec<Vector> = m
        .vertices()
        .iter()
        .zip(&used)
        .filter_map(|(p, &u)| u.then_some(*p))
        .collect();
    let mut out = Vec::new();
    let mut dist = vec![f32::INFINITY; verts.len()];
    let mut next = 0;
    while out.len() < n.min(verts.len()) {
        let p = verts[next];
        out.push(p);
        for (d, q) in dist.iter_mut().zip(&verts) {
            *d = d.min((*q - p).length_squared());
        }
        next = (0..verts.len())
            .max_by(|&i, &j| dist[i].total_cmp(&dist[j]))
            .unwrap_or(0);
        if dist[next] == 0.0 {
            break;
        }
    }
    out
}

/// Whether one of part `w`'s [`Part::witness`] points, posed by `pos` in
/// the frame of part `outer`, lies inside `outer`'s solid by more than
/// [`TOUCH`] (far above the `f32` rounding): inside its hull (a part
/// without a mesh) or inside one of its inscribed spheres (a part that
/// keeps its mesh). A point of `w`'s solid inside the other solid, so the
/// two touch. False when `w` has no witness points.
fn witness_inside(w: &Part, outer: &Part, pos: &Pose) -> bool {
    if w.witness.is_empty() {
        return false;
    }
    let [ex, ey, ez] = [Vector::X, Vector::Y, Vector::Z].map(|e| pos.rotation * e);
    let t = pos.translation;
    let s = f32x8::splat;
    let below = s(-TOUCH);
    let place = |[x, y, z]: &[f32x8; 3]| {
        [
            *x * s(ex.x) + *y * s(ey.x) + *z * s(ez.x) + s(t.x),
            *x * s(ex.y) + *y * s(ey.y) + *z * s(ez.y) + s(t.y),
            *x * s(ex.z) + *y * s(ey.z) + *z * s(ez.z) + s(t.z),
        ]
    };
    let h = match (&outer.shape, &outer.fine) {
        (Convex::Hull(h), None) => h,
        (_, Some(_)) => {
            // The inscribed spheres (radius already shrunk by TOUCH).
            let packs = &w.witness[..w.witness.len().min(WITNESS_PACKS_VS_SPHERES)];
            return packs.iter().any(|pack| {
                let p = place(pack);
                outer.inner_local.iter().any(|[cx, cy, cz, r]| {
                    let d = [p[0] - s(*cx), p[1] - s(*cy), p[2] - s(*cz)];
                    let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                    dd.simd_lt(s(r * r)).to_bitmask() != 0
                })
            });
        }
        _ => return false,
    };
    w.witness.iter().any(|pack| {
        let p = place(pack);
        let mut inside = 0xffu32;
        for chunk in h.planes32.chunks(4) {
            for [nx, ny, nz, d] in chunk {
                let v = p[0] * s(*nx) + p[1] * s(*ny) + p[2] * s(*nz) - s(*d);
                inside &= v.simd_lt(below).to_bitmask();
            }
            if inside == 0 {
                return false;
            }
        }
        true
    })
}

/// The collision geometry of one link: convex parts posed in the body's
/// lane frame.
#[derive(Clone)]
pub struct ExactBody {
    parts: Arc<[Part]>,
}

impl std::fmt::Debug for ExactBody {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ExactBody({} parts)", self.parts.len())
    }
}

impl ExactBody {
    /// How many parts keep their mesh because its hull is too coarse
    /// ([`HULL_EXCESS`]): hull contacts of those are re-decided on the
    /// triangles.
    pub fn refined_parts(&self) -> usize {
        self.parts.iter().filter(|p| p.fine.is_some()).count()
    }

    /// Every part's inscribed spheres (body lane frame: centre, radius):
    /// two bodies whose inscribed spheres overlap are confirmed touching by
    /// [`confirm`] for any margin.
    pub fn inscribed(&self) -> impl Iterator<Item = &([f32; 3], f32)> {
        self.parts.iter().flat_map(|p| p.inner.iter())
    }

    /// The collision geometry of `link`, posed by `corr` (link frame in the
    /// lane frame). None if the link has no collision geometry or a part
    /// cannot be represented (a degenerate mesh): spheres alone decide.
    pub fn of_link(link: &Link, corr: &Isometry3<f64>) -> Option<Self> {
        let mut parts = Vec::new();
        for g in &link.collisions {
            let at = corr * g.origin;
            let rot = at.rotation.to_rotation_matrix().into_inner();
            let centre = at.translation.vector;
            let part = match &g.shape {
                Shape::Box { half_extents: h } => Part::new(
                    at,
                    Obb::new(centre, &rot, h),
                    Convex::Cuboid(Cuboid::new(Vector::new(h.x as f32, h.y as f32, h.z as f32))),
                    None,
                ),
                Shape::Sphere { radius } => Part::new(
                    at,
                    Obb::new(centre, &rot, &Vector3::repeat(*radius)),
                    Convex::Ball(Ball::new(*radius as f32)),
                    None,
                ),
                Shape::Cylinder {
                    radius,
                    half_height,
                } => {
                    // parry's cylinders run along y, URDF's along z.
                    let turn = UnitQuaternion::from_axis_angle(
                        &Vector3::x_axis(),
                        std::f64::consts::FRAC_PI_2,
                    );
                    Part::new(
                        at * turn,
                        Obb::new(centre, &rot, &Vector3::new(*radius, *radius, *half_height)),
                        Convex::Cylinder(Cylinder::new(*half_height as f32, *radius as f32)),
                        None,
                    )
                }
                Shape::Capsule {
                    radius,
                    half_height,
                } => Part::new(
                    at,
                    Obb::new(
                        centre,
                        &rot,
                        &Vector3::new(*radius, *radius, half_height + radius),
                    ),
                    Convex::Capsule(Capsule::new(
                        Vector::new(0.0, 0.0, (-half_height) as f32),
                        Vector::new(0.0, 0.0, *half_height as f32),
                        *radius as f32,
                    )),
                    None,
                ),
                Shape::PointCloud(_) => return None,
                Shape::Mesh(_) | Shape::ConvexDecomposition(_) | Shape::ConvexHull(_) => {
                    let pts: Vec<Vector> = match &g.shape {
                        Shape::ConvexHull(h) => h
                            .points()
                            .iter()
                            .map(|p| Vector::new(p.x as f32, p.y as f32, p.z as f32))
                            .collect(),
                        Shape::Mesh(m) | Shape::ConvexDecomposition(m) => m.parry_vertices(),
                        _ => unreachable!("matched above"),
                    };
                    let hull = Hull::new(&pts)?;
                    // The box holds the hull's f32 vertices placed in the
                    // lane frame: the smaller of the box along the mesh
                    // frame's axes and the box along the principal axes.
                    let placed: Vec<Point3<f64>> = hull
                        .points
                        .iter()
                        .map(|p| at * Point3::new(p.x as f64, p.y as f64, p.z as f64))
                        .collect();
                    let (mut obb, volume) = Obb::fit(&placed, &rot);
                    let mean = placed.iter().fold(Vector3::zeros(), |a, p| a + p.coords)
                        / placed.len() as f64;
                    let cov = placed.iter().fold(Matrix3::zeros(), |a, p| {
                        let d = p.coords - mean;
                        a + d * d.transpose()
                    });
                    let eig = SymmetricEigen::new(cov).eigenvectors;
                    if eig.iter().all(|v| v.is_finite()) {
                        let (pca, v) = Obb::fit(&placed, &eig);
                        if v < volume {
                            obb = pca;
                        }
                    }
                    let fine = match &g.shape {
                        Shape::Mesh(m) | Shape::ConvexDecomposition(m) => {
                            coarse_hull_mesh(&hull, pts, m.triangles())
                        }
                        _ => None,
                    };
                    Part::new(at, obb, Convex::Hull(Arc::new(hull)), fine)
                }
            };
            #[cfg(feature = "exact-stats")]
            stats::name(part.uid, format!("{}#{}", link.name, parts.len()));
            parts.push(part);
        }
        (!parts.is_empty()).then(|| Self {
            parts: parts.into(),
        })
    }
}

/// The mesh `(vertices, triangles)` as a parry `TriMesh` if its `hull` is
/// too coarse: some hull face's centroid or edge midpoint lies more than
/// [`HULL_EXCESS`] from the mesh's surface. None when the hull is tight
/// enough or the mesh cannot be built (the hull then decides alone, which
/// is conservative).
fn coarse_hull_mesh(
    hull: &Hull,
    vertices: Vec<Vector>,
    triangles: &[[u32; 3]],
) -> Option<Arc<TriMesh>> {
    if triangles.is_empty() {
        return None;
    }
    let mesh = TriMesh::new(vertices, triangles.to_vec()).ok()?;
    let far = |p: Vector| {
        let proj = mesh.project_local_point(p, false);
        (proj.point - p).length() as f64 > HULL_EXCESS
    };
    let coarse = hull.faces.iter().any(|[a, b, c]| {
        far((*a + *b + *c) / 3.0)
            || far((*a + *b) / 2.0)
            || far((*b + *c) / 2.0)
            || far((*c + *a) / 2.0)
    });
    coarse.then(|| Arc::new(mesh))
}

/// Whether the solid of part `inner` (posed by `pos` in the frame of part
/// `outer`) may lie inside the solid of `outer`. False when `inner`'s hull
/// reaches further than `outer`'s hull (which contains `outer`) along one
/// of 26 directions: then some point of `inner` is outside `outer`.
/// `outer`'s reach along each direction is precomputed
/// ([`Part::reach26`]).
fn may_hold(outer: &Part, inner: &Convex, pos: &Pose, reach: f32) -> bool {
    for (d, o) in directions26().iter().zip(&outer.reach26) {
        let i = inner.support_point(pos, *d).dot(*d);
        if i > o + reach {
            return false;
        }
    }
    true
}

/// Re-decides a contact of the hulls of parts `a` and `b` (`b` posed by
/// `pos12` in `a`'s frame) where at least one keeps its mesh: whether the
/// meshes (triangles; the other part's hull faces where it has no mesh)
/// come within `margin` (0: touch). Conservative: "apart" only when no
/// triangle pair is within the margin plus [`TOUCH`] (exact triangle
/// distances, not GJK, which misjudges flat triangles by millimetres) and
/// neither solid may hold the other (a mesh inside the other part's hull
/// is found by its first vertex and the hull's planes, a solid inside a
/// mesh is ruled out by [`may_hold`]). A primitive other part keeps the
/// hulls' verdict: contact. Before the triangles, a point of one solid
/// found inside the other ([`witness_inside`]) answers "contact" at once:
/// the same answer, since two solids sharing a point have crossing
/// surfaces (a triangle pair touches) or one holds the other.
fn refine(a: &Part, b: &Part, pos12: &Pose, margin: f32) -> bool {
    refine_with(a, b, pos12, margin, true)
}

/// [`refine`] as it was before the witness points (the test-only reference
/// of the new path: same answers, more triangle pairs tested).
#[cfg(test)]
fn refine_reference(a: &Part, b: &Part, pos12: &Pose, margin: f32) -> bool {
    refine_with(a, b, pos12, margin, false)
}

/// [`refine`], with or without the [`witness_inside`] search for a point
/// of one solid inside the other before the triangle traversal.
#[inline]
fn refine_with(a: &Part, b: &Part, pos12: &Pose, margin: f32, witness: bool) -> bool {
    let reach = margin + TOUCH;
    let (Some(ma), Some(mb)) = (a.surface(), b.surface()) else {
        return true;
    };
    #[cfg(feature = "exact-stats")]
    let tests = std::cell::Cell::new(0u64);
    #[cfg(feature = "exact-stats")]
    let by = |k: usize, n: u64| {
        stats::add(a.uid, b.uid, |t| {
            t.by[k] += 1;
            t.touch_tests += n;
        })
    };
    let touch = |i: u32, j: u32| {
        #[cfg(feature = "exact-stats")]
        tests.set(tests.get() + 1);
        let (ta, tb) = (ma.triangle(i), mb.triangle(j));
        let ta = [ta.a, ta.b, ta.c];
        let tb = [tb.a, tb.b, tb.c].map(|p| pos12 * p);
        !beyond_plane(&ta, &tb, reach)
            && !beyond_plane(&tb, &ta, reach)
            && triangles_within(&ta, &tb, reach)
    };
    // The pair that touched last time first (pairs move little between
    // consecutive checks of a motion).
    let hint = a.hint.load(Relaxed);
    if hint >> 44 == u64::from(b.uid) {
        let (i, j) = (((hint >> 22) & TRI_MASK) as u32, (hint & TRI_MASK) as u32);
        if (i as usize) < ma.num_triangles() && (j as usize) < mb.num_triangles() && touch(i, j) {
            #[cfg(feature = "exact-stats")]
            by(0, tests.get());
            return true;
        }
    }
    // The answer is "a triangle pair touches, or one solid may hold the
    // other": the cheap containment tests (a vertex of one mesh inside the
    // other part's hull, its planes) first, since deep contacts, which
    // every such test finds, would otherwise traverse the whole BVH first.
    let vertex_in_hull = |outer: &Part, pos: &Pose, m: &TriMesh| {
        let p = pos * m.vertices()[0];
        let p = Vector3::new(p.x as f64, p.y as f64, p.z as f64);
        outer.shape.depth(&p) > -(reach as f64)
    };
    let pos21 = pos12.inverse();
    if (a.fine.is_none() && vertex_in_hull(a, pos12, mb))
        || (b.fine.is_none() && vertex_in_hull(b, &pos21, ma))
    {
        #[cfg(feature = "exact-stats")]
        by(1, tests.get());
        return true;
    }
    // A point of one solid inside the other part's solid (its hull, or an
    // inscribed sphere of a part that keeps its mesh).
    if witness && (witness_inside(b, a, pos12) || witness_inside(a, b, &pos21)) {
        #[cfg(feature = "exact-stats")]
        by(2, tests.get());
        return true;
    }
    let found = ma
        .bvh()
        .leaf_pairs(mb.bvh(), |n1, n2| {
            n1.aabb()
                .loosened(reach)
                .intersects(&n2.aabb().transform_by(pos12))
        })
        .find(|&(i, j)| touch(i, j));
    if let Some((i, j)) = found {
        let new = u64::from(b.uid) << 44 | u64::from(i) << 22 | u64::from(j);
        // Stored only when it changes: threads checking in parallel share
        // the hint, and a store takes the cache line from the others.
        if u64::from(i) <= TRI_MASK && u64::from(j) <= TRI_MASK && new != hint {
            a.hint.store(new, Relaxed);
        }
        #[cfg(feature = "exact-stats")]
        by(3, tests.get());
        return true;
    }
    // A solid inside a mesh part: ruled out unless the mesh part's hull
    // reaches at least as far in every one of 26 directions.
    let held = (a.fine.is_some() && may_hold(a, &b.shape, pos12, reach))
        || (b.fine.is_some() && may_hold(b, &a.shape, &pos21, reach));
    #[cfg(feature = "exact-stats")]
    by(if held { 4 } else { 5 }, tests.get());
    held
}

impl Part {
    /// The triangles standing for this part in [`refine`]: its mesh, else
    /// its hull's faces. None for primitives.
    fn surface(&self) -> Option<&TriMesh> {
        self.fine.as_deref().or(self.hull_faces.as_deref())
    }
}

/// Whether triangles `a` and `b` (same frame) are closer than `reach`:
/// an edge of one piercing the other, else the smallest of the vertex to
/// triangle and edge to edge distances (exact for disjoint triangles).
fn triangles_within(a: &[Vector; 3], b: &[Vector; 3], reach: f32) -> bool {
    let edges = |t: &[Vector; 3]| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])];
    let pierces = |t: &[Vector; 3], (p, q): (Vector, Vector)| {
        // Moller-Trumbore on the segment p -> q.
        let (e1, e2, dir) = (t[1] - t[0], t[2] - t[0], q - p);
        let h = dir.cross(e2);
        let det = e1.dot(h);
        if det.abs() < 1e-20 {
            return false;
        }
        let f = 1.0 / det;
        let s = p - t[0];
        let u = f * s.dot(h);
        let qv = s.cross(e1);
        let v = f * dir.dot(qv);
        let w = f * e2.dot(qv);
        (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && (0.0..=1.0).contains(&w)
    };
    if edges(a).into_iter().any(|e| pierces(b, e)) || edges(b).into_iter().any(|e| pierces(a, e)) {
        return true;
    }
    let ta = parry3d::shape::Triangle::new(a[0], a[1], a[2]);
    let tb = parry3d::shape::Triangle::new(b[0], b[1], b[2]);
    let near = |t: &parry3d::shape::Triangle, p: Vector| t.distance_to_local_point(p, true) < reach;
    if a.iter().any(|&p| near(&tb, p)) || b.iter().any(|&p| near(&ta, p)) {
        return true;
    }
    edges(a).into_iter().any(|ea| {
        edges(b)
            .into_iter()
            .any(|eb| segments_distance(ea, eb) < reach)
    })
}

/// The distance between segments `a` and `b` (the clamped closest-points
/// construction for two segments).
fn segments_distance((p1, q1): (Vector, Vector), (p2, q2): (Vector, Vector)) -> f32 {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.dot(d1), d2.dot(d2), d2.dot(r));
    let eps = 1e-20;
    let (s, t) = if a <= eps && e <= eps {
        (0.0, 0.0)
    } else if a <= eps {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= eps {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > eps {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p1 + d1 * s) - (p2 + d2 * t)).length()
}

/// Whether every point of `other` lies more than `reach` to one side of
/// the plane of triangle `t` (then the triangles are more than `reach`
/// apart): a cheap rejection before GJK. False for a degenerate `t`.
#[inline]
fn beyond_plane(t: &[Vector; 3], other: &[Vector; 3], reach: f32) -> bool {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let len = n.length();
    if len <= 1e-12 {
        return false;
    }
    let n = n / len;
    let d = other.map(|p| n.dot(p - t[0]));
    d.iter().all(|&x| x > reach) || d.iter().all(|&x| x < -reach)
}

/// A box's centre and axes in the base frame, on every lane.
#[inline(always)]
fn place<L: Lanes>(f: &LaneFrame<L>, o: &Obb) -> ([L; 3], [[L; 3]; 3]) {
    let s = L::splat;
    let rot = |v: [f32; 3]| {
        [
            f[0] * s(v[0]) + f[1] * s(v[1]) + f[2] * s(v[2]),
            f[3] * s(v[0]) + f[4] * s(v[1]) + f[5] * s(v[2]),
            f[6] * s(v[0]) + f[7] * s(v[1]) + f[8] * s(v[2]),
        ]
    };
    let c = rot(o.c);
    (
        [c[0] + f[9], c[1] + f[10], c[2] + f[11]],
        [
            rot([o.u[0], o.u[1], o.u[2]]),
            rot([o.u[3], o.u[4], o.u[5]]),
            rot([o.u[6], o.u[7], o.u[8]]),
        ],
    )
}

#[inline(always)]
fn dot<L: Lanes>(a: &[L; 3], b: &[L; 3]) -> L {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Lanes where boxes `a` (frame `fa`) and `b` (frame `fb`), each grown by
/// `grow`, may overlap: the separating-axis test on the 15 axes.
#[inline(always)]
fn boxes_overlap<L: Lanes>(
    a: &Obb,
    b: &Obb,
    fa: &LaneFrame<L>,
    fb: &LaneFrame<L>,
    grow: f32,
) -> u32 {
    let s = L::splat;
    let (ca, ua) = place(fa, a);
    let (cb, ub) = place(fb, b);
    let ha = a.h.map(|h| s(h + grow));
    let hb = b.h.map(|h| s(h + grow));
    let t = [cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2]];
    let r: [[L; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| dot(&ua[i], &ub[j])));
    let ar: [[L; 3]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|j| r[i][j].abs() + s(AXIS_EPS)));
    let ta: [L; 3] = std::array::from_fn(|i| dot(&t, &ua[i]));
    let mut sep = 0u32;
    for i in 0..3 {
        let rb = hb[0] * ar[i][0] + hb[1] * ar[i][1] + hb[2] * ar[i][2];
        sep |= (ha[i] + rb).lt_mask(ta[i].abs());
    }
    for j in 0..3 {
        let ra = ha[0] * ar[0][j] + ha[1] * ar[1][j] + ha[2] * ar[2][j];
        let tb = ta[0] * r[0][j] + ta[1] * r[1][j] + ta[2] * r[2][j];
        sep |= (ra + hb[j]).lt_mask(tb.abs());
    }
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let ra = ha[i1] * ar[i2][j] + ha[i2] * ar[i1][j];
            let rb = hb[j1] * ar[i][j2] + hb[j2] * ar[i][j1];
            let tt = ta[i2] * r[i1][j] - ta[i1] * r[i2][j];
            sep |= (ra + rb).lt_mask(tt.abs());
        }
    }
    L::FULL & !sep
}

/// Lanes where an inner sphere of `a` (frame `fa`) overlaps one of `b`
/// (frame `fb`): the parts certainly touch there. Stops once every lane of
/// `want` is found (other lanes may then be missing from the answer).
#[inline(always)]
fn inner_overlap<L: Lanes>(
    a: &Part,
    b: &Part,
    fa: &LaneFrame<L>,
    fb: &LaneFrame<L>,
    want: u32,
) -> u32 {
    if L::WIDTH == 1 {
        return inner_overlap_one(a, b, fa, fb);
    }
    let mut bs = [([L::splat(0.0); 3], L::splat(0.0)); INNER];
    for (k, (c, r)) in b.inner.iter().enumerate() {
        bs[k] = (crate::kernel::apply(fb, c), L::splat(*r));
    }
    let bs = &bs[..b.inner.len()];
    let mut hit = 0;
    for (c, r) in &a.inner {
        let p = crate::kernel::apply(fa, c);
        let r = L::splat(*r);
        for (q, rq) in bs {
            let d = [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
            let rr = r + *rq;
            hit |= (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).lt_mask(rr * rr);
        }
        if hit & want == want {
            break;
        }
    }
    hit
}

/// [`inner_overlap`] for one lane: the spheres of `b` eight at a time,
/// with the same arithmetic per sphere pair (so the same answer).
#[inline(always)]
fn inner_overlap_one<L: Lanes>(a: &Part, b: &Part, fa: &LaneFrame<L>, fb: &LaneFrame<L>) -> u32 {
    let f: [f32x8; 12] = std::array::from_fn(|k| f32x8::splat(fb[k].lane(0)));
    let mut bs = [[f32x8::splat(0.0); 4]; INNER.div_ceil(8)];
    for (out, [x, y, z, r]) in bs.iter_mut().zip(&b.inner_packs) {
        *out = [
            f[0] * *x + f[1] * *y + f[2] * *z + f[9],
            f[3] * *x + f[4] * *y + f[5] * *z + f[10],
            f[6] * *x + f[7] * *y + f[8] * *z + f[11],
            *r,
        ];
    }
    let bs = &bs[..b.inner_packs.len()];
    for (c, r) in &a.inner {
        let p = crate::kernel::apply(fa, c).map(|v| f32x8::splat(v.lane(0)));
        let r = f32x8::splat(*r);
        for q in bs {
            let d = [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
            let rr = r + q[3];
            if (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).lt_mask(rr * rr) != 0 {
                return 1;
            }
        }
    }
    0
}

/// Row-major 3x3 product.
#[inline(always)]
fn mul3(a: &[f32; 9], b: &[f32; 9]) -> [f32; 9] {
    std::array::from_fn(|k| {
        let (i, j) = (k / 3, k % 3);
        a[i * 3] * b[j] + a[i * 3 + 1] * b[3 + j] + a[i * 3 + 2] * b[6 + j]
    })
}

/// The pose of a part on lane `i` of frame `f`: rotation and translation.
#[inline(always)]
fn part_pose<L: Lanes>(f: &LaneFrame<L>, i: usize, p: &Frame32) -> ([f32; 9], [f32; 3]) {
    let m: [f32; 9] = std::array::from_fn(|k| f[k].lane(i));
    let rot = mul3(&m, &p.r);
    let t = std::array::from_fn(|r| {
        m[r * 3] * p.t[0] + m[r * 3 + 1] * p.t[1] + m[r * 3 + 2] * p.t[2] + f[9 + r].lane(i)
    });
    (rot, t)
}

/// The pose of part `b` in the frame of part `a` (parry's `pos12`).
#[inline(always)]
fn relative(a: &([f32; 9], [f32; 3]), b: &([f32; 9], [f32; 3])) -> Pose {
    let (ra, ta) = a;
    let (rb, tb) = b;
    // rel = ra^T rb; columns of rel as glam vectors.
    let col = |j: usize| {
        Vector::new(
            ra[0] * rb[j] + ra[3] * rb[3 + j] + ra[6] * rb[6 + j],
            ra[1] * rb[j] + ra[4] * rb[3 + j] + ra[7] * rb[6 + j],
            ra[2] * rb[j] + ra[5] * rb[3 + j] + ra[8] * rb[6 + j],
        )
    };
    let rel = Mat3::from_cols(col(0), col(1), col(2));
    let d = [tb[0] - ta[0], tb[1] - ta[1], tb[2] - ta[2]];
    let t = Vector::new(
        ra[0] * d[0] + ra[3] * d[1] + ra[6] * d[2],
        ra[1] * d[0] + ra[4] * d[1] + ra[7] * d[2],
        ra[2] * d[0] + ra[5] * d[1] + ra[8] * d[2],
    );
    Pose::from_parts(t, Rot3::from_mat3(&rel).normalize())
}

/// The cheap steps of [`confirm`] (boxes, inscribed spheres) on `lanes`:
/// `(sure, open)`, the lanes where some pair of parts certainly touches
/// (an inscribed-sphere overlap), and the lanes, not sure, where some pair
/// of parts' boxes overlap without one (GJK, and maybe the mesh, would have
/// to decide). Every lane of `confirm(.., lanes, ..)` is in `sure | open`
/// and every lane of `sure` is in it, so a kernel can take `sure` at once
/// and leave `open` to [`confirm`] after every cheaper test of the check
/// (only lanes that nothing else found colliding then reach GJK): the
/// answer does not change, only the order of the work.
#[inline(always)]
pub fn confirm_cheap<L: Lanes>(
    a: &ExactBody,
    b: &ExactBody,
    fa: &LaneFrame<L>,
    fb: &LaneFrame<L>,
    lanes: u32,
    margin: f32,
) -> (u32, u32) {
    let margin = margin.max(0.0);
    let (mut sure, mut open) = (0, 0);
    for pa in a.parts.iter() {
        for pb in b.parts.iter() {
            let todo = lanes & !sure;
            if todo == 0 {
                return (sure, 0);
            }
            let bits = todo & boxes_overlap(&pa.obb, &pb.obb, fa, fb, margin / 2.0);
            if bits == 0 {
                continue;
            }
            let s = bits & inner_overlap(pa, pb, fa, fb, bits);
            #[cfg(feature = "exact-stats")]
            stats::add(pa.uid, pb.uid, |t| {
                t.boxes += u64::from(bits.count_ones());
                t.inner += u64::from(s.count_ones());
            });
            sure |= s;
            open |= bits & !s;
        }
    }
    (sure, open & !sure)
}

/// Of the lanes in `lanes`, those where the exact geometry of bodies `a`
/// and `b` (lane frames `fa`, `fb`) is closer than `margin` (or touches,
/// for a margin of zero or less). Inlined into the [`crate::dispatch`]
/// entry points.
#[inline(always)]
pub fn confirm<L: Lanes>(
    a: &ExactBody,
    b: &ExactBody,
    fa: &LaneFrame<L>,
    fb: &LaneFrame<L>,
    lanes: u32,
    margin: f32,
) -> u32 {
    let margin = margin.max(0.0);
    let mut out = 0;
    for pa in a.parts.iter() {
        for pb in b.parts.iter() {
            let todo = lanes & !out;
            if todo == 0 {
                return out;
            }
            let mut bits = todo & boxes_overlap(&pa.obb, &pb.obb, fa, fb, margin / 2.0);
            if bits == 0 {
                continue;
            }
            let sure = bits & inner_overlap(pa, pb, fa, fb, bits);
            out |= sure;
            bits &= !sure;
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let pos12 = relative(&part_pose(fa, i, &pa.pose), &part_pose(fb, i, &pb.pose));
                let (sa, sb) = (&pa.shape, &pb.shape);
                #[cfg(feature = "exact-stats")]
                let t0 = std::time::Instant::now();
                let mut hit = if margin > 0.0 {
                    within_margin(&pos12, sa, sb, margin)
                } else {
                    intersection_test_support_map_support_map(&pos12, sa, sb)
                };
                #[cfg(feature = "exact-stats")]
                let (t1, gjk_hit) = (std::time::Instant::now(), hit);
                if hit && (pa.fine.is_some() || pb.fine.is_some()) {
                    hit = refine(pa, pb, &pos12, margin);
                    #[cfg(feature = "exact-stats")]
                    stats::add(pa.uid, pb.uid, |t| {
                        t.refine += 1;
                        t.refine_hit += u64::from(hit);
                        t.refine_ns += t1.elapsed().as_nanos() as u64;
                    });
                }
                #[cfg(feature = "exact-stats")]
                stats::add(pa.uid, pb.uid, |t| {
                    t.gjk += 1;
                    t.gjk_hit += u64::from(gjk_hit);
                    t.gjk_ns += (t1 - t0).as_nanos() as u64;
                });
                if hit {
                    out |= 1 << i;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A U: three boxes (one triangle soup), the slot between the arms
    /// 0.06 wide and open towards +z.
    fn u_mesh() -> (Vec<Vector>, Vec<[u32; 3]>) {
        let boxes = [
            ([0.0, 0.0, -0.04], [0.1, 0.05, 0.02]),
            ([-0.08, 0.0, 0.02], [0.02, 0.05, 0.08]),
            ([0.08, 0.0, 0.02], [0.02, 0.05, 0.08]),
        ];
        let (mut v, mut t) = (Vec::new(), Vec::new());
        for (c, h) in boxes {
            let b = v.len() as u32;
            for k in 0..8 {
                let s = |i: usize| if k >> i & 1 == 1 { 1.0 } else { -1.0 };
                v.push(Vector::new(
                    c[0] + s(0) * h[0],
                    c[1] + s(1) * h[1],
                    c[2] + s(2) * h[2],
                ));
            }
            for f in ferrobot_geometry::BOX_TRIANGLES {
                t.push(f.map(|i| b + i));
            }
        }
        (v, t)
    }

    fn mesh_part(v: Vec<Vector>, t: &[[u32; 3]]) -> Part {
        let hull = Hull::new(&v).unwrap();
        let fine = coarse_hull_mesh(&hull, v, t);
        let obb = Obb::new(
            Vector3::zeros(),
            &Matrix3::identity(),
            &Vector3::repeat(0.2),
        );
        Part::new(
            Isometry3::identity(),
            obb,
            Convex::Hull(Arc::new(hull)),
            fine,
        )
    }

    /// A convex mesh (a box) keeps its hull; the U (hull 2.3 cm beyond
    /// the mesh at the slot) keeps its triangles, and its inner spheres lie
    /// inside its solid (the union of its three boxes, checked on points of
    /// each sphere's surface), none in the slot.
    #[test]
    fn only_coarse_hulls_are_refined() {
        let (v, t) = u_mesh();
        let part = mesh_part(v.clone(), &t);
        assert!(part.fine.is_some() && !part.inner.is_empty());
        let in_box = |p: Vector, k: usize| {
            (0..3).all(|a| (p[a] - v[8 * k][a]) * (p[a] - v[8 * k + 7][a]) <= 0.0)
        };
        for (c, r) in &part.inner {
            for i in 0..200 {
                let z = 1.0 - (2.0 * i as f32 + 1.0) / 200.0;
                let rho = (1.0 - z * z).max(0.0).sqrt();
                let a = 2.399_963 * i as f32;
                let p = Vector::new(c[0], c[1], c[2])
                    + Vector::new(rho * a.cos(), rho * a.sin(), z) * *r;
                assert!(
                    (0..3).any(|k| in_box(p, k)),
                    "inner sphere {c:?} {r} reaches {p:?}"
                );
            }
        }
        // In the slot: outside (0); in an arm: inside (1 in absolute value).
        let m = part.fine.as_deref().unwrap();
        assert!(winding_number(m, &Vector3::new(0.0, 0.0, 0.05)).abs() < 1e-6);
        assert!((winding_number(m, &Vector3::new(0.08, 0.0, 0.05)).abs() - 1.0).abs() < 1e-6);
        let (bv, bt) = (v[..8].to_vec(), t[..12].to_vec());
        let part = mesh_part(bv, &bt);
        assert!(part.fine.is_none() && !part.inner.is_empty());
    }

    /// The U against a 4 cm cube mesh (convex: it keeps its hull) moved
    /// along x and z, against the exact distance of axis-aligned boxes:
    /// every contact is reported, also the cube inside an arm's solid; a
    /// cube in the slot (where the hulls overlap) is free unless the U's
    /// hull may hold it; within a margin, touching.
    #[test]
    fn mesh_against_hull_matches_box_distances() {
        let (v, t) = u_mesh();
        let u = mesh_part(v.clone(), &t);
        let h = Vector::new(0.02, 0.02, 0.02);
        let cube_v: Vec<Vector> = (0..8)
            .map(|k| {
                let s = |i: usize| if k >> i & 1 == 1 { 1.0 } else { -1.0 };
                Vector::new(s(0) * h.x, s(1) * h.y, s(2) * h.z)
            })
            .collect();
        let cube = mesh_part(cube_v, &t[..12]);
        assert!(cube.fine.is_none() && cube.hull_faces.is_some());
        let boxes = [
            (Vector::new(0.0, 0.0, -0.04), Vector::new(0.1, 0.05, 0.02)),
            (Vector::new(-0.08, 0.0, 0.02), Vector::new(0.02, 0.05, 0.08)),
            (Vector::new(0.08, 0.0, 0.02), Vector::new(0.02, 0.05, 0.08)),
        ];
        let (mut free, mut hit) = (0, 0);
        for i in 0..=48 {
            for k in 0..=30 {
                let c = Vector::new(-0.144 + 0.006 * i as f32, 0.0, -0.04 + 0.006 * k as f32);
                let d = boxes
                    .iter()
                    .map(|(bc, bh)| {
                        let gap = ((c - *bc).abs() - *bh - h).max(Vector::ZERO);
                        gap.length()
                    })
                    .fold(f32::INFINITY, f32::min);
                let pos = Pose::from_translation(c);
                let got = refine(&u, &cube, &pos, 0.0);
                if d <= 0.0 {
                    assert!(got, "{c:?}: boxes touch, refine says apart");
                    hit += 1;
                } else if d > 1e-4 && !may_hold(&u, &cube.shape, &pos, TOUCH) {
                    assert!(!got, "{c:?}: {d} m apart, refine says touch");
                    free += usize::from(c.x.abs() < 0.06 && c.z < 0.1);
                }
                if d < 0.004 {
                    assert!(refine(&u, &cube, &pos, 0.005), "{c:?}: {d} m < margin");
                }
            }
        }
        assert!(free > 5 && hit > 100, "{free} {hit}");
    }

    /// Mesh against mesh at random poses, against parry's TriMesh-TriMesh
    /// distance: a contact is always reported; "apart" is answered
    /// whenever the meshes are apart and neither hull can hold the other.
    #[test]
    fn mesh_against_mesh_matches_parry() {
        let (v, t) = u_mesh();
        let a = mesh_part(v.clone(), &t);
        let b = mesh_part(v.iter().map(|p| *p * 0.5).collect(), &t);
        let ra = TriMesh::new(v.clone(), t.clone()).unwrap();
        let rb = TriMesh::new(v.iter().map(|p| *p * 0.5).collect(), t).unwrap();
        let (mut apart, mut touch) = (0, 0);
        for k in 0..600 {
            let f = |s: f32| ((k as f32 * s).sin() * 43758.547).fract();
            let axis = Vector::new(f(1.1) - 0.5, f(2.3) - 0.5, f(3.7) - 0.5 + 1e-3).normalize();
            let rot = Rot3::from_axis_angle(axis, 6.3 * f(7.9));
            let pos = Pose::from_parts(
                Vector::new(0.2 * f(4.1) - 0.1, 0.1 * f(5.3) - 0.05, 0.2 * f(6.7) - 0.1),
                rot,
            );
            let d = parry3d::query::distance(&Pose::IDENTITY, &ra, &pos, &rb)
                .unwrap()
                .distance;
            let got = refine(&a, &b, &pos, 0.0);
            if d <= 0.0 {
                assert!(got, "{k}: meshes touch, refine says apart");
                touch += 1;
            } else if d > 5e-3
                && !may_hold(&a, &b.shape, &pos, TOUCH)
                && !may_hold(&b, &a.shape, &pos.inverse(), TOUCH)
            {
                assert!(!got, "{k}: meshes {d} m apart, refine says touch");
                apart += 1;
            }
        }
        assert!(apart > 50 && touch > 50, "{apart} {touch}");
    }

    /// Whether an edge of triangle `a` crosses triangle `b` well inside
    /// (f64; endpoints more than 1e-7 m on either side of `b`'s plane, the
    /// crossing point's barycentric coordinates all above 1e-6): the two
    /// triangles certainly intersect.
    fn edge_crosses_f64(a: &[Vector3<f64>; 3], b: &[Vector3<f64>; 3]) -> bool {
        let n = (b[1] - b[0]).cross(&(b[2] - b[0]));
        let area2 = n.norm_squared();
        if area2 < 1e-20 {
            return false;
        }
        let side = |p: &Vector3<f64>| n.dot(&(p - b[0])) / area2.sqrt();
        (0..3).any(|k| {
            let (p, q) = (a[k], a[(k + 1) % 3]);
            let (sp, sq) = (side(&p), side(&q));
            if !((sp > 1e-7 && sq < -1e-7) || (sp < -1e-7 && sq > 1e-7)) {
                return false;
            }
            let x = p + (q - p) * (sp / (sp - sq));
            let bary = |u: usize| {
                let (v, w) = (b[(u + 1) % 3], b[(u + 2) % 3]);
                (w - v).cross(&(x - v)).dot(&n) / area2
            };
            (0..3).all(|u| bary(u) > 1e-6)
        })
    }

    /// The path with witness points against the reference without them
    /// (the refinement as before) and against parry's exact mesh-mesh
    /// intersection test and an f64 scan for crossing triangles, on 4,000
    /// configurations each of the Panda (half with the elbow folded, so
    /// link 6 reaches links 0-1) and the UR5 (every link keeps its mesh):
    /// every hull contact of a pair of parts where one keeps its mesh is
    /// refined both ways (margins 0 and 1 cm); the answers are equal, and
    /// every pair of meshes that cross (the f64 scan) is a contact. parry's
    /// `intersection_test` (GJK on each pair of flat triangles) is counted,
    /// not asserted: it reports some pairs intersecting that the scan finds
    /// apart (one checked by hand: triangles disjoint, parry's `contact`
    /// calling them 4 mm deep).
    #[test]
    fn witness_refinement_matches_reference_and_parry() {
        use ferrobot_model::{LoadOptions, RobotModel, SrdfSource};
        use rand::{Rng, SeedableRng, rngs::StdRng};
        let shared = |rel: &str| {
            std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../../../shared")
                .join(rel)
        };
        for (robot, fold) in [("panda", true), ("ur5", false)] {
            let model = RobotModel::from_urdf_file(
                shared(&format!("robots/{robot}/{robot}.urdf")),
                &LoadOptions {
                    srdf: Some(SrdfSource::File(shared(&format!(
                        "robots/{robot}/{robot}.srdf"
                    )))),
                    ..Default::default()
                },
            )
            .unwrap();
            let bodies: Vec<Option<ExactBody>> = model
                .links()
                .iter()
                .map(|l| ExactBody::of_link(l, &Isometry3::identity()))
                .collect();
            let disabled: std::collections::HashSet<(usize, usize)> = model
                .disabled_collision_pairs()
                .into_iter()
                .map(|(a, b, _)| (a, b))
                .collect();
            let (lo, hi) = (model.lower_limits(), model.upper_limits());
            let mut rng = StdRng::seed_from_u64(23);
            let (mut refined, mut contacts, mut witnessed, mut touching, mut apart) =
                (0, 0, 0, 0, 0);
            let (mut parry_touch, mut parry_missed) = (0, 0);
            for k in 0..4000 {
                let mut q: Vec<f64> = (0..lo.len())
                    .map(|i| rng.random_range(lo[i]..hi[i]))
                    .collect();
                if fold && k % 2 == 0 {
                    // Elbow folded, shoulder bent back.
                    q[3] = rng.random_range(lo[3]..lo[3] + 0.3);
                    q[1] = rng.random_range(-1.0..1.0);
                }
                let margin = if k % 4 == 3 { 0.01 } else { 0.0 };
                let poses = model.fk_all(&q).unwrap();
                let frame = |iso: &Isometry3<f64>| -> LaneFrame<f32> {
                    let r = iso.rotation.to_rotation_matrix().into_inner();
                    let t = iso.translation.vector;
                    std::array::from_fn(|i| {
                        if i < 9 {
                            r[(i / 3, i % 3)] as f32
                        } else {
                            t[i - 9] as f32
                        }
                    })
                };
                for a in 0..bodies.len() {
                    for b in a + 1..bodies.len() {
                        let (Some(ea), Some(eb)) = (&bodies[a], &bodies[b]) else {
                            continue;
                        };
                        if disabled.contains(&(a, b)) {
                            continue;
                        }
                        let (fa, fb) = (frame(&poses[a]), frame(&poses[b]));
                        for pa in ea.parts.iter() {
                            for pb in eb.parts.iter() {
                                if pa.fine.is_none() && pb.fine.is_none() {
                                    continue;
                                }
                                let pos12 = relative(
                                    &part_pose(&fa, 0, &pa.pose),
                                    &part_pose(&fb, 0, &pb.pose),
                                );
                                let hulls = if margin > 0.0 {
                                    within_margin(&pos12, &pa.shape, &pb.shape, margin)
                                } else {
                                    intersection_test_support_map_support_map(
                                        &pos12, &pa.shape, &pb.shape,
                                    )
                                };
                                if !hulls {
                                    continue;
                                }
                                refined += 1;
                                let new = refine(pa, pb, &pos12, margin);
                                let old = refine_reference(pa, pb, &pos12, margin);
                                assert_eq!(new, old, "{robot} {q:?} links {a} {b}");
                                contacts += usize::from(new);
                                witnessed += usize::from(
                                    witness_inside(pb, pa, &pos12)
                                        || witness_inside(pa, pb, &pos12.inverse()),
                                );
                                let (Some(ma), Some(mb)) = (pa.surface(), pb.surface()) else {
                                    continue;
                                };
                                // The independent references, margin 0:
                                // parry's mesh-mesh intersection test, and
                                // an f64 scan for an edge of one mesh that
                                // crosses a triangle of the other well
                                // inside (1e-6, far above f32 rounding).
                                // (On every fourth UR5 configuration:
                                // its meshes are large, the scans slow.)
                                if margin > 0.0 || (!fold && k % 4 != 0) {
                                    continue;
                                }
                                let parry_hit = parry3d::query::intersection_test(
                                    &Pose::IDENTITY,
                                    ma,
                                    &pos12,
                                    mb,
                                )
                                .unwrap()
                                .intersecting;
                                parry_touch += usize::from(parry_hit);
                                parry_missed += usize::from(parry_hit && !new);
                                let crossing = ma
                                    .bvh()
                                    .leaf_pairs(mb.bvh(), |n1, n2| {
                                        n1.aabb()
                                            .loosened(1e-4)
                                            .intersects(&n2.aabb().transform_by(&pos12))
                                    })
                                    .any(|(i, j)| {
                                        let (ta, tb) = (ma.triangle(i), mb.triangle(j));
                                        let f = |p: Vector| {
                                            Vector3::new(p.x as f64, p.y as f64, p.z as f64)
                                        };
                                        let ta = [ta.a, ta.b, ta.c].map(f);
                                        let tb = [tb.a, tb.b, tb.c].map(|p| f(pos12 * p));
                                        edge_crosses_f64(&ta, &tb) || edge_crosses_f64(&tb, &ta)
                                    });
                                if crossing {
                                    touching += 1;
                                    assert!(new, "{robot} {q:?} links {a} {b}: meshes cross");
                                } else if !new {
                                    apart += 1;
                                }
                            }
                        }
                    }
                }
            }
            println!(
                "{robot}: {refined} refined, {contacts} contacts, {witnessed} witnessed, \
                 {touching} crossing, {apart} apart; parry: {parry_touch} intersecting, \
                 {parry_missed} of them called apart"
            );
            assert!(
                witnessed > 100 && touching > 100 && apart > 5 && contacts < refined,
                "{robot}: {refined} refined, {contacts} contacts, {witnessed} witnessed, \
                 {touching} crossing, {apart} apart"
            );
        }
    }

    /// The packed scan finds the furthest vertex of a hull with many
    /// coplanar vertices (against a plain scan of the input points).
    #[test]
    fn hull_support_matches_scan() {
        let mut pts = Vec::new();
        for i in 0..40 {
            let a = i as f32 * 0.157;
            for z in [-0.1f32, 0.0, 0.1] {
                pts.push(Vector::new(0.05 * a.cos(), 0.05 * a.sin(), z));
            }
        }
        let hull = Hull::new(&pts).unwrap();
        for k in 0..1000 {
            let d = Vector::new(
                (k as f32 * 0.37).sin(),
                (k as f32 * 0.91).cos(),
                (k as f32 * 0.13).sin() - 0.3,
            );
            let got = hull.support(d).dot(d);
            let best = pts.iter().map(|p| p.dot(d)).fold(f32::MIN, f32::max);
            assert!(got >= best - 1e-6, "{k}: {got} < {best}");
        }
    }

    /// The eight-wide scan returns the very vertex of a plain scalar scan
    /// (the first of the hull's vertices with the largest `x dx + y dy +
    /// z dz`, same `f32` operations), ties included, as its docs say:
    /// hulls with an odd and an even number of packs (padding lanes repeat
    /// the last vertex), directions along the axes (many equal values) and
    /// random ones.
    #[test]
    fn hull_support_is_the_first_maximum() {
        for (n, rings) in [(40usize, 3usize), (44, 3), (23, 2), (8, 1)] {
            let mut pts = Vec::new();
            for i in 0..n {
                let a = i as f32 * std::f32::consts::TAU / n as f32;
                for r in 0..rings.max(2) {
                    pts.push(Vector::new(
                        0.05 * a.cos(),
                        0.05 * a.sin(),
                        0.1 * r as f32 - 0.05,
                    ));
                }
            }
            let hull = Hull::new(&pts).unwrap();
            let mut dirs: Vec<Vector> = [Vector::X, Vector::Y, Vector::Z]
                .into_iter()
                .flat_map(|e| [e, -e])
                .collect();
            dirs.extend((0..500).map(|k| {
                Vector::new(
                    (k as f32 * 0.37).sin(),
                    (k as f32 * 0.91).cos(),
                    (k as f32 * 0.13).sin() - 0.3,
                )
            }));
            for d in dirs {
                let value = |p: &Vector| p.x * d.x + p.y * d.y + p.z * d.z;
                let mut first = 0;
                for (i, p) in hull.points.iter().enumerate() {
                    if value(p) > value(&hull.points[first]) {
                        first = i;
                    }
                }
                assert_eq!(
                    hull.support(d),
                    hull.points[first],
                    "{n} x {rings}, {} packs, direction {d:?}",
                    hull.packs.len()
                );
            }
        }
    }

    /// The box test never separates boxes that overlap (checked against
    /// points sampled inside the boxes), and separates far ones.
    #[test]
    fn box_test_is_conservative() {
        let a = Obb::new(
            Vector3::new(0.0, 0.0, 0.0),
            &Matrix3::identity(),
            &Vector3::new(0.1, 0.05, 0.2),
        );
        let rot = UnitQuaternion::from_euler_angles(0.3, -0.7, 1.1)
            .to_rotation_matrix()
            .into_inner();
        let b = Obb::new(Vector3::zeros(), &rot, &Vector3::new(0.03, 0.08, 0.06));
        let ident: LaneFrame<f32> = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
        let (mut overlaps, mut seps) = (0, 0);
        for k in 0..4000 {
            let off = Vector3::new(
                ((k * 7919) % 1000) as f64 / 1000.0 - 0.5,
                ((k * 104_729) % 1000) as f64 / 1000.0 - 0.5,
                ((k * 1_299_709) % 1000) as f64 / 1000.0 - 0.5,
            ) * 0.7;
            let mut fb = ident;
            fb[9..12].copy_from_slice(&[off.x as f32, off.y as f32, off.z as f32]);
            let says = boxes_overlap(&a, &b, &ident, &fb, 0.0) != 0;
            // A point of b (grid over its volume) inside a proves overlap.
            let mut inside = false;
            for x in -4..=4 {
                for y in -4..=4 {
                    for z in -4..=4 {
                        let l =
                            Vector3::new(0.03 * x as f64, 0.08 * y as f64, 0.06 * z as f64) / 4.0;
                        let p = rot * l + off;
                        inside |= p.x.abs() <= 0.1 && p.y.abs() <= 0.05 && p.z.abs() <= 0.2;
                    }
                }
            }
            assert!(!inside || says, "{k}: overlapping boxes separated");
            if inside {
                overlaps += 1;
            }
            if !says {
                seps += 1;
            }
        }
        assert!(overlaps > 100 && seps > 100, "{overlaps} {seps}");
    }
}
