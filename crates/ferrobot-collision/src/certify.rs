//! Continuous certification of motions: every configuration of a motion
//! free, not only its samples.
//!
//! A motion checked at a resolution (no DOF moves more than it between
//! neighbouring samples) is free at its samples; between two of them a
//! sphere can still graze an obstacle, and a re-check that samples the same
//! motion elsewhere (another time step of the same trajectory) finds it.
//! The certificate used here closes that gap with a bound on how far any
//! point of the robot's spheres moves when the DOFs move:
//!
//! For a point fixed in the frame of body `B`, a revolute joint turning by
//! `dq` moves it by at most `|dq|` times its distance from the joint's axis,
//! and that distance is at most the sum of the chain's translations from
//! the joint down to `B`'s frame plus the point's distance from that frame's
//! origin (prismatic joints below add their largest extension). A prismatic
//! joint moves it by `|dq|`. So a body's spheres move by at most
//! `sum_d |dq_d| rate[B][d]` ([`displacement_rates`]), where mimic joints add
//! their gain times their own lever to their driving DOF. A configuration
//! found free with every sphere grown by `m` (the kernel's margin) is then
//! the centre of a region where the robot stays free for every motion whose
//! spheres move by less than `m`. For a self pair the kernel's margin
//! counts once per pair, so the bound is on the change of distance between
//! the two bodies: the sum of both bodies' bounds over the joints below
//! their deepest common frame (joints above it move both rigidly).
//!
//! [`crate::CollisionChecker::curve_certified_until`] uses this on a curve
//! `q(u)`, `u` in `[0, 1]`, with a bound on each DOF's speed `|dq_d/du|`: an
//! interval of the curve of width `w` is certified by its midpoint, checked
//! with the margin grown by the motion bound over `w / 2`; an interval that
//! fails is split in two (the margin halves), until its midpoint collides
//! with no growth (a collision) or the bound falls below the `f32`
//! allowance ([`MAX_LEVELS`]) or the work exceeds [`CHECKS_PER_INTERVAL`].
//! The checker applies the grown margins to world contacts only; self pairs
//! are checked at the samples (see that method). Free motions with clearance need a few
//! refinements where they pass close to an obstacle; grazing ones are
//! reported as colliding.

use crate::compiled::CompiledRobot;

/// Added to every certifying margin (m): covers the kernel's `f32`
/// arithmetic and the rounding of configurations to `f32` (positions of a
/// few metres at most, so rounding errors stay below a micrometre).
pub const CERTIFY_SLACK: f64 = 2e-6;

/// Halvings of an interval before a motion is given up as not certified.
pub const MAX_LEVELS: usize = 30;

/// Most configurations one certification checks, per interval it starts
/// from, before giving up (as not certified): a motion that stays within
/// micrometres of an obstacle over a long stretch would otherwise be split
/// until the deadline.
pub const CHECKS_PER_INTERVAL: usize = 32;

/// How far the robot's spheres can move per unit of each DOF (see the
/// module docs), per body and per self pair.
#[derive(Debug, Clone, Default)]
pub struct Rates {
    /// Per body, per DOF: a bound (m per unit of the DOF) on how far any
    /// point of the body's spheres moves when that DOF moves, the others
    /// fixed. Bodies fixed to the base have all zeros.
    pub bodies: Vec<Vec<f64>>,
    /// Per self pair of the robot (aligned with `CompiledRobot::pairs`),
    /// per DOF: a bound on how much the distance between a point of one
    /// body and a point of the other changes. Joints above the two bodies'
    /// deepest common frame move both rigidly and count for nothing.
    pub pairs: Vec<Vec<f64>>,
}

