//! Automatic, conservative sphere models of robot links.
//!
//! [`spherize_link`] turns a link's collision geometry (boxes, spheres,
//! cylinders, capsules and triangle meshes, closed or open, freely mixed)
//! into a few spheres whose union holds the link's whole collision surface:
//! every surface point lies within [`SpherizeOptions::tolerance`] of a
//! sphere. Within that constraint the spheres stick out of the geometry as
//! little as the sphere count allows. [`spherize_robot`] does every link of
//! a model, splitting a total sphere budget between the links so that the
//! worst protrusion over the robot is as small as it can make it.
//! [`evaluate_link`] measures any sphere set (e.g. a hand-made one) the same
//! way.
//!
//! # Algorithm
//!
//! 1. *Surface lattices with a known covering radius δ* (every surface point
//!    lies within δ of a sample): on triangles the cheaper of a similar
//!    sub-triangle lattice (δ = longest sub-edge / √3) and a projected square
//!    grid, parametric grids on box faces, cylinder sides and caps, spheres
//!    and capsule caps. Samples lying deeper than δ inside another shape of
//!    the link are not on the link's surface and are dropped.
//! 2. *Candidate centres*: a grid of points inside the geometry plus a subset
//!    of surface points (for open or thin geometry). A centre `c` has depth
//!    `d(c)` (distance to the surface inside the geometry, negative outside);
//!    a sphere at `c` of radius `d(c) + α` sticks out by at most `α`.
//! 3. *Greedy set cover* of coarse samples by the candidate spheres of growth
//!    `α`, with a binary search on `α` for the smallest growth whose cover
//!    fits the sphere count.
//! 4. *Refinement*: Lloyd-style rounds assigning every sample to the sphere
//!    needing the least growth to hold it and moving each centre (pattern
//!    search) to minimise its `radius − depth`, the bound on how far it
//!    sticks out; while the cover has fewer spheres than allowed, the worst
//!    sphere is split in two.
//! 5. *Conservative radii* from a dense lattice whose covering radius is
//!    below the tolerance: each sphere grows to hold the dense samples
//!    assigned to it, then shrinks to the smallest radius still holding the
//!    samples no other sphere holds; spheres holding none alone, or whose
//!    samples the others take over by growing at most a quarter of the
//!    tolerance, are dropped. As every surface point is within the lattice's
//!    covering radius of a held sample, the continuous surface is covered
//!    within the tolerance, not only the samples.
//! 6. *Counts*: without a budget, the bounded model below. With a robot budget,
//!    a common growth bound gives a first split; each link is then solved
//!    for counts around it and the split minimising the worst measured
//!    protrusion is chosen (leftover spheres go to the links sticking out
//!    most).
//!
//! *Bounded automatic model* (no budget, the default every checker and
//! planner uses): every sphere sticks out of the geometry by at most
//! [`AUTO_MAX_PROTRUSION`] (1 cm) by construction. A sphere centred at `c`,
//! whose depth `d(c)` (a lower bound of the distance from `c` to the outside
//! of the geometry) is known, with radius at most `d(c) + α`, lies within `α`
//! of the ball of radius `d(c)` around `c`, which the geometry holds. So the
//! candidate centres (a grid inside the geometry about `α / 2` apart, plus
//! surface points) get radius `d + α`, a greedy set cover of up to
//! 12,000 surface samples picks among them, the samples of the dense lattice
//! left uncovered get more spheres (greedily), spheres whose dense samples
//! others hold are dropped, and every sphere shrinks to the dense samples
//! only it holds. Coverage is as in step 5. More spheres than the step-3
//! model (about 3-4 times on primitive robots, whose sharp edges need many),
//! in exchange for the bound. Should a link need more than 1,024 spheres
//! (or `max_per_link`), it falls back to the count search with the same
//! target, which does not guarantee it.
//!
//! Links whose collision geometry is already spheres keep them as they are
//! (see [`given_spheres`]).
//!
//! [`spherize_robot`] caches its results ([`crate::spherize_cache`]): a change
//! to the output for the same input must bump
//! [`crate::spherize_cache::CACHE_VERSION`].
//!
//! Closed mesh pieces (every edge shared by two consistently wound
//! triangles) use parry's pseudo-normals for inside tests. Other meshes
//! (T-junctions, cracks, overlapping pieces) get a voxel flood fill that
//! seals cracks narrower than about two voxels (1/64 of the mesh size);
//! truly open surfaces have no inside and are covered as sheets.
//!
//! The reports measure coverage on independent random surface points, and
//! protrusion on Fibonacci points of the sphere union's boundary, the
//! maximum refined by a local ascent.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap, HashSet};
use std::f64::consts::{PI, SQRT_2};
use std::sync::Mutex;

use ferrobot_model::{Geometry, RobotModel, Shape};
use nalgebra::{Isometry3, Point3, Vector3};
use parry3d::math::Vector as PVec;
use parry3d::query::PointQuery;
use parry3d::shape::{TriMesh as ParryMesh, TriMeshFlags};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

use crate::error::{CollisionError, Result};
use crate::sphere::Sphere;

/// The largest protrusion (m) of the automatic model: without a budget,
/// every sphere sticks out of its link's geometry by at most this (see the
/// bounded model in the [module documentation](self)).
pub const AUTO_MAX_PROTRUSION: f64 = 0.01;

/// Most fitting samples per link (the spacing grows beyond).
const MAX_FIT_SAMPLES: usize = 20_000;
/// Most samples of the set-cover search per link.
const MAX_SEARCH_SAMPLES: usize = 2_500;
/// Most dense (radius-setting) samples per link (the spacing grows beyond,
/// and the radii get the difference as a margin).
const MAX_DENSE_SAMPLES: usize = 600_000;
/// Random points per link for the coverage figure of the report.
const VERIFY_SAMPLES: usize = 20_000;
/// Interior candidate centres aimed for.
const INTERIOR_CANDIDATES: usize = 700;
/// Surface candidate centres aimed for.
const SURFACE_CANDIDATES: usize = 250;
/// Meshes with more connected components than this are one solid.
const MAX_COMPONENTS: usize = 16;
/// Most spheres per link of the automatic count (without `max_per_link`).
const AUTO_MAX_COUNT: usize = 1024;
/// Most grid points evaluated for the candidate centres of the bounded
/// automatic model (see `Problem::solve_bounded`).
const BOUNDED_GRID: usize = 40_000;
/// Most samples of the set cover of the bounded automatic model per link.
const BOUNDED_SEARCH_SAMPLES: usize = 12_000;
/// Most solves of the bounded automatic model of a link whose mesh inside
/// is a voxel flood fill (each lowering the depth of centres whose sphere
/// was measured sticking out further than the bound).
const BOUNDED_ROUNDS: usize = 5;
/// Counts solved below and above a link's growth-bound allocation.
const WINDOW_BELOW: usize = 1;
const WINDOW_ABOVE: usize = 2;
/// Points per sphere when measuring protrusion to choose counts.
const DECISION_PROBES: usize = 1_000;
/// Points per sphere when measuring protrusion for the reports.
const REPORT_PROBES: usize = 4_000;

/// Options of the spherizer.
#[derive(Debug, Clone, PartialEq)]
pub struct SpherizeOptions {
    /// Coverage tolerance (m): every point of the link's collision surface
    /// must lie within `tolerance` of some sphere (i.e. inside the sphere
    /// grown by tolerance). Default 0.001.
    pub tolerance: f64,
    /// Total sphere budget for the robot, split among links (by the count
    /// each needs for equal protrusion) to minimise the worst protrusion;
    /// every link with geometry gets at least one sphere. `None` (the
    /// default): each link gets the bounded automatic model, every sphere
    /// sticking out by at most [`AUTO_MAX_PROTRUSION`] (1 cm). Only
    /// [`spherize_robot`] reads it.
    pub total_budget: Option<usize>,
    /// Per-link cap on the sphere count, or `None` (default).
    pub max_per_link: Option<usize>,
    /// Surface sample spacing (m) used to fit the spheres (every surface
    /// point lies within half of it from a fitting sample). Default 0.004.
    /// The radii are set and checked on a denser lattice derived from the
    /// tolerance, so this only trades fitting quality against time.
    pub sample_spacing: f64,
    /// Seed of the random verification points (results are deterministic
    /// for a given seed).
    pub seed: u64,
}

impl Default for SpherizeOptions {
    fn default() -> Self {
        Self {
            tolerance: 0.001,
            total_budget: None,
            max_per_link: None,
            sample_spacing: 0.004,
            seed: 0,
        }
    }
}

impl SpherizeOptions {
    /// Checks every option, naming the offending one.
    fn validate(&self) -> Result<()> {
        use ferrobot_model::ranges::{MAX_SPHERES, SPHERIZE_TOLERANCE, check_count};
        SPHERIZE_TOLERANCE.check(self.tolerance)?;
        if !(self.sample_spacing.is_finite() && self.sample_spacing > 0.0) {
            return Err(CollisionError::InvalidArgument(format!(
                "sample_spacing must be a finite positive length, got {}",
                self.sample_spacing
            )));
        }
        if let Some(n) = self.total_budget {
            check_count("total_budget", n, 1, MAX_SPHERES)?;
        }
        if let Some(n) = self.max_per_link {
            check_count("max_per_link", n, 1, MAX_SPHERES)?;
        }
        Ok(())
    }
}

/// How well the spheres of one link fit its collision geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkSphereReport {
    /// Link name.
    pub link: String,
    /// Number of spheres.
    pub spheres: usize,
    /// Fraction (0..1) of verification surface samples covered (within
    /// tolerance). The verification samples are random, area-weighted
    /// points of the link's surface, independent of the fitting lattices.
    pub coverage: f64,
    /// Mean protrusion (m) of the spheres beyond the link's surface: the
    /// distance to the geometry of the sphere surface sample points that lie
    /// outside the geometry (and on the boundary of the spheres' union),
    /// averaged over those points.
    pub mean_protrusion: f64,
    /// Max protrusion (m), measured on the same points.
    pub max_protrusion: f64,
}

/// Spheres for one link's collision geometry (all `geoms`, in the link
/// frame). Empty geometry (or geometry without area) gives no spheres.
///
/// `budget` caps the sphere count (the fewest-protrusion cover with at most
/// that many spheres is returned); `None` gives the bounded automatic model
/// (every sphere sticks out by at most [`AUTO_MAX_PROTRUSION`]).
/// `options.max_per_link` caps both; `options.total_budget` is not read.
///
/// Fails on invalid options, `budget == Some(0)`, or invalid shapes
/// (negative or non-finite sizes, non-finite poses, mesh indices out of
/// range).
pub fn spherize_link(
    name: &str,
    geoms: &[Geometry],
    budget: Option<usize>,
    options: &SpherizeOptions,
) -> Result<(Vec<Sphere>, LinkSphereReport)> {
    options.validate()?;
    if budget == Some(0) {
        return Err(CollisionError::InvalidArgument(format!(
            "link '{name}': budget must be at least 1"
        )));
    }
    if let Some(spheres) = given_spheres(geoms) {
        return Ok(given_report(name, spheres));
    }
    let Some(problem) = Problem::new(name, geoms, options)? else {
        return Ok((Vec::new(), empty_report(name)));
    };
    let cap = min_cap(budget, options.max_per_link);
    let spheres = match budget {
        Some(_) => problem.solve_count(cap.unwrap_or(1)),
        None => problem.solve_auto(cap),
    }
    .spheres;
    let report = problem.report(&spheres);
    Ok((spheres, report))
}

/// Spheres for every link of the model, indexed like `model.links()` (links
/// without collision geometry get none), and one report per link with
/// collision geometry, in link order.
///
/// With `options.total_budget` (at least the number of links with
/// geometry) the budget is split to minimise the robot's worst measured
/// protrusion, see the [module documentation](self); `max_per_link` caps
/// every link. Without it every link gets its automatic count. Links are
/// processed in parallel; the result depends only on the model and options.
///
/// A link whose collision geometry is made only of spheres (a spherized
/// URDF loaded as the robot, as MotionBenchMaker and VAMP ship) keeps those
/// spheres exactly ([`given_spheres`]), whatever `max_per_link`; they count
/// against `total_budget`, the rest of which is split among the other links.
///
/// Results are cached in memory and on disk, keyed by the links' geometry
/// and the options ([`crate::spherize_cache`]): the same robot is spherized
/// once.
pub fn spherize_robot(
    model: &RobotModel,
    options: &SpherizeOptions,
) -> Result<(Vec<Vec<Sphere>>, Vec<LinkSphereReport>)> {
    options.validate()?;
    let links = model.links();
    let key = crate::spherize_cache::key(
        &links
            .iter()
            .map(|l| (l.name.as_str(), l.collisions.as_slice()))
            .collect::<Vec<_>>(),
        options,
    );
    if let Some(hit) = crate::spherize_cache::get(key, links.len()) {
        return Ok(hit);
    }
    let out = spherize_robot_uncached(model, options)?;
    crate::spherize_cache::put(key, &out);
    Ok(out)
}

/// [`spherize_robot`] without the cache.
fn spherize_robot_uncached(
    model: &RobotModel,
    options: &SpherizeOptions,
) -> Result<(Vec<Vec<Sphere>>, Vec<LinkSphereReport>)> {
    let links = model.links();
    // Links whose collision geometry is already spheres keep them.
    let given: Vec<Option<Vec<Sphere>>> =
        links.iter().map(|l| given_spheres(&l.collisions)).collect();
    let problems: Vec<Option<Problem>> = links
        .par_iter()
        .zip(&given)
        .map(|(l, g)| {
            if l.collisions.is_empty() || g.is_some() {
                Ok(None)
            } else {
                Problem::new(&l.name, &l.collisions, options)
            }
        })
        .collect::<Result<_>>()?;
    let active: Vec<&Problem> = problems.iter().flatten().collect();
    let kept: usize = given.iter().flatten().map(Vec::len).sum();
    let solved: Vec<Vec<Sphere>> = match options.total_budget {
        Some(total) => {
            let left = total.saturating_sub(kept);
            if left < active.len() {
                return Err(CollisionError::InvalidArgument(format!(
                    "total_budget ({total}) leaves {left} sphere(s) after the {kept} sphere(s) of \
                     links whose collision geometry is spheres, fewer than the {} other link(s) \
                     with collision geometry; each needs at least one sphere",
                    active.len()
                )));
            }
            if active.is_empty() {
                Vec::new()
            } else {
                solve_budget(&active, left, options.max_per_link)
            }
        }
        None => active
            .par_iter()
            .map(|p| p.solve_auto(options.max_per_link))
            .collect(),
    }
    .into_iter()
    .map(|s| s.spheres)
    .collect();
    let solved_reports: Vec<LinkSphereReport> = active
        .par_iter()
        .zip(solved.par_iter())
        .map(|(p, s)| p.report(s))
        .collect();
    let mut out = vec![Vec::new(); links.len()];
    let mut reports = Vec::new();
    let mut next = solved.into_iter().zip(solved_reports);
    for (((l, p), g), slot) in links.iter().zip(&problems).zip(given).zip(out.iter_mut()) {
        if let Some(g) = g {
            let (s, r) = given_report(&l.name, g);
            *slot = s;
            reports.push(r);
        } else if p.is_some() {
            if let Some((s, r)) = next.next() {
                *slot = s;
                reports.push(r);
            }
        } else if !l.collisions.is_empty() {
            reports.push(empty_report(&l.name));
        }
    }
    Ok((out, reports))
}

