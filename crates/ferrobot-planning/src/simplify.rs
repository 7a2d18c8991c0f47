//! Path simplification: greedy vertex reduction (connect each kept vertex to
//! the farthest later vertex it can see) and random partial shortcuts
//! between points on non-adjacent segments, every new edge motion-checked.

use rand::Rng;
use rand::rngs::SmallRng;

use crate::rrt::Edges;

/// Options of [`simplify`].
#[derive(Debug, Clone)]
pub struct SimplifyOptions {
    /// Random shortcut attempts at most.
    pub max_shortcuts: usize,
    /// Stop after this many failed attempts in a row.
    pub max_failures: usize,
}

impl Default for SimplifyOptions {
    fn default() -> Self {
        Self {
            max_shortcuts: 40,
            max_failures: 10,
        }
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

/// Keeps the first vertex, then from each kept vertex jumps to the farthest
/// later vertex reachable in a straight line.
pub(crate) fn reduce_vertices(edges: &mut Edges<'_>, path: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    if path.len() <= 2 {
        return path;
    }
    let n = path.len();
    let mut keep = vec![0usize];
    let mut i = 0;
    while i < n - 1 {
        let mut j = n - 1;
        while j > i + 1 && !edges.valid(&path[i], &path[j]) {
            j -= 1;
        }
        keep.push(j);
        i = j;
    }
    keep.into_iter().map(|k| path[k].clone()).collect()
}

/// Point at parameter `t` along segment `s` of `path`.
fn point(path: &[Vec<f64>], s: usize, t: f64) -> Vec<f64> {
    path[s]
        .iter()
        .zip(&path[s + 1])
        .map(|(a, b)| a + (b - a) * t)
        .collect()
}

/// Shortens a valid path; the result is valid at the edges' resolution and
/// has the same end points.
pub(crate) fn simplify(
    edges: &mut Edges<'_>,
    path: Vec<Vec<f64>>,
    opts: &SimplifyOptions,
    rng: &mut SmallRng,
) -> Vec<Vec<f64>> {
    let mut path = reduce_vertices(edges, path);
    let vertex_only = path.clone();
    let mut failures = 0;
    for _ in 0..opts.max_shortcuts {
        if path.len() < 3 || failures >= opts.max_failures {
            break;
        }
        let segs = path.len() - 1;
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
        if edges.valid(&a, &b) {
            let mut next = path[..=s0].to_vec();
            next.push(a);
            next.push(b);
            next.extend_from_slice(&path[s1 + 1..]);
            // Drop points that coincide with their neighbour (t = 0 or 1).
            next.dedup_by(|x, y| distance(x, y) < 1e-9);
            path = next;
            failures = 0;
        } else {
            failures += 1;
        }
    }
    let reduced = reduce_vertices(edges, path);
    // Partial shortcuts create edges that are parts of checked edges; the
    // sample points of a part differ from those of the whole, so every
    // final edge is checked on its own, falling back to the vertex-only
    // reduction (whose edges were all checked whole) if one fails.
    if reduced.windows(2).all(|w| edges.valid(&w[0], &w[1])) {
        reduced
    } else {
        vertex_only
    }
}
