//! Candidate hands: a search in the local frame of a seed point over
//! approach rotations, with a finger-slot search and deepening (GPD's
//! scheme), each hand checked for collision and scored.
//!
//! At a seed with outward normal n and dominant tangent t, the approach
//! starts as -n; the closing axis is t turned about the approach by
//! k·π/`num_rotations` (k = 0..num_rotations; y and -y give the same hand),
//! and the approach is tilted about the closing axis by each of
//! `approach_tilts`. For each orientation the fingertip depths are tried
//! deepest first: the points in the finger slot form a connected interval
//! along y around the seed (binned at half the width of a finger plus its
//! clearance on both sides: a run of occupied bins is one interval); the
//! fingers are centred on that interval and opened to its extent plus
//! clearance; the first depth whose opening fits and whose hand (grown by a
//! voxel margin) is free of points and above the support plane wins.

use nalgebra::{Matrix3, Point3, Vector3};

use crate::grasp::Grasp;
use crate::gripper::{GripperGeometry, body_margin};
use crate::normals::SurfaceCloud;
use crate::plane::Plane;
use crate::quality::{contacts_from_profile, friction_needed, lever_arm, score, torque_factor};

/// Parameters of the hand search.
#[derive(Debug, Clone)]
pub struct SearchParams {
    /// Gripper geometry.
    pub gripper: GripperGeometry,
    /// Fingertip depths beyond the seed to try, metres.
    pub depths: Vec<f64>,
    /// Number of closing-axis rotations about the approach over a half turn.
    pub num_rotations: usize,
    /// Tilts of the approach about the closing axis, radians.
    pub approach_tilts: Vec<f64>,
    /// Voxel size of the cloud (points are voxel centroids).
    pub voxel_size: f64,
    /// Friction coefficient of the fingers.
    pub friction: f64,
    /// Preferred approach direction (unit).
    pub approach_direction: Vector3<f64>,
    /// A support plane whose far side is solid, if any.
    pub plane: Option<Plane>,
    /// Estimated centre of mass per object label (see [`crate::mass`]).
    pub mass_centres: Vec<(i32, Point3<f64>)>,
    /// Lever arm of the weight about the grasp axis at which the score
    /// halves ([`torque_factor`]); 0 disables the term.
    pub torque_scale: f64,
    /// Reject hands whose closing region holds [`MAX_FOREIGN_POINTS`] or
    /// more points labelled as another object than the seed's (labelled
    /// seeds only): such a grasp would lift two objects, or none cleanly.
    pub single_object: bool,
}

/// Fewest points of another labelled object between the fingers that make
/// a hand grasp more than its seed's object ([`SearchParams::single_object`]):
/// a 1 cm² patch at the default 5 mm voxels; single stray points (depth
/// edges, segmentation bleeding) are tolerated.
pub const MAX_FOREIGN_POINTS: usize = 4;

/// Whether a point labelled `other` belongs to another object than a seed
/// labelled `own`: both labels known (>= 0) and different. Label 0 (no
/// object in a segmentation) counts as another object for a seed with a
/// positive label: unsegmented clutter is not the target either.
pub fn is_foreign(own: i32, other: i32) -> bool {
    own > 0 && other >= 0 && other != own
}

/// How far (m) a hand corner may dip below the support plane.
const PLANE_TOLERANCE: f64 = 0.001;

/// Fewest (x, z) cells of a finger pad the object must reach.
const MIN_CONTACT_CELLS: usize = 4;

/// How far (m) along the approach a hand's pads overlap the object between
/// its fingers: from the fingertips (x = `depth`) back to the highest of the
/// points between the fingers (`inside`, hand frame: the object's top there,
/// at most the seed, x = 0). 0 without points.
pub(crate) fn pad_engagement(inside: &[Vector3<f64>], depth: f64) -> f64 {
    let top = inside.iter().map(|q| q.x).fold(f64::INFINITY, f64::min);
    if top.is_finite() { depth - top } else { 0.0 }
}

/// The depth policy's engagement term for a hand of `g` whose pads overlap
/// the object by `engaged` (m, [`pad_engagement`]): how much of a square
/// patch of the pad (as long along the approach as the pad is wide, `g.height`)
/// the object covers, in [0, 1].
///
/// Why a square: the two pads resist the object turning about the
/// approach with the patch's extent across the pad (at most the pad's
/// width) and turning about the pad's width axis (rolling out between the
/// fingers, the usual slip of shallow grasps) with its extent along the
/// approach, the engagement. Below the pad's width the roll-out axis is the
/// weak one, and the shallower, the weaker: on tables, 15 mm hands of the
/// Panda's 20 mm wide pads lifted 78 % (ferrobot) / 83 % (MuJoCo) against
/// 96 % / 89 % for hands >= 17.5 mm deep, and 7 of 8 reproducible bin slips
/// were 15 mm hands (BENCHMARKS.md, table18e and slip18h).
///
/// A fixed-depth hand must engage a full square (factor 1, else the search
/// goes on to the next depth); a plane-limited hand (a piece lower than the
/// pad's width, only where the support plane stops every fixed depth) is
/// kept with its score multiplied by this factor, so it ranks below full
/// hands of the same quality.
pub fn engagement_factor(g: &GripperGeometry, engaged: f64) -> f64 {
    (engaged / g.height).clamp(0.0, 1.0)
}

/// Whether a fixed-depth hand of `g` with pad engagement `engaged` qualifies
/// (see [`engagement_factor`]); rounding of the seed's own coordinate is
/// tolerated.
pub(crate) fn engages_fully(g: &GripperGeometry, engaged: f64) -> bool {
    engaged >= g.height - 1e-9
}

/// Shallowest plane-limited depth tried (see `plane_limited_depth`):
/// fingertips must reach at least this far past the seed.
pub const MIN_PLANE_DEPTH: f64 = 0.005;

/// The shallowest depth a hand of `sp` may take: the smallest fixed depth,
/// or [`MIN_PLANE_DEPTH`] with a support plane.
pub fn shallowest_depth(sp: &SearchParams) -> f64 {
    let d = sp.depths.iter().copied().fold(f64::INFINITY, f64::min);
    if sp.plane.is_some() {
        d.min(MIN_PLANE_DEPTH)
    } else {
        d
    }
}

/// The deepest fingertip depth at which no finger corner of a hand at `p`
/// with orientation `r` (fingers anywhere within `reach_y` of the approach
/// axis) goes more than [`PLANE_TOLERANCE`] below `plane`; None when the
/// approach does not head towards the plane.
fn plane_limited_depth(
    plane: &Plane,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    g: &GripperGeometry,
    reach_y: f64,
) -> Option<f64> {
    let a = r.column(0).dot(&plane.normal);
    if a >= -1e-6 {
        return None;
    }
    let (y, z) = (
        r.column(1).dot(&plane.normal),
        r.column(2).dot(&plane.normal),
    );
    // Lowest corner of the fingertips at depth 0: distance + depth·a.
    let lowest = plane.distance(p) - (y * reach_y).abs() - (z * g.height / 2.0).abs();
    Some((lowest + 0.5 * PLANE_TOLERANCE) / -a)
}

/// The deepest fingertip depth at which no corner of the hand of
/// orientation `r` at `p`, opened to `width` around `yc` (both fingers, the
/// palm with the approach corridor, and the housing: the boxes the search
/// checks against the plane), goes more than half of [`PLANE_TOLERANCE`]
/// below `plane`; None when the approach does not head towards the plane.
/// [`plane_limited_depth`] is the same for fingers anywhere within
/// `reach_y` (9 cm for the Panda hand) of the seed: for a hand rolled by θ
/// (the closing axis θ off the plane) it is shallower by up to
/// (`reach_y` - the fingers' actual reach)·sin θ, e.g. 3.5 mm at 5° for
/// the open Panda hand centred on the seed, which on a piece 1-2 cm tall
/// keeps the fingertips above a rounded rim's widest line.
pub fn exact_plane_depth(
    plane: &Plane,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    g: &GripperGeometry,
    width: f64,
    yc: f64,
) -> Option<f64> {
    let a = r.column(0).dot(&plane.normal);
    if a >= -1e-6 {
        return None;
    }
    let (yn, zn) = (
        r.column(1).dot(&plane.normal),
        r.column(2).dot(&plane.normal),
    );
    let [f1, f2, palm] = g.boxes(0.0, width, yc);
    let dist = plane.distance(p);
    let lowest = [f1, f2, palm, g.body_box(0.0, yc)]
        .iter()
        .map(|(lo, hi)| {
            // The box's lowest corner at depth 0 (a < 0: its largest x).
            let cy = if yn < 0.0 { hi.y } else { lo.y };
            let cz = if zn < 0.0 { hi.z } else { lo.z };
            dist + hi.x * a + cy * yn + cz * zn
        })
        .fold(f64::INFINITY, f64::min);
    Some((lowest + 0.5 * PLANE_TOLERANCE) / -a)
}

