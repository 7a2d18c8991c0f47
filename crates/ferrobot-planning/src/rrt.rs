//! RRT-Connect (Kuffner and LaValle, 2000) in the active space, with every
//! edge validated by the collision checker's vectorised motion check (eight
//! configurations spread along the edge per SIMD pack, as VAMP does).
//!
//! The goal tree may hold several roots (a goal set from IK); the planner
//! first tries the straight motion from the start to each goal. Two
//! standard refinements keep hard problems (narrow passages into shelves)
//! from drawing thousands of samples: balanced trees (the smaller tree is
//! extended) and dynamic domains (samples far beyond a node whose
//! extensions collided are not steered towards from it).

use std::time::{Duration, Instant};

use ferrobot_collision::CollisionChecker;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

use crate::space::ActiveSpace;

/// Options of RRT-Connect.
#[derive(Debug, Clone)]
pub struct RrtOptions {
    /// Longest edge added by one extension (Euclidean, active space).
    pub range: f64,
    /// Motion-check resolution: largest joint step between checked
    /// configurations (max norm, rad or m).
    pub resolution: f64,
    /// Samples at most.
    pub max_samples: usize,
    /// Wall-clock limit: of the whole plan in [`crate::Planner`] (IK for
    /// pose goals, search, shortcutting and every collision re-check), of
    /// the search alone in [`rrt_connect`].
    pub time_limit: Duration,
    /// Random seed (same inputs and seed, same path).
    pub seed: u64,
    /// Grow the smaller tree at each iteration (balanced trees) instead of
    /// alternating.
    pub balance: bool,
    /// Dynamic domain: a node from which an extension collided accepts only
    /// samples within its domain radius (see [`DOMAIN_RADIUS`]).
    pub dynamic_domain: bool,
}

impl Default for RrtOptions {
    fn default() -> Self {
        Self {
            range: 1.0,
            resolution: 0.005,
            max_samples: 100_000,
            time_limit: Duration::from_secs(1),
            seed: 0,
            balance: true,
            dynamic_domain: true,
        }
    }
}

/// Dynamic domain (Yershova et al., 2005; [`RrtOptions::dynamic_domain`]): a node from which an extension
/// collided only accepts samples within its domain radius, so samples
/// behind obstacles stop pulling the tree into them. The radius a node gets
/// at its first collision (active-space Euclidean norm, rad or m).
pub const DOMAIN_RADIUS: f64 = 4.0;
/// The smallest domain radius.
const DOMAIN_MIN_RADIUS: f64 = 1.0;
/// Relative change of a finite domain radius per extension from the node
/// (grows on success, shrinks on collision).
const DOMAIN_ALPHA: f64 = 1e-4;
/// Samples rejected by the dynamic domain in a row before one is accepted
/// regardless (so the domain cannot stall the search where every node is
/// bounded).
const DOMAIN_MAX_REJECTS: usize = 64;

/// A tree of configurations stored flat.
struct Tree {
    dim: usize,
    nodes: Vec<f64>,
    parents: Vec<u32>,
    /// Dynamic-domain radius per node (infinite until an extension from
    /// it collides).
    radius: Vec<f64>,
}

impl Tree {
    fn new(dim: usize) -> Self {
        Self {
            dim,
            nodes: Vec::with_capacity(dim * 256),
            parents: Vec::with_capacity(256),
            radius: Vec::with_capacity(256),
        }
    }

    fn len(&self) -> usize {
        self.parents.len()
    }

    fn push(&mut self, q: &[f64], parent: u32) -> u32 {
        self.nodes.extend_from_slice(q);
        self.parents.push(parent);
        self.radius.push(f64::INFINITY);
        (self.parents.len() - 1) as u32
    }

    /// Records an extension from node `i`: grows a finite domain on success,
    /// sets or shrinks it on collision.
    fn extended(&mut self, i: u32, free: bool) {
        let r = &mut self.radius[i as usize];
        if free {
            if r.is_finite() {
                *r *= 1.0 + DOMAIN_ALPHA;
            }
        } else if r.is_finite() {
            *r = (*r * (1.0 - DOMAIN_ALPHA)).max(DOMAIN_MIN_RADIUS);
        } else {
            *r = DOMAIN_RADIUS;
        }
    }

