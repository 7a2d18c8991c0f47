//! The detection pipeline: cloud -> voxels -> normals -> hands -> scores ->
//! non-maximum suppression -> sorted grasp group.

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use crate::approaches::hands_with_clear_approaches;
use crate::backproject::{Intrinsics, Workspace};
use crate::candidates::{Obstacles, SearchParams, body_collides, body_sweep_box, hands_at_seed};
use crate::error::{GraspError, Result, positive};
use crate::grasp::{Grasp, GraspGroup};
use crate::gripper::{GripperGeometry, body_margin};
use crate::mass::mass_centres;
use crate::nms::nms_filtered;
use crate::normals::SurfaceCloud;
use crate::plane::find_support_plane;
use crate::seeds::spread_seeds;
use crate::voxel::{voxel_downsample, voxel_downsample_depth};

/// Options of [`detect`]. Frame-dependent options (`viewpoint`,
/// `approach_direction`) are in the cloud's frame; the defaults suit a cloud
/// in the camera's OpenCV frame.
#[derive(Debug, Clone)]
pub struct DetectOptions {
    /// Gripper geometry (default: Panda hand).
    pub gripper: GripperGeometry,
    /// Voxel size for downsampling, metres (default 0.005).
    pub voxel_size: f64,
    /// Neighbourhood radius for normals, metres (default 0.015).
    pub normal_radius: f64,
    /// Number of seed points sampled (default 128).
    pub num_seeds: usize,
    /// Seeds are kept at least this far apart while possible, metres
    /// (default 0: a plain random sample).
    pub seed_spacing: f64,
    /// Closing-axis rotations over a half turn (default 8).
    pub num_rotations: usize,
    /// Approach tilts about the closing axis, radians (default 0, ±0.4).
    pub approach_tilts: Vec<f64>,
    /// Fingertip depths beyond the surface to try, deepest first, metres
    /// (default 0.04, 0.03, 0.02: [`DEPTH_FRACTIONS`] of the Panda's 5 cm
    /// fingers). The depth policy, the same for every caller (tables, bins,
    /// the pipeline, the grasp service): per orientation the deepest of
    /// these whose hand (fingers, palm, approach corridor, housing) is clear
    /// of the cloud and above the support plane, and whose pads overlap the
    /// object between the fingers by at least the pad's width
    /// (`gripper.height`; see [`crate::candidates::engagement_factor`]);
    /// where the support plane (a table, a bin's floor) stops every one of
    /// them, the deepest depth the plane allows, ranked below by the
    /// fraction of the pad's width it engages. A depth shallower than the
    /// pad's width yields a hand only where the object rises above the seed
    /// between the fingers by the difference.
    pub depths: Vec<f64>,
    /// Friction coefficient the grasp must close at (default 1.0).
    pub friction: f64,
    /// Camera position, for orienting normals (default: origin).
    pub viewpoint: Point3<f64>,
    /// Preferred approach direction (default +z: along the camera's view).
    pub approach_direction: Vector3<f64>,
    /// NMS translation threshold, metres (default 0.03).
    pub nms_translation: f64,
    /// NMS rotation threshold, radians (default 30°).
    pub nms_rotation: f64,
    /// Keep at most this many grasps after NMS (0: all).
    pub max_grasps: usize,
    /// Seed of the random seed-point and plane sampling.
    pub rng_seed: u64,
    /// Find the dominant plane (a table) by RANSAC: hands may not dip
    /// below it, its points are not seeds, and the hidden volume under
    /// every point above it counts as solid (objects rest on it without
    /// hidden overhangs; see [`SurfaceCloud::extrude`]) (default true).
    pub support_plane: bool,
    /// Inlier distance of the support plane, metres (default 0.005).
    pub plane_threshold: f64,
    /// Prefer grasps whose axis passes near the object's estimated centre
    /// of mass ([`crate::mass`]; labelled points only): the score is
    /// multiplied by 1 / (1 + (arm / torque_scale)²) for the lever arm of
    /// the weight about the grasp axis, metres (default 0.01; 0 disables).
    pub torque_scale: f64,
    /// Check the hand's body (the housing behind the fingers, swept back by
    /// the approach distance) against every point of the cloud, not only
    /// against the support plane: in clutter and bins the housing must stay
    /// out of the neighbours and the walls (default true; see
    /// [`crate::candidates::body_collides`]).
    pub body_collision: bool,
    /// Where the housing of a hand along `approach_direction` would meet
    /// another object (a bin wall, a neighbour; any point without labels),
    /// also search hands whose approach is chosen to keep the housing clear
    /// of them: along `approach_direction` or tilted away from the
    /// obstacles, with the closing axis turned to fit (see
    /// [`crate::approaches`]; default true). Out in the open nothing changes.
    pub wall_approaches: bool,
    /// With labels, reject hands whose closing region holds another
    /// labelled object's points (see [`SearchParams::single_object`];
    /// default true).
    pub single_object: bool,
    /// With an RGB-D frame and a segmentation mask, reject grasps whose
    /// fingers or palm go into space hidden behind another object (see
    /// `hidden_by_another_object`; default true). Has no effect on
    /// [`detect`] (no image) or without a mask.
    pub occlusion: bool,
}