/// Depths closer than this (m) to the plane-limited depth already tried are
/// not tried again by [`plane_depths`].
const PLANE_DEPTH_STEP: f64 = 0.001;

/// The plane-limited depths a hand of orientation `r` at `p` tries once
/// every fixed depth failed, best first: the depth the plane allows for
/// the hand fully open and centred on the object's interval there
/// ([`exact_plane_depth`] for the interval found at the conservative depth,
/// or at [`MIN_PLANE_DEPTH`] when that is shallower), then the
/// conservative [`plane_limited_depth`] (fingers anywhere within `reach_y`
/// of the seed). Each lies within [[`MIN_PLANE_DEPTH`], `shallowest`)
/// (the shallowest fixed depth); the search checks every hand against the
/// plane as for fixed depths, so a deeper depth whose interval grew is
/// rejected there. `interval(depth)` is the object's interval along y at
/// a depth (None: no point at the seed), `pad` the clearance per side.
#[allow(clippy::too_many_arguments)]
pub(crate) fn plane_depths(
    plane: &Plane,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    g: &GripperGeometry,
    reach_y: f64,
    shallowest: f64,
    pad: f64,
    mut interval: impl FnMut(f64) -> Option<(f64, f64)>,
) -> [Option<f64>; 2] {
    let Some(d0) = plane_limited_depth(plane, p, r, g, reach_y) else {
        return [None, None];
    };
    let valid = |d: f64| d >= MIN_PLANE_DEPTH && d < shallowest;
    let conservative = Some(d0).filter(|&d| valid(d));
    let probe = d0.max(MIN_PLANE_DEPTH);
    if probe >= shallowest {
        return [None, conservative];
    }
    // The hand approaches fully open (executors open it before the
    // approach), centred where it will close: the open fingers must clear
    // the plane too, so the depth is that of the widest opening at the
    // object's centre, not only of the closing width.
    let refined = interval(probe)
        .and_then(|(ymin, ymax)| {
            let width = (ymax - ymin + 2.0 * pad).max(g.max_width);
            exact_plane_depth(plane, p, r, g, width, (ymin + ymax) / 2.0)
        })
        .map(|d| d.min(shallowest - 0.5 * PLANE_DEPTH_STEP))
        .filter(|&d| valid(d) && conservative.is_none_or(|c| d > c + PLANE_DEPTH_STEP));
    [refined, conservative]
}

/// The object's interval along y around the seed (y = 0) among the slot
/// points `(xs, ys)` in the finger slot of `depth` (x in [depth -
/// `finger_depth`, depth]): bins of `layout`, the run of occupied bins
/// through the seed's bin (`lo_y`, `hi_y` are scratch of `layout.nbins`).
/// None when the seed's bin is empty.
fn slot_interval(
    xs: &[f64],
    ys: &[f64],
    depth: f64,
    finger_depth: f64,
    layout: &SlotLayout,
    lo_y: &mut [f64],
    hi_y: &mut [f64],
) -> Option<(f64, f64)> {
    let base = depth - finger_depth;
    lo_y.fill(f64::INFINITY);
    hi_y.fill(f64::NEG_INFINITY);
    for (&x, &y) in xs.iter().zip(ys) {
        if x >= base && x <= depth {
            let k = layout.index(y);
            lo_y[k] = lo_y[k].min(y);
            hi_y[k] = hi_y[k].max(y);
        }
    }
    run_through_centre(layout, lo_y, hi_y)
}

/// Whether both fingertips of a hand at `p` of orientation `r` (fingertip
/// centres at x = `depth`, y = `yc` ± `width` / 2, z = 0) are at most half
/// as high above `plane` as the highest of the points between the fingers
/// (`inside`, hand frame): the object's top there. For a piece lower than
/// the fingers can reach past its top (the plane-limited depths), the pads
/// then cover the lower half of its side, where a rounded rim (a ring, a
/// torus, a tube lying flat) is widest; fingertips above that squeeze the
/// rim from above and push the piece down and out instead of holding it
/// (see BENCHMARKS.md, "Thin and flat objects": hands rolled so that one
/// finger is higher than the other were the usual case). False without
/// points between the fingers.
fn tips_below_mid_height(
    plane: &Plane,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    depth: f64,
    width: f64,
    yc: f64,
    inside: &[Vector3<f64>],
) -> bool {
    let top = inside
        .iter()
        .map(|q| plane.distance(&(p + r * q)))
        .fold(f64::NEG_INFINITY, f64::max);
    [-1.0, 1.0].iter().all(|s| {
        plane.distance(&(p + r * Vector3::new(depth, yc + s * width / 2.0, 0.0))) <= 0.5 * top
    })
}

/// The y extent of the run of occupied bins through the seed's bin (y = 0).
fn run_through_centre(layout: &SlotLayout, lo_y: &[f64], hi_y: &[f64]) -> Option<(f64, f64)> {
    let centre = layout.index(0.0);
    if lo_y[centre] > hi_y[centre] {
        return None;
    }
    let (mut lo, mut hi) = (centre, centre);
    while lo > 0 && lo_y[lo - 1] <= hi_y[lo - 1] {
        lo -= 1;
    }
    while hi + 1 < layout.nbins && lo_y[hi + 1] <= hi_y[hi + 1] {
        hi += 1;
    }
    Some((lo_y[lo], hi_y[hi]))
}

/// How much the hand's solid parts are grown for collision: points are
/// voxel centroids, up to about half a voxel and more from the surface.
fn margin(sp: &SearchParams) -> f64 {
    body_margin(sp.voxel_size)
}

/// The layout of the finger-slot binning (see [`evaluate`]), the same for
/// every hand of a search.
struct SlotLayout {
    /// Points further than this from the approach axis along y are out of
    /// every finger slot (widest opening plus a finger).
    reach_y: f64,
    /// Slot points lie at x in [`Self::x_lo`, `Self::x_hi`] (the shallowest
    /// finger base to the deepest fingertips).
    x_lo: f64,
    x_hi: f64,
    /// Bin width along y and number of bins over [-reach_y, reach_y].
    bin: f64,
    nbins: usize,
    /// The windows' ends along x (each depth's slot is
    /// [depth - finger_depth, depth]), sorted, without repeats.
    edges: Vec<f64>,
}

impl SlotLayout {
    fn new(sp: &SearchParams) -> Self {
        let g = &sp.gripper;
        let pad = g.clearance + margin(sp);
        let gap_max = g.finger_width + 2.0 * pad;
        let reach_y = g.max_width + g.finger_width;
        let bin = gap_max / 2.0;
        let mut edges: Vec<f64> = sp
            .depths
            .iter()
            .flat_map(|&d| [d - g.finger_depth, d])
            .collect();
        edges.sort_by(f64::total_cmp);
        edges.dedup();
        Self {
            reach_y,
            x_lo: shallowest_depth(sp) - g.finger_depth,
            x_hi: sp.depths.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            bin,
            nbins: (2.0 * reach_y / bin).ceil() as usize + 1,
            edges,
        }
    }

    /// The bin of `y`.
    fn index(&self, y: f64) -> usize {
        (((y + self.reach_y) / self.bin).floor() as usize).min(self.nbins - 1)
    }
}