/// Measures how well `spheres` (link frame) fit `geoms`: coverage of random
/// surface points within `options.tolerance`, and protrusion, as in
/// [`LinkSphereReport`]. Useful to compare with hand-made sphere models.
pub fn evaluate_link(
    name: &str,
    geoms: &[Geometry],
    spheres: &[Sphere],
    options: &SpherizeOptions,
) -> Result<LinkSphereReport> {
    options.validate()?;
    if let Some(s) = spheres.iter().find(|s| {
        !(s.radius.is_finite() && s.radius >= 0.0 && s.center.iter().all(|c| c.is_finite()))
    }) {
        return Err(CollisionError::InvalidArgument(format!(
            "link '{name}': invalid sphere {s:?}"
        )));
    }
    match Problem::new(name, geoms, options)? {
        Some(p) => Ok(p.report(spheres)),
        None => Ok(LinkSphereReport {
            spheres: spheres.len(),
            ..empty_report(name)
        }),
    }
}

/// The spheres of geometry made only of spheres (as in the spherized URDFs
/// MotionBenchMaker and VAMP ship), in the link frame; `None` when any
/// element is another shape or there is none. Such links keep their spheres
/// exactly: re-fitting them could only make the model larger.
pub fn given_spheres(geoms: &[Geometry]) -> Option<Vec<Sphere>> {
    if geoms.is_empty() {
        return None;
    }
    // Invalid radii fall through to the spherizer, which reports them; a
    // sphere of radius 0 has no surface and needs no sphere.
    let spheres: Option<Vec<Sphere>> = geoms
        .iter()
        .map(|g| match g.shape {
            Shape::Sphere { radius } if radius.is_finite() && radius >= 0.0 => Some(Sphere::new(
                Point3::from(g.origin.translation.vector),
                radius,
            )),
            _ => None,
        })
        .collect();
    spheres.map(|s| s.into_iter().filter(|s| s.radius > 0.0).collect())
}

/// The report of spheres taken as given: they are the geometry, so they
/// cover it exactly and protrude nowhere.
fn given_report(name: &str, spheres: Vec<Sphere>) -> (Vec<Sphere>, LinkSphereReport) {
    let report = LinkSphereReport {
        spheres: spheres.len(),
        ..empty_report(name)
    };
    (spheres, report)
}

fn empty_report(name: &str) -> LinkSphereReport {
    LinkSphereReport {
        link: name.to_string(),
        spheres: 0,
        coverage: 1.0,
        mean_protrusion: 0.0,
        max_protrusion: 0.0,
    }
}

fn min_cap(a: Option<usize>, b: Option<usize>) -> Option<usize> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, None) => a,
        (None, b) => b,
    }
}