    fn node(&self, i: u32) -> &[f64] {
        let i = i as usize * self.dim;
        &self.nodes[i..i + self.dim]
    }

    fn nearest(&self, q: &[f64]) -> u32 {
        self.nearest_with_distance(q).0
    }

    /// The nearest node and its squared distance.
    fn nearest_with_distance(&self, q: &[f64]) -> (u32, f64) {
        let mut best = (f64::INFINITY, 0u32);
        for (i, n) in self.nodes.chunks_exact(self.dim).enumerate() {
            let d: f64 = n.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum();
            if d < best.0 {
                best = (d, i as u32);
            }
        }
        (best.1, best.0)
    }

    /// Path from the root to node `i`.
    fn path_to(&self, mut i: u32) -> Vec<Vec<f64>> {
        let mut out = vec![self.node(i).to_vec()];
        while self.parents[i as usize] != u32::MAX {
            i = self.parents[i as usize];
            out.push(self.node(i).to_vec());
        }
        out.reverse();
        out
    }
}

/// Edge validation with reusable full-configuration buffers and an
/// optional deadline.
pub(crate) struct Edges<'a> {
    checker: &'a CollisionChecker,
    space: &'a ActiveSpace,
    resolution: f64,
    a: Vec<f64>,
    b: Vec<f64>,
    deadline: Option<Instant>,
    timed_out: bool,
    /// Motions are certified free continuously
    /// ([`CollisionChecker::curve_certified_until`]), not at samples.
    certified: bool,
    /// Motion checks run.
    pub checks: usize,
}

impl<'a> Edges<'a> {
    pub(crate) fn new(
        checker: &'a CollisionChecker,
        space: &'a ActiveSpace,
        resolution: f64,
    ) -> Self {
        Self {
            checker,
            space,
            resolution,
            a: space.locked.clone(),
            b: space.locked.clone(),
            deadline: None,
            timed_out: false,
            certified: false,
            checks: 0,
        }
    }

    /// The same, certifying every motion continuously (every configuration
    /// of it free, see [`ferrobot_collision::certify`]) instead of checking
    /// it at samples `resolution` apart.
    pub(crate) fn certified(mut self, certified: bool) -> Self {
        self.certified = certified;
        self
    }

    /// The same, giving up at `deadline`: once it has passed, every motion
    /// counts as not free (unproven) and [`Edges::timed_out`] is true.
    pub(crate) fn until(mut self, deadline: Instant) -> Self {
        self.deadline = Some(deadline);
        self
    }

    /// Whether the deadline passed during a check (the answers since then
    /// were `false` without a check).
    pub(crate) fn timed_out(&self) -> bool {
        self.timed_out
    }

    /// Whether the straight motion from `q0` to `q1` (active) is free;
    /// `false` once the deadline has passed.
    pub(crate) fn valid(&mut self, q0: &[f64], q1: &[f64]) -> bool {
        if self.timed_out {
            return false;
        }
        self.checks += 1;
        self.space.expand_into(q0, &mut self.a);
        self.space.expand_into(q1, &mut self.b);
        let answer = if self.certified {
            certify_segment(
                self.checker,
                &self.a,
                &self.b,
                self.resolution,
                0.0,
                self.deadline,
            )
        } else {
            self.checker
                .motion_valid_until(&self.a, &self.b, self.resolution, self.deadline)
        };
        match answer {
            Some(free) => free,
            None => {
                self.timed_out = true;
                false
            }
        }
    }
}

/// Certification intervals of world contacts, in units of the resolution:
/// an interval is proven free by its midpoint with the margin grown by what
/// the robot can move over half of it, and split where that fails, so wider
/// first intervals cost fewer checks where the motion has clearance (the
/// usual case) and a few more splits where it grazes an obstacle. Self
/// pairs, which cannot be certified with a grown margin (links in
/// near-contact), are checked at samples `resolution` apart by the motion
/// check that comes first.
pub const WORLD_INTERVALS: f64 = 2.0;