/// Scratch space of the finger-slot search, reused across the hands of a
/// seed: per strip and bin the smallest and largest y, per bin the same
/// for one depth, and the points on a strip's edge.
struct SlotScratch {
    strip_lo: Vec<f64>,
    strip_hi: Vec<f64>,
    lo_y: Vec<f64>,
    hi_y: Vec<f64>,
    on_edge: Vec<(f64, f64)>,
    /// Per slot point of a hand, its strip (see [`evaluate`]).
    strip_of: Vec<u32>,
}

impl SlotScratch {
    /// For hands of up to `n` points.
    fn new(layout: &SlotLayout, n: usize) -> Self {
        let cells = (layout.edges.len() - 1) * layout.nbins;
        Self {
            strip_of: vec![0; n],
            strip_lo: vec![f64::INFINITY; cells],
            strip_hi: vec![f64::NEG_INFINITY; cells],
            lo_y: vec![f64::INFINITY; layout.nbins],
            hi_y: vec![f64::NEG_INFINITY; layout.nbins],
            on_edge: Vec::new(),
        }
    }
}

/// All scored collision-free hands at `seed` (score > 0 only).
pub fn hands_at_seed(cloud: &SurfaceCloud, seed: usize, sp: &SearchParams) -> Vec<Grasp> {
    hands_in_frame(cloud, seed, -cloud.normal(seed), cloud.tangent(seed), sp)
}

/// [`hands_at_seed`] in a given seed frame: approach `a0` and closing axis
/// `t0` (unit, perpendicular) instead of the seed's inward normal and
/// tangent, turned by `sp.num_rotations` about `a0` and tilted by
/// `sp.approach_tilts` about the closing axis as there.
pub fn hands_in_frame(
    cloud: &SurfaceCloud,
    seed: usize,
    a0: Vector3<f64>,
    t0: Vector3<f64>,
    sp: &SearchParams,
) -> Vec<Grasp> {
    let p = cloud.points[seed];
    let b0 = a0.cross(&t0);
    let max_depth = sp.depths.iter().copied().fold(0.0, f64::max);
    let nb = cloud.within(&p, sp.gripper.reach(max_depth));
    let g = &sp.gripper;
    let m = margin(sp);
    let half_h = g.height / 2.0 + m;
    // Points outside this slab of the hand frame are Free for every hand
    // evaluated here (behind the approach corridor, beyond the deepest
    // fingertips, or further along y than any opening and centring reach):
    // dropping them changes nothing but the work.
    let dmin = shallowest_depth(sp);
    let x_lo = dmin - g.finger_depth - g.finger_width - g.approach_distance - m;
    let x_hi = max_depth + m;
    let y_max = g.max_width + g.finger_width + m;
    // The same slab in the seed frame, over every tilt t (the hand frame is
    // the seed frame turned by t about y): a = cos t·x' + sin t·z' and
    // |z'| <= half_h bound the seed-frame x; y and the rotated z bound the
    // distance from the seed's approach axis.
    let (mut cmin, mut smax) = (1.0f64, 0.0f64);
    for &t in &sp.approach_tilts {
        cmin = cmin.min(t.cos());
        smax = smax.max(t.sin().abs());
    }
    let sx_lo = x_lo.min(cmin * x_lo) - smax * half_h;
    let sx_hi = x_hi.max(cmin * x_hi) + smax * half_h;
    let kz_max = (half_h + smax * sx_lo.abs().max(sx_hi.abs())) / cmin;
    let r2_max = y_max * y_max + kz_max * kz_max;
    // Neighbours in the seed frame (a0, t0, b0), one array per axis.
    let n = nb.len();
    let (mut sx, mut sy, mut sz) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let own = cloud.labels[seed];
    let mut sf: Vec<bool> = Vec::with_capacity(n);
    for &i in &nb {
        let d = cloud.points[i] - p;
        let (x, y, z) = (d.dot(&a0), d.dot(&t0), d.dot(&b0));
        if x >= sx_lo && x <= sx_hi && y * y + z * z <= r2_max {
            sx.push(x);
            sy.push(y);
            sz.push(z);
            sf.push(is_foreign(own, cloud.labels[i]));
        }
    }
    let n = sx.len();
    let layout = SlotLayout::new(sp);
    let mut bins = SlotScratch::new(&layout, n);
    let mut out = Vec::new();
    let mut local = LocalPoints::new(n);
    // The x, y and y-bin of the points that can be in a finger slot at
    // some depth, in the neighbours' order (a hand uses the first
    // `in_slot`).
    let (mut slot_x, mut slot_y, mut slot_bin) = (vec![0.0; n], vec![0.0; n], vec![0u32; n]);
    // Per point, its y and z for the current closing axis.
    let (mut ky, mut kz) = (vec![0.0; n], vec![0.0; n]);
    // The points that can be in the slab of some tilt about the current
    // closing axis, in order: seed-frame x, y and z for the closing axis,
    // the bin of that y in the finger-slot layout, and whether each is
    // foreign.
    let (mut rx, mut ry, mut rz) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut ybin, mut rf) = (vec![0u32; n], vec![false; n]);
    // A tilt t keeps |sin t·x + cos t·z| <= half_h, so |z| <= (half_h +
    // smax·|x|) / cmin over every tilt (cmin > 0); grown a little so that
    // rounding never drops a point the exact test per tilt would keep.
    let z_reach = |x: f64| {
        if cmin > 0.0 {
            (half_h + smax * x.abs()) / cmin * (1.0 + 1e-9) + 1e-12
        } else {
            f64::INFINITY
        }
    };
    // Per point of the current hand: its hand-frame x and z, and flags:
    // [`IN_HAND`] when it is inside the hand's slab, plus [`IN_SLOT`] when
    // it can also be in a finger slot (padded to whole words of 8 flags,
    // the padding never set).
    let (mut lxs, mut lzs) = (vec![0.0; n], vec![0.0; n]);
    let mut flags = vec![0u8; n.div_ceil(8) * 8];
    let slot_h = g.height / 2.0;
    for k in 0..sp.num_rotations {
        // Closing axis y = t0 turned by phi about a0; z = a0 × y.
        let phi = k as f64 * std::f64::consts::PI / sp.num_rotations as f64;
        let (s, c) = phi.sin_cos();
        let y = t0 * c + b0 * s;
        let z0 = b0 * c - t0 * s;
        for (((ky, kz), flag), ((&sy, &sz), &x)) in ky
            .iter_mut()
            .zip(kz.iter_mut())
            .zip(flags.iter_mut())
            .zip(sy.iter().zip(&sz).zip(&sx))
        {
            *ky = c * sy + s * sz;
            *kz = -s * sy + c * sz;
            *flag = u8::from((ky.abs() <= y_max) & (kz.abs() <= z_reach(x)));
        }
        // Only those can be in any hand about this axis (the per-tilt test
        // below includes |y| <= y_max and |z| <= half_h): compacted, in
        // order, for the tilts.
        let mut nr = 0;
        for (w, bytes) in flags.chunks_exact(8).enumerate() {
            let mut word = u64::from_le_bytes(bytes.try_into().expect("8 flags"));
            while word != 0 {
                let i = 8 * w + word.trailing_zeros() as usize / 8;
                word &= word - 1;
                rx[nr] = sx[i];
                ry[nr] = ky[i];
                rz[nr] = kz[i];
                rf[nr] = sf[i];
                nr += 1;
            }
        }
        for (b, &y) in ybin[..nr].iter_mut().zip(&ry) {
            *b = layout.index(y) as u32;
        }
        let words = nr.div_ceil(8) * 8;
        flags[nr..words].fill(0);
        for &tilt in &sp.approach_tilts {
            // Approach a0 turned by tilt about y: a = cos·a0 - sin·z0, z = sin·a0 + cos·z0.
            let (st, ct) = tilt.sin_cos();
            let a = a0 * ct - z0 * st;
            let z = a0 * st + z0 * ct;
            // The hand-frame x and z of every point, whether it is inside
            // the slab and whether it can be in a finger slot (a loop
            // without branches or scattered stores, which the compiler
            // vectorises).
            for ((((lx_out, lz_out), flag), (&x, &kz)), &ky) in lxs[..nr]
                .iter_mut()
                .zip(lzs.iter_mut())
                .zip(flags.iter_mut())
                .zip(rx.iter().zip(rz.iter()))
                .zip(ry.iter())
            {
                let lz = st * x + ct * kz;
                let lx = ct * x - st * kz;
                *lx_out = lx;
                *lz_out = lz;
                let inside =
                    (lz.abs() <= half_h) & (lx >= x_lo) & (lx <= x_hi) & (ky.abs() <= y_max);
                let slotted = (lx >= layout.x_lo)
                    & (lx <= layout.x_hi)
                    & (lz.abs() <= slot_h)
                    & (ky.abs() <= layout.reach_y);
                *flag = (u8::from(inside) * IN_HAND) | (u8::from(inside & slotted) * IN_SLOT);
            }
            // The slot points, in order, skipping 8 flags at a time; the
            // hand's other points are gathered only if a depth gets as far
            // as the collision test (most hands fail on the object's width
            // first).
            let mut in_slot = 0;
            for (w, bytes) in flags[..words].chunks_exact(8).enumerate() {
                let mut word = u64::from_le_bytes(bytes.try_into().expect("8 flags"))
                    & (0x0101_0101_0101_0101 * u64::from(IN_SLOT));
                while word != 0 {
                    let i = 8 * w + word.trailing_zeros() as usize / 8;
                    word &= word - 1;
                    slot_x[in_slot] = lxs[i];
                    slot_y[in_slot] = ry[i];
                    slot_bin[in_slot] = ybin[i];
                    in_slot += 1;
                }
            }
            local.len = None;
            let r = Matrix3::from_columns(&[a, y, z]);
            let hand = HandPoints {
                flags: &flags[..words],
                lx: &lxs,
                ly: &ry,
                lz: &lzs,
                foreign: &rf,
                slot_x: &slot_x[..in_slot],
                slot_y: &slot_y[..in_slot],
                slot_bin: &slot_bin[..in_slot],
            };
            if let Some(g) = evaluate(
                cloud, &p, &r, &hand, &mut local, &layout, &mut bins, seed, sp,
            ) {
                out.push(g);
            }
        }
    }
    out
}

