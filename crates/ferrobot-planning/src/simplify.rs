//! Path simplification: greedy vertex reduction (connect each kept vertex to
//! the farthest later vertex it can see) and random partial shortcuts
//! between points on non-adjacent segments, every new edge motion-checked.

use rand::Rng;
use rand::rngs::SmallRng;

use crate::planner::PlanCounts;
use crate::rrt::Edges;

/// Options of `simplify`.
#[derive(Debug, Clone)]
pub struct SimplifyOptions {
    /// Random shortcut attempts at most.
    pub max_shortcuts: usize,
    /// Stop after this many failed attempts in a row.
    pub max_failures: usize,
    /// A random shortcut that would shorten the path by less than this
    /// fraction of its length is not checked and counts as a failed
    /// attempt (0 checks every candidate). Without it, shortcuts that gain
    /// almost nothing keep succeeding (each resets the failure count and
    /// adds two vertices), so the path grows to dozens of tiny edges that
    /// the vertex reduction and the certification then check one by one:
    /// the slowest MotionBenchMaker problems spent 10-30 ms there.
    pub min_gain: f64,
    /// Check the parts of checked edges that survive shortcutting on their
    /// own at the end (their samples differ from the whole edge's). Off by
    /// default: [`crate::Planner`] certifies every edge of the final path
    /// continuously afterwards (and a part of a certified edge is
    /// certified), so this check would be a second one.
    pub recheck_parts: bool,
}

impl Default for SimplifyOptions {
    fn default() -> Self {
        Self {
            max_shortcuts: 40,
            max_failures: 10,
            min_gain: 0.01,
            recheck_parts: false,
        }
    }
}

/// Range of [`SimplifyOptions::min_gain`] (a fraction of the path length).
pub const MIN_GAIN: ferrobot_model::ranges::Range = ferrobot_model::ranges::Range {
    name: "min_gain",
    min: 0.0,
    max: 0.5,
    unit: "",
};
/// Largest [`SimplifyOptions::max_shortcuts`].
pub const MAX_SHORTCUTS: usize = 100_000;
/// Largest [`SimplifyOptions::max_failures`].
pub const MAX_FAILURES: usize = 100_000;

impl SimplifyOptions {
    /// Checks every option: `min_gain` in [0, 0.5], `max_shortcuts` in
    /// [0, 100000], `max_failures` in [1, 100000] (named by its Python
    /// name, `max_shortcut_failures`, in the error).
    pub fn validate(&self) -> crate::Result<()> {
        use ferrobot_model::ranges::check_count;
        MIN_GAIN.check(self.min_gain)?;
        check_count("max_shortcuts", self.max_shortcuts, 0, MAX_SHORTCUTS)?;
        check_count("max_shortcut_failures", self.max_failures, 1, MAX_FAILURES)?;
        Ok(())
    }
}

/// Euclidean length of a path in the active space.
pub fn path_length(path: &[Vec<f64>]) -> f64 {
    path.windows(2).map(|w| distance(&w[0], &w[1])).sum()
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// A path vertex and whether the edge arriving at it was checked whole
/// (a part of a checked edge is not: its sample points differ).
type Vertex = (Vec<f64>, bool);

/// Keeps the first vertex, then from each kept vertex jumps to the farthest
/// later vertex reachable in a straight line (a checked, whole edge).
fn reduce_vertices(
    edges: &mut Edges<'_>,
    path: Vec<Vertex>,
    counts: &mut PlanCounts,
) -> Vec<Vertex> {
    if path.len() <= 2 {
        return path;
    }
    let before = edges.checks;
    let n = path.len();
    let mut out = vec![path[0].clone()];
    let mut i = 0;
    while i < n - 1 {
        let mut j = n - 1;
        while j > i + 1 && !edges.valid(&path[i].0, &path[j].0) {
            j -= 1;
        }
        // j == i + 1 keeps the existing edge (and its flag) unchecked.
        let whole = j > i + 1 || path[j].1;
        out.push((path[j].0.clone(), whole));
        i = j;
    }
    counts.reduce_checks += edges.checks - before;
    out
}

/// Point at parameter `t` along segment `s` of `path`.
fn point(path: &[Vertex], s: usize, t: f64) -> Vec<f64> {
    path[s]
        .0
        .iter()
        .zip(&path[s + 1].0)
        .map(|(a, b)| a + (b - a) * t)
        .collect()
}

/// Shortens a valid path (every edge checked whole); the result is valid
/// at the edges' resolution, every edge checked whole, same end points
/// (with `opts.recheck_parts` off: every edge is a checked edge or a part
/// of one, which a continuous certification of the result must cover).
///
/// When `edges` has a deadline and it passes, shortcutting stops: a check
/// cut short answers "not free", so the edges kept are still only those
/// checked whole (in the worst case the input path itself is returned).
pub(crate) fn simplify(
    edges: &mut Edges<'_>,
    path: Vec<Vec<f64>>,
    opts: &SimplifyOptions,
    rng: &mut SmallRng,
    counts: &mut PlanCounts,
) -> Vec<Vec<f64>> {
    let path: Vec<Vertex> = path.into_iter().map(|q| (q, true)).collect();
    let mut path = reduce_vertices(edges, path, counts);
    let vertex_only = path.clone();
    let mut failures = 0;
    for _ in 0..opts.max_shortcuts {
        if path.len() < 3 || failures >= opts.max_failures || edges.timed_out() {
            break;
        }
        let segs = path.len() - 1;
        counts.shortcuts_drawn += 1;
        let (mut s0, mut s1) = (rng.random_range(0..segs), rng.random_range(0..segs));
        if s0 == s1 {
            failures += 1;
            continue;
        }
        if s0 > s1 {
            std::mem::swap(&mut s0, &mut s1);
        }
        let (t0, t1) = (rng.random::<f64>(), rng.random::<f64>());
        let (a, b) = (point(&path, s0, t0), point(&path, s1, t1));
        if opts.min_gain > 0.0 {
            // Length of the path between `a` and `b` against the shortcut.
            let mut along = distance(&a, &path[s0 + 1].0) + distance(&path[s1].0, &b);
            for k in s0 + 1..s1 {
                along += distance(&path[k].0, &path[k + 1].0);
            }
            let total = path
                .windows(2)
                .map(|w| distance(&w[0].0, &w[1].0))
                .sum::<f64>();
            if along - distance(&a, &b) < opts.min_gain * total {
                counts.shortcuts_small += 1;
                failures += 1;
                continue;
            }
        }
        counts.shortcuts_checked += 1;
        if edges.valid(&a, &b) {
            counts.shortcuts_kept += 1;
            let mut next = path[..=s0].to_vec();
            next.push((a, false));
            next.push((b, true));
            next.push((path[s1 + 1].0.clone(), false));
            next.extend_from_slice(&path[s1 + 2..]);
            path = next;
            failures = 0;
        } else {
            failures += 1;
        }
    }
    let path = reduce_vertices(edges, path, counts);
    if !opts.recheck_parts {
        return path.into_iter().map(|v| v.0).collect();
    }
    // Parts of checked edges that survived are checked on their own (their
    // sample points differ from the whole edge's); if one fails, the
    // shortcuts are given up for the vertex-only reduction, whose edges
    // were all checked whole.
    for w in path.windows(2) {
        if !w[1].1 && !edges.valid(&w[0].0, &w[1].0) {
            return vertex_only.into_iter().map(|v| v.0).collect();
        }
    }
    path.into_iter().map(|v| v.0).collect()
}