/// Whether the straight motion from `a` to `b` (full configurations) is
/// free: every configuration free of the world with the spheres grown by
/// `tube` (m), certified continuously
/// ([`CollisionChecker::curve_certified_until`] from intervals of
/// [`WORLD_INTERVALS`] x `resolution`), and free of self-collision at
/// samples no more than `resolution` apart in any DOF (the motion check,
/// which also finds most collisions cheapest); `None` when `deadline`
/// passed first.
pub(crate) fn certify_segment(
    checker: &CollisionChecker,
    a: &[f64],
    b: &[f64],
    resolution: f64,
    tube: f64,
    deadline: Option<Instant>,
) -> Option<bool> {
    if !checker.motion_valid_until(a, b, resolution, deadline)? {
        return Some(false);
    }
    certify_world(checker, a, b, resolution, tube, deadline)
}

/// The world half of [`certify_segment`] (no motion check at samples).
pub(crate) fn certify_world(
    checker: &CollisionChecker,
    a: &[f64],
    b: &[f64],
    resolution: f64,
    tube: f64,
    deadline: Option<Instant>,
) -> Option<bool> {
    let steps = certify_steps(a, b, resolution * WORLD_INTERVALS);
    certify_segment_part(checker, a, b, (0, steps, steps), tube, deadline, &mut 0)
}

/// Intervals of the motion from `a` to `b` over which no DOF moves more
/// than `resolution`.
pub(crate) fn certify_steps(a: &[f64], b: &[f64], resolution: f64) -> usize {
    let span = a
        .iter()
        .zip(b)
        .map(|(x, y)| (y - x).abs())
        .fold(0.0, f64::max);
    // `as` saturates; callers bound the resolution (ranges::RESOLUTION).
    ((span / resolution).ceil() as usize).max(1)
}

/// [`certify_segment`] of the intervals `k0..k1` of the `steps` equal
/// intervals of the motion from `a` to `b` (`part = (k0, k1, steps)`): the
/// same intervals, so the same certificate, as the whole motion's.
/// Configurations tested are added to `tested`.
pub(crate) fn certify_segment_part(
    checker: &CollisionChecker,
    a: &[f64],
    b: &[f64],
    part: (usize, usize, usize),
    tube: f64,
    deadline: Option<Instant>,
    tested: &mut usize,
) -> Option<bool> {
    let (k0, k1, steps) = part;
    let (u0, u1) = (k0 as f64 / steps as f64, k1 as f64 / steps as f64);
    let delta: Vec<f64> = a
        .iter()
        .zip(b)
        .map(|(x, y)| (y - x).abs() * (u1 - u0))
        .collect();
    let mut point = |u: f64, q: &mut [f64]| {
        let s = u0 + (u1 - u0) * u;
        for ((o, x), y) in q.iter_mut().zip(a).zip(b) {
            *o = x + (y - x) * s;
        }
    };
    checker.curve_certified_until(&mut point, &delta, k1 - k0, tube, deadline, tested)
}

/// Why RRT-Connect stopped without a path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RrtFailure {
    /// The time limit passed.
    Timeout,
    /// The sample budget ran out.
    SampleLimit,
}

/// Statistics of a run.
#[derive(Debug, Clone, Copy, Default)]
pub struct RrtStats {
    /// Samples drawn.
    pub samples: usize,
    /// Nodes in both trees.
    pub nodes: usize,
    /// Motion checks run.
    pub motion_checks: usize,
}

/// Moves from `from` towards `to` by at most `range`; returns the new
/// configuration and whether it reached `to`.
fn steer(from: &[f64], to: &[f64], range: f64, out: &mut Vec<f64>) -> bool {
    let d: f64 = from
        .iter()
        .zip(to)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    out.clear();
    if d <= range {
        out.extend_from_slice(to);
        true
    } else {
        let t = range / d;
        out.extend(from.iter().zip(to).map(|(a, b)| a + (b - a) * t));
        false
    }
}