/// Flag of a point inside a hand's slab (|z| <= height / 2 + margin, within
/// the hand's reach along x and y): it may collide or be grasped.
const IN_HAND: u8 = 1;

/// Flag of a slab point that can be in a finger slot at some depth.
const IN_SLOT: u8 = 2;

/// The hand-frame coordinates of every neighbour of one hand (one array
/// per axis, [`IN_HAND`] set in `flags` for those in the hand's slab),
/// `foreign` whether each belongs to another object than the seed's, and
/// `slot_*` the x, y and y-bin ([`SlotLayout::index`]) of the slab points
/// that can be in a finger slot at some depth (in the neighbours' order).
struct HandPoints<'a> {
    flags: &'a [u8],
    lx: &'a [f64],
    ly: &'a [f64],
    lz: &'a [f64],
    foreign: &'a [bool],
    slot_x: &'a [f64],
    slot_y: &'a [f64],
    slot_bin: &'a [u32],
}

/// The points of one hand's slab, gathered in the neighbours' order (one
/// array per axis), when a hand first needs them.
struct LocalPoints {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    foreign: Vec<bool>,
    /// How many are gathered for the current hand; None: not yet.
    len: Option<usize>,
}

impl LocalPoints {
    fn new(n: usize) -> Self {
        Self {
            x: vec![0.0; n],
            y: vec![0.0; n],
            z: vec![0.0; n],
            foreign: vec![false; n],
            len: None,
        }
    }

    /// Gathers `hand`'s slab points (once per hand); returns their count.
    fn gather(&mut self, hand: &HandPoints) -> usize {
        if let Some(len) = self.len {
            return len;
        }
        let mut m = 0;
        for (w, bytes) in hand.flags.chunks_exact(8).enumerate() {
            let mut word = u64::from_le_bytes(bytes.try_into().expect("8 flags"))
                & (0x0101_0101_0101_0101 * u64::from(IN_HAND));
            while word != 0 {
                let i = 8 * w + word.trailing_zeros() as usize / 8;
                word &= word - 1;
                self.x[m] = hand.lx[i];
                self.y[m] = hand.ly[i];
                self.z[m] = hand.lz[i];
                self.foreign[m] = hand.foreign[i];
                m += 1;
            }
        }
        self.len = Some(m);
        m
    }
}

