use crate::geometry::ContactManifold;
use crate::math::Real;

/// Chooses at most 4 of a manifold's points for the solver (ferrobot change 12,
/// see `FERROBOT.md`).
///
/// The points are split in two tiers: the *support* points, whose distance is
/// within `support_tolerance` of the deepest one (the points the bodies actually
/// rest on: depth differences below the solver's allowed error are noise), and
/// the *speculative* ones (further apart, up to `prediction_distance`). Support
/// points are always chosen before speculative ones, and among one tier the
/// choice is geometric, not by depth: the first point is the extreme one along a
/// fixed direction of the first collider's frame, the second the furthest from
/// it, the last two the furthest on either side of the segment they span (an
/// approximation of the largest-area support polygon). The same contact
/// geometry therefore gives the same choice from step to step.
///
/// Upstream seeded the choice with the deepest point and allowed any point
/// within the prediction distance at every stage: on a resting body the deepest
/// point changes with sub-micrometre noise, and on curved bodies or clustered
/// convex decompositions (many manifolds merged into one) the spread-out
/// speculative points hovering millimetres away won over the points the body
/// rests on, so the body sank onto contacts the solver did not see and rocked.
pub(crate) fn reduce_manifold_naive(
    manifold: &ContactManifold,
    selected: &mut [usize; 4],
    num_selected: &mut usize,
    prediction_distance: Real,
    support_tolerance: Real,
) {
    if manifold.points.len() <= 4 {
        return;
    }

    *selected = [usize::MAX; 4];
    *num_selected = 0;

    let mut deepest_dist = Real::MAX;
    for pt in &manifold.points {
        if pt.dist < deepest_dist {
            deepest_dist = pt.dist;
        }
    }
    if deepest_dist > prediction_distance {
        // Upstream kept the deepest point even beyond the prediction distance.
        let deepest = manifold
            .points
            .iter()
            .position(|pt| pt.dist == deepest_dist);
        if let Some(i) = deepest {
            selected[0] = i;
            *num_selected = 1;
        }
        return;
    }

    let support_limit = deepest_dist + support_tolerance.max(0.0);
    // Tier of a point: 0 support, 1 speculative, 2 not eligible.
    let tier = |i: usize| {
        let d = manifold.points[i].dist;
        if d <= support_limit {
            0u8
        } else if d <= prediction_distance {
            1
        } else {
            2
        }
    };

    use crate::utils::OrthonormalBasis;
    let basis = manifold.local_n1.orthonormal_basis();
    // A fixed generic direction of the contact plane (not aligned with the
    // basis, so that polygons aligned with it have no tie for the extreme).
    let seed_dir = basis[0] + basis[1] * 0.381_966;

    // Best point by (lowest tier, highest score) among the unselected.
    let pick = |selected: &[usize; 4], score: &dyn Fn(usize) -> Real| -> Option<usize> {
        let mut best: Option<(u8, Real, usize)> = None;
        for i in 0..manifold.points.len() {
            if selected.contains(&i) {
                continue;
            }
            let t = tier(i);
            if t == 2 {
                continue;
            }
            let s = score(i);
            let better = match best {
                None => true,
                Some((bt, bs, _)) => t < bt || (t == bt && s > bs),
            };
            if better {
                best = Some((t, s, i));
            }
        }
        best.map(|b| b.2)
    };

    // 1. The extreme support point along the seed direction.
    let Some(a) = pick(selected, &|i| manifold.points[i].local_p1.dot(seed_dir)) else {
        return;
    };
    selected[0] = a;
    *num_selected = 1;
    let pa = manifold.points[a].local_p1;

    // 2. The point furthest from it.
    let Some(b) = pick(selected, &|i| {
        (manifold.points[i].local_p1 - pa).length_squared()
    }) else {
        return;
    };
    selected[1] = b;
    *num_selected = 2;
    let pb = manifold.points[b].local_p1;
    if pa == pb {
        *num_selected = 1;
        return;
    }

    // 3. and 4. The points furthest on either side of the segment.
    let tangent = (pb - pa).cross(manifold.local_n1);
    let Some(c) = pick(selected, &|i| {
        -(manifold.points[i].local_p1 - pa).dot(tangent)
    }) else {
        return;
    };
    selected[2] = c;
    *num_selected = 3;
    let Some(d) = pick(selected, &|i| {
        (manifold.points[i].local_p1 - pa).dot(tangent)
    }) else {
        return;
    };
    selected[3] = d;
    *num_selected = 4;
}
