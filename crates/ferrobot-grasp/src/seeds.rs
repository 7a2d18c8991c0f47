//! Seed points: a random sample spread over the surface.

use std::collections::HashMap;

use nalgebra::Point3;
use rand::SeedableRng;
use rand::rngs::StdRng;

/// Up to `num` of the `candidates` (indices into `points`), in random order
/// (deterministic for `rng_seed`) but kept at least `spacing` apart while
/// possible: a candidate closer than `spacing` to an accepted seed is only
/// taken once every well-spaced one is. `spacing` 0 gives a plain random
/// sample. Returned sorted.
pub fn spread_seeds(
    points: &[Point3<f64>],
    candidates: &[usize],
    num: usize,
    spacing: f64,
    rng_seed: u64,
) -> Vec<usize> {
    let mut rng = StdRng::seed_from_u64(rng_seed);
    let order: Vec<usize> = rand::seq::index::sample(&mut rng, candidates.len(), candidates.len())
        .into_iter()
        .map(|k| candidates[k])
        .collect();
    let mut picked = Vec::with_capacity(num.min(order.len()));
    if spacing > 0.0 {
        let key = |p: &Point3<f64>| {
            (
                (p.x / spacing).floor() as i64,
                (p.y / spacing).floor() as i64,
                (p.z / spacing).floor() as i64,
            )
        };
        let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
        let mut rest = Vec::new();
        for &i in &order {
            if picked.len() == num {
                break;
            }
            let p = &points[i];
            let (kx, ky, kz) = key(p);
            let near = (-1..=1).any(|dx| {
                (-1..=1).any(|dy| {
                    (-1..=1).any(|dz| {
                        grid.get(&(kx + dx, ky + dy, kz + dz)).is_some_and(|v| {
                            v.iter()
                                .any(|&j| (points[j] - p).norm_squared() < spacing * spacing)
                        })
                    })
                })
            });
            if near {
                rest.push(i);
            } else {
                grid.entry((kx, ky, kz)).or_default().push(i);
                picked.push(i);
            }
        }
        let missing = num.saturating_sub(picked.len());
        picked.extend(rest.into_iter().take(missing));
    } else {
        picked.extend(order.into_iter().take(num));
    }
    picked.sort_unstable();
    picked
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spaced_then_filled() {
        let pts: Vec<_> = (0..100)
            .map(|i| Point3::new(0.001 * i as f64, 0.0, 0.0))
            .collect();
        let all: Vec<usize> = (0..100).collect();
        // Greedy spacing on a 10 cm segment always fits 3 seeds 2 cm apart.
        let s = spread_seeds(&pts, &all, 3, 0.02, 0);
        assert_eq!(s.len(), 3);
        for (a, &i) in s.iter().enumerate() {
            for &j in &s[a + 1..] {
                assert!((pts[i] - pts[j]).norm() >= 0.02);
            }
        }
        assert_eq!(spread_seeds(&pts, &all, 50, 0.02, 0).len(), 50);
        assert_eq!(spread_seeds(&pts, &all, 500, 0.0, 0).len(), 100);
        assert_eq!(
            spread_seeds(&pts, &all, 7, 0.02, 3),
            spread_seeds(&pts, &all, 7, 0.02, 3)
        );
    }
}