/// The first (deepest) collision-free hand of orientation `r` at `p`
/// holding `hand`'s points (gathered into `local` when first needed);
/// `layout` is the finger-slot binning and `bins` scratch space reused
/// across hands.
#[allow(clippy::too_many_arguments)]
fn evaluate(
    cloud: &SurfaceCloud,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    hand: &HandPoints,
    local: &mut LocalPoints,
    layout: &SlotLayout,
    bins: &mut SlotScratch,
    seed: usize,
    sp: &SearchParams,
) -> Option<Grasp> {
    let g = &sp.gripper;
    let m = margin(sp);
    let pad = g.clearance + m;
    let (slot_x, slot_y) = (hand.slot_x, hand.slot_y);
    // The object's interval along y around the seed (y = 0): bins of half
    // the largest gap a finger cannot use; a run of occupied bins is one
    // object (an empty bin is a gap a finger may use: collision decides).
    let nbins = layout.nbins;
    let reach_y = layout.reach_y;
    // Each depth's finger slot is x in [depth - finger_depth, depth]. The
    // slot's points are binned once into strips along x between the
    // windows' ends (`edges`), and each depth merges the strips inside its
    // window; a point exactly on an edge is kept apart and tested per depth.
    let edges = &layout.edges;
    let strips = edges.len() - 1;
    let SlotScratch {
        strip_lo,
        strip_hi,
        lo_y,
        hi_y,
        on_edge,
        strip_of,
    } = bins;
    strip_lo.fill(f64::INFINITY);
    strip_hi.fill(f64::NEG_INFINITY);
    on_edge.clear();
    // The strip holding each x: the first j with x < edges[j + 1] (edges
    // ascend), none past the last edge; counted one edge at a time over
    // all the points (a loop the compiler vectorises).
    let strip_of = &mut strip_of[..slot_x.len()];
    strip_of.fill(0);
    for &e in &edges[1..] {
        for (j, &x) in strip_of.iter_mut().zip(slot_x) {
            *j += u32::from(e <= x);
        }
    }
    for ((&x, &y), (&j, &b)) in slot_x
        .iter()
        .zip(slot_y)
        .zip(strip_of.iter().zip(hand.slot_bin))
    {
        // Slot points lie within [edges[0], edges[strips]], or in front of
        // edges[0] for the plane-limited depth only (scanned directly).
        if x < edges[0] {
            continue;
        }
        let j = j as usize;
        if j == strips || x == edges[j] {
            on_edge.push((x, y));
            continue;
        }
        let k = j * nbins + b as usize;
        strip_lo[k] = strip_lo[k].min(y);
        strip_hi[k] = strip_hi[k].max(y);
    }
    // The fixed depths, deepest first; then, when the support plane stopped
    // them all, the deepest depths it allows (objects lower than the
    // shallowest fixed depth: thin pieces lying flat, small objects; see
    // [`plane_depths`]).
    let shallowest = sp.depths.iter().copied().fold(f64::INFINITY, f64::min);
    let nfixed = sp.depths.len();
    let mut plane_stage: [Option<f64>; 2] = [None, None];
    for k in 0..nfixed + 2 {
        let depth = if k < nfixed {
            sp.depths[k]
        } else {
            if k == nfixed {
                let Some(pl) = sp.plane.as_ref() else {
                    break;
                };
                plane_stage = plane_depths(pl, p, r, g, reach_y, shallowest, pad, |d| {
                    slot_interval(slot_x, slot_y, d, g.finger_depth, layout, lo_y, hi_y)
                });
            }
            match plane_stage[k - nfixed] {
                Some(d) => d,
                None => continue,
            }
        };
        let interval = if k < nfixed {
            let base = depth - g.finger_depth;
            lo_y.fill(f64::INFINITY);
            hi_y.fill(f64::NEG_INFINITY);
            for j in 0..strips {
                if edges[j] >= base && edges[j + 1] <= depth {
                    let (sl, sh) = (
                        &strip_lo[j * nbins..(j + 1) * nbins],
                        &strip_hi[j * nbins..(j + 1) * nbins],
                    );
                    for k in 0..nbins {
                        lo_y[k] = lo_y[k].min(sl[k]);
                        hi_y[k] = hi_y[k].max(sh[k]);
                    }
                }
            }
            for &(x, y) in on_edge.iter() {
                if x >= base && x <= depth {
                    let k = layout.index(y);
                    lo_y[k] = lo_y[k].min(y);
                    hi_y[k] = hi_y[k].max(y);
                }
            }
            run_through_centre(layout, lo_y, hi_y)
        } else {
            slot_interval(slot_x, slot_y, depth, g.finger_depth, layout, lo_y, hi_y)
        };
        let Some((ymin, ymax)) = interval else {
            continue;
        };
        let width = ymax - ymin + 2.0 * pad;
        if width > g.max_width {
            continue;
        }
        let yc = (ymin + ymax) / 2.0;
        // The support plane first (a few corners), then the points: a hand
        // must pass both, so the order changes nothing but the work.
        if let Some(plane) = &sp.plane {
            let [f1, f2, palm] = g.boxes(depth, width, yc);
            let below = [f1, f2, palm, g.body_box(depth, yc)]
                .iter()
                .any(|(lo, hi)| {
                    (0..8).any(|k| {
                        let c = Vector3::new(
                            if k & 1 == 0 { lo.x } else { hi.x },
                            if k & 2 == 0 { lo.y } else { hi.y },
                            if k & 4 == 0 { lo.z } else { hi.z },
                        );
                        plane.distance(&(p + r * c)) < -PLANE_TOLERANCE
                    })
                });
            if below {
                continue;
            }
        }
        let n = local.gather(hand);
        let (collision, closing) = g.collision_and_closing_xyz(
            &local.x[..n],
            &local.y[..n],
            &local.z[..n],
            depth,
            width,
            yc,
            m,
        );
        if collision || closing == 0 {
            continue;
        }
        // The points in the closing region ([`Region::Closing`](crate::gripper::Region::Closing) of
        // `GripperGeometry::region`, the same comparisons without branches)
        // in order, and how many of them belong to another object.
        let (half, base) = (width / 2.0, depth - g.finger_depth);
        let (hz, x_in, y_in) = (g.height / 2.0, base + m, half - m);
        let mut inside = Vec::new();
        let mut foreign_inside = 0;
        for (((&x, &y), &z), &f) in local.x[..n]
            .iter()
            .zip(&local.y[..n])
            .zip(&local.z[..n])
            .zip(&local.foreign[..n])
        {
            if (z.abs() <= hz) & (x >= x_in) & (x <= depth) & ((y - yc).abs() < y_in) {
                inside.push(Vector3::new(x, y, z));
                foreign_inside += usize::from(f);
            }
        }
        if sp.single_object && foreign_inside >= MAX_FOREIGN_POINTS {
            continue;
        }
        if k >= nfixed
            && let Some(plane) = &sp.plane
            && !tips_below_mid_height(plane, p, r, depth, width, yc, &inside)
        {
            continue;
        }
        let engaged = pad_engagement(&inside, depth);
        if k < nfixed && !engages_fully(g, engaged) {
            continue;
        }
        let factor = engagement_factor(g, engaged);
        return score_hand(cloud, p, r, &inside, seed, depth, width, yc, factor, sp);
    }
    None
}

/// The hand body's box in the grasp frame of `g` (see
/// [`GripperGeometry::body_box`]) swept back by the approach distance (the
/// hand comes from there) and grown by `margin`, as (min, max) corners.
pub fn body_sweep_box(
    gripper: &GripperGeometry,
    depth: f64,
    margin: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let (mut lo, hi) = gripper.body_box(depth, 0.0);
    lo.x -= gripper.approach_distance;
    (lo.add_scalar(-margin), hi.add_scalar(margin))
}

/// Whether any obstacle point of `cloud` (observed above the support plane
/// or hidden, see [`SurfaceCloud::within`]) lies inside the hand body of
/// grasp `g` swept back along the approach ([`body_sweep_box`]). The
/// fingers, palm and approach corridor are checked during the search; this
/// is the housing behind them, against the whole cloud (neighbouring
/// objects and bin walls included).
pub fn body_collides(
    cloud: &SurfaceCloud,
    extra: Option<&Obstacles>,
    g: &Grasp,
    gripper: &GripperGeometry,
    margin: f64,
) -> bool {
    let (lo, hi) = body_sweep_box(gripper, g.depth, margin);
    let centre = (lo + hi) / 2.0;
    let radius = ((hi - lo) / 2.0).norm();
    let c = Point3::from(g.translation + g.rotation * centre);
    let rt = g.rotation.transpose();
    let inside = |p: &Point3<f64>| {
        let q = rt * (p.coords - g.translation);
        (0..3).all(|k| q[k] >= lo[k] && q[k] <= hi[k])
    };
    cloud
        .within(&c, radius)
        .into_iter()
        .any(|i| inside(&cloud.points[i]))
        || extra.is_some_and(|o| o.within(&c, radius).any(inside))
}

/// Obstacle points beyond the hand search's crop that only the housing
/// can reach (observed points above the support plane), with a kd-tree.
#[derive(Debug)]
pub struct Obstacles {
    points: Vec<Point3<f64>>,
    tree: kiddo::KdTree<f64, 3>,
}

impl Obstacles {
    /// Indexes `points`.
    pub fn new(points: Vec<Point3<f64>>) -> Self {
        let mut tree: kiddo::KdTree<f64, 3> = kiddo::KdTree::with_capacity(points.len().max(1));
        for (i, p) in points.iter().enumerate() {
            tree.add(&[p.x, p.y, p.z], i as u64);
        }
        Self { points, tree }
    }

    /// The points within `r` of `p`.
    pub fn within(&self, p: &Point3<f64>, r: f64) -> impl Iterator<Item = &Point3<f64>> {
        self.tree
            .within_unsorted::<kiddo::SquaredEuclidean>(&[p.x, p.y, p.z], r * r)
            .into_iter()
            .map(|n| &self.points[n.item as usize])
    }
}

#[allow(clippy::too_many_arguments)]
fn score_hand(
    cloud: &SurfaceCloud,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    inside: &[Vector3<f64>],
    seed: usize,
    depth: f64,
    width: f64,
    yc: f64,
    engagement: f64,
    sp: &SearchParams,
) -> Option<Grasp> {
    let g = &sp.gripper;
    let (left, right) = contacts_from_profile(inside, sp.voxel_size)?;
    // Enough of each finger pad must touch the object (not a tip).
    if left.cells.min(right.cells) < MIN_CONTACT_CELLS {
        return None;
    }
    let mu = friction_needed(&left, &right);
    let full = (g.height / sp.voxel_size).max(1.0);
    let support = left.cells.min(right.cells) as f64 / full;
    let approach = r.column(0).into_owned();
    // The weight's torque about the closing axis through the contacts'
    // midpoint (gravity against the support plane's normal when known).
    let label = cloud.labels[seed];
    let torque = match sp.mass_centres.iter().find(|(l, _)| *l == label) {
        Some((_, com)) if sp.torque_scale > 0.0 => {
            let centre = p.coords + r * ((left.point + right.point) / 2.0);
            let up = sp.plane.as_ref().map(|pl| pl.normal);
            let arm = lever_arm(&com.coords, &centre, &r.column(1).into_owned(), up.as_ref());
            torque_factor(arm, sp.torque_scale)
        }
        _ => 1.0,
    };
    let s = engagement
        * torque
        * score(
            mu,
            sp.friction,
            support,
            approach.dot(&sp.approach_direction),
        );
    if s <= 0.0 {
        return None;
    }
    Some(Grasp {
        score: s,
        width,
        height: g.height,
        depth,
        rotation: *r,
        translation: (p + r * Vector3::new(0.0, yc, 0.0)).coords,
        object_id: cloud.labels[seed],
    })
}