impl Default for DetectOptions {
    fn default() -> Self {
        Self {
            gripper: GripperGeometry::default(),
            voxel_size: 0.005,
            normal_radius: 0.015,
            num_seeds: 128,
            seed_spacing: 0.0,
            num_rotations: 8,
            approach_tilts: vec![0.0, -0.4, 0.4],
            depths: vec![0.04, 0.03, 0.02],
            friction: 1.0,
            viewpoint: Point3::origin(),
            approach_direction: Vector3::z(),
            nms_translation: 0.03,
            nms_rotation: 30f64.to_radians(),
            max_grasps: 0,
            rng_seed: 0,
            support_plane: true,
            plane_threshold: 0.005,
            torque_scale: 0.01,
            body_collision: true,
            wall_approaches: true,
            single_object: true,
            occlusion: true,
        }
    }
}

/// The fingertip depths [`DetectOptions::for_gripper`] searches, as
/// fractions of the gripper's finger length (`Fingers::depth`): the Panda
/// hand's default depths 40, 30 and 20 mm of its 50 mm fingers. The
/// shallowest is at least the pad's width for the bundled grippers (Panda
/// 20 mm of 20 mm, 2F-85 15 mm of 22 mm: its hands at 15 mm need the object
/// to rise 7 mm above the seed between the fingers, see
/// [`DetectOptions::depths`]); shallower hands come from the support
/// plane's limit only. 0.3 (15 mm on the Panda) was dropped: those hands
/// engage less than the pad's width and were the marginal grasps on tables
/// and in bins (BENCHMARKS.md, table18e, slip18h, depth18i).
pub const DEPTH_FRACTIONS: [f64; 3] = [0.8, 0.6, 0.4];

impl DetectOptions {
    /// These options for `gripper`: its hand geometry
    /// ([`GripperGeometry::from_gripper`]: opening, finger and palm sizes;
    /// this `approach_distance` and `clearance` kept) and the searched
    /// `depths` scaled to its pads ([`DEPTH_FRACTIONS`] of the pad length),
    /// every other option unchanged.
    pub fn for_gripper(mut self, gripper: &ferrobot_model::Gripper) -> Self {
        let hand = GripperGeometry::from_gripper(gripper);
        self.gripper = GripperGeometry {
            approach_distance: self.gripper.approach_distance,
            clearance: self.gripper.clearance,
            ..hand
        };
        self.depths = DEPTH_FRACTIONS
            .iter()
            .map(|f| f * hand.finger_depth)
            .collect();
        self
    }