/// [`Rates`] of `robot`, whose DOFs have the limits `lower` and `upper`
/// (the extensions of prismatic joints between a revolute joint and a body
/// lengthen its lever; unbounded ones make it infinite).
pub fn displacement_rates(robot: &CompiledRobot, lower: &[f64], upper: &[f64]) -> Rates {
    let norm = |v: [f32; 3]| (v[0] as f64).hypot(v[1] as f64).hypot(v[2] as f64);
    // Per body: (step, DOF, contribution per unit of the DOF) along its
    // chain to the base.
    let chains: Vec<Vec<(usize, usize, f64)>> = robot
        .bodies
        .iter()
        .map(|b| {
            let mut out = Vec::new();
            // Farthest point of the body's spheres from its frame's origin.
            let mut lever = (b.first..b.first + b.count)
                .map(|k| norm(robot.centers[k]) + robot.radii[k] as f64)
                .fold(0.0, f64::max);
            let mut f = b.frame;
            while f != 0 {
                let s = &robot.steps[f - 1];
                let g = (s.gain as f64).abs();
                // The compiled data are `f32`: a relative allowance for
                // their rounding.
                let c = g * if s.prismatic { 1.0 } else { lever } * (1.0 + 1e-5);
                out.push((f - 1, s.dof, c));
                lever += norm(s.k.t);
                if s.prismatic {
                    let lo = lower.get(s.dof).copied().unwrap_or(f64::NEG_INFINITY);
                    let hi = upper.get(s.dof).copied().unwrap_or(f64::INFINITY);
                    lever += g * lo.abs().max(hi.abs()) + (s.offset as f64).abs();
                }
                f = s.parent;
            }
            out
        })
        .collect();
    let sum = |parts: &mut dyn Iterator<Item = &(usize, usize, f64)>| {
        let mut rate = vec![0.0f64; robot.num_dof];
        for &(_, d, c) in parts {
            rate[d] += c;
        }
        rate
    };
    let bodies = chains.iter().map(|c| sum(&mut c.iter())).collect();
    let pairs = robot
        .pairs
        .iter()
        .map(|&(a, b)| {
            let (ca, cb) = (&chains[a], &chains[b]);
            let below = |x: &(usize, usize, f64), other: &[(usize, usize, f64)]| {
                !other.iter().any(|y| y.0 == x.0)
            };
            sum(&mut ca
                .iter()
                .filter(|x| below(x, cb))
                .chain(cb.iter().filter(|x| below(x, ca))))
        })
        .collect();
    Rates { bodies, pairs }
}

/// A bound (m) on the kernel margin that certifies a motion in which DOF
/// `d` moves by at most `delta[d]` (non-negative) from the checked
/// configuration: the largest displacement of a moving body, or change of
/// distance within a self pair, whichever is larger. Infinite when a
/// moving DOF has an unbounded rate.
pub fn motion_margin(robot: &CompiledRobot, rates: &Rates, delta: &[f64]) -> f64 {
    let bound = |r: &Vec<f64>| {
        r.iter()
            .zip(delta)
            .filter(|(_, d)| **d != 0.0)
            .map(|(r, d)| r * d.abs())
            .sum::<f64>()
    };
    let world = robot
        .bodies
        .iter()
        .zip(&rates.bodies)
        .filter(|(b, _)| b.frame != 0)
        .map(|(_, r)| bound(r))
        .fold(0.0, f64::max);
    rates.pairs.iter().map(bound).fold(world, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn margin_adds_up_over_dofs_and_pairs() {
        // Rates built by hand: two bodies, two DOFs.
        let robot = CompiledRobot::new(
            &ferrobot_model::RobotModel::from_urdf_str(
                r#"<robot name="r"><link name="a"/><link name="b"/>
                <joint name="j" type="revolute"><parent link="a"/><child link="b"/>
                <origin xyz="0 0 1"/><axis xyz="0 0 1"/>
                <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#,
                &Default::default(),
            )
            .unwrap(),
            &[
                vec![],
                vec![crate::Sphere::new(
                    nalgebra::Point3::new(0.5, 0.0, 0.0),
                    0.1,
                )],
            ],
            &[],
            &[],
            |_, _| false,
        );
        let rates = displacement_rates(&robot, &[-1.0], &[1.0]);
        // The sphere's farthest point is 0.6 m from the joint axis, which
        // passes through its frame's origin.
        assert!((rates.bodies[0][0] - 0.6).abs() < 1e-5);
        assert!((motion_margin(&robot, &rates, &[0.01]) - 0.006).abs() < 1e-7);
    }
}