/// Splits `total` spheres between links: the smallest common growth bound
/// whose greedy covers fit the total, then leftover spheres one by one to
/// the link with the largest bound.
fn allocate(problems: &[&Problem], total: usize, cap: Option<usize>) -> Vec<usize> {
    let limit = cap.unwrap_or(total).min(total);
    let count_at = |alpha: f64| -> usize {
        problems
            .par_iter()
            .map(|p| p.greedy_logged(alpha, limit).map_or(limit + 1, |s| s.len()))
            .collect::<Vec<_>>()
            .iter()
            .map(|&k| k.min(cap.unwrap_or(usize::MAX)))
            .sum()
    };
    let mut hi = problems.iter().map(|p| p.alpha_one).fold(0.0, f64::max);
    let mut lo = 0.0;
    while hi - lo > (1e-4f64).max(0.002 * hi) {
        let mid = 0.5 * (lo + hi);
        if count_at(mid) <= total {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let mut counts: Vec<usize> = problems
        .par_iter()
        .map(|p| {
            p.greedy_logged(hi, limit)
                .map_or(limit, |s| s.len())
                .clamp(1, limit)
        })
        .collect();
    let used: usize = counts.iter().sum();
    let mut leftover = total.saturating_sub(used);
    if leftover == 0 {
        return counts;
    }
    let mut alphas: Vec<f64> = problems
        .par_iter()
        .zip(counts.par_iter())
        .map(|(p, &k)| p.alpha_for(k).0)
        .collect();
    let mut open: Vec<bool> = counts.iter().map(|&k| k < limit).collect();
    while leftover > 0 {
        let Some(i) = (0..problems.len())
            .filter(|&i| open[i])
            .max_by(|&a, &b| alphas[a].total_cmp(&alphas[b]).then(b.cmp(&a)))
        else {
            break;
        };
        let (a, _) = problems[i].alpha_for(counts[i] + 1);
        if a < alphas[i] * 0.999 {
            counts[i] += 1;
            alphas[i] = a;
            leftover -= 1;
            open[i] = counts[i] < limit;
        } else {
            open[i] = false;
        }
    }
    counts
}

/// Solves every link within a total budget, minimising the worst measured
/// protrusion: each link is solved for counts around its growth-bound
/// allocation, the smallest threshold whose cheapest per-link solutions fit
/// the budget is found, the window of the link that sets it is widened
/// while that helps, and leftover spheres go to the links sticking out most.
fn solve_budget(problems: &[&Problem], total: usize, cap: Option<usize>) -> Vec<Solution> {
    let n = problems.len();
    let limit = cap.unwrap_or(usize::MAX);
    let start = allocate(problems, total, cap);
    let mut cache: Vec<HashMap<usize, Solution>> = vec![HashMap::new(); n];
    let fill = |cache: &mut Vec<HashMap<usize, Solution>>, want: Vec<(usize, usize)>| {
        let want: Vec<(usize, usize)> = want
            .into_iter()
            .filter(|(l, k)| *k >= 1 && *k <= limit && !cache[*l].contains_key(k))
            .collect();
        let solved: Vec<(usize, usize, Solution)> = want
            .par_iter()
            .map(|&(l, k)| (l, k, problems[l].solve_count(k)))
            .collect();
        for (l, k, s) in solved {
            cache[l].insert(k, s);
        }
    };
    let mut want = Vec::new();
    for (l, &k) in start.iter().enumerate() {
        for kk in k.saturating_sub(WINDOW_BELOW).max(1)..=k + WINDOW_ABOVE {
            want.push((l, kk));
        }
    }
    fill(&mut cache, want);
    // The cheapest cached solution of link `l` within threshold `t`.
    let pick = |cache: &[HashMap<usize, Solution>], l: usize, t: f64| -> Option<usize> {
        cache[l]
            .iter()
            .filter(|(_, s)| s.max <= t)
            .min_by(|a, b| {
                a.1.spheres
                    .len()
                    .cmp(&b.1.spheres.len())
                    .then(a.1.max.total_cmp(&b.1.max))
                    .then(a.0.cmp(b.0))
            })
            .map(|(k, _)| *k)
    };
    let choose = |cache: &[HashMap<usize, Solution>]| -> Vec<usize> {
        let mut values: Vec<f64> = cache
            .iter()
            .flat_map(|c| c.values().map(|s| s.max))
            .collect();
        values.sort_by(f64::total_cmp);
        values.dedup();
        let cost = |t: f64| -> Option<(usize, Vec<usize>)> {
            let ks: Option<Vec<usize>> = (0..n).map(|l| pick(cache, l, t)).collect();
            let ks = ks?;
            let used = ks
                .iter()
                .enumerate()
                .map(|(l, k)| cache[l][k].spheres.len())
                .sum();
            Some((used, ks))
        };
        let i = values.partition_point(|&t| cost(t).is_none_or(|(u, _)| u > total));
        match values.get(i).and_then(|&t| cost(t)) {
            Some((_, ks)) => ks,
            // Nothing fits (cannot happen with one sphere per link cached).
            None => (0..n)
                .map(|l| *cache[l].keys().min().unwrap_or(&1))
                .collect(),
        }
    };
    let worst_of = |cache: &[HashMap<usize, Solution>], ks: &[usize]| {
        (0..n).map(|l| cache[l][&ks[l]].max).fold(0.0, f64::max)
    };
    let mut ks = choose(&cache);
    let mut stalls = 0;
    for _ in 0..8 {
        let worst = worst_of(&cache, &ks);
        let mut want = Vec::new();
        for (l, &k) in ks.iter().enumerate() {
            let top = cache[l].keys().copied().max().unwrap_or(1);
            let bottom = cache[l].keys().copied().min().unwrap_or(1);
            // The links setting the threshold may do better with more spheres
            // than tried, and links at the bottom of their window may give
            // some up.
            let improves = cache[l]
                .iter()
                .any(|(kk, s)| *kk > k && s.max < worst - 1e-4);
            if cache[l][&k].max >= worst - 1e-9 && !improves {
                want.extend((top + 1..=top + WINDOW_ABOVE * (stalls + 1)).map(|kk| (l, kk)));
            }
            if k == bottom && bottom > 1 {
                want.extend((bottom.saturating_sub(WINDOW_BELOW).max(1)..bottom).map(|kk| (l, kk)));
            }
        }
        if want.is_empty() {
            break;
        }
        fill(&mut cache, want);
        ks = choose(&cache);
        if worst_of(&cache, &ks) >= worst - 1e-9 {
            stalls += 1;
            if stalls == 3 {
                break;
            }
        } else {
            stalls = 0;
        }
    }
    // Leftover spheres: to the links sticking out most, if that helps them.
    let mut done = vec![false; n];
    loop {
        let used: usize = (0..n).map(|l| cache[l][&ks[l]].spheres.len()).sum();
        let free = total.saturating_sub(used);
        let Some(l) = (0..n).filter(|&l| !done[l]).max_by(|&a, &b| {
            cache[a][&ks[a]]
                .max
                .total_cmp(&cache[b][&ks[b]].max)
                .then(b.cmp(&a))
        }) else {
            break;
        };
        let cur = &cache[l][&ks[l]];
        let better = cache[l]
            .iter()
            .filter(|(_, s)| s.spheres.len() <= cur.spheres.len() + free && s.max < cur.max - 1e-4)
            .min_by(|a, b| a.1.max.total_cmp(&b.1.max).then(a.0.cmp(b.0)))
            .map(|(k, _)| *k);
        match better {
            Some(k) if free > 0 || cache[l][&k].spheres.len() <= cur.spheres.len() => ks[l] = k,
            _ => done[l] = true,
        }
    }
    (0..n).map(|l| cache[l][&ks[l]].clone()).collect()
}

// ---------------------------------------------------------------------------
// Shapes
// ---------------------------------------------------------------------------

/// A primitive [`Shape`] (box, sphere, cylinder, capsule) in its own frame,
/// with what the spherizer asks of it (sizes may be zero here).
#[derive(Debug, Clone)]
struct Prim(Shape);

const NOT_PRIM: &str = "Prim holds a box, sphere, cylinder or capsule only";

fn steps(len: f64, max_step: f64) -> usize {
    let n = (len / max_step).ceil();
    if n.is_finite() && n >= 1.0 {
        n.min(1e7) as usize
    } else {
        1
    }
}

/// Points of a circle of `radius` at height `z`, at most `delta` apart
/// along the arc.
fn ring(radius: f64, z: f64, delta: f64, emit: &mut dyn FnMut(Point3<f64>)) {
    let n = steps(2.0 * PI * radius, delta);
    for k in 0..n {
        let t = 2.0 * PI * k as f64 / n as f64;
        emit(Point3::new(radius * t.cos(), radius * t.sin(), z));
    }
}

/// Cylinder side lattice: cells at most `√2 δ` along the arc and along z.
fn cylinder_side(r: f64, h: f64, delta: f64, emit: &mut dyn FnMut(Point3<f64>)) {
    let nz = steps(2.0 * h, SQRT_2 * delta);
    for i in 0..=nz {
        let z = -h + 2.0 * h * i as f64 / nz as f64;
        ring(r, z, SQRT_2 * delta, emit);
    }
}

impl Prim {
    fn sd(&self, p: &Point3<f64>) -> f64 {
        match self.0 {
            Shape::Box { half_extents: he } => {
                let q = p.coords.abs() - he;
                q.sup(&Vector3::zeros()).norm() + q.max().min(0.0)
            }
            Shape::Sphere { radius: r } => p.coords.norm() - r,
            Shape::Cylinder {
                radius: r,
                half_height: h,
            } => {
                let dx = p.x.hypot(p.y) - r;
                let dz = p.z.abs() - h;
                dx.max(dz).min(0.0) + dx.max(0.0).hypot(dz.max(0.0))
            }
            Shape::Capsule {
                radius: r,
                half_height: h,
            } => {
                let z = p.z.clamp(-h, h);
                (p.coords - Vector3::new(0.0, 0.0, z)).norm() - r
            }
            _ => unreachable!("{}", NOT_PRIM),
        }
    }

    fn area(&self) -> f64 {
        match self.0 {
            Shape::Box { half_extents: e } => 8.0 * (e.x * e.y + e.y * e.z + e.z * e.x),
            Shape::Sphere { radius: r } => 4.0 * PI * r * r,
            Shape::Cylinder {
                radius: r,
                half_height: h,
            } => 4.0 * PI * r * h + 2.0 * PI * r * r,
            Shape::Capsule {
                radius: r,
                half_height: h,
            } => 4.0 * PI * r * h + 4.0 * PI * r * r,
            _ => unreachable!("{}", NOT_PRIM),
        }
    }

    fn half_extents(&self) -> Vector3<f64> {
        match self.0 {
            Shape::Box { half_extents: e } => e,
            Shape::Sphere { radius: r } => Vector3::repeat(r),
            Shape::Cylinder {
                radius: r,
                half_height: h,
            } => Vector3::new(r, r, h),
            Shape::Capsule {
                radius: r,
                half_height: h,
            } => Vector3::new(r, r, h + r),
            _ => unreachable!("{}", NOT_PRIM),
        }
    }

    /// Lattice with covering radius at most `delta`, own frame.
    fn lattice(&self, delta: f64, emit: &mut dyn FnMut(Point3<f64>)) {
        match self.0 {
            Shape::Box { half_extents: e } => {
                for a in 0..3 {
                    let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                    let nu = steps(2.0 * e[u], SQRT_2 * delta);
                    let nv = steps(2.0 * e[v], SQRT_2 * delta);
                    let signs: &[f64] = if e[a] > 0.0 { &[-1.0, 1.0] } else { &[1.0] };
                    for &s in signs {
                        for i in 0..=nu {
                            for j in 0..=nv {
                                let mut p = Point3::origin();
                                p[a] = s * e[a];
                                p[u] = e[u] * (2.0 * i as f64 / nu as f64 - 1.0);
                                p[v] = e[v] * (2.0 * j as f64 / nv as f64 - 1.0);
                                emit(p);
                            }
                        }
                    }
                }
            }
            Shape::Sphere { radius: r } => {
                // Along a meridian to the nearest ring (≤ δ/2), then along the ring (≤ δ/2).
                let n = steps(PI * r, delta);
                for i in 0..=n {
                    let phi = PI * i as f64 / n as f64;
                    ring(r * phi.sin(), r * phi.cos(), delta, emit);
                }
            }
            Shape::Cylinder {
                radius: r,
                half_height: h,
            } => {
                cylinder_side(r, h, delta, emit);
                let n = steps(r, delta);
                let caps: &[f64] = if h > 0.0 { &[-1.0, 1.0] } else { &[1.0] };
                for &s in caps {
                    for i in 0..=n {
                        ring(r * i as f64 / n as f64, s * h, delta, emit);
                    }
                }
            }
            Shape::Capsule {
                radius: r,
                half_height: h,
            } => {
                if h > 0.0 {
                    cylinder_side(r, h, delta, emit);
                }
                let n = steps(0.5 * PI * r, delta);
                for i in 0..=n {
                    let phi = 0.5 * PI * i as f64 / n as f64;
                    ring(r * phi.sin(), h + r * phi.cos(), delta, emit);
                    ring(r * phi.sin(), -h - r * phi.cos(), delta, emit);
                }
            }
            _ => unreachable!("{}", NOT_PRIM),
        }
    }

    /// A uniformly (area-weighted) random surface point, own frame.
    fn random(&self, rng: &mut StdRng) -> Point3<f64> {
        let dir = |rng: &mut StdRng| {
            let z: f64 = rng.random_range(-1.0..=1.0);
            let t: f64 = rng.random_range(0.0..2.0 * PI);
            let s = (1.0 - z * z).max(0.0).sqrt();
            Vector3::new(s * t.cos(), s * t.sin(), z)
        };
        match self.0 {
            Shape::Box { half_extents: e } => {
                let w = [4.0 * e.y * e.z, 4.0 * e.z * e.x, 4.0 * e.x * e.y];
                let mut x = rng.random::<f64>() * (w[0] + w[1] + w[2]);
                let mut a = 0;
                while a < 2 && x > w[a] {
                    x -= w[a];
                    a += 1;
                }
                let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                let mut p = Point3::origin();
                p[a] = if rng.random::<bool>() { e[a] } else { -e[a] };
                p[u] = e[u] * rng.random_range(-1.0..=1.0);
                p[v] = e[v] * rng.random_range(-1.0..=1.0);
                p
            }
            Shape::Sphere { radius: r } => Point3::from(dir(rng) * r),
            Shape::Cylinder {
                radius: r,
                half_height: h,
            } => {
                let side = 4.0 * PI * r * h;
                let t: f64 = rng.random_range(0.0..2.0 * PI);
                if rng.random::<f64>() * (side + 2.0 * PI * r * r) < side {
                    Point3::new(r * t.cos(), r * t.sin(), rng.random_range(-h..=h))
                } else {
                    let rho = r * rng.random::<f64>().sqrt();
                    let z = if rng.random::<bool>() { h } else { -h };
                    Point3::new(rho * t.cos(), rho * t.sin(), z)
                }
            }
            Shape::Capsule {
                radius: r,
                half_height: h,
            } => {
                let side = 4.0 * PI * r * h;
                if rng.random::<f64>() * (side + 4.0 * PI * r * r) < side {
                    let t: f64 = rng.random_range(0.0..2.0 * PI);
                    Point3::new(r * t.cos(), r * t.sin(), rng.random_range(-h..=h))
                } else {
                    let d = dir(rng) * r;
                    Point3::new(d.x, d.y, d.z + h.copysign(d.z))
                }
            }
            _ => unreachable!("{}", NOT_PRIM),
        }
    }
}

/// One closed or open piece of a triangle mesh, in the link frame.
struct MeshSolid {
    tris: Vec<[Point3<f64>; 3]>,
    cum_area: Vec<f64>,
    mesh: ParryMesh,
    /// Inside test: parry's pseudo-normals (`None`, closed meshes), or a
    /// voxel flood fill (meshes that are not edge-manifold: T-junctions,
    /// cracks, overlapping pieces, open sheets).
    voxels: Option<Voxels>,
    /// Face planes `(normal, offset)` of a closed, (nearly) convex mesh:
    /// inside it the largest plane distance approximates the signed distance.
    planes: Option<Vec<[f64; 4]>>,
}

/// One shape of a link, in the link frame.
enum Solid {
    Prim {
        prim: Prim,
        pose: Isometry3<f64>,
        inv: Isometry3<f64>,
    },
    Mesh(Box<MeshSolid>),
}

fn to_p(p: &Point3<f64>) -> PVec {
    PVec::new(p.x as f32, p.y as f32, p.z as f32)
}

fn tri_area(t: &[Point3<f64>; 3]) -> f64 {
    0.5 * (t[1] - t[0]).cross(&(t[2] - t[0])).norm()
}

impl Solid {
    /// Signed distance (negative inside; open meshes are never inside).
    fn sd(&self, p: &Point3<f64>) -> f64 {
        match self {
            Solid::Prim { prim, inv, .. } => prim.sd(&(inv * p)),
            Solid::Mesh(m) => {
                let proj = m.mesh.project_local_point(to_p(p), false);
                let q = Point3::new(
                    proj.point.x as f64,
                    proj.point.y as f64,
                    proj.point.z as f64,
                );
                let d = (p - q).norm();
                let inside = match m.voxels.as_ref().map(|v| v.class(p)) {
                    None | Some(UNDECIDED) => proj.is_inside,
                    Some(c) => c == IN,
                };
                if inside { -d } else { d }
            }
        }
    }

    /// [`Self::sd`], or inside a (nearly) convex closed mesh the largest
    /// face-plane distance: exact for convex meshes, close for nearly
    /// convex ones, and much cheaper (used only to place centres).
    fn fast_sd(&self, p: &Point3<f64>) -> f64 {
        if let Solid::Mesh(m) = self
            && let Some(planes) = &m.planes
        {
            let d = planes
                .iter()
                .map(|q| q[0] * p.x + q[1] * p.y + q[2] * p.z - q[3])
                .fold(f64::NEG_INFINITY, f64::max);
            if d <= 0.0 {
                return d;
            }
        }
        self.sd(p)
    }

    /// Whether the inside test is exact (not a voxel approximation).
    fn exact_inside(&self) -> bool {
        match self {
            Solid::Prim { .. } => true,
            Solid::Mesh(m) => m.voxels.is_none(),
        }
    }

    fn area(&self) -> f64 {
        match self {
            Solid::Prim { prim, .. } => prim.area(),
            Solid::Mesh(m) => m.cum_area.last().copied().unwrap_or(0.0),
        }
    }

    fn aabb(&self) -> (Point3<f64>, Point3<f64>) {
        match self {
            Solid::Prim { prim, pose, .. } => {
                let r = pose.rotation.to_rotation_matrix().into_inner().abs();
                let h = r * prim.half_extents();
                let c = Point3::from(pose.translation.vector);
                (c - h, c + h)
            }
            Solid::Mesh(m) => {
                let mut lo = Point3::from(Vector3::repeat(f64::INFINITY));
                let mut hi = Point3::from(Vector3::repeat(f64::NEG_INFINITY));
                for p in m.tris.iter().flatten() {
                    lo = lo.inf(p);
                    hi = hi.sup(p);
                }
                (lo, hi)
            }
        }
    }

    /// Lattice with covering radius at most `delta`, link frame.
    fn lattice(&self, delta: f64, emit: &mut dyn FnMut(Point3<f64>)) {
        match self {
            Solid::Prim { prim, pose, .. } => prim.lattice(delta, &mut |p| emit(pose * p)),
            Solid::Mesh(m) => {
                for t in &m.tris {
                    tri_lattice(t, delta, emit);
                }
            }
        }
    }

    fn random(&self, rng: &mut StdRng) -> Point3<f64> {
        match self {
            Solid::Prim { prim, pose, .. } => pose * prim.random(rng),
            Solid::Mesh(m) => {
                let total = m.cum_area.last().copied().unwrap_or(0.0);
                let x = rng.random::<f64>() * total;
                let i = m.cum_area.partition_point(|&c| c < x).min(m.tris.len() - 1);
                let t = &m.tris[i];
                let s = rng.random::<f64>().sqrt();
                let u = rng.random::<f64>();
                Point3::from(
                    t[0].coords * (1.0 - s) + t[1].coords * (s * (1.0 - u)) + t[2].coords * (s * u),
                )
            }
        }
    }
}

/// Appends the pieces of a mesh geometry (link frame) to `out`.
fn mesh_solids(
    what: &str,
    mesh: &ferrobot_model::TriMesh,
    scale: &Vector3<f64>,
    origin: &Isometry3<f64>,
    out: &mut Vec<Solid>,
) -> Result<()> {
    let bad = |m: String| CollisionError::InvalidShape(format!("{what}: {m}"));
    if !scale.iter().all(|s| s.is_finite()) {
        return Err(bad(format!("non-finite mesh scale {:?}", scale.as_slice())));
    }
    let nv = mesh.vertices.len();
    if let Some(t) = mesh
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= nv))
    {
        return Err(bad(format!(
            "triangle {t:?} refers to a vertex beyond the {nv} given"
        )));
    }
    if mesh
        .vertices
        .iter()
        .any(|v| !v.iter().all(|c| c.is_finite()))
    {
        return Err(bad("non-finite mesh vertex".into()));
    }
    // Merge vertices at equal positions (files often split them per face).
    let mut index: HashMap<[u64; 3], u32> = HashMap::new();
    let mut verts: Vec<Point3<f64>> = Vec::new();
    let remap: Vec<u32> = mesh
        .vertices
        .iter()
        .map(|v| {
            let p = origin * Point3::from(v.coords.component_mul(scale));
            let key = [
                (p.x + 0.0).to_bits(),
                (p.y + 0.0).to_bits(),
                (p.z + 0.0).to_bits(),
            ];
            *index.entry(key).or_insert_with(|| {
                verts.push(p);
                (verts.len() - 1) as u32
            })
        })
        .collect();
    let tris: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .map(|t| {
            [
                remap[t[0] as usize],
                remap[t[1] as usize],
                remap[t[2] as usize],
            ]
        })
        .filter(|t| {
            let [a, b, c] = t.map(|i| verts[i as usize]);
            let l2 = (b - a)
                .norm_squared()
                .max((c - b).norm_squared())
                .max((a - c).norm_squared());
            t[0] != t[1]
                && t[1] != t[2]
                && t[0] != t[2]
                && (b - a).cross(&(c - a)).norm() > 1e-12 * l2
        })
        .collect();
    if tris.is_empty() {
        return Ok(());
    }
    // Connected components (union-find over vertices).
    let mut parent: Vec<u32> = (0..verts.len() as u32).collect();
    fn find(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    for t in &tris {
        let a = find(&mut parent, t[0]);
        for &v in &t[1..] {
            let b = find(&mut parent, v);
            parent[b as usize] = a;
        }
    }
    let mut group_of: HashMap<u32, usize> = HashMap::new();
    let mut groups: Vec<Vec<[u32; 3]>> = Vec::new();
    for t in &tris {
        let root = find(&mut parent, t[0]);
        let g = *group_of.entry(root).or_insert_with(|| {
            groups.push(Vec::new());
            groups.len() - 1
        });
        groups[g].push(*t);
    }
    // Closed pieces (every directed edge matched once by its reverse, with
    // volume) are separate solids with parry's pseudo-normal sign, wound
    // outwards. Otherwise the whole mesh is one solid whose inside is
    // decided by its winding number.
    let closed: Vec<bool> = groups
        .iter_mut()
        .map(|g| orient_closed(&verts, g))
        .collect();
    if closed.iter().all(|&c| c) {
        if groups.len() > MAX_COMPONENTS {
            groups = vec![groups.concat()];
        }
        for g in groups {
            out.push(Solid::Mesh(mesh_solid(what, &verts, g, true)?));
        }
    } else {
        out.push(Solid::Mesh(mesh_solid(
            what,
            &verts,
            groups.concat(),
            false,
        )?));
    }
    Ok(())
}

/// Whether a piece is closed (every directed edge matched exactly once by
/// its reverse, non-zero volume); closed pieces are wound outwards.
fn orient_closed(verts: &[Point3<f64>], tris: &mut [[u32; 3]]) -> bool {
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in tris.iter() {
        for k in 0..3 {
            *edges.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    if !edges
        .iter()
        .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1))
    {
        return false;
    }
    let (lo, hi) = bounds(tris.iter().flatten().map(|&i| verts[i as usize]));
    let c = nalgebra::center(&lo, &hi);
    let volume: f64 = tris
        .iter()
        .map(|t| {
            let [a, b, d] = t.map(|i| verts[i as usize] - c);
            a.dot(&b.cross(&d)) / 6.0
        })
        .sum();
    let size = (hi - lo).norm();
    if volume.abs() <= 1e-9 * size * size * size {
        return false;
    }
    if volume < 0.0 {
        for t in tris.iter_mut() {
            t.swap(1, 2);
        }
    }
    true
}

fn bounds(points: impl Iterator<Item = Point3<f64>>) -> (Point3<f64>, Point3<f64>) {
    let mut lo = Point3::from(Vector3::repeat(f64::INFINITY));
    let mut hi = Point3::from(Vector3::repeat(f64::NEG_INFINITY));
    for p in points {
        lo = lo.inf(&p);
        hi = hi.sup(&p);
    }
    (lo, hi)
}

fn mesh_solid(
    what: &str,
    verts: &[Point3<f64>],
    tris: Vec<[u32; 3]>,
    closed: bool,
) -> Result<Box<MeshSolid>> {
    let mut local: HashMap<u32, u32> = HashMap::new();
    let mut pv: Vec<PVec> = Vec::new();
    let idx: Vec<[u32; 3]> = tris
        .iter()
        .map(|t| {
            t.map(|i| {
                *local.entry(i).or_insert_with(|| {
                    pv.push(to_p(&verts[i as usize]));
                    (pv.len() - 1) as u32
                })
            })
        })
        .collect();
    let mesh = ParryMesh::with_flags(pv, idx, TriMeshFlags::ORIENTED)
        .map_err(|e| CollisionError::InvalidShape(format!("{what}: {e}")))?;
    let tris: Vec<[Point3<f64>; 3]> = tris.iter().map(|t| t.map(|i| verts[i as usize])).collect();
    let mut acc = 0.0;
    let cum_area = tris
        .iter()
        .map(|t| {
            acc += tri_area(t);
            acc
        })
        .collect();
    let voxels = (!closed).then(|| Voxels::new(&tris));
    let planes = if closed { convex_planes(&tris) } else { None };
    Ok(Box::new(MeshSolid {
        tris,
        cum_area,
        mesh,
        voxels,
        planes,
    }))
}

/// The distinct face planes of an outward-wound closed mesh if it is nearly
/// convex (no vertex more than 2 % of its size outside a face plane).
fn convex_planes(tris: &[[Point3<f64>; 3]]) -> Option<Vec<[f64; 4]>> {
    let (lo, hi) = bounds(tris.iter().flatten().copied());
    let eps = 1e-7 * (hi - lo).norm().max(1e-9);
    let mut planes: Vec<[f64; 4]> = Vec::new();
    let mut seen = HashSet::new();
    for t in tris {
        let n = (t[1] - t[0]).cross(&(t[2] - t[0]));
        let len = n.norm();
        if len.is_nan() || len <= 0.0 {
            continue;
        }
        let n = n / len;
        let o = n.dot(&t[0].coords);
        let key = [n.x, n.y, n.z, o / eps].map(|x| (x * 1e6).round() as i64);
        if seen.insert(key) {
            planes.push([n.x, n.y, n.z, o]);
        }
    }
    let size = (hi - lo).norm();
    let convex = tris.iter().flatten().all(|v| {
        planes
            .iter()
            .all(|q| q[0] * v.x + q[1] * v.y + q[2] * v.z - q[3] <= 0.02 * size)
    });
    (convex && planes.len() <= 2048).then_some(planes)
}

/// Lattice points of a triangle with covering radius at most `delta`: the
/// cheaper of a similar-sub-triangle lattice (every point within the
/// longest sub-edge / √3 of a vertex) and a square grid of step √2 δ in
/// the triangle's plane whose nodes near the triangle are projected onto it
/// (projection onto a convex set does not increase distances to its points).
fn tri_lattice(t: &[Point3<f64>; 3], delta: f64, emit: &mut dyn FnMut(Point3<f64>)) {
    let edge = |k: usize| (t[(k + 1) % 3] - t[k]).norm();
    let k = (0..3)
        .max_by(|&a, &b| edge(a).total_cmp(&edge(b)))
        .unwrap_or(0);
    let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
    let l = (b - a).norm();
    let n = steps(l, 3f64.sqrt() * delta);
    let bary = (n + 1) * (n + 2) / 2;
    // Plane frame: a at the origin, b on +x, c above.
    let e1 = (b - a) / l;
    let cx = (c - a).dot(&e1);
    let perp = (c - a) - e1 * cx;
    let cy = perp.norm();
    let g = SQRT_2 * delta;
    let rows = |f: &mut dyn FnMut(f64, f64, f64)| {
        let j1 = (cy / g).ceil() as i64 + 1;
        for j in -1..=j1 {
            let y = j as f64 * g;
            let s0 = (y - g).max(0.0);
            if s0 > cy || y + g < 0.0 {
                continue;
            }
            // Over the band the triangle spans x in [xl(s0), xr(s0)].
            let xl = cx * s0 / cy;
            let xr = l + (cx - l) * s0 / cy;
            f(y, xl - g, xr + g);
        }
    };
    let mut grid = 0usize;
    rows(&mut |_, x0, x1| grid += ((x1 / g).ceil() - (x0 / g).floor()) as usize + 1);
    if bary <= grid || cy.is_nan() || cy <= 0.0 {
        let (e1, e2) = ((b - a) / n as f64, (c - a) / n as f64);
        for i in 0..=n {
            for j in 0..=(n - i) {
                emit(a + e1 * i as f64 + e2 * j as f64);
            }
        }
        return;
    }
    let e2 = perp / cy;
    let (pa, pb, pc) = ([0.0, 0.0], [l, 0.0], [cx, cy]);
    rows(&mut |y, x0, x1| {
        let (i0, i1) = ((x0 / g).floor() as i64, (x1 / g).ceil() as i64);
        for i in i0..=i1 {
            let q = closest_in_triangle([i as f64 * g, y], pa, pb, pc);
            emit(a + e1 * q[0] + e2 * q[1]);
        }
    });
}

/// The point of the counter-clockwise 2D triangle `abc` closest to `p`.
fn closest_in_triangle(p: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> [f64; 2] {
    let cross = |o: [f64; 2], u: [f64; 2], v: [f64; 2]| {
        (u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0])
    };
    if cross(a, b, p) >= 0.0 && cross(b, c, p) >= 0.0 && cross(c, a, p) >= 0.0 {
        return p;
    }
    let seg = |u: [f64; 2], v: [f64; 2]| {
        let d = [v[0] - u[0], v[1] - u[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        let t = if len2 > 0.0 {
            (((p[0] - u[0]) * d[0] + (p[1] - u[1]) * d[1]) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = [u[0] + t * d[0], u[1] + t * d[1]];
        (q, (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2))
    };
    let cands = [seg(a, b), seg(b, c), seg(c, a)];
    cands
        .iter()
        .min_by(|x, y| x.1.total_cmp(&y.1))
        .map_or(p, |x| x.0)
}

/// Inside/outside classes of a voxel grid around a mesh that is not
/// edge-manifold (T-junctions, cracks, overlapping pieces, open sheets):
/// voxels touching the surface form a shell; the rest is flood-filled from
/// the border (6-connected, so cracks narrower than a voxel do not leak).
/// Shell voxels are inside when no outside voxel neighbours them, outside
/// when no inside voxel does, and otherwise undecided (the nearest
/// feature's pseudo-normal decides).
struct Voxels {
    lo: Point3<f64>,
    h: f64,
    dims: [usize; 3],
    class: Vec<u8>,
}

const OUT: u8 = 0;
const IN: u8 = 1;
const SHELL: u8 = 2;
const UNDECIDED: u8 = 3;

impl Voxels {
    /// Cells along the longest side.
    const RESOLUTION: f64 = 64.0;

    fn new(tris: &[[Point3<f64>; 3]]) -> Self {
        let (lo, hi) = bounds(tris.iter().flatten().copied());
        let h = ((hi - lo).max() / Self::RESOLUTION).max(1e-9);
        let lo = lo - Vector3::repeat(3.0 * h);
        let size = hi - lo + Vector3::repeat(3.0 * h);
        let dims = [0, 1, 2].map(|a| (size[a] / h).ceil() as usize + 1);
        let mut v = Self {
            lo,
            h,
            dims,
            class: vec![u8::MAX; dims[0] * dims[1] * dims[2]],
        };
        // Shell: surface points less than a voxel apart mark a 26-connected barrier.
        for t in tris {
            tri_lattice(t, 0.25 * h, &mut |p| {
                if let Some(i) = v.index(&p) {
                    v.class[i] = SHELL;
                }
            });
        }
        // Close cracks: flood the outside from a corner around the shell
        // dilated by one voxel, then grow that outside back by one voxel.
        let shell: Vec<bool> = v.class.iter().map(|&c| c == SHELL).collect();
        let thick = v.dilate(&shell);
        let mut outside = vec![false; shell.len()];
        let mut stack = vec![0usize];
        outside[0] = true;
        while let Some(i) = stack.pop() {
            let c = v.coords(i);
            for (a, d) in [(0, -1i64), (0, 1), (1, -1), (1, 1), (2, -1), (2, 1)] {
                let mut n = c;
                n[a] += d;
                if let Some(j) = v.flat(n)
                    && !thick[j]
                    && !outside[j]
                {
                    outside[j] = true;
                    stack.push(j);
                }
            }
        }
        let outside = v.dilate(&outside);
        for ((c, &o), &s) in v.class.iter_mut().zip(&outside).zip(&shell) {
            if !s {
                *c = if o { OUT } else { IN };
            }
        }
        let shell_class: Vec<(usize, u8)> = (0..v.class.len())
            .filter(|&i| v.class[i] == SHELL)
            .map(|i| {
                let c = v.coords(i);
                let (mut has_in, mut has_out) = (false, false);
                for d in 0..27i64 {
                    let n = [c[0] + d % 3 - 1, c[1] + d / 3 % 3 - 1, c[2] + d / 9 - 1];
                    match v.flat(n).map(|j| v.class[j]) {
                        Some(IN) => has_in = true,
                        Some(OUT) | None => has_out = true,
                        _ => {}
                    }
                }
                let k = match (has_in, has_out) {
                    (_, false) => IN,
                    (false, true) => OUT,
                    (true, true) => UNDECIDED,
                };
                (i, k)
            })
            .collect();
        for (i, k) in shell_class {
            v.class[i] = k;
        }
        v
    }

    /// The set grown by the 26-neighbourhood.
    fn dilate(&self, set: &[bool]) -> Vec<bool> {
        let mut out = set.to_vec();
        for (i, _) in set.iter().enumerate().filter(|(_, s)| **s) {
            let c = self.coords(i);
            for d in 0..27i64 {
                if let Some(j) =
                    self.flat([c[0] + d % 3 - 1, c[1] + d / 3 % 3 - 1, c[2] + d / 9 - 1])
                {
                    out[j] = true;
                }
            }
        }
        out
    }

    fn coords(&self, i: usize) -> [i64; 3] {
        let [nx, ny, _] = self.dims;
        [
            (i % nx) as i64,
            (i / nx % ny) as i64,
            (i / (nx * ny)) as i64,
        ]
    }

    fn flat(&self, c: [i64; 3]) -> Option<usize> {
        let [nx, ny, nz] = self.dims.map(|d| d as i64);
        (c[0] >= 0 && c[1] >= 0 && c[2] >= 0 && c[0] < nx && c[1] < ny && c[2] < nz)
            .then(|| (c[0] + nx * (c[1] + ny * c[2])) as usize)
    }

    fn index(&self, p: &Point3<f64>) -> Option<usize> {
        let q = (p - self.lo) / self.h;
        if !q.iter().all(|x| x.is_finite()) {
            return None;
        }
        self.flat([q.x.floor() as i64, q.y.floor() as i64, q.z.floor() as i64])
    }

    fn class(&self, p: &Point3<f64>) -> u8 {
        self.index(p).map_or(OUT, |i| self.class[i])
    }
}

/// All shapes of a link, queried as their union.
struct LinkGeom {
    solids: Vec<Solid>,
    boxes: Vec<(Point3<f64>, Point3<f64>)>,
    area: f64,
    lo: Point3<f64>,
    hi: Point3<f64>,
}

fn aabb_dist(lo: &Point3<f64>, hi: &Point3<f64>, p: &Point3<f64>) -> f64 {
    (lo - p).sup(&(p - hi)).sup(&Vector3::zeros()).norm()
}

impl LinkGeom {
    fn build(name: &str, geoms: &[Geometry]) -> Result<Self> {
        let mut solids = Vec::new();
        for (k, g) in geoms.iter().enumerate() {
            let what = format!("link '{name}' collision {k} ({})", g.shape.kind());
            let bad = |m: &str| CollisionError::InvalidShape(format!("{what}: {m}"));
            let o = &g.origin;
            if !(o.translation.vector.iter().all(|c| c.is_finite())
                && o.rotation.coords.iter().all(|c| c.is_finite()))
            {
                return Err(bad("non-finite origin"));
            }
            let size_ok = |v: f64| v.is_finite() && v >= 0.0;
            let prim = match &g.shape {
                Shape::Box { half_extents } => {
                    if !half_extents.iter().all(|&v| size_ok(v)) {
                        return Err(bad("box sizes must be finite and non-negative"));
                    }
                    Prim(g.shape.clone())
                }
                Shape::Sphere { radius } => {
                    if !size_ok(*radius) {
                        return Err(bad("radius must be finite and non-negative"));
                    }
                    Prim(g.shape.clone())
                }
                Shape::Cylinder {
                    radius,
                    half_height,
                }
                | Shape::Capsule {
                    radius,
                    half_height,
                } => {
                    if !(size_ok(*radius) && size_ok(*half_height)) {
                        return Err(bad("radius and length must be finite and non-negative"));
                    }
                    Prim(g.shape.clone())
                }
                Shape::Mesh(m) | Shape::ConvexDecomposition(m) => {
                    mesh_solids(&what, m.data(), m.scale(), o, &mut solids)?;
                    continue;
                }
                Shape::ConvexHull(h) => {
                    let m = h.surface();
                    mesh_solids(&what, m.data(), m.scale(), o, &mut solids)?;
                    continue;
                }
                Shape::PointCloud(_) => return Err(bad("a point cloud has no surface to cover")),
            };
            if prim.area() > 0.0 {
                solids.push(Solid::Prim {
                    prim,
                    pose: *o,
                    inv: o.inverse(),
                });
            }
        }
        let boxes: Vec<_> = solids.iter().map(Solid::aabb).collect();
        let mut lo = Point3::from(Vector3::repeat(f64::INFINITY));
        let mut hi = Point3::from(Vector3::repeat(f64::NEG_INFINITY));
        for (a, b) in &boxes {
            lo = lo.inf(a);
            hi = hi.sup(b);
        }
        let area = solids.iter().map(Solid::area).sum();
        Ok(Self {
            solids,
            boxes,
            area,
            lo,
            hi,
        })
    }

    /// Depth inside the union: at least the distance to its surface inside,
    /// minus the distance to it outside.
    fn depth(&self, p: &Point3<f64>) -> f64 {
        let mut best = f64::NEG_INFINITY;
        for (s, (lo, hi)) in self.solids.iter().zip(&self.boxes) {
            if -aabb_dist(lo, hi, p) <= best {
                continue;
            }
            best = best.max(-s.sd(p));
        }
        best
    }

    /// [`Self::depth`] with [`Solid::fast_sd`] (to place centres).
    fn fast_depth(&self, p: &Point3<f64>) -> f64 {
        let mut best = f64::NEG_INFINITY;
        for (s, (lo, hi)) in self.solids.iter().zip(&self.boxes) {
            if -aabb_dist(lo, hi, p) <= best {
                continue;
            }
            best = best.max(-s.fast_sd(p));
        }
        best
    }

    /// Whether `p` (on shape `i`) lies deeper than `thr` in another shape
    /// whose inside is exact (primitives and closed meshes: the surface of
    /// other meshes is never taken as buried, to stay conservative).
    fn inside_other(&self, p: &Point3<f64>, i: usize, thr: f64) -> bool {
        self.solids
            .iter()
            .zip(&self.boxes)
            .enumerate()
            .any(|(j, (s, (lo, hi)))| {
                j != i && s.exact_inside() && aabb_dist(lo, hi, p) == 0.0 && -s.sd(p) > thr
            })
    }

    fn lattice_count(&self, delta: f64) -> usize {
        let mut n = 0usize;
        for s in &self.solids {
            s.lattice(delta, &mut |_| n += 1);
        }
        n
    }

    /// The smallest covering radius ≥ `delta` whose lattice has at most `max` points.
    /// (Meshes with very many triangles may stay above `max`: every
    /// triangle keeps its corners.)
    fn spacing_for(&self, delta: f64, max: usize) -> f64 {
        let mut d = delta.max((self.area / max as f64).sqrt());
        let mut count = self.lattice_count(d);
        for _ in 0..60 {
            if count <= max {
                break;
            }
            let next = self.lattice_count(d * 1.2);
            if next >= count {
                break;
            }
            (d, count) = (d * 1.2, next);
        }
        d
    }

    /// Lattice points (covering radius `delta`) on the union's surface: points
    /// deeper than `delta` inside another shape are left out.
    fn samples(&self, delta: f64) -> Vec<Point3<f64>> {
        let mut out = Vec::new();
        let thr = delta * 1.01 + 1e-7;
        let multi = self.solids.len() > 1;
        for (i, s) in self.solids.iter().enumerate() {
            s.lattice(delta, &mut |p| {
                if !multi || !self.inside_other(&p, i, thr) {
                    out.push(p);
                }
            });
        }
        out
    }

    /// `n` random area-weighted points of the union's surface.
    fn random_samples(&self, n: usize, rng: &mut StdRng) -> Vec<Point3<f64>> {
        let mut out = Vec::with_capacity(n);
        let multi = self.solids.len() > 1;
        let mut tries = 0;
        while out.len() < n && tries < 20 * n {
            tries += 1;
            let mut x = rng.random::<f64>() * self.area;
            let mut i = 0;
            while i + 1 < self.solids.len() && x > self.solids[i].area() {
                x -= self.solids[i].area();
                i += 1;
            }
            let p = self.solids[i].random(rng);
            if !multi || !self.inside_other(&p, i, 1e-7) {
                out.push(p);
            }
        }
        out
    }
}

/// Keeps the first point in each cubic cell of size `cell`.
fn voxel_subset(points: &[Point3<f64>], cell: f64) -> Vec<usize> {
    let mut seen = HashSet::new();
    (0..points.len())
        .filter(|&i| {
            let p = points[i] / cell;
            seen.insert([p.x.floor() as i64, p.y.floor() as i64, p.z.floor() as i64])
        })
        .collect()
}

/// Unit vectors of the 26 grid neighbours.
fn directions() -> Vec<Vector3<f64>> {
    let mut d = Vec::with_capacity(26);
    for x in -1..=1 {
        for y in -1..=1 {
            for z in -1..=1 {
                if (x, y, z) != (0, 0, 0) {
                    d.push(Vector3::new(x as f64, y as f64, z as f64).normalize());
                }
            }
        }
    }
    d
}

// ---------------------------------------------------------------------------
// The fitting problem of one link
// ---------------------------------------------------------------------------

/// Spheres of one link and their measured maximum protrusion.
#[derive(Debug, Clone)]
struct Solution {
    spheres: Vec<Sphere>,
    max: f64,
}

/// Surface samples for the greedy set cover: f32 columns in Morton order,
/// with the bounding box of every 64 consecutive samples.
struct CoverSamples {
    sx: Vec<f32>,
    sy: Vec<f32>,
    sz: Vec<f32>,
    /// Bounding boxes (lo, hi) of each 64 samples.
    blocks: Vec<[f32; 6]>,
}

impl CoverSamples {
    /// The points `pts[i]` for `i` in `idx`.
    fn new(pts: &[Point3<f64>], mut idx: Vec<usize>) -> Self {
        // Morton order: blocks of 64 consecutive samples are compact.
        let (blo, bhi) = bounds(idx.iter().map(|&i| pts[i]));
        let ext_s = (bhi - blo).max().max(1e-12);
        let morton = |p: &Point3<f64>| {
            let q = (p - blo) / ext_s * 1023.0;
            let spread = |v: f64| {
                let mut x = (v.clamp(0.0, 1023.0) as u64) & 0x3ff;
                x = (x | (x << 16)) & 0x0300_00ff;
                x = (x | (x << 8)) & 0x0300_f00f;
                x = (x | (x << 4)) & 0x030c_30c3;
                (x | (x << 2)) & 0x0924_9249
            };
            spread(q.x) | (spread(q.y) << 1) | (spread(q.z) << 2)
        };
        idx.sort_by_key(|&i| (morton(&pts[i]), i));
        let blocks = idx
            .chunks(64)
            .map(|c| {
                let (lo, hi) = bounds(c.iter().map(|&i| pts[i]));
                [
                    lo.x as f32,
                    lo.y as f32,
                    lo.z as f32,
                    hi.x as f32,
                    hi.y as f32,
                    hi.z as f32,
                ]
            })
            .collect();
        Self {
            sx: idx.iter().map(|&i| pts[i].x as f32).collect(),
            sy: idx.iter().map(|&i| pts[i].y as f32).collect(),
            sz: idx.iter().map(|&i| pts[i].z as f32).collect(),
            blocks,
        }
    }

    fn len(&self) -> usize {
        self.sx.len()
    }
}

struct Problem {
    name: String,
    geom: LinkGeom,
    tol: f64,
    /// Covering radius of the dense lattice.
    delta_dense: f64,
    fit: Vec<Point3<f64>>,
    /// Coarse samples for the set cover.
    cover: CoverSamples,
    dense: Vec<Point3<f64>>,
    verify: Vec<Point3<f64>>,
    cands: Vec<Point3<f64>>,
    cand_d: Vec<f64>,
    /// Candidate grid step.
    step: f64,
    /// Smallest growth with which one candidate covers every coarse sample.
    alpha_one: f64,
    /// The candidate achieving `alpha_one`.
    one: usize,
    /// Sample spacing on sphere surfaces for protrusion measurements.
    probe: f64,
    /// Greedy covers computed so far, by growth.
    greedy_log: Mutex<Vec<(f64, GreedyResult)>>,
}

/// What a greedy cover at some growth gave.
#[derive(Debug, Clone)]
enum GreedyResult {
    /// The chosen candidates.
    Cover(Vec<usize>),
    /// More spheres than this limit were needed (or no cover exists).
    MoreThan(usize),
}

impl Problem {
    fn new(name: &str, geoms: &[Geometry], options: &SpherizeOptions) -> Result<Option<Self>> {
        let geom = LinkGeom::build(name, geoms)?;
        if geom.solids.is_empty() || geom.area.is_nan() || geom.area <= 0.0 {
            return Ok(None);
        }
        let delta_fit = geom.spacing_for(0.5 * options.sample_spacing, MAX_FIT_SAMPLES);
        let fit = geom.samples(delta_fit);
        if fit.is_empty() {
            return Ok(None);
        }
        let delta_dense =
            geom.spacing_for((0.95 * options.tolerance).min(delta_fit), MAX_DENSE_SAMPLES);
        let dense = geom.samples(delta_dense);
        let mut rng = StdRng::seed_from_u64(options.seed ^ fnv(name));
        let verify = geom.random_samples(VERIFY_SAMPLES, &mut rng);

        // Coarse samples for the set cover.
        let search: Vec<usize> = if fit.len() <= MAX_SEARCH_SAMPLES {
            (0..fit.len()).collect()
        } else {
            let mut cell = (geom.area / MAX_SEARCH_SAMPLES as f64).sqrt();
            loop {
                let s = voxel_subset(&fit, cell);
                if s.len() <= MAX_SEARCH_SAMPLES {
                    break s;
                }
                cell *= 1.15;
            }
        };
        let cover = CoverSamples::new(&fit, search);

        // Candidates: interior grid points, then a subset of surface points.
        let ext = (geom.hi - geom.lo).map(|e| e.max(delta_fit));
        let mut step = (ext.x * ext.y * ext.z / (2.0 * INTERIOR_CANDIDATES as f64)).cbrt();
        let mut cands = Vec::new();
        let mut cand_d = Vec::new();
        for _ in 0..6 {
            cands.clear();
            cand_d.clear();
            let n = ext.map(|e| ((e / step).ceil() as usize).max(1));
            if n.x * n.y * n.z > 200_000 {
                break;
            }
            let centre = nalgebra::center(&geom.lo, &geom.hi);
            for i in 0..n.x {
                for j in 0..n.y {
                    for k in 0..n.z {
                        let off = Vector3::new(i as f64, j as f64, k as f64)
                            - (n.cast::<f64>() - Vector3::repeat(1.0)) * 0.5;
                        let p = centre + off * step;
                        let d = geom.depth(&p);
                        if d > 0.0 {
                            cands.push(p);
                            cand_d.push(d);
                        }
                    }
                }
            }
            if cands.len() >= INTERIOR_CANDIDATES / 3 || step < delta_fit {
                break;
            }
            step /= 1.6;
        }
        let surf_cell = (geom.area / SURFACE_CANDIDATES as f64).sqrt();
        for i in voxel_subset(&fit, surf_cell) {
            cands.push(fit[i]);
            cand_d.push(geom.depth(&fit[i]));
        }

        let mut problem = Self {
            name: name.to_string(),
            tol: options.tolerance,
            delta_dense,
            fit,
            cover,
            dense,
            verify,
            cands,
            cand_d,
            step,
            alpha_one: 0.0,
            one: 0,
            probe: (0.5 * options.sample_spacing).max(delta_fit),
            greedy_log: Mutex::new(Vec::new()),
            geom,
        };
        let (one, alpha_one) = problem
            .cands
            .iter()
            .zip(&problem.cand_d)
            .map(|(c, d)| problem.max_dist2_search(c).sqrt() - d)
            .enumerate()
            .fold(
                (0, f64::INFINITY),
                |b, (i, a)| if a < b.1 { (i, a) } else { b },
            );
        problem.one = one;
        problem.alpha_one = alpha_one.max(0.0);
        Ok(Some(problem))
    }

    fn max_dist2_search(&self, c: &Point3<f64>) -> f64 {
        let (cx, cy, cz) = (c.x as f32, c.y as f32, c.z as f32);
        let mut m = 0.0f32;
        for ((x, y), z) in self.cover.sx.iter().zip(&self.cover.sy).zip(&self.cover.sz) {
            let (dx, dy, dz) = (x - cx, y - cy, z - cz);
            m = m.max(dx * dx + dy * dy + dz * dz);
        }
        m as f64
    }

    /// Greedy cover of the coarse samples by candidate spheres of radius
    /// `depth + alpha`: the chosen candidates, or `None` when they would be
    /// more than `limit` or some sample cannot be covered.
    fn greedy(&self, alpha: f64, limit: usize) -> Option<Vec<usize>> {
        self.greedy_over(&self.cover, &self.cands, &self.cand_d, alpha, limit)
    }

    /// [`Self::greedy`] over the candidate centres `cands` of depths `cand_d`.
    fn greedy_over(
        &self,
        samples: &CoverSamples,
        cands: &[Point3<f64>],
        cand_d: &[f64],
        alpha: f64,
        limit: usize,
    ) -> Option<Vec<usize>> {
        let n = samples.len();
        let words = n.div_ceil(64);
        let mut rows: Vec<u64> = Vec::new();
        let mut ids: Vec<usize> = Vec::new();
        let mut union = vec![0u64; words];
        let mut row = vec![0u64; words];
        for (ci, (c, d)) in cands.iter().zip(cand_d).enumerate() {
            let r = d + alpha;
            if r <= 0.0 {
                continue;
            }
            let r2 = ((r * (1.0 + 1e-6) + 1e-9) as f32).powi(2);
            let (cx, cy, cz) = (c.x as f32, c.y as f32, c.z as f32);
            let mut any = 0u64;
            for ((w, word), b) in row.iter_mut().enumerate().zip(&samples.blocks) {
                let start = w * 64;
                let end = (start + 64).min(n);
                let (mut dmin, mut dmax) = (0.0f32, 0.0f32);
                for (c, (lo, hi)) in [cx, cy, cz].into_iter().zip(b[..3].iter().zip(&b[3..])) {
                    let out = (lo - c).max(c - hi).max(0.0);
                    let far = (c - lo).abs().max((hi - c).abs());
                    dmin += out * out;
                    dmax += far * far;
                }
                if dmin > r2 {
                    *word = 0;
                    continue;
                }
                if dmax <= r2 {
                    *word = if end - start == 64 {
                        u64::MAX
                    } else {
                        (1u64 << (end - start)) - 1
                    };
                    any |= *word;
                    continue;
                }
                let mut bits = 0u64;
                for (b, i) in (start..end).enumerate() {
                    let (dx, dy, dz) = (samples.sx[i] - cx, samples.sy[i] - cy, samples.sz[i] - cz);
                    bits |= u64::from(dx * dx + dy * dy + dz * dz <= r2) << b;
                }
                *word = bits;
                any |= bits;
            }
            if any != 0 {
                for (u, w) in union.iter_mut().zip(&row) {
                    *u |= w;
                }
                rows.extend_from_slice(&row);
                ids.push(ci);
            }
        }
        let covered_all: u32 = union.iter().map(|w| w.count_ones()).sum();
        if covered_all as usize != n {
            return None;
        }
        let row_of = |k: usize| &rows[k * words..(k + 1) * words];
        let mut heap: BinaryHeap<(u32, Reverse<usize>)> = (0..ids.len())
            .map(|k| (row_of(k).iter().map(|w| w.count_ones()).sum(), Reverse(k)))
            .collect();
        let mut covered = vec![0u64; words];
        let mut remaining = n;
        let mut chosen: Vec<usize> = Vec::new();
        while remaining > 0 {
            if chosen.len() >= limit {
                return None;
            }
            let k = loop {
                let (cnt, Reverse(k)) = heap.pop()?;
                let fresh: u32 = row_of(k)
                    .iter()
                    .zip(&covered)
                    .map(|(r, c)| (r & !c).count_ones())
                    .sum();
                if fresh == cnt {
                    break k;
                }
                if fresh > 0 {
                    heap.push((fresh, Reverse(k)));
                }
            };
            for (c, r) in covered.iter_mut().zip(row_of(k)) {
                remaining -= (r & !*c).count_ones() as usize;
                *c |= r;
            }
            chosen.push(k);
        }
        // Drop spheres whose samples others cover too (latest first).
        let mut count = vec![0u16; n];
        let bits = |k: usize| {
            row_of(k).iter().enumerate().flat_map(|(w, &word)| {
                (0..64)
                    .filter(move |b| word >> b & 1 == 1)
                    .map(move |b| w * 64 + b)
            })
        };
        for &k in &chosen {
            for i in bits(k) {
                count[i] = count[i].saturating_add(1);
            }
        }
        let mut keep = vec![true; chosen.len()];
        for idx in (0..chosen.len()).rev() {
            if bits(chosen[idx]).all(|i| count[i] >= 2) {
                keep[idx] = false;
                for i in bits(chosen[idx]) {
                    count[i] -= 1;
                }
            }
        }
        Some(
            chosen
                .iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(&k, _)| ids[k])
                .collect(),
        )
    }

    /// The smallest growth (binary search) whose greedy cover has at most
    /// `k` spheres, and that cover. Earlier searches narrow the bracket.
    fn alpha_for(&self, k: usize) -> (f64, Vec<usize>) {
        let k = k.max(1);
        let (mut lo, mut hi, mut best) = (0.0, self.alpha_one, None);
        {
            let log = self.greedy_log.lock().unwrap_or_else(|e| e.into_inner());
            for (alpha, result) in log.iter() {
                match result {
                    GreedyResult::Cover(c) if c.len() <= k && *alpha < hi => {
                        hi = *alpha;
                        best = Some(c.clone());
                    }
                    GreedyResult::Cover(c) if c.len() > k => lo = f64::max(lo, *alpha),
                    GreedyResult::MoreThan(limit) if *limit >= k => lo = f64::max(lo, *alpha),
                    _ => {}
                }
            }
        }
        if lo >= hi {
            // The greedy count is not monotone in the growth: search afresh.
            (lo, hi, best) = (0.0, self.alpha_one, None);
        }
        if best.is_none() {
            // One sphere always fits (float rounding aside: then the best candidate alone).
            best = Some(self.greedy_logged(hi, k).unwrap_or_else(|| vec![self.one]));
        }
        while hi - lo > (5e-5f64).max(0.005 * hi) {
            let mid = 0.5 * (lo + hi);
            match self.greedy_logged(mid, k) {
                Some(s) => {
                    hi = mid;
                    best = Some(s);
                }
                None => lo = mid,
            }
        }
        (hi, best.unwrap_or_default())
    }

    /// [`Self::greedy`], remembered for later searches.
    fn greedy_logged(&self, alpha: f64, limit: usize) -> Option<Vec<usize>> {
        let r = self.greedy(alpha, limit);
        let entry = match &r {
            Some(c) => GreedyResult::Cover(c.clone()),
            None => GreedyResult::MoreThan(limit),
        };
        self.greedy_log
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push((alpha, entry));
        r
    }

    /// max |p − c| − depth(c) over the fit samples `pts`: a bound on how far
    /// the sphere at `c` holding `pts` sticks out of the geometry.
    fn objective(&self, c: &Point3<f64>, pts: &[usize]) -> f64 {
        self.max_dist(c, pts) - self.geom.fast_depth(c)
    }

    fn max_dist(&self, c: &Point3<f64>, pts: &[usize]) -> f64 {
        pts.iter()
            .map(|&i| (self.fit[i] - c).norm_squared())
            .fold(0.0, f64::max)
            .sqrt()
    }

    /// Moves the centre of one sphere (pattern search over 26 directions,
    /// first steps `step`) to minimise [`Self::objective`] over the fit
    /// samples `pts`. The search runs on an active set of the farthest
    /// samples, grown until it holds the farthest sample of the result.
    fn optimize_centre(
        &self,
        c0: Point3<f64>,
        pts: &[usize],
        dirs: &[Vector3<f64>],
        step: f64,
    ) -> Point3<f64> {
        const CHUNK: usize = 48;
        let farthest = |c: &Point3<f64>, n: usize| -> Vec<usize> {
            let mut v: Vec<(f64, usize)> = pts
                .iter()
                .map(|&i| ((self.fit[i] - c).norm_squared(), i))
                .collect();
            if v.len() > n {
                v.select_nth_unstable_by(n, |a, b| b.0.total_cmp(&a.0));
                v.truncate(n);
            }
            v.into_iter().map(|(_, i)| i).collect()
        };
        let mut active = farthest(&c0, CHUNK);
        let mut c = c0;
        let mut step = step;
        for _ in 0..8 {
            c = self.pattern_search(c, &active, dirs, step);
            step = 0.25 * self.step;
            let max_active = active
                .iter()
                .map(|&i| (self.fit[i] - c).norm_squared())
                .fold(0.0, f64::max);
            let mut extra: Vec<usize> = farthest(&c, CHUNK)
                .into_iter()
                .filter(|&i| (self.fit[i] - c).norm_squared() > max_active)
                .collect();
            if extra.is_empty() {
                break;
            }
            active.append(&mut extra);
        }
        c
    }

    /// Best-move pattern search; a depth query is skipped when the depth's
    /// 1-Lipschitz bound already rules the move out.
    fn pattern_search(
        &self,
        c0: Point3<f64>,
        pts: &[usize],
        dirs: &[Vector3<f64>],
        step: f64,
    ) -> Point3<f64> {
        let mut c = c0;
        let mut depth = self.geom.fast_depth(&c);
        let mut fc = self.max_dist(&c, pts) - depth;
        let mut step = step.max(1e-4);
        let min_step = 1e-4f64.min(0.1 * self.delta_dense);
        let mut sweeps = 0;
        while step > min_step && sweeps < 200 {
            sweeps += 1;
            let mut best: Option<(f64, Point3<f64>, f64)> = None;
            for d in dirs {
                let cn = c + d * step;
                let m = self.max_dist(&cn, pts);
                let bar = best.map_or(fc, |b| b.0) - 1e-12;
                if m - (depth + step) >= bar {
                    continue;
                }
                let dn = self.geom.fast_depth(&cn);
                if m - dn < bar {
                    best = Some((m - dn, cn, dn));
                }
            }
            match best {
                Some((f, cn, dn)) => (fc, c, depth) = (f, cn, dn),
                None => step *= 0.5,
            }
        }
        c
    }

    /// Assigns each fit sample to the sphere needing the least growth.
    fn assign(&self, centres: &[Point3<f64>]) -> Vec<Vec<usize>> {
        let depths: Vec<f64> = centres.iter().map(|c| self.geom.fast_depth(c)).collect();
        let mut groups = vec![Vec::new(); centres.len()];
        for (i, p) in self.fit.iter().enumerate() {
            let j = (0..centres.len())
                .min_by(|&a, &b| {
                    ((p - centres[a]).norm() - depths[a])
                        .total_cmp(&((p - centres[b]).norm() - depths[b]))
                })
                .unwrap_or(0);
            groups[j].push(i);
        }
        groups
    }

    /// Lloyd-style refinement of the chosen candidates: centres.
    fn refine(&self, chosen: &[usize]) -> Vec<Point3<f64>> {
        self.refine_centres(chosen.iter().map(|&i| self.cands[i]).collect())
    }

    fn refine_centres(&self, mut centres: Vec<Point3<f64>>) -> Vec<Point3<f64>> {
        let dirs = directions();
        let score = |cs: &[Point3<f64>], groups: &[Vec<usize>]| -> (f64, f64) {
            let f: Vec<f64> = cs
                .iter()
                .zip(groups)
                .filter(|(_, g)| !g.is_empty())
                .map(|(c, g)| self.objective(c, g))
                .collect();
            (f.iter().copied().fold(0.0, f64::max), f.iter().sum())
        };
        let mut groups = self.assign(&centres);
        let mut best_score = score(&centres, &groups);
        for round in 0..5 {
            let step = self.step * 0.5f64.powi(round);
            let moved: Vec<Point3<f64>> = centres
                .iter()
                .zip(&groups)
                .filter(|(_, g)| !g.is_empty())
                .map(|(c, g)| self.optimize_centre(*c, g, &dirs, step))
                .collect();
            let new_groups = self.assign(&moved);
            let s = score(&moved, &new_groups);
            if s.0 > best_score.0 + 1e-9
                || (s.0 >= best_score.0 - 1e-9 && s.1 >= best_score.1 - 1e-9)
            {
                break;
            }
            let shift = moved
                .iter()
                .zip(&centres)
                .map(|(a, b)| (a - b).norm())
                .fold(0.0, f64::max);
            centres = moved;
            groups = new_groups;
            best_score = s;
            if shift < 1e-5 {
                break;
            }
        }
        centres
            .into_iter()
            .zip(&groups)
            .filter(|(_, g)| !g.is_empty())
            .map(|(c, _)| c)
            .collect()
    }

    /// Bound of each sphere (objective over its assigned samples) and the groups.
    fn scores(&self, centres: &[Point3<f64>]) -> (Vec<f64>, Vec<Vec<usize>>) {
        let groups = self.assign(centres);
        let f = centres
            .iter()
            .zip(&groups)
            .map(|(c, g)| {
                if g.is_empty() {
                    0.0
                } else {
                    self.objective(c, g)
                }
            })
            .collect();
        (f, groups)
    }

    /// Replaces the sphere with the largest bound by two (its samples split
    /// between their two mutually farthest points, each half given the best
    /// candidate centre), refines, and returns the result if the largest
    /// bound went down.
    fn split_worst(&self, centres: &[Point3<f64>]) -> Option<Vec<Point3<f64>>> {
        let (f, groups) = self.scores(centres);
        let worst = f.iter().copied().fold(0.0, f64::max);
        let w = (0..centres.len()).max_by(|&a, &b| f[a].total_cmp(&f[b]))?;
        let g = &groups[w];
        let far = |from: &Point3<f64>| {
            g.iter().copied().max_by(|&a, &b| {
                (self.fit[a] - from)
                    .norm_squared()
                    .total_cmp(&(self.fit[b] - from).norm_squared())
            })
        };
        let p1 = self.fit[far(&centres[w])?];
        let p2 = self.fit[far(&p1)?];
        let (h1, h2): (Vec<usize>, Vec<usize>) = g.iter().partition(|&&i| {
            (self.fit[i] - p1).norm_squared() <= (self.fit[i] - p2).norm_squared()
        });
        if h1.is_empty() || h2.is_empty() {
            return None;
        }
        let best_for = |h: &[usize]| {
            self.cands
                .iter()
                .zip(&self.cand_d)
                .map(|(c, d)| {
                    let m2 = h
                        .iter()
                        .map(|&i| (self.fit[i] - c).norm_squared())
                        .fold(0.0, f64::max);
                    (m2.sqrt() - d, *c)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|x| x.1)
        };
        let mut next: Vec<Point3<f64>> = centres.to_vec();
        next[w] = best_for(&h1)?;
        next.push(best_for(&h2)?);
        let next = self.refine_centres(next);
        let (f2, _) = self.scores(&next);
        (next.len() > centres.len() && f2.iter().copied().fold(0.0, f64::max) < worst - 1e-6)
            .then_some(next)
    }

    /// Conservative radii on the dense lattice: grow to hold every sample,
    /// then shrink each sphere to the samples only it holds.
    fn finalize(&self, centres: &[Point3<f64>]) -> Vec<Sphere> {
        let k = centres.len();
        if k == 0 {
            return Vec::new();
        }
        // A dense sample held by a sphere (within `slack`) is within the
        // tolerance for every surface point near it.
        let slack = self.tol - self.delta_dense;
        let depths: Vec<f64> = centres.iter().map(|c| self.geom.depth(c)).collect();
        let groups = self.assign(centres);
        let mut radii: Vec<f64> = centres
            .iter()
            .zip(&groups)
            .map(|(c, g)| {
                g.iter()
                    .map(|&i| (self.fit[i] - c).norm())
                    .fold(0.0, f64::max)
                    - slack
            })
            .collect();
        let dist = |i: usize, j: usize| (self.dense[i] - centres[j]).norm();
        for i in 0..self.dense.len() {
            if (0..k).any(|j| dist(i, j) <= radii[j] + slack) {
                continue;
            }
            let j = (0..k)
                .min_by(|&a, &b| (dist(i, a) - depths[a]).total_cmp(&(dist(i, b) - depths[b])))
                .unwrap_or(0);
            radii[j] = dist(i, j) - slack;
        }
        // Shrink, most protruding first.
        let mut count = vec![0u16; self.dense.len()];
        for (i, c) in count.iter_mut().enumerate() {
            *c = (0..k).filter(|&j| dist(i, j) <= radii[j] + slack).count() as u16;
        }
        let mut order: Vec<usize> = (0..k).collect();
        order.sort_by(|&a, &b| {
            (radii[b] - depths[b])
                .total_cmp(&(radii[a] - depths[a]))
                .then(a.cmp(&b))
        });
        let mut alive = vec![true; k];
        for &j in &order {
            let needed = (0..self.dense.len())
                .filter(|&i| count[i] == 1 && dist(i, j) <= radii[j] + slack)
                .map(|i| dist(i, j))
                .fold(f64::NEG_INFINITY, f64::max);
            let new_r = if needed == f64::NEG_INFINITY {
                alive[j] = false;
                f64::NEG_INFINITY
            } else {
                needed - slack
            };
            for (i, c) in count.iter_mut().enumerate() {
                let d = dist(i, j);
                if d <= radii[j] + slack && d > new_r + slack {
                    *c -= 1;
                }
            }
            radii[j] = new_r;
        }
        // Near-duplicates: drop a sphere when the others hold the samples
        // only it holds after growing by at most a quarter of the tolerance.
        let merge = 0.25 * self.tol;
        loop {
            let mut best: Option<(f64, usize)> = None;
            for j in (0..k).filter(|&j| alive[j]) {
                let mut growth = 0.0f64;
                for i in (0..self.dense.len())
                    .filter(|&i| count[i] == 1 && dist(i, j) <= radii[j] + slack)
                {
                    let g = (0..k)
                        .filter(|&l| l != j && alive[l])
                        .map(|l| dist(i, l) - radii[l] - slack)
                        .fold(f64::INFINITY, f64::min);
                    growth = growth.max(g);
                    if growth > merge {
                        break;
                    }
                }
                if growth <= merge && best.is_none_or(|b| growth < b.0) {
                    best = Some((growth, j));
                }
            }
            let Some((_, j)) = best else {
                break;
            };
            alive[j] = false;
            let orphans: Vec<usize> = (0..self.dense.len())
                .filter(|&i| count[i] == 1 && dist(i, j) <= radii[j] + slack)
                .collect();
            for i in orphans {
                let l = (0..k)
                    .filter(|&l| alive[l])
                    .min_by(|&a, &b| (dist(i, a) - radii[a]).total_cmp(&(dist(i, b) - radii[b])))
                    .unwrap_or(j);
                radii[l] = radii[l].max(dist(i, l) - slack);
            }
            for (i, c) in count.iter_mut().enumerate() {
                *c = (0..k)
                    .filter(|&l| alive[l] && dist(i, l) <= radii[l] + slack)
                    .count() as u16;
            }
        }
        centres
            .iter()
            .zip(&radii)
            .zip(&alive)
            .filter(|(_, a)| **a)
            .map(|((c, &r), _)| Sphere::new(*c, r.max(1e-9)))
            .collect()
    }

    /// The fewest-protrusion spheres found with at most `k` spheres.
    fn solve_count(&self, k: usize) -> Solution {
        let (_, chosen) = self.alpha_for(k.max(1));
        let mut centres = self.refine(&chosen);
        // The greedy count may fall short of `k`: split the worst sphere.
        while centres.len() < k {
            match self.split_worst(&centres) {
                Some(c) => centres = c,
                None => break,
            }
        }
        let spheres = self.finalize(&centres);
        let (_, max) = self.protrusion(&spheres, DECISION_PROBES);
        Solution { spheres, max }
    }

    /// Candidate centres for [`Self::solve_bounded`] with growth `alpha`:
    /// the fitting candidates, every coarse (set-cover) sample, and a grid
    /// inside the geometry with a step of about `alpha / 2` (at most
    /// [`BOUNDED_GRID`] points evaluated), with their depths.
    fn bounded_candidates(&self, alpha: f64) -> (Vec<Point3<f64>>, Vec<f64>) {
        let mut cands = self.cands.clone();
        let mut cand_d = self.cand_d.clone();
        let ext = self.geom.hi - self.geom.lo;
        let mut step = (0.5 * alpha).max(self.delta_dense);
        let count = |step: f64| ext.map(|e| (e / step).ceil() as usize + 1);
        while {
            let n = count(step);
            n.x * n.y * n.z > BOUNDED_GRID
        } {
            step *= 1.1;
        }
        let n = count(step);
        let centre = nalgebra::center(&self.geom.lo, &self.geom.hi);
        let grid: Vec<Point3<f64>> = (0..n.x * n.y * n.z)
            .map(|idx| {
                let (i, j, k) = (idx / (n.y * n.z), (idx / n.z) % n.y, idx % n.z);
                let off = Vector3::new(i as f64, j as f64, k as f64)
                    - (n.cast::<f64>() - Vector3::repeat(1.0)) * 0.5;
                centre + off * step
            })
            .collect();
        let inside: Vec<(Point3<f64>, f64)> = grid
            .par_iter()
            .filter_map(|p| {
                // A point further from every shape's box than the growth
                // cannot be a useful centre.
                let d = self.geom.depth(p);
                (d > 0.0).then_some((*p, d))
            })
            .collect();
        for (p, d) in inside {
            cands.push(p);
            cand_d.push(d);
        }
        // Surface points (for thin or open geometry), about alpha / 2 apart.
        let surface: Vec<(Point3<f64>, f64)> = voxel_subset(&self.fit, 0.5 * alpha)
            .into_par_iter()
            .map(|i| (self.fit[i], self.geom.depth(&self.fit[i])))
            .collect();
        for (p, d) in surface {
            cands.push(p);
            cand_d.push(d);
        }
        (cands, cand_d)
    }

    /// Spheres that each stick out of the geometry by at most `alpha`, by
    /// construction: every sphere is centred at a point `c` of depth `d(c)`
    /// (a lower bound of the distance from `c` to the outside of the
    /// geometry, negative outside) with radius at most `d(c) + alpha`, so
    /// every point of it lies within `alpha` of the ball of radius `d(c)`
    /// around `c`, which the geometry holds. A greedy set cover of the
    /// coarse samples picks the centres, uncovered samples of the dense
    /// lattice get more spheres (greedily, the dense samples themselves
    /// being candidates), then every sphere shrinks, most protruding first,
    /// to the dense samples only it holds (and is dropped if there are
    /// none). Coverage is that of [`Self::finalize`]: every dense sample
    /// within `tol - delta_dense` of a sphere, so every surface point within
    /// `tol`. None when more than `cap` spheres would be needed.
    fn solve_bounded(&self, alpha: f64, cap: usize) -> Option<Solution> {
        let (cands, mut cand_d) = self.bounded_candidates(alpha);
        if self.geom.solids.iter().all(Solid::exact_inside) {
            return self.bounded_once(alpha, cap, &cands, &cand_d, &HashMap::new());
        }
        // A mesh whose inside is a voxel flood fill: depth is the distance
        // to the triangles, too large where a sealed crack or hole lets the
        // outside in. Every sphere is probed; a centre whose sphere sticks
        // out further than `alpha` gets its depth lowered by the excess,
        // and the cover is solved again.
        let mut lowered: HashMap<[u64; 3], f64> = HashMap::new();
        let key = |c: &Point3<f64>| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()];
        let mut best = None;
        for _ in 0..BOUNDED_ROUNDS {
            let sol = self.bounded_once(alpha, cap, &cands, &cand_d, &lowered)?;
            let excess: Vec<(Point3<f64>, f64)> = sol
                .spheres
                .par_iter()
                .filter_map(|s| {
                    let e = self.sphere_excess(s, 400);
                    (e > alpha + 1e-4).then_some((s.center, e - alpha))
                })
                .collect();
            best = Some(sol);
            if excess.is_empty() {
                break;
            }
            for (c, e) in excess {
                *lowered.entry(key(&c)).or_insert(0.0) += e + 1e-4;
            }
            for (c, d) in cands.iter().zip(cand_d.iter_mut()) {
                if let Some(e) = lowered.get(&key(c)) {
                    *d = self.geom.depth(c) - e;
                }
            }
        }
        best
    }

    /// How far the sphere `s` sticks out of the geometry, measured on `n`
    /// Fibonacci points of its surface.
    fn sphere_excess(&self, s: &Sphere, n: usize) -> f64 {
        let golden = PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
                let rho = (1.0 - z * z).max(0.0).sqrt();
                let t = golden * i as f64;
                let u = Vector3::new(rho * t.cos(), rho * t.sin(), z);
                -self.geom.depth(&(s.center + u * s.radius))
            })
            .fold(0.0, f64::max)
    }

    /// One solve of [`Self::solve_bounded`] with candidate depths `cand_d`
    /// and, for centres taken from the dense samples, the depth reductions
    /// `lowered` (keyed by the centre's bits).
    fn bounded_once(
        &self,
        alpha: f64,
        cap: usize,
        cands: &[Point3<f64>],
        cand_d: &[f64],
        lowered: &HashMap<[u64; 3], f64>,
    ) -> Option<Solution> {
        // The set cover runs on more samples than the count searches (fewer
        // gaps left for the dense repair).
        let search = if self.fit.len() <= BOUNDED_SEARCH_SAMPLES {
            (0..self.fit.len()).collect()
        } else {
            let mut cell = (self.geom.area / BOUNDED_SEARCH_SAMPLES as f64).sqrt();
            loop {
                let s = voxel_subset(&self.fit, cell);
                if s.len() <= BOUNDED_SEARCH_SAMPLES {
                    break s;
                }
                cell *= 1.1;
            }
        };
        let samples = CoverSamples::new(&self.fit, search);
        let chosen = self.greedy_over(&samples, cands, cand_d, alpha, cap)?;
        let mut centres: Vec<Point3<f64>> = chosen.iter().map(|&i| cands[i]).collect();
        let mut depths: Vec<f64> = chosen.iter().map(|&i| cand_d[i]).collect();
        let slack = self.tol - self.delta_dense;
        let holds = |c: &Point3<f64>, d: f64, p: &Point3<f64>| {
            (p - c).norm_squared() <= (d + alpha + slack).max(0.0).powi(2)
        };
        // Dense samples no sphere holds, repaired greedily.
        let mut open: Vec<usize> = (0..self.dense.len())
            .into_par_iter()
            .filter(|&i| {
                let p = &self.dense[i];
                !centres.iter().zip(&depths).any(|(c, &d)| holds(c, d, p))
            })
            .collect();
        while let Some(&first) = open.first() {
            if centres.len() >= cap {
                return None;
            }
            let u = self.dense[first];
            let du = self.geom.depth(&u)
                - lowered
                    .get(&[u.x.to_bits(), u.y.to_bits(), u.z.to_bits()])
                    .copied()
                    .unwrap_or(0.0);
            // Candidates holding `u`: the sample itself and the candidate
            // centres reaching it; the one holding the most open samples.
            let mut best = (0usize, u, du);
            let tries = std::iter::once((u, du)).chain(
                cands
                    .iter()
                    .zip(cand_d)
                    .filter(|(c, d)| holds(c, **d, &u))
                    .map(|(c, d)| (*c, *d)),
            );
            for (c, d) in tries {
                let n = open
                    .iter()
                    .filter(|&&i| holds(&c, d, &self.dense[i]))
                    .count();
                if n > best.0 {
                    best = (n, c, d);
                }
            }
            let (_, c, d) = best;
            open.retain(|&i| !holds(&c, d, &self.dense[i]));
            centres.push(c);
            depths.push(d);
        }
        // Radii: d + alpha, then shrunk to what only each sphere holds.
        let k = centres.len();
        let mut radii: Vec<f64> = depths.iter().map(|d| (d + alpha).max(0.0)).collect();
        let dist = |i: usize, j: usize| (self.dense[i] - centres[j]).norm();
        let holders = |alive: &[bool], radii: &[f64]| -> Vec<u16> {
            (0..self.dense.len())
                .into_par_iter()
                .map(|i| {
                    (0..k)
                        .filter(|&j| alive[j] && dist(i, j) <= radii[j] + slack)
                        .count()
                        .min(u16::MAX as usize) as u16
                })
                .collect()
        };
        // Spheres whose dense samples the others hold too (at full radius):
        // dropped, those holding fewest first.
        let mut alive = vec![true; k];
        let mut count = holders(&alive, &radii);
        let held: Vec<Vec<usize>> = (0..k)
            .into_par_iter()
            .map(|j| {
                (0..self.dense.len())
                    .filter(|&i| dist(i, j) <= radii[j] + slack)
                    .collect()
            })
            .collect();
        let mut by_size: Vec<usize> = (0..k).collect();
        by_size.sort_by_key(|&j| (held[j].len(), j));
        for j in by_size {
            if held[j].iter().all(|&i| count[i] >= 2) {
                alive[j] = false;
                for &i in &held[j] {
                    count[i] -= 1;
                }
            }
        }
        drop(held);
        let mut order: Vec<usize> = (0..k).filter(|&j| alive[j]).collect();
        order.sort_by(|&a, &b| {
            (radii[b] - depths[b])
                .total_cmp(&(radii[a] - depths[a]))
                .then(a.cmp(&b))
        });
        for &j in &order {
            let r = radii[j];
            let needed = (0..self.dense.len())
                .into_par_iter()
                .filter(|&i| count[i] == 1 && dist(i, j) <= r + slack)
                .map(|i| dist(i, j))
                .reduce(|| f64::NEG_INFINITY, f64::max);
            let new_r = if needed == f64::NEG_INFINITY {
                alive[j] = false;
                f64::NEG_INFINITY
            } else {
                (needed - slack).max(0.0).min(r)
            };
            count.par_iter_mut().enumerate().for_each(|(i, c)| {
                let d = dist(i, j);
                if d <= r + slack && d > new_r + slack {
                    *c -= 1;
                }
            });
            radii[j] = new_r;
        }
        let spheres: Vec<Sphere> = centres
            .iter()
            .zip(&radii)
            .zip(&alive)
            .filter(|(_, a)| **a)
            .map(|((c, &r), _)| Sphere::new(*c, r.max(1e-9)))
            .collect();
        let (_, max) = self.protrusion(&spheres, DECISION_PROBES);
        Some(Solution { spheres, max })
    }

    /// The bounded model ([`Self::solve_bounded`] at
    /// [`AUTO_MAX_PROTRUSION`]); if that needs more than `cap` spheres, the
    /// smallest count whose measured maximum protrusion is at most the
    /// target (binary search below the greedy count at that bound), within
    /// `cap`; the least protruding try when none is.
    fn solve_auto(&self, cap: Option<usize>) -> Solution {
        let cap = cap.unwrap_or(AUTO_MAX_COUNT).max(1);
        let target = AUTO_MAX_PROTRUSION;
        if let Some(s) = self.solve_bounded(target, cap) {
            return s;
        }
        let mut k = self
            .greedy_logged(target, cap)
            .map_or(cap, |s| s.len())
            .clamp(1, cap);
        let mut best = self.solve_count(k);
        for _ in 0..4 {
            if best.max <= target || k >= cap {
                break;
            }
            k = (k + 1 + k / 4).min(cap);
            let s = self.solve_count(k);
            if s.max < best.max {
                best = s;
            }
        }
        if best.max > target {
            return best;
        }
        let (mut lo, mut hi) = (0, best.spheres.len());
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            let s = self.solve_count(mid);
            if s.max <= target {
                hi = s.spheres.len().min(mid);
                best = s;
            } else {
                lo = mid;
            }
        }
        best
    }

    /// Mean and max protrusion, measured on up to `max_pts` points per sphere.
    fn protrusion(&self, spheres: &[Sphere], max_pts: usize) -> (f64, f64) {
        const REFINED: usize = 6;
        let golden = PI * (3.0 - 5f64.sqrt());
        // Protrusion of the point of sphere `j` in direction `u`, if it is on
        // the boundary of the union.
        let probe = |j: usize, u: &Vector3<f64>| -> Option<f64> {
            let s = &spheres[j];
            let x = s.center + u * s.radius;
            let buried = spheres
                .iter()
                .enumerate()
                .any(|(l, o)| l != j && (x - o.center).norm() < o.radius - 1e-9);
            (!buried).then(|| -self.geom.depth(&x))
        };
        let (mut sum, mut n, mut max) = (0.0, 0usize, 0.0f64);
        let mut top: Vec<(f64, usize, Vector3<f64>, f64)> = Vec::new();
        for (j, s) in spheres.iter().enumerate() {
            let m = ((4.0 * PI * s.radius * s.radius / (self.probe * self.probe)).ceil() as usize)
                .clamp(64, max_pts.max(64));
            let spacing = (4.0 * PI / m as f64).sqrt();
            for i in 0..m {
                let z = 1.0 - (2.0 * i as f64 + 1.0) / m as f64;
                let rho = (1.0 - z * z).max(0.0).sqrt();
                let t = golden * i as f64;
                let u = Vector3::new(rho * t.cos(), rho * t.sin(), z);
                if let Some(p) = probe(j, &u).filter(|p| *p > 0.0) {
                    sum += p;
                    n += 1;
                    max = max.max(p);
                    if top.len() < REFINED || p > top[REFINED - 1].0 {
                        top.push((p, j, u, spacing));
                        top.sort_by(|a, b| b.0.total_cmp(&a.0));
                        top.truncate(REFINED);
                    }
                }
            }
        }
        // Local ascent from the most protruding samples (the maximum lies
        // between samples).
        for (mut p, j, mut u, spacing) in top {
            let mut angle = 0.5 * spacing;
            while angle > 1e-4 {
                let t1 = u
                    .cross(&if u.x.abs() < 0.9 {
                        Vector3::x()
                    } else {
                        Vector3::y()
                    })
                    .normalize();
                let t2 = u.cross(&t1);
                let mut moved = false;
                for k in 0..8 {
                    let phi = PI / 4.0 * k as f64;
                    let un = (u * angle.cos() + (t1 * phi.cos() + t2 * phi.sin()) * angle.sin())
                        .normalize();
                    if let Some(q) = probe(j, &un).filter(|q| *q > p) {
                        (p, u, moved) = (q, un, true);
                    }
                }
                if !moved {
                    angle *= 0.5;
                }
            }
            max = max.max(p);
        }
        (if n > 0 { sum / n as f64 } else { 0.0 }, max)
    }

    fn report(&self, spheres: &[Sphere]) -> LinkSphereReport {
        let covered = self
            .verify
            .iter()
            .filter(|p| {
                spheres
                    .iter()
                    .any(|s| (*p - s.center).norm() <= s.radius + self.tol)
            })
            .count();
        let coverage = if self.verify.is_empty() {
            1.0
        } else {
            covered as f64 / self.verify.len() as f64
        };
        let (mean, max) = self.protrusion(spheres, REPORT_PROBES);
        LinkSphereReport {
            link: self.name.clone(),
            spheres: spheres.len(),
            coverage,
            mean_protrusion: mean,
            max_protrusion: max,
        }
    }
}

/// FNV-1a hash of a link name (per-link seeds).
fn fnv(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use nalgebra::{Translation3, UnitQuaternion};

    use super::*;

    fn geom(shape: Shape, origin: Isometry3<f64>) -> Geometry {
        Geometry {
            name: None,
            origin,
            shape,
            rgba: None,
        }
    }

    fn pose() -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(0.1, -0.2, 0.3),
            UnitQuaternion::from_euler_angles(0.3, -0.5, 1.1),
        )
    }

    /// Every point lies within `tol` of a sphere.
    fn assert_covered(spheres: &[Sphere], points: &[Point3<f64>], tol: f64) {
        for p in points {
            let gap = spheres
                .iter()
                .map(|s| (p - s.center).norm() - s.radius)
                .fold(f64::INFINITY, f64::min);
            assert!(gap <= tol + 1e-12, "{p:?} is {gap} outside the spheres");
        }
    }

    /// A regular grid on the faces of a box (its own frame), then posed.
    fn box_grid(e: Vector3<f64>, n: usize, pose: &Isometry3<f64>) -> Vec<Point3<f64>> {
        let mut out = Vec::new();
        for a in 0..3 {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            for s in [-1.0, 1.0] {
                for i in 0..=n {
                    for j in 0..=n {
                        let mut p = Point3::origin();
                        p[a] = s * e[a];
                        p[u] = e[u] * (2.0 * i as f64 / n as f64 - 1.0);
                        p[v] = e[v] * (2.0 * j as f64 / n as f64 - 1.0);
                        out.push(pose * p);
                    }
                }
            }
        }
        out
    }

    /// Coarser than the defaults: the tests run unoptimised.
    fn small() -> SpherizeOptions {
        SpherizeOptions {
            tolerance: 0.002,
            sample_spacing: 0.01,
            ..Default::default()
        }
    }

    #[test]
    fn a_sphere_gives_itself() {
        let opts = SpherizeOptions {
            tolerance: 0.001,
            ..small()
        };
        let g = [geom(Shape::Sphere { radius: 0.03 }, pose())];
        for budget in [None, Some(3)] {
            let (s, r) = spherize_link("ball", &g, budget, &opts).unwrap();
            assert_eq!(s.len(), 1, "budget {budget:?}: {s:?}");
            assert!((s[0].center - Point3::new(0.1, -0.2, 0.3)).norm() <= opts.tolerance);
            assert!((s[0].radius - 0.03).abs() <= opts.tolerance);
            assert_eq!(r.spheres, 1);
            assert_eq!(r.coverage, 1.0);
            assert!(r.max_protrusion <= opts.tolerance);
        }
    }

    #[test]
    fn a_box_is_covered_on_an_analytic_grid() {
        let opts = small();
        let e = Vector3::new(0.04, 0.025, 0.015);
        let g = [geom(Shape::Box { half_extents: e }, pose())];
        let (s, r) = spherize_link("box", &g, Some(4), &opts).unwrap();
        assert!(!s.is_empty() && s.len() <= 4);
        assert_eq!(r.coverage, 1.0);
        assert_covered(&s, &box_grid(e, 60, &pose()), opts.tolerance);
        // Deterministic.
        assert_eq!(spherize_link("box", &g, Some(4), &opts).unwrap(), (s, r));
    }

    #[test]
    fn a_capsule_is_covered_on_an_analytic_grid() {
        let opts = small();
        let (radius, length) = (0.02, 0.06);
        let g = [geom(Shape::capsule_from_length(radius, length), pose())];
        let (s, r) = spherize_link("capsule", &g, None, &opts).unwrap();
        assert!(!s.is_empty() && s.len() <= 6, "{} spheres", s.len());
        assert_eq!(r.coverage, 1.0);
        assert!(r.max_protrusion <= AUTO_MAX_PROTRUSION);
        let mut pts = Vec::new();
        for i in 0..72 {
            let t = 2.0 * PI * (i as f64 + 0.5) / 72.0;
            for j in 0..=40 {
                let z = length * (j as f64 / 40.0 - 0.5);
                pts.push(Point3::new(radius * t.cos(), radius * t.sin(), z));
            }
            for j in 0..=20 {
                let phi = 0.5 * PI * j as f64 / 20.0;
                let (rho, h) = (radius * phi.sin(), radius * phi.cos());
                pts.push(Point3::new(rho * t.cos(), rho * t.sin(), 0.5 * length + h));
                pts.push(Point3::new(rho * t.cos(), rho * t.sin(), -0.5 * length - h));
            }
        }
        let pts: Vec<_> = pts.iter().map(|p| pose() * p).collect();
        assert_covered(&s, &pts, opts.tolerance);
    }

    fn cube_mesh(open: bool) -> Shape {
        let v = [
            [0.0, 0.0, 0.0],
            [0.04, 0.0, 0.0],
            [0.04, 0.04, 0.0],
            [0.0, 0.04, 0.0],
            [0.0, 0.0, 0.04],
            [0.04, 0.0, 0.04],
            [0.04, 0.04, 0.04],
            [0.0, 0.04, 0.04],
        ];
        let mut t = vec![
            [0, 2, 1],
            [0, 3, 2],
            [0, 1, 5],
            [0, 5, 4],
            [1, 2, 6],
            [1, 6, 5],
            [2, 3, 7],
            [2, 7, 6],
            [3, 0, 4],
            [3, 4, 7],
        ];
        if !open {
            t.extend([[4, 5, 6], [4, 6, 7]]);
        }
        Shape::Mesh(Arc::new(ferrobot_model::Mesh::from_shared(
            Arc::new(ferrobot_model::TriMesh {
                vertices: v.iter().map(|p| Point3::new(p[0], p[1], p[2])).collect(),
                triangles: t,
            }),
            Vector3::new(1.0, 1.0, 1.5),
            None,
        )))
    }

    #[test]
    fn meshes_closed_and_open_are_covered() {
        let opts = small();
        let e = Vector3::new(0.02, 0.02, 0.03);
        let centre = pose() * Isometry3::translation(0.02, 0.02, 0.03);
        for open in [false, true] {
            let g = [geom(cube_mesh(open), pose())];
            let (s, r) = spherize_link("cube", &g, Some(6), &opts).unwrap();
            assert!(!s.is_empty() && s.len() <= 6);
            assert_eq!(r.coverage, 1.0);
            let pts: Vec<_> = box_grid(e, 40, &centre)
                .into_iter()
                .filter(|p| !open || (centre.inverse() * p).z < 0.03 - 1e-9)
                .collect();
            assert_covered(&s, &pts, opts.tolerance);
        }
    }

    #[test]
    fn mixed_geometry_and_odd_meshes() {
        let opts = small();
        let g = [
            geom(
                Shape::Box {
                    half_extents: Vector3::new(0.03, 0.02, 0.01),
                },
                pose(),
            ),
            geom(
                Shape::Sphere { radius: 0.015 },
                pose() * Isometry3::translation(0.03, 0.0, 0.0),
            ),
            geom(
                Shape::Cylinder {
                    radius: 0.01,
                    half_height: 0.025,
                },
                pose(),
            ),
        ];
        let (s, r) = spherize_link("mixed", &g, Some(5), &opts).unwrap();
        assert!(!s.is_empty() && s.len() <= 5);
        assert_eq!(r.coverage, 1.0);
        // Only degenerate triangles, or nothing with area: no spheres.
        let flat = Shape::Mesh(Arc::new(ferrobot_model::Mesh::from_shared(
            Arc::new(ferrobot_model::TriMesh {
                vertices: vec![
                    Point3::origin(),
                    Point3::new(0.1, 0.0, 0.0),
                    Point3::new(0.2, 0.0, 0.0),
                ],
                triangles: vec![[0, 1, 2], [0, 0, 1]],
            }),
            Vector3::repeat(1.0),
            None,
        )));
        for g in [
            geom(flat, pose()),
            geom(Shape::Sphere { radius: 0.0 }, pose()),
        ] {
            let (s, r) = spherize_link("nothing", &[g], None, &opts).unwrap();
            assert!(s.is_empty());
            assert_eq!((r.spheres, r.coverage), (0, 1.0));
        }
        assert!(
            spherize_link("empty", &[], None, &opts)
                .unwrap()
                .0
                .is_empty()
        );
        // Out-of-range indices and negative sizes are errors.
        let bad = Shape::Mesh(Arc::new(ferrobot_model::Mesh::from_shared(
            Arc::new(ferrobot_model::TriMesh {
                vertices: vec![Point3::origin()],
                triangles: vec![[0, 1, 2]],
            }),
            Vector3::repeat(1.0),
            None,
        )));
        for g in [
            geom(bad, pose()),
            geom(
                Shape::Box {
                    half_extents: Vector3::new(-1.0, 0.1, 0.1),
                },
                pose(),
            ),
        ] {
            assert!(matches!(
                spherize_link("bad", &[g], None, &opts),
                Err(CollisionError::InvalidShape(_))
            ));
        }
    }

    #[test]
    fn bad_options_are_rejected() {
        let g = [geom(Shape::Sphere { radius: 0.03 }, pose())];
        let cases = [
            (
                "tolerance",
                SpherizeOptions {
                    tolerance: 0.0,
                    ..small()
                },
            ),
            (
                "tolerance",
                SpherizeOptions {
                    tolerance: f64::NAN,
                    ..small()
                },
            ),
            (
                "sample_spacing",
                SpherizeOptions {
                    sample_spacing: -0.001,
                    ..small()
                },
            ),
            (
                "sample_spacing",
                SpherizeOptions {
                    sample_spacing: f64::INFINITY,
                    ..small()
                },
            ),
            (
                "total_budget",
                SpherizeOptions {
                    total_budget: Some(0),
                    ..small()
                },
            ),
            (
                "max_per_link",
                SpherizeOptions {
                    max_per_link: Some(0),
                    ..small()
                },
            ),
            // Unbounded work (issue 15): these never finished.
            (
                "tolerance",
                SpherizeOptions {
                    tolerance: 1e-12,
                    ..small()
                },
            ),
            (
                "total_budget",
                SpherizeOptions {
                    total_budget: Some(1_000_000_000_000),
                    ..small()
                },
            ),
            (
                "max_per_link",
                SpherizeOptions {
                    max_per_link: Some(10_001),
                    ..small()
                },
            ),
        ];
        for (name, opts) in cases {
            match spherize_link("ball", &g, None, &opts) {
                Err(CollisionError::InvalidArgument(m)) => assert!(m.contains(name), "{m}"),
                other => panic!("{name}: {other:?}"),
            }
        }
        match spherize_link("ball", &g, Some(0), &small()) {
            Err(CollisionError::InvalidArgument(m)) => assert!(m.contains("budget"), "{m}"),
            other => panic!("{other:?}"),
        }
    }

    const URDF: &str = r#"<robot name="r">
      <link name="base"><collision><geometry><box size="0.06 0.04 0.03"/></geometry></collision></link>
      <link name="arm"><collision><origin xyz="0 0 0.04"/><geometry><capsule radius="0.015" length="0.05"/></geometry></collision></link>
      <link name="tip"><collision><geometry><cylinder radius="0.01" length="0.03"/></geometry></collision></link>
      <link name="tool"/>
      <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="j2" type="revolute"><parent link="arm"/><child link="tip"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="j3" type="fixed"><parent link="tip"/><child link="tool"/></joint>
    </robot>"#;

    #[test]
    fn robot_budget_is_respected() {
        let model = RobotModel::from_urdf_str(URDF, &Default::default()).unwrap();
        let opts = SpherizeOptions {
            total_budget: Some(6),
            ..small()
        };
        let (spheres, reports) = spherize_robot(&model, &opts).unwrap();
        assert_eq!(spheres.len(), model.links().len());
        assert_eq!(reports.len(), 3);
        let total: usize = spheres.iter().map(Vec::len).sum();
        assert!(total <= 6, "{total} spheres");
        for (l, s) in model.links().iter().zip(&spheres) {
            assert_eq!(s.is_empty(), l.collisions.is_empty(), "{}", l.name);
        }
        assert!(reports.iter().all(|r| r.coverage == 1.0 && r.spheres >= 1));
        let few = SpherizeOptions {
            total_budget: Some(2),
            ..small()
        };
        assert!(
            matches!(spherize_robot(&model, &few), Err(CollisionError::InvalidArgument(m)) if m.contains("total_budget"))
        );
    }
}