    /// Checks every option.
    pub fn validate(&self) -> Result<()> {
        self.gripper.validate()?;
        positive("voxel_size", self.voxel_size)?;
        positive("normal_radius", self.normal_radius)?;
        positive("friction", self.friction)?;
        if self.num_rotations == 0 {
            return Err(GraspError::InvalidArgument(
                "num_rotations must be >= 1".into(),
            ));
        }
        if self.approach_tilts.is_empty() || self.depths.is_empty() {
            return Err(GraspError::InvalidArgument(
                "approach_tilts and depths must not be empty".into(),
            ));
        }
        for &t in &self.approach_tilts {
            if !(t.is_finite() && t.abs() < std::f64::consts::FRAC_PI_2) {
                return Err(GraspError::InvalidArgument(format!(
                    "approach tilt {t} must be finite and within (-pi/2, pi/2)"
                )));
            }
        }
        for &d in &self.depths {
            if !(d.is_finite() && d >= 0.0 && d < self.gripper.finger_depth) {
                return Err(GraspError::InvalidArgument(format!(
                    "depth {d} must be within [0, finger_depth = {})",
                    self.gripper.finger_depth
                )));
            }
        }
        positive("nms_translation", self.nms_translation)?;
        positive("plane_threshold", self.plane_threshold)?;
        if !(self.torque_scale.is_finite() && self.torque_scale >= 0.0) {
            return Err(GraspError::InvalidArgument(format!(
                "torque_scale must be finite and >= 0, got {}",
                self.torque_scale
            )));
        }
        if !(self.seed_spacing.is_finite() && self.seed_spacing >= 0.0) {
            return Err(GraspError::InvalidArgument(format!(
                "seed_spacing must be finite and >= 0, got {}",
                self.seed_spacing
            )));
        }
        positive("nms_rotation", self.nms_rotation)?;
        if !self.viewpoint.coords.iter().all(|v| v.is_finite()) {
            return Err(GraspError::NonFinite("viewpoint must be finite".into()));
        }
        if !(self.approach_direction.iter().all(|v| v.is_finite())
            && self.approach_direction.norm() > 1e-9)
        {
            return Err(GraspError::InvalidArgument(
                "approach_direction must be a finite non-zero vector".into(),
            ));
        }
        Ok(())
    }
}

/// Detects grasps in `points`. All points are obstacles for the gripper;
/// seeds are drawn from the points whose `seedable` flag is set (all when
/// None). `labels` gives each point's object id (-1 when None); a grasp
/// takes its seed's label. An empty cloud gives an empty group.
pub fn detect(
    points: &[Point3<f64>],
    labels: Option<&[i32]>,
    seedable: Option<&[bool]>,
    opts: &DetectOptions,
) -> Result<GraspGroup> {
    detect_with(points, labels, seedable, opts, &|_| true)
}

/// [`detect`] with an extra test each grasp must pass to be kept (run
/// lazily during non-maximum suppression, like the hand body's check).
fn detect_with(
    points: &[Point3<f64>],
    labels: Option<&[i32]>,
    seedable: Option<&[bool]>,
    opts: &DetectOptions,
    accept: &dyn Fn(&Grasp) -> bool,
) -> Result<GraspGroup> {
    opts.validate()?;
    for (what, len) in [
        ("labels", labels.map(|l| l.len())),
        ("seed mask", seedable.map(|s| s.len())),
    ] {
        if let Some(len) = len
            && len != points.len()
        {
            return Err(GraspError::Shape(format!(
                "{what}: {len} values for {} points",
                points.len()
            )));
        }
    }
    if let Some(i) = points
        .iter()
        .position(|p| !p.coords.iter().all(|c| c.is_finite()))
    {
        return Err(GraspError::NonFinite(format!(
            "points: point {i} is not finite"
        )));
    }
    if points.is_empty() {
        return Ok(GraspGroup::default());
    }
    let (centroids, first) = voxel_downsample(points, opts.voxel_size)?;
    let ds_labels: Vec<i32> = first.iter().map(|&i| labels.map_or(-1, |l| l[i])).collect();
    let ds_seedable: Vec<bool> = first
        .iter()
        .map(|&i| seedable.is_none_or(|s| s[i]))
        .collect();
    detect_voxels(&centroids, &ds_labels, &ds_seedable, opts, accept)
}