#[cfg(test)]
#[path = "candidates_reference.rs"]
mod reference;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::DetectOptions;

    fn table() -> Plane {
        Plane {
            normal: Vector3::z(),
            offset: 0.0,
        }
    }

    #[test]
    fn plane_limited_depth_straight_down() {
        // Seed on top of a 1 cm tall piece, hand pointing straight down
        // (x = -z, y = +x, z = x × y = -y): the corners are as low as the
        // fingertips, so the depth is the seed's height plus half the
        // tolerance.
        let r = Matrix3::from_columns(&[-Vector3::z(), Vector3::x(), -Vector3::y()]);
        let g = GripperGeometry::default();
        let d = plane_limited_depth(&table(), &Point3::new(0.0, 0.0, 0.01), &r, &g, 0.09).unwrap();
        assert!((d - (0.01 + 0.5 * PLANE_TOLERANCE)).abs() < 1e-12, "{d}");
        // Pointing up or sideways: no limit.
        let up = Matrix3::from_columns(&[Vector3::z(), Vector3::x(), Vector3::y()]);
        assert!(
            plane_limited_depth(&table(), &Point3::new(0.0, 0.0, 0.01), &up, &g, 0.09).is_none()
        );
    }

    #[test]
    fn plane_limited_depth_tilted() {
        // Approach tilted by t from straight down about the world y axis:
        // the closing axis y stays horizontal, the fingers' z half-height
        // h/2 drops by sin t; the fingertips descend cos t per unit depth.
        let t: f64 = 0.4;
        let a = Vector3::new(t.sin(), 0.0, -t.cos());
        let y = Vector3::y();
        let r = Matrix3::from_columns(&[a, y, a.cross(&y)]);
        let g = GripperGeometry::default();
        let h = 0.012;
        let d = plane_limited_depth(&table(), &Point3::new(0.0, 0.0, h), &r, &g, 0.09).unwrap();
        let expect = (h - g.height / 2.0 * t.sin() + 0.5 * PLANE_TOLERANCE) / t.cos();
        assert!((d - expect).abs() < 1e-12, "{d} vs {expect}");
        // Every finger corner at that depth is within the tolerance.
        for sy in [-0.09, 0.09] {
            for sz in [-g.height / 2.0, g.height / 2.0] {
                let c = Point3::new(0.0, 0.0, h) + r * Vector3::new(d, sy, sz);
                assert!(c.z >= -PLANE_TOLERANCE, "{c:?}");
            }
        }
    }

    #[test]
    fn fingertips_below_half_the_top_between_the_fingers() {
        // A 16 mm tall piece between fingers 30 mm apart, hand straight down
        // from a seed on its top (x = -z, y = +x): the tips must be at most
        // 8 mm above the table (depth >= 8 mm). Turned by t about its z axis,
        // the approach tilts and the closing axis rises by sin t: the higher
        // tip is at 16 mm - d·cos t + 15 mm·sin t.
        let r = Matrix3::from_columns(&[-Vector3::z(), Vector3::x(), Vector3::y()]);
        let p = Point3::new(0.0, 0.0, 0.016);
        let inside: Vec<Vector3<f64>> = (0..8)
            .map(|i| Vector3::new(0.002 * i as f64, 0.0, 0.0))
            .collect();
        let ok = |r: &Matrix3<f64>, depth: f64| {
            tips_below_mid_height(&table(), &p, r, depth, 0.03, 0.0, &inside)
        };
        assert!(ok(&r, 0.0081));
        assert!(!ok(&r, 0.0079));
        let t = 0.2f64;
        let turned = r * Matrix3::from(nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), t));
        let limit = (0.008 + 0.015 * t.sin()) / t.cos();
        assert!(ok(&turned, limit + 1e-4));
        assert!(!ok(&turned, limit - 1e-4));
        assert!(!tips_below_mid_height(
            &table(),
            &p,
            &r,
            0.015,
            0.03,
            0.0,
            &[]
        ));
    }

    #[test]
    fn exact_plane_depth_is_the_deepest_depth_every_corner_clears() {
        // Hands rolled and tilted at random over a table: at the returned
        // depth the lowest of the 32 corners of the fingers, the palm and
        // the housing (enumerated, not derived) is exactly half the
        // tolerance below the plane; it is never shallower than the
        // conservative depth for any opening within reach.
        let g = GripperGeometry::default();
        let mut state = 7u64;
        let mut rand = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut checked = 0;
        for _ in 0..500 {
            let (yaw, roll, tilt) = (6.3 * rand(), 0.6 * (rand() - 0.5), 0.9 * (rand() - 0.5));
            // Straight down, rolled about the approach, tilted about y.
            let r = nalgebra::Rotation3::from_euler_angles(0.0, 0.0, yaw)
                * nalgebra::Rotation3::from_axis_angle(
                    &Vector3::y_axis(),
                    std::f64::consts::FRAC_PI_2,
                )
                * nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), roll)
                * nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), tilt);
            let r = *r.matrix();
            let p = Point3::new(0.0, 0.0, 0.005 + 0.03 * rand());
            let width = 0.08 * rand();
            let yc = 0.02 * (rand() - 0.5);
            let Some(d) = exact_plane_depth(&table(), &p, &r, &g, width, yc) else {
                continue;
            };
            let lowest = |d: f64| {
                let [f1, f2, palm] = g.boxes(d, width, yc);
                let mut lowest = f64::INFINITY;
                for (lo, hi) in [f1, f2, palm, g.body_box(d, yc)] {
                    for k in 0..8 {
                        let c = Vector3::new(
                            if k & 1 == 0 { lo.x } else { hi.x },
                            if k & 2 == 0 { lo.y } else { hi.y },
                            if k & 4 == 0 { lo.z } else { hi.z },
                        );
                        lowest = lowest.min((p + r * c).z);
                    }
                }
                lowest
            };
            assert!(
                (lowest(d) + 0.5 * PLANE_TOLERANCE).abs() < 1e-12,
                "{}",
                lowest(d)
            );
            // Any depth whose hand clears the plane as well is no deeper,
            // e.g. the conservative one, when it clears.
            let c = plane_limited_depth(&table(), &p, &r, &g, 0.09).unwrap();
            if lowest(c) >= -0.5 * PLANE_TOLERANCE - 1e-12 {
                assert!(d >= c - 1e-12, "{d} < {c}");
            }
            checked += 1;
        }
        assert!(checked > 400, "{checked}");
    }

    #[test]
    fn body_collision_against_points_in_and_out_of_the_housing() {
        // A grasp at the origin pointing down (-z), closing along x: the
        // housing spans x in ±palm_width/2, y in ±palm_height/2 and z from
        // the fingers' base (depth - finger_depth above the origin, as
        // approach is -z) up by palm_depth + approach_distance.
        let g = GripperGeometry::default();
        let r = Matrix3::from_columns(&[-Vector3::z(), Vector3::x(), -Vector3::y()]);
        let grasp = Grasp {
            score: 1.0,
            width: 0.05,
            height: g.height,
            depth: 0.03,
            rotation: r,
            translation: Vector3::zeros(),
            object_id: -1,
        };
        let base_z = g.finger_depth - 0.03; // 2 cm above the origin
        let top_z = base_z + g.palm_depth + g.approach_distance;
        let m = 0.001;
        let cases = [
            (Point3::new(0.1, 0.03, base_z + 0.05), true),
            (Point3::new(0.0, 0.0, top_z - 0.002), true),
            (Point3::new(0.0, 0.0, top_z + 0.002), false),
            (Point3::new(0.106, 0.0, base_z + 0.01), false),
            (Point3::new(0.0, 0.0333, base_z + 0.01), false),
            (Point3::new(0.0, 0.0, base_z - 0.002), false),
        ];
        for (pt, expect) in cases {
            let cloud = SurfaceCloud::new(
                vec![pt, Point3::new(1.0, 1.0, 1.0)],
                vec![-1, -1],
                0.01,
                Point3::new(0.0, 0.0, 1.0),
            )
            .unwrap();
            assert_eq!(body_collides(&cloud, None, &grasp, &g, m), expect, "{pt:?}");
            let far = SurfaceCloud::new(
                vec![Point3::new(1.0, 1.0, 1.0)],
                vec![-1],
                0.01,
                Point3::new(0.0, 0.0, 1.0),
            )
            .unwrap();
            let extra = Obstacles::new(vec![pt]);
            assert_eq!(
                body_collides(&far, Some(&extra), &grasp, &g, m),
                expect,
                "{pt:?} (extra)"
            );
        }
    }

    /// Points on the faces of an axis-aligned box `[lo, hi]` every `step`
    /// that face `eye`, labelled `label`.
    fn box_faces(
        lo: Vector3<f64>,
        hi: Vector3<f64>,
        yaw: f64,
        eye: &Point3<f64>,
        step: f64,
        label: i32,
        out: &mut Vec<(Point3<f64>, i32)>,
    ) {
        let rot = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), yaw);
        let centre = (lo + hi) / 2.0;
        let half = (hi - lo) / 2.0;
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut n = Vector3::zeros();
                n[axis] = sign;
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let (nu, nv) = (
                    (2.0 * half[u] / step).round() as usize,
                    (2.0 * half[v] / step).round() as usize,
                );
                for i in 0..=nu {
                    for j in 0..=nv {
                        let mut q = Vector3::zeros();
                        q[axis] = sign * half[axis];
                        q[u] = -half[u] + 2.0 * half[u] * i as f64 / nu as f64;
                        q[v] = -half[v] + 2.0 * half[v] * j as f64 / nv as f64;
                        let p = Point3::from(centre + rot * q);
                        if (rot * n).dot(&(eye - p)) > 0.0 {
                            out.push((p, label));
                        }
                    }
                }
            }
        }
    }

    /// Points on the side and top of an upright cylinder facing `eye`.
    fn cylinder_faces(
        centre: Point3<f64>,
        radius: f64,
        height: f64,
        eye: &Point3<f64>,
        step: f64,
        label: i32,
        out: &mut Vec<(Point3<f64>, i32)>,
    ) {
        let na = (std::f64::consts::TAU * radius / step).round() as usize;
        let nh = (height / step).round() as usize;
        for i in 0..na {
            let t = std::f64::consts::TAU * i as f64 / na as f64;
            let n = Vector3::new(t.cos(), t.sin(), 0.0);
            for j in 0..=nh {
                let p = centre + n * radius + Vector3::z() * (height * j as f64 / nh as f64);
                if n.dot(&(eye - p)) > 0.0 {
                    out.push((p, label));
                }
            }
        }
        let nr = (radius / step).round() as usize;
        for i in -(nr as i64)..=nr as i64 {
            for j in -(nr as i64)..=nr as i64 {
                let (x, y) = (i as f64 * step, j as f64 * step);
                if x * x + y * y <= radius * radius {
                    out.push((centre + Vector3::new(x, y, height), label));
                }
            }
        }
    }

    /// A cloud as detection builds it: `raw` voxel-downsampled, normals
    /// facing `eye`, and with a table at z = 0 the hidden volume completed;
    /// also the indices of the points fit to be seeds (above the table).
    fn scene_cloud(
        raw: Vec<(Point3<f64>, i32)>,
        eye: Point3<f64>,
        with_plane: bool,
    ) -> (SurfaceCloud, Vec<usize>, Option<Plane>) {
        let pts: Vec<Point3<f64>> = raw.iter().map(|r| r.0).collect();
        let (centroids, first) = crate::voxel::voxel_downsample(&pts, 0.005).unwrap();
        let labels = first.iter().map(|&i| raw[i].1).collect();
        let mut cloud = SurfaceCloud::new(centroids, labels, 0.015, eye).unwrap();
        let plane = with_plane.then(table);
        if let Some(pl) = &plane {
            cloud.extrude(pl, 0.005, 0.005, 0.01, None);
        }
        let seeds = (0..cloud.num_observed())
            .filter(|&i| cloud.points[i].z > 0.005)
            .collect();
        (cloud, seeds, plane)
    }

    fn table_points(half: f64, step: f64, out: &mut Vec<(Point3<f64>, i32)>) {
        let n = (2.0 * half / step).round() as i64;
        for i in 0..=n {
            for j in 0..=n {
                let (x, y) = (-half + i as f64 * step, -half + j as f64 * step);
                out.push((Point3::new(x, y, 0.0), 0));
            }
        }
    }

    #[test]
    fn search_matches_the_exhaustive_reference() {
        // The optimised hand search (per-seed scratch, vectorised slab
        // test, fused slot compaction) must return exactly the hands of
        // the exhaustive one, bit for bit, in the same order: on a box, a
        // cylinder and touching objects of several labels on a table
        // (hidden volume, support plane, plane-limited depths, foreign
        // points, centres of mass), on a floating box without a plane, and
        // with other rotation, tilt and depth sets.
        let eye = Point3::new(-0.35, -0.25, 0.45);
        let step = 0.0025;
        let mut single_box = Vec::new();
        table_points(0.2, step, &mut single_box);
        box_faces(
            Vector3::new(-0.025, -0.035, 0.0),
            Vector3::new(0.025, 0.035, 0.1),
            0.35,
            &eye,
            step,
            1,
            &mut single_box,
        );
        let mut cylinder = Vec::new();
        table_points(0.2, step, &mut cylinder);
        cylinder_faces(Point3::origin(), 0.03, 0.12, &eye, step, 1, &mut cylinder);
        let mut clutter = Vec::new();
        table_points(0.2, step, &mut clutter);
        box_faces(
            Vector3::new(-0.02, -0.03, 0.0),
            Vector3::new(0.02, 0.03, 0.06),
            0.2,
            &eye,
            step,
            1,
            &mut clutter,
        );
        box_faces(
            Vector3::new(0.03, -0.02, 0.0),
            Vector3::new(0.07, 0.02, 0.012),
            -0.3,
            &eye,
            step,
            2,
            &mut clutter,
        );
        cylinder_faces(
            Point3::new(-0.01, 0.065, 0.0),
            0.025,
            0.09,
            &eye,
            step,
            3,
            &mut clutter,
        );
        let mut floating = Vec::new();
        box_faces(
            Vector3::new(-0.02, -0.02, 0.3),
            Vector3::new(0.02, 0.04, 0.33),
            0.0,
            &eye,
            step,
            -1,
            &mut floating,
        );
        let defaults = DetectOptions::default();
        let params = |plane: Option<Plane>, labelled: bool| SearchParams {
            gripper: defaults.gripper,
            depths: defaults.depths.clone(),
            num_rotations: defaults.num_rotations,
            approach_tilts: defaults.approach_tilts.clone(),
            voxel_size: defaults.voxel_size,
            friction: defaults.friction,
            approach_direction: (Point3::new(0.0, 0.0, 0.05) - eye).normalize(),
            plane,
            mass_centres: if labelled {
                vec![
                    (1, Point3::new(0.0, 0.0, 0.04)),
                    (3, Point3::new(-0.01, 0.065, 0.045)),
                ]
            } else {
                Vec::new()
            },
            torque_scale: defaults.torque_scale,
            single_object: labelled,
        };
        let mut total = 0;
        for (name, raw, with_plane, labelled) in [
            ("box", single_box, true, true),
            ("cylinder", cylinder, true, false),
            ("clutter", clutter, true, true),
            ("floating", floating, false, false),
        ] {
            let (cloud, seeds, plane) = scene_cloud(raw, eye, with_plane);
            let base = params(plane, labelled);
            let variants = [
                base.clone(),
                SearchParams {
                    num_rotations: 5,
                    approach_tilts: vec![0.3, 0.0],
                    depths: vec![0.045, 0.035, 0.02, 0.01],
                    ..base.clone()
                },
                SearchParams {
                    // A depth whose window starts where another ends.
                    depths: vec![0.04, 0.02, 0.01],
                    friction: 0.5,
                    ..base
                },
            ];
            let mut found = 0;
            for sp in &variants {
                for &s in seeds.iter().step_by(seeds.len().div_ceil(60)) {
                    let fast = hands_at_seed(&cloud, s, sp);
                    let exhaustive = reference::hands_at_seed(&cloud, s, sp);
                    assert_eq!(fast, exhaustive, "{name}, seed {s}");
                    found += fast.len();
                }
            }
            assert!(found > 0, "{name}: no hands to compare");
            total += found;
        }
        assert!(total > 200, "{total} hands compared");
    }

    #[test]
    fn hands_must_engage_the_pads_width_unless_the_plane_limits_them() {
        // A 5 x 7 x 10 cm box on a table, searched straight down from seeds
        // on its flat top (z = 10 cm; approach tilts 0). The pads are 2 cm
        // wide (`height`): a hand whose fingertips reach d below the top
        // engages d of the box between the fingers (a little more where the
        // seed's normal leans: the top face rises towards one finger).
        // Hand derivation: at d = 1.5 cm about 75 % of a square patch, so no
        // hand qualifies (the table, 10 cm down, does not limit the depth);
        // at d = 2.5 cm more than the square, so the seeds whose hand clears
        // get one, 2.5 cm deep. (At exactly 2 cm this synthetic cloud's
        // hidden columns stop the hands before the engagement test.)
        let g = GripperGeometry::default();
        assert_eq!(engagement_factor(&g, 0.0125), 0.625);
        assert_eq!(engagement_factor(&g, 0.03), 1.0);
        assert_eq!(engagement_factor(&g, -0.001), 0.0);
        let inside = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.004, 0.01, 0.0)];
        assert_eq!(pad_engagement(&inside, 0.02), 0.02);
        assert_eq!(pad_engagement(&[], 0.02), 0.0);

        let eye = Point3::new(-0.35, -0.25, 0.45);
        let step = 0.0025;
        let mut raw = Vec::new();
        table_points(0.2, step, &mut raw);
        box_faces(
            Vector3::new(-0.025, -0.035, 0.0),
            Vector3::new(0.025, 0.035, 0.1),
            0.0,
            &eye,
            step,
            1,
            &mut raw,
        );
        let (cloud, seeds, plane) = scene_cloud(raw, eye, true);
        let defaults = DetectOptions::default();
        let sp = |depths: Vec<f64>| SearchParams {
            gripper: g,
            depths,
            num_rotations: defaults.num_rotations,
            approach_tilts: vec![0.0],
            voxel_size: defaults.voxel_size,
            friction: defaults.friction,
            approach_direction: -Vector3::z(),
            plane,
            mass_centres: Vec::new(),
            torque_scale: 0.0,
            single_object: true,
        };
        let top: Vec<usize> = seeds
            .iter()
            .copied()
            .filter(|&s| {
                let q = cloud.points[s];
                (q.z - 0.1).abs() < 1e-9
                    && q.x.abs() < 0.015
                    && q.y.abs() < 0.025
                    && cloud.normal(s).z > 0.99
            })
            .collect();
        assert!(top.len() >= 10, "{} top seeds", top.len());
        let (shallow, full) = (sp(vec![0.015]), sp(vec![0.025]));
        let mut found = 0;
        for &s in &top {
            for h in hands_at_seed(&cloud, s, &shallow) {
                // Down from the top face (the seeds' normals lean up to 5
                // degrees: the normal radius reaches the sides): none at 1.5 cm.
                assert!(h.rotation.column(0).dot(&-Vector3::z()) < 0.99, "{h:?}");
            }
            for h in hands_at_seed(&cloud, s, &full) {
                if h.rotation.column(0).dot(&-Vector3::z()) > 0.99 {
                    assert_eq!(h.depth, 0.025);
                    found += 1;
                }
            }
        }
        assert!(found >= 10, "{found} hands down at 2.5 cm");
    }

    #[test]
    fn wall_approaches_match_the_reference() {
        // Touching objects of three labels on a table with its hidden
        // volume, and a 32 x 32 x 12 cm bin around them (walls of label 0):
        // at every 1/40 of the seeds, the orientations of the wall
        // approaches equal those of the former code (`main` at bec4c63),
        // and the hands searched in them and at the seed's normal equal
        // those of the exhaustive reference, bit for bit, in order.
        let eye = Point3::new(-0.35, -0.25, 0.45);
        let step = 0.0025;
        let mut raw = Vec::new();
        table_points(0.2, step, &mut raw);
        box_faces(
            Vector3::new(-0.02, -0.03, 0.0),
            Vector3::new(0.02, 0.03, 0.06),
            0.2,
            &eye,
            step,
            1,
            &mut raw,
        );
        box_faces(
            Vector3::new(0.03, -0.02, 0.0),
            Vector3::new(0.07, 0.02, 0.012),
            -0.3,
            &eye,
            step,
            2,
            &mut raw,
        );
        cylinder_faces(
            Point3::new(-0.01, 0.065, 0.0),
            0.025,
            0.09,
            &eye,
            step,
            3,
            &mut raw,
        );
        for (lo, hi) in [
            ([-0.17, -0.17, 0.0], [-0.16, 0.17, 0.12]),
            ([0.16, -0.17, 0.0], [0.17, 0.17, 0.12]),
            ([-0.16, -0.17, 0.0], [0.16, -0.16, 0.12]),
            ([-0.16, 0.16, 0.0], [0.16, 0.17, 0.12]),
        ] {
            box_faces(
                Vector3::from(lo),
                Vector3::from(hi),
                0.0,
                &eye,
                step,
                0,
                &mut raw,
            );
        }
        let (cloud, seeds, plane) = scene_cloud(raw, eye, true);
        let defaults = DetectOptions::default();
        let sp = SearchParams {
            gripper: defaults.gripper,
            depths: defaults.depths.clone(),
            num_rotations: defaults.num_rotations,
            approach_tilts: defaults.approach_tilts.clone(),
            voxel_size: defaults.voxel_size,
            friction: defaults.friction,
            approach_direction: -Vector3::z(),
            plane,
            mass_centres: Vec::new(),
            torque_scale: defaults.torque_scale,
            single_object: true,
        };
        let far = Obstacles::new(vec![Point3::new(0.0, 0.3, 0.05)]);
        let (mut with_walls, mut hands) = (0, 0);
        for &s in seeds.iter().step_by(seeds.len().div_ceil(40)) {
            for extra in [None, Some(&far)] {
                let new = crate::approaches::clear_approaches(&cloud, extra, s, &sp);
                let old = crate::approaches::reference::clear_approaches(&cloud, extra, s, &sp);
                assert_eq!(new.len(), old.len(), "seed {s}");
                for (a, b) in new.iter().zip(&old) {
                    assert_eq!(
                        (a.approach, a.closing, &a.depths),
                        (b.approach, b.closing, &b.depths),
                        "seed {s}"
                    );
                }
                with_walls += usize::from(!new.is_empty());
                let fast = crate::approaches::hands_with_clear_approaches(&cloud, extra, s, &sp);
                let mut exhaustive = reference::hands_at_seed(&cloud, s, &sp);
                for ap in old {
                    let one = SearchParams {
                        depths: ap.depths,
                        num_rotations: 1,
                        approach_tilts: vec![0.0],
                        ..sp.clone()
                    };
                    exhaustive.extend(reference::hands_in_frame(
                        &cloud,
                        s,
                        ap.approach,
                        ap.closing,
                        &one,
                    ));
                }
                assert_eq!(fast, exhaustive, "seed {s}");
                hands += fast.len();
            }
        }
        assert!(with_walls > 5, "{with_walls} seeds with wall approaches");
        assert!(hands > 20, "{hands} hands compared");
    }

    #[test]
    fn foreign_labels() {
        assert!(is_foreign(1, 2));
        assert!(is_foreign(1, 0));
        assert!(!is_foreign(1, 1));
        assert!(!is_foreign(1, -1));
        assert!(!is_foreign(-1, 2));
        assert!(!is_foreign(0, 2));
    }
}