/// Plans from `start` to any of `goals` (active, all collision-free and in
/// limits). Returns the path of active configurations (start first).
pub fn rrt_connect(
    checker: &CollisionChecker,
    space: &ActiveSpace,
    start: &[f64],
    goals: &[Vec<f64>],
    opts: &RrtOptions,
) -> (Result<Vec<Vec<f64>>, RrtFailure>, RrtStats) {
    let deadline = Instant::now() + opts.time_limit;
    rrt_connect_until(checker, space, start, goals, opts, deadline, false)
}

/// [`rrt_connect`] with an absolute deadline instead of `opts.time_limit`
/// (the planner's deadline for the whole plan). Motion checks give up at
/// the deadline too, so one long edge cannot overrun it.
pub(crate) fn rrt_connect_until(
    checker: &CollisionChecker,
    space: &ActiveSpace,
    start: &[f64],
    goals: &[Vec<f64>],
    opts: &RrtOptions,
    deadline: Instant,
    certified: bool,
) -> (Result<Vec<Vec<f64>>, RrtFailure>, RrtStats) {
    let dim = space.len();
    let mut edges = Edges::new(checker, space, opts.resolution)
        .until(deadline)
        .certified(certified);
    let mut stats = RrtStats::default();
    for g in goals {
        if edges.valid(start, g) {
            stats.motion_checks = edges.checks;
            return (Ok(vec![start.to_vec(), g.clone()]), stats);
        }
    }
    let mut rng = SmallRng::seed_from_u64(opts.seed);
    let mut ta = Tree::new(dim);
    let mut tb = Tree::new(dim);
    ta.push(start, u32::MAX);
    for g in goals {
        tb.push(g, u32::MAX);
    }
    // Whether `ta` is the start tree.
    let mut a_is_start = true;
    let mut sample = vec![0.0; dim];
    let mut new = Vec::with_capacity(dim);
    let mut step = Vec::with_capacity(dim);
    let mut rejects = 0usize;
    let failure = loop {
        if stats.samples >= opts.max_samples {
            break RrtFailure::SampleLimit;
        }
        // Checked every sample (a clock read is small next to one motion
        // check), so that fine resolutions cannot overrun the limit by
        // many edges.
        if edges.timed_out() || Instant::now() >= deadline {
            break RrtFailure::Timeout;
        }
        stats.samples += 1;
        for (k, s) in sample.iter_mut().enumerate() {
            *s = rng.random_range(space.sample_lower[k]..=space.sample_upper[k]);
        }
        // Extend tree A (the smaller one: balanced trees) towards the
        // sample, if the sample lies in its nearest node's domain.
        let (near, d2) = ta.nearest_with_distance(&sample);
        let domain = ta.radius[near as usize];
        if opts.dynamic_domain && d2 > domain * domain && rejects < DOMAIN_MAX_REJECTS {
            rejects += 1;
            continue;
        }
        rejects = 0;
        steer(ta.node(near), &sample, opts.range, &mut new);
        let free = edges.valid(ta.node(near), &new);
        if opts.dynamic_domain {
            ta.extended(near, free);
        }
        if free {
            let added = ta.push(&new, near);
            // Connect tree B to the new node, step by step.
            let mut nb = tb.nearest(&new);
            loop {
                let reached = steer(tb.node(nb), &new, opts.range, &mut step);
                if !edges.valid(tb.node(nb), &step) {
                    break;
                }
                nb = tb.push(&step, nb);
                if reached {
                    let (pa, pb) = (ta.path_to(added), tb.path_to(nb));
                    let (mut from_start, to_goal) = if a_is_start { (pa, pb) } else { (pb, pa) };
                    // The meeting node appears in both halves.
                    from_start.pop();
                    from_start.extend(to_goal.into_iter().rev());
                    stats.nodes = ta.len() + tb.len();
                    stats.motion_checks = edges.checks;
                    return (Ok(from_start), stats);
                }
            }
        }
        // Balanced trees: the next extension grows the smaller tree (the
        // trees alternate while they are the same size).
        if !opts.balance || tb.len() <= ta.len() {
            std::mem::swap(&mut ta, &mut tb);
            a_is_start = !a_is_start;
        }
    };
    stats.nodes = ta.len() + tb.len();
    stats.motion_checks = edges.checks;
    (Err(failure), stats)
}