/// Detection on a voxel-downsampled cloud (`opts` checked): the voxel
/// centroids, each voxel's label and whether it may be a seed.
fn detect_voxels(
    centroids: &[Point3<f64>],
    ds_labels: &[i32],
    ds_seedable: &[bool],
    opts: &DetectOptions,
    accept: &dyn Fn(&Grasp) -> bool,
) -> Result<GraspGroup> {
    if centroids.is_empty() {
        return Ok(GraspGroup::default());
    }
    let plane = if opts.support_plane {
        find_support_plane(
            centroids,
            opts.plane_threshold,
            0.2,
            200,
            &opts.viewpoint,
            opts.rng_seed,
        )
    } else {
        None
    };
    let mass_centres = if opts.torque_scale > 0.0 {
        mass_centres(
            centroids,
            ds_labels,
            plane.as_ref(),
            opts.plane_threshold,
            opts.voxel_size,
        )
    } else {
        Vec::new()
    };
    let is_candidate = |i: usize| {
        ds_seedable[i] && plane.is_none_or(|pl| pl.distance(&centroids[i]) > opts.plane_threshold)
    };
    // Hands only ever look at points within the gripper's reach of a seed
    // (and normals within normal_radius of it): crop the cloud to the
    // candidates' bounding box grown by that much before building the
    // kd-trees and the hidden volume. Exact: nothing outside is ever read
    // (a point whose hidden column down to the plane crosses the box stays).
    let max_depth = opts.depths.iter().copied().fold(0.0, f64::max);
    let grow = opts.gripper.reach(max_depth).max(opts.normal_radius) + opts.voxel_size;
    // The housing reaches further: the body sweep of a hand at the
    // shallowest depth, from its translation (up to half the widest
    // opening from the seed). Points between the two crops are kept apart
    // as obstacles for the housing only (observed points above the plane;
    // the hidden volume is completed inside the hands' crop only).
    let body_grow = {
        let mut dmin = opts.depths.iter().copied().fold(f64::INFINITY, f64::min);
        if opts.support_plane {
            dmin = dmin.min(crate::candidates::MIN_PLANE_DEPTH);
        }
        let (blo, bhi) = body_sweep_box(&opts.gripper, dmin, body_margin(opts.voxel_size));
        let far = blo.abs().sup(&bhi.abs());
        far.norm() + opts.gripper.max_width / 2.0 + opts.voxel_size
    };
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for (i, p) in centroids.iter().enumerate() {
        if is_candidate(i) {
            lo = lo.inf(&p.coords);
            hi = hi.sup(&p.coords);
        }
    }
    let (blo, bhi) = (lo.add_scalar(-body_grow), hi.add_scalar(body_grow));
    let (lo, hi) = (lo.add_scalar(-grow), hi.add_scalar(grow));
    let mut far_obstacles = Vec::new();
    let keep: Vec<usize> = (0..centroids.len())
        .filter(|&i| {
            let c = centroids[i].coords;
            let foot = match &plane {
                Some(pl) => c - pl.normal * pl.distance(&centroids[i]).max(0.0),
                None => c,
            };
            let near = segment_meets_box(&c, &foot, &lo, &hi);
            if !near
                && opts.body_collision
                && (0..3).all(|k| c[k] >= blo[k] && c[k] <= bhi[k])
                && plane
                    .as_ref()
                    .is_none_or(|pl| pl.distance(&centroids[i]) > opts.plane_threshold)
            {
                far_obstacles.push(centroids[i]);
            }
            near
        })
        .collect();
    let far_obstacles = Obstacles::new(far_obstacles);
    let candidates: Vec<usize> = keep
        .iter()
        .enumerate()
        .filter(|&(_, &i)| is_candidate(i))
        .map(|(k, _)| k)
        .collect();
    let kept_points: Vec<Point3<f64>> = keep.iter().map(|&i| centroids[i]).collect();
    let kept_labels: Vec<i32> = keep.iter().map(|&i| ds_labels[i]).collect();
    let mut cloud =
        SurfaceCloud::new(kept_points, kept_labels, opts.normal_radius, opts.viewpoint)?;
    if let Some(pl) = &plane {
        cloud.extrude(
            pl,
            opts.plane_threshold,
            opts.voxel_size,
            2.0 * opts.voxel_size,
            Some((lo, hi)),
        );
    }
    let seeds = spread_seeds(
        &cloud.points,
        &candidates,
        opts.num_seeds,
        opts.seed_spacing,
        opts.rng_seed,
    );
    let params = SearchParams {
        gripper: opts.gripper,
        depths: {
            let mut d = opts.depths.clone();
            d.sort_by(|a, b| b.total_cmp(a));
            d
        },
        num_rotations: opts.num_rotations,
        approach_tilts: opts.approach_tilts.clone(),
        voxel_size: opts.voxel_size,
        friction: opts.friction,
        approach_direction: opts.approach_direction.normalize(),
        plane,
        mass_centres,
        torque_scale: opts.torque_scale,
        single_object: opts.single_object,
    };
    let grasps: Vec<_> = seeds
        .par_iter()
        .flat_map_iter(|&s| {
            if opts.wall_approaches {
                hands_with_clear_approaches(&cloud, Some(&far_obstacles), s, &params)
            } else {
                hands_at_seed(&cloud, s, &params)
            }
        })
        .collect();
    let margin = body_margin(opts.voxel_size);
    let kept = nms_filtered(&grasps, opts.nms_translation, opts.nms_rotation, |i| {
        (!opts.body_collision
            || !body_collides(
                &cloud,
                Some(&far_obstacles),
                &grasps[i],
                &opts.gripper,
                margin,
            ))
            && accept(&grasps[i])
    });
    let mut group = GraspGroup {
        grasps: kept.into_iter().map(|i| grasps[i]).collect(),
    };
    group.sort_by_score();
    if opts.max_grasps > 0 {
        group.grasps.truncate(opts.max_grasps);
    }
    Ok(group)
}

/// Whether the segment from `a` to `b` meets the box `[lo, hi]` (slabs).
fn segment_meets_box(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    lo: &Vector3<f64>,
    hi: &Vector3<f64>,
) -> bool {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..3 {
        let d = b[k] - a[k];
        if d.abs() < 1e-15 {
            if a[k] < lo[k] || a[k] > hi[k] {
                return false;
            }
            continue;
        }
        let (u, v) = ((lo[k] - a[k]) / d, (hi[k] - a[k]) / d);
        t0 = t0.max(u.min(v));
        t1 = t1.min(u.max(v));
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// Detects grasps in a depth image: back-projects it (see
/// [`crate::backproject()`]), crops to `workspace`, and seeds on the masked
/// pixels. The same grasps as [`detect`] on the back-projected cloud (with
/// each point's label and seed flag from its pixel), but the pixels go
/// straight into the voxel grid ([`voxel_downsample_depth`]): the full
/// cloud is never stored.
/// `mask` (one label per pixel, row-major) marks objects with non-zero
/// labels, which become the grasps' object ids; with `object_id` only that
/// label is seeded. Without a mask every point is seeded and ids are -1.
/// All back-projected points are obstacles.
#[allow(clippy::too_many_arguments)]
pub fn detect_rgbd(
    depth: &[f64],
    intrinsics: &Intrinsics,
    mask: Option<&[i32]>,
    object_id: Option<i32>,
    workspace: Option<&Workspace>,
    opts: &DetectOptions,
) -> Result<GraspGroup> {
    let (height, width) = (intrinsics.height, intrinsics.width);
    if let Some(m) = mask
        && m.len() != height * width
    {
        return Err(GraspError::Shape(format!(
            "mask: {} values for a {height}x{width} depth image",
            m.len()
        )));
    }
    if object_id.is_some() && mask.is_none() {
        return Err(GraspError::InvalidArgument(
            "object_id needs a segmentation mask".into(),
        ));
    }
    // The same errors, in the same order, as back-projecting the image and
    // then detecting on its cloud: the workspace, the image, then options.
    if let Err(e) = opts.validate() {
        if let Some(w) = workspace {
            w.validate()?;
        }
        ferrobot_camera::for_each_point(depth, intrinsics, |_, _, _| {})?;
        return Err(e);
    }
    // The voxel grid straight from the pixels (the ~300k-point cloud is never
    // stored); each voxel takes the label of its first pixel, as the cloud's
    // first point in the voxel gave it.
    let (centroids, first) = voxel_downsample_depth(depth, intrinsics, workspace, opts.voxel_size)?;
    match mask {
        None => {
            let n = centroids.len();
            detect_voxels(&centroids, &vec![-1; n], &vec![true; n], opts, &|_| true)
        }
        Some(m) => {
            let labels: Vec<i32> = first.iter().map(|&i| m[i]).collect();
            let seedable: Vec<bool> = labels
                .iter()
                .map(|&l| l != 0 && object_id.is_none_or(|o| o == l))
                .collect();
            let margin = body_margin(opts.voxel_size);
            let hidden = |g: &Grasp| -> bool {
                !opts.occlusion
                    || !hidden_by_another_object(g, &opts.gripper, depth, m, intrinsics, margin)
            };
            detect_voxels(&centroids, &labels, &seedable, opts, &hidden)
        }
    }
}

/// Samples per hand box edge for [`hidden_by_another_object`].
const OCCLUSION_SAMPLES: usize = 4;

/// Whether some part of the fingers or the palm of `g` (camera frame) lies
/// in space the camera cannot see because another object is in front of
/// it: a sample point of the hand's boxes projects onto a pixel whose
/// observed depth is more than `margin` nearer the camera and whose label
/// differs from the grasp's object. Such space may hold that object's
/// unseen part (or the grasp's own object, cut off by it): the hidden
/// volume of the grasp's own object is completed from what was seen of it,
/// but what a neighbour hides is unknown. Pixels without depth and samples
/// outside the image or behind the camera count as free.
fn hidden_by_another_object(
    g: &Grasp,
    gripper: &GripperGeometry,
    depth: &[f64],
    mask: &[i32],
    k: &Intrinsics,
    margin: f64,
) -> bool {
    let n = OCCLUSION_SAMPLES;
    let t = |i: usize| i as f64 / (n - 1) as f64;
    gripper.boxes(g.depth, g.width, 0.0).iter().any(|(lo, hi)| {
        (0..n * n * n).any(|s| {
            let local = Vector3::new(
                lo.x + (hi.x - lo.x) * t(s % n),
                lo.y + (hi.y - lo.y) * t((s / n) % n),
                lo.z + (hi.z - lo.z) * t(s / (n * n)),
            );
            let p = g.translation + g.rotation * local;
            if p.z <= 1e-6 {
                return false;
            }
            let u = (k.fx * p.x / p.z + k.cx).round();
            let v = (k.fy * p.y / p.z + k.cy).round();
            if u < 0.0 || v < 0.0 || u >= k.width as f64 || v >= k.height as f64 {
                return false;
            }
            let i = v as usize * k.width + u as usize;
            let z = depth[i] / k.depth_scale;
            z.is_finite() && z > 0.0 && p.z > z + margin && mask[i] != g.object_id
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backproject::backproject;

    /// A ray-cast frame in the camera's frame: a table (plane facing the
    /// camera, 0.6 m away, seen obliquely) with spheres of labels 1-3
    /// resting on it (two touching), a strip of missing depth (0) and one of
    /// rays that hit nothing (+inf); labels 0 on the table. The spheres
    /// stand on the table where the image centre's ray meets it.
    fn frame(width: usize, height: usize, f: f64) -> (Vec<f64>, Vec<i32>, Intrinsics) {
        let k = Intrinsics::new(
            width,
            height,
            f,
            f,
            width as f64 / 2.0 - 0.5,
            height as f64 / 2.0 - 0.5,
        )
        .unwrap();
        let n = Vector3::new(0.0, -0.6, -0.8);
        let foot = |x: f64, y: f64| {
            // A point on the table under (x, y) of the image centre's ray.
            let p = Vector3::new(x, y, 0.75);
            p - n * (n.dot(&p) + 0.6)
        };
        let spheres = [
            (foot(0.0, 0.0) + n * 0.03, 0.03, 1),
            (foot(0.06, 0.0) + n * 0.03, 0.03, 2),
            (foot(-0.09, 0.05) + n * 0.025, 0.025, 3),
        ];
        let (mut depth, mut mask) = (vec![0.0; width * height], vec![0; width * height]);
        for v in 0..height {
            for u in 0..width {
                let i = v * width + u;
                if u < 4 {
                    continue; // missing depth (0)
                }
                let d = Vector3::new((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy, 1.0);
                let mut best = (f64::INFINITY, 0);
                if n.dot(&d) < 0.0 && v + 6 < height {
                    best = (-0.6 / n.dot(&d), 0);
                }
                for (c, r, label) in spheres {
                    // |t d - c|² = r²: the nearer root.
                    let (a, b, cc) = (d.dot(&d), -2.0 * d.dot(&c), c.dot(&c) - r * r);
                    let disc = b * b - 4.0 * a * cc;
                    if disc >= 0.0 {
                        let t = (-b - disc.sqrt()) / (2.0 * a);
                        if t > 0.0 && t < best.0 {
                            best = (t, label);
                        }
                    }
                }
                depth[i] = best.0; // +inf where the ray hits nothing
                mask[i] = best.1;
            }
        }
        (depth, mask, k)
    }

    /// What `detect_rgbd` did before the voxel grid was built from the
    /// pixels: back-project the whole cloud, label every point by its
    /// pixel, and detect on the cloud.
    fn reference(
        depth: &[f64],
        k: &Intrinsics,
        mask: Option<&[i32]>,
        object_id: Option<i32>,
        workspace: Option<&Workspace>,
        opts: &DetectOptions,
    ) -> Result<GraspGroup> {
        let bp = backproject(depth, k, workspace)?;
        match mask {
            None => detect(&bp.points, None, None, opts),
            Some(m) => {
                let labels: Vec<i32> = bp.pixels.iter().map(|&(r, c)| m[r * k.width + c]).collect();
                let seedable: Vec<bool> = labels
                    .iter()
                    .map(|&l| l != 0 && object_id.is_none_or(|o| o == l))
                    .collect();
                let margin = body_margin(opts.voxel_size);
                let hidden = |g: &Grasp| -> bool {
                    !opts.occlusion
                        || !hidden_by_another_object(g, &opts.gripper, depth, m, k, margin)
                };
                detect_with(&bp.points, Some(&labels), Some(&seedable), opts, &hidden)
            }
        }
    }

    #[test]
    fn rgbd_detection_equals_the_back_projected_cloud_path() {
        let (depth, mask, k) = frame(320, 240, 300.0);
        let opts = DetectOptions {
            num_seeds: 48,
            ..DetectOptions::default()
        };
        let ws = Workspace([-0.12, 0.2, -0.3, 0.3, 0.0, 0.75]);
        let mut total = 0;
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for (m, oid, w) in [
                (Some(&mask[..]), Some(1), None),
                (Some(&mask[..]), None, None),
                (Some(&mask[..]), Some(3), Some(&ws)),
                (None, None, None),
            ] {
                let got = pool
                    .install(|| detect_rgbd(&depth, &k, m, oid, w, &opts))
                    .unwrap();
                let want = pool
                    .install(|| reference(&depth, &k, m, oid, w, &opts))
                    .unwrap();
                // Bit for bit: the same grasps, scores and order.
                assert_eq!(
                    got,
                    want,
                    "mask {} object {oid:?} workspace {w:?}",
                    m.is_some()
                );
                total += got.len();
            }
        }
        assert!(total > 20, "{total} grasps: the frame should give grasps");
    }

    #[test]
    fn rgbd_errors_are_those_of_the_cloud_path() {
        let (mut depth, mask, k) = frame(64, 48, 60.0);
        let bad = DetectOptions {
            voxel_size: -1.0,
            ..DetectOptions::default()
        };
        let ok = DetectOptions::default();
        let both = |d: &[f64], o: &DetectOptions, w: Option<&Workspace>| {
            (
                detect_rgbd(d, &k, Some(&mask), None, w, o),
                reference(d, &k, Some(&mask), None, w, o),
            )
        };
        let (a, b) = both(&depth, &bad, None);
        assert!(matches!(a, Err(GraspError::InvalidArgument(_))));
        assert_eq!(a, b);
        let flipped = Workspace([1.0, 0.0, -1.0, 1.0, 0.0, 1.0]);
        let (a, b) = both(&depth, &bad, Some(&flipped));
        assert_eq!(a, b);
        assert!(matches!(a, Err(GraspError::InvalidArgument(m)) if m.contains("xmin")));
        depth[100] = f64::NAN;
        for o in [&bad, &ok] {
            let (a, b) = both(&depth, o, None);
            assert!(matches!(&a, Err(GraspError::NonFinite(m)) if m.contains("row 1, column 36")));
            assert_eq!(a, b);
        }
        // A point the voxel grid cannot hold: named by its pixel.
        depth[100] = 1e300;
        let a = detect_rgbd(&depth, &k, Some(&mask), None, None, &ok);
        assert!(
            matches!(&a, Err(GraspError::InvalidArgument(m)) if m.contains("row 1, column 36")),
            "{a:?}"
        );
        // Nothing within the workspace: no grasps.
        let far = Workspace([5.0, 6.0, 5.0, 6.0, 5.0, 6.0]);
        depth[100] = 0.5;
        assert!(
            detect_rgbd(&depth, &k, Some(&mask), None, Some(&far), &ok)
                .unwrap()
                .is_empty()
        );
    }
}
