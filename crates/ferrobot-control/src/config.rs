//! Controller parameters: plain structs of `f64` fields, each with a
//! documented, validated range, readable and writable by name (the Python
//! bindings pass them as dictionaries).

use crate::error::{ControlError, Result};

macro_rules! config_struct {
    (
        $(#[$meta:meta])*
        $name:ident {
            $(
                $(#[doc = $doc:expr])*
                $field:ident : $default:expr, [$lo:expr, $hi:expr]
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, PartialEq)]
        pub struct $name {
            $(
                $(#[doc = $doc])*
                pub $field: f64,
            )*
        }

        impl Default for $name {
            fn default() -> Self {
                Self { $($field: $default,)* }
            }
        }

        impl $name {
            /// Every parameter: name, lowest and highest accepted value
            /// (inclusive).
            pub const FIELDS: &'static [(&'static str, f64, f64)] =
                &[$((stringify!($field), $lo, $hi),)*];

            /// The value of parameter `name`.
            pub fn get(&self, name: &str) -> Result<f64> {
                match name {
                    $(stringify!($field) => Ok(self.$field),)*
                    _ => Err(unknown(stringify!($name), name, Self::FIELDS)),
                }
            }

            /// Sets parameter `name` to `value`, checking its range.
            pub fn set(&mut self, name: &str, value: f64) -> Result<()> {
                let (_, lo, hi) = *Self::FIELDS
                    .iter()
                    .find(|f| f.0 == name)
                    .ok_or_else(|| unknown(stringify!($name), name, Self::FIELDS))?;
                check_range(name, value, lo, hi)?;
                match name {
                    $(stringify!($field) => self.$field = value,)*
                    _ => unreachable!("name checked above"),
                }
                Ok(())
            }

            /// Checks every parameter against its range.
            pub fn validate(&self) -> Result<()> {
                for &(name, lo, hi) in Self::FIELDS {
                    check_range(name, self.get(name)?, lo, hi)?;
                }
                Ok(())
            }
        }
    };
}

fn unknown(what: &str, name: &str, fields: &[(&str, f64, f64)]) -> ControlError {
    let known: Vec<&str> = fields.iter().map(|f| f.0).collect();
    ControlError::UnknownName(format!(
        "{what}: unknown parameter '{name}'; known: {}",
        known.join(", ")
    ))
}

fn check_range(name: &str, v: f64, lo: f64, hi: f64) -> Result<()> {
    if !v.is_finite() {
        return Err(ControlError::NonFinite(format!(
            "config '{name}': value {v} is not finite"
        )));
    }
    if v < lo || v > hi {
        return Err(ControlError::InvalidArgument(format!(
            "config '{name}': {v} is outside its range [{lo}, {hi}]"
        )));
    }
    Ok(())
}

config_struct! {
    /// Gains of [`crate::ReactiveController`]. Every policy is an
    /// acceleration in its task space plus a metric (its weight); the
    /// ranges below are inclusive. Defaults were tuned on the bundled Panda
    /// and the UR5 in `../shared/robots/ur5` (benches/reactive.py).
    ReactiveConfig {
        /// End-effector position attractor: acceleration magnitude far from
        /// the target (m/s²), [0, 200]. The attractor is soft-normalised:
        /// `a = -gain x / (|x| + length) - damping v`.
        target_gain: 12.0, [0.0, 200.0],
        /// Length (m) below which the attractor becomes a linear spring of
        /// stiffness `gain / length`, [1e-3, 1].
        target_length: 0.08, [1e-3, 1.0],
        /// Damping of the end-effector velocity (1/s), [0, 200].
        target_damping: 14.0, [0.0, 200.0],
        /// Metric of the position attractor far from the target, [0, 1e4].
        target_metric_far: 1.0, [0.0, 1e4],
        /// Metric of the position attractor at the target (it stiffens
        /// towards it over `target_metric_radius`), [0, 1e4].
        target_metric_near: 10.0, [0.0, 1e4],
        /// Distance (m) over which the attractor's metric blends from far to
        /// near (a Gaussian in the distance), [1e-3, 2].
        target_metric_radius: 0.1, [1e-3, 2.0],
        /// Orientation attractor: angular acceleration far from the target
        /// orientation (rad/s²), [0, 200]; 0 leaves orientation free.
        orientation_gain: 15.0, [0.0, 200.0],
        /// Angle (rad) below which the orientation attractor is linear, [1e-3, 3].
        orientation_length: 0.15, [1e-3, 3.0],
        /// Damping of the end-effector angular velocity (1/s), [0, 200].
        orientation_damping: 12.0, [0.0, 200.0],
        /// Metric of the orientation attractor far from the position target, [0, 1e4].
        orientation_metric_far: 0.1, [0.0, 1e4],
        /// Metric of the orientation attractor at the position target, [0, 1e4].
        orientation_metric_near: 2.0, [0.0, 1e4],
        /// Robot sphere to world obstacle: distance (m) below which the
        /// avoidance policy acts; its metric vanishes at and beyond it, [1e-3, 2].
        collision_distance: 0.25, [1e-3, 2.0],
        /// Reach (m) of the avoidance metric for an obstacle that is not
        /// closing in on a sphere; for one closing at speed `v` the reach is
        /// `collision_near + collision_horizon v`, at most
        /// `collision_distance`: the metric covers the distance the
        /// obstacle closes within the horizon. An obstacle moving along
        /// with the arm (the arm fleeing ahead of it, the target behind it)
        /// then no longer holds the arm `collision_distance` off and herds
        /// it away from its path for seconds; it passes at a shorter
        /// distance, the velocity filter's hold still the hard bound.
        /// Equal to `collision_distance`: a fixed reach, [1e-3, 2].
        collision_near: 0.1, [1e-3, 2.0],
        /// Seconds of closing speed added to `collision_near` (0: the reach
        /// is always `collision_distance`), [0, 10].
        collision_horizon: 0.3, [0.0, 10.0],
        /// Repulsive acceleration at contact (m/s²): `gain exp(-d / length)`, [0, 1e4].
        collision_gain: 40.0, [0.0, 1e4],
        /// Decay length (m) of the repulsion, [1e-3, 1].
        collision_length: 0.04, [1e-3, 1.0],
        /// Braking factor: when a sphere approaches an obstacle at speed
        /// `v` at distance `d`, the policy adds `brake v² / (2 d)`, the
        /// deceleration that stops it before contact, [0, 100].
        collision_brake: 2.0, [0.0, 100.0],
        /// Scale of the avoidance metric, [0, 1e6]: `metric (1 - d/D)² / (d/D + eps) (1 + approach / speed)`.
        collision_metric: 20.0, [0.0, 1e6],
        /// `eps` of the avoidance metric (bounds it at contact), [1e-4, 10].
        collision_metric_eps: 0.05, [1e-4, 10.0],
        /// Approach speed (m/s) at which the avoidance metric doubles, [1e-3, 10].
        collision_speed: 0.2, [1e-3, 10.0],
        /// Safety distance (m) used as the braking floor: the braking term
        /// plans to stop `collision_margin` away from the obstacle, [0, 0.5].
        collision_margin: 0.01, [0.0, 0.5],
        /// World velocity filter: robot sphere to obstacle pairs closer
        /// than `collision_filter_distance` join the self-collision
        /// velocity filter (see `self_hold`) with the bound that their
        /// distance stays at least `min(d, collision_hold)` after the step,
        /// the obstacle's velocity included, [0, 0.1].
        collision_hold: 0.005, [0.0, 0.1],
        /// Distance (m) within which sphere-obstacle pairs enter the
        /// velocity filter (0 leaves the world out of it), [0, 1].
        collision_filter_distance: 0.05, [0.0, 1.0],
        /// Self-collision: distance (m) between robot spheres of checked link
        /// pairs below which the policy acts, [1e-3, 1].
        self_distance: 0.015, [1e-3, 1.0],
        /// Self-collision repulsion at contact (m/s²), [0, 1e4].
        self_gain: 10.0, [0.0, 1e4],
        /// Self-collision metric scale, [0, 1e6].
        self_metric: 5.0, [0.0, 1e6],
        /// Share of the self-collision metric kept while a sphere pair is
        /// not approaching (velocity gating, as in RMPflow's collision
        /// policies): the policy brakes approaches without holding the arm
        /// off a target next to another link at rest, [0, 1].
        self_rest_weight: 0.02, [0.0, 1.0],
        /// Self-collision velocity filter: after the policies are combined
        /// (and the velocity scaled to its limits), the joint velocity is
        /// changed as little as possible (least squares, joint space) so
        /// that no checked sphere pair closer than `self_filter_distance`
        /// comes closer than `self_hold` (m) within the step, to first
        /// order; a pair already closer than `self_hold` may not approach
        /// further (it is never pushed apart by the filter), unless the
        /// exact geometry of its two links (meshes as convex hulls, parry)
        /// is more than `self_hold` apart: spheres protrude beyond the
        /// links, and configurations with overlapping spheres but separate
        /// links stay reachable, as in the collision checker's two-stage
        /// verdict. The gated self
        /// policy alone lets a fast arm (a UR5 at 3 rad/s closes 2 cm per
        /// 10 ms step) or an attractor pressing two links together reach
        /// contact; the filter is the hard guarantee, [0, 0.1].
        self_hold: 0.002, [0.0, 0.1],
        /// Distance (m) between sphere surfaces within which pairs enter the
        /// self-collision velocity filter: at least the closing distance of
        /// one control step (0 turns the self filter off), [0, 1].
        self_filter_distance: 0.05, [0.0, 1.0],
        /// 1: the velocity filter watches the links' exact geometry (meshes
        /// as convex hulls, primitives exactly; parry's closest points) for
        /// every checked self link pair and every link near an obstacle
        /// (boxes, spheres, cylinders, capsules), with the same holds and
        /// filter distances as the sphere pairs, instead of trusting the
        /// spheres to cover the links (a hand-made sphere model may not:
        /// links then touch while their spheres are apart). Self sphere
        /// pairs of links with exact geometry then leave the filter (the
        /// exact pair replaces them); their avoidance policy stays. 0: the
        /// spheres alone, [0, 1], whole.
        exact_filter: 1.0, [0.0, 1.0],
        /// 1: the avoidance policies also act on the links' exact distances
        /// that the filter's exact layer measures (needs `exact_filter`):
        /// a self barrier (the `self_*` gains) on every watched link pair
        /// closer than `self_distance`, and a world barrier (the
        /// `collision_*` gains) on every link closer than
        /// `collision_filter_distance` to an obstacle, each along the exact
        /// witness points' normal. Their metrics resist motion along the
        /// normal only, so the combined solve turns the attraction into
        /// motion along the links' surfaces before the filter's hold stops
        /// it, where the sphere policies cannot see the geometry (links not
        /// covered by their spheres). 0: the sphere policies alone, [0, 1], whole.
        exact_policy: 1.0, [0.0, 1.0],
        /// Joint limits: the controller works in limit-aware coordinates
        /// `q = m + h tanh(u / h)` per joint (`m` the middle of the range,
        /// `h` half the range minus this buffer), so its joints stay at least
        /// `limit_buffer` (rad or m) inside their hard limits without any
        /// repulsion: a target at the edge of the range is approached, not
        /// pushed away from, [0, 0.5].
        limit_buffer: 0.01, [0.0, 0.5],
        /// Fraction of each joint's velocity limit above which the
        /// velocity-limit policy damps the joint, [0.05, 1].
        velocity_soft_fraction: 0.8, [0.05, 1.0],
        /// Velocity-limit policy damping (1/s) and metric scale, [0, 1e4].
        velocity_gain: 20.0, [0.0, 1e4],
        /// C-space policy: stiffness towards the posture (1/s²), [0, 1e3].
        posture_gain: 4.0, [0.0, 1e3],
        /// C-space policy: joint velocity damping (1/s), [0, 1e3].
        joint_damping: 6.0, [0.0, 1e3],
        /// Metric of the c-space policy (resolves redundancy), [0, 1e3].
        posture_metric: 0.02, [0.0, 1e3],
        /// Progress watch: a step reports `stalled` when the end-effector
        /// error (position error plus 0.1 m per radian of rotation error)
        /// has not dropped by `stall_progress` over `stall_time` seconds of
        /// the arm at rest (every joint slower than `stall_speed`) while it
        /// is above `stall_progress`: a local minimum, the cue for global
        /// guidance (see `set_waypoints`), [0.05, 100].
        stall_time: 0.4, [0.05, 100.0],
        /// Progress (m) that resets the stall watch, [1e-4, 1].
        stall_progress: 0.005, [1e-4, 1.0],
        /// Joint speed (rad/s or m/s) above which the arm counts as moving
        /// (evading, say) and the stall watch restarts: a local minimum is
        /// a rest away from the target, [1e-4, 10].
        stall_speed: 0.05, [1e-4, 10.0],
        /// 1: a step whose commanded velocity the velocity filter changed
        /// (the arm pressed against a hold: `StepInfo::filter_active`)
        /// counts as at rest for the stall watch, whatever the joints'
        /// speed: an arm sliding along a hold without getting
        /// `stall_progress` closer within `stall_time` is in a local
        /// minimum too, and asks for guidance. 0: only joint speed counts
        /// (an arm jittering at a hold never stalls), [0, 1], whole.
        stall_filtered: 1.0, [0.0, 1.0],
        /// 1: motion counts as evasion (which restarts the stall watch)
        /// only while a world avoidance policy acts (an obstacle within
        /// `collision_distance` of the arm at the previous step); motion
        /// with no obstacle near that does not get `stall_progress` closer
        /// within `stall_time` is a crawl, not an evasion (a 6-axis arm
        /// creeping along a near-singular direction, or sliding towards a
        /// saddle of the attractor, after an obstacle pushed it off its
        /// path), and asks for guidance. 0: any joint faster than
        /// `stall_speed` restarts the watch, [0, 1], whole.
        stall_unforced: 1.0, [0.0, 1.0],
        /// Global guidance (see `crate::guidance`): plan attempts per target
        /// when a step reports `stalled` (a whole number; 0 disables
        /// guidance), [0, 100].
        guidance_plans: 3.0, [0.0, 100.0],
        /// Seconds (controller clock: the sum of the steps' `dt`) between two
        /// guidance attempts for one target, [0, 60].
        guidance_retry: 0.3, [0.0, 60.0],
        /// Time limit (s) of one guidance plan (IK and path search), [1e-3, 60].
        guidance_time_limit: 0.5, [1e-3, 60.0],
        /// 1: plan inside the step that detected the stall (deterministic;
        /// simulator loops); 0: plan on a background thread while the loop
        /// keeps running (a real robot's state stream), [0, 1], whole.
        guidance_blocking: 1.0, [0.0, 1.0],
        /// Position error (m) under which the guidance status is `reached`, [1e-5, 1].
        reach_position_tolerance: 0.01, [1e-5, 1.0],
        /// Rotation error (rad) under which the guidance status is `reached`
        /// (when the orientation is controlled), [1e-4, 3.2].
        reach_rotation_tolerance: 0.05, [1e-4, 3.2],
        /// Waypoint (global guidance) attractor in the limit-aware joint
        /// coordinates: acceleration far from the waypoint (rad/s²), [0, 200].
        waypoint_gain: 20.0, [0.0, 200.0],
        /// Joint distance (rad, max norm) below which the waypoint attractor
        /// is a linear spring, [1e-3, 3].
        waypoint_length: 0.1, [1e-3, 3.0],
        /// Damping of the waypoint attractor (1/s), [0, 200].
        waypoint_damping: 10.0, [0.0, 200.0],
        /// Metric of the waypoint attractor, [0, 1e4].
        waypoint_metric: 10.0, [0.0, 1e4],
        /// Joint distance (rad or m, max norm) at which a waypoint counts as
        /// passed; passing the last one hands back to the end-effector
        /// target, [1e-3, 3].
        waypoint_tolerance: 0.1, [1e-3, 3.0],
        /// Ridge added to the summed metric before the solve, [1e-9, 10].
        regularization: 1e-4, [1e-9, 10.0],
        /// Hard acceleration limit per joint (rad/s² or m/s²); the
        /// acceleration vector is scaled down uniformly to respect it, [1e-2, 1e4].
        max_acceleration: 20.0, [1e-2, 1e4],
        /// Fraction of the URDF velocity limits used as hard limits (the
        /// velocity vector is scaled uniformly to respect them), [0.01, 1].
        velocity_scale: 1.0, [0.01, 1.0],
        /// Velocity limit (rad/s or m/s) for joints whose URDF states none, [1e-2, 100].
        default_velocity_limit: 2.0, [1e-2, 100.0],
    }
}

config_struct! {
    /// Gains of [`crate::PotentialFieldController`]: attractive and
    /// repulsive potentials mapped to joint space by Jacobian transposes;
    /// obstacle distances come from voxelised signed distance fields.
    PotentialFieldConfig {
        /// Attractive stiffness (1/s²) of the end-effector position, [0, 1e4].
        attract_gain: 150.0, [0.0, 1e4],
        /// Distance (m) beyond which the attractive force stops growing
        /// (conic potential outside, quadratic inside), [1e-3, 2].
        attract_radius: 0.15, [1e-3, 2.0],
        /// Attractive stiffness (1/s²) of the orientation error; 0 leaves it free, [0, 1e4].
        orientation_gain: 30.0, [0.0, 1e4],
        /// Angle (rad) beyond which the orientation force stops growing, [1e-3, 3.2].
        orientation_radius: 0.5, [1e-3, 3.2],
        /// Repulsive gain `eta` of `U = eta/2 (1/d - 1/d0)²` per robot sphere, [0, 100].
        repulse_gain: 0.005, [0.0, 100.0],
        /// Influence distance `d0` (m) of the world repulsion, [1e-3, 1].
        repulse_distance: 0.2, [1e-3, 1.0],
        /// Repulsive gain between robot spheres of checked link pairs, [0, 100].
        self_gain: 1e-5, [0.0, 100.0],
        /// Influence distance (m) of the self repulsion, [1e-3, 1].
        self_distance: 0.02, [1e-3, 1.0],
        /// Repulsive gain of the joint limits, [0, 100].
        limit_gain: 0.002, [0.0, 100.0],
        /// Influence distance (rad or m) of the joint limits, [1e-3, 3].
        limit_distance: 0.15, [1e-3, 3.0],
        /// Smallest distance (m) used in `1/d` terms (keeps them finite), [1e-4, 0.1].
        min_distance: 0.005, [1e-4, 0.1],
        /// Joint velocity damping (1/s), [0, 1e3].
        damping: 6.0, [0.0, 1e3],
        /// Stiffness towards the posture (1/s²), [0, 1e3].
        posture_gain: 0.05, [0.0, 1e3],
        /// Voxel edge length (m) of the distance fields, [1e-3, 0.2].
        field_resolution: 0.01, [1e-3, 0.2],
        /// Extent (m) of each object's field beyond the object; must be at
        /// least `repulse_distance` plus one voxel, [1e-3, 2].
        field_padding: 0.25, [1e-3, 2.0],
        /// Hard acceleration limit per joint (rad/s² or m/s²), [1e-2, 1e4].
        max_acceleration: 20.0, [1e-2, 1e4],
        /// Fraction of the URDF velocity limits used as hard limits, [0.01, 1].
        velocity_scale: 1.0, [0.01, 1.0],
        /// Velocity limit for joints whose URDF states none, [1e-2, 100].
        default_velocity_limit: 2.0, [1e-2, 100.0],
    }
}

impl ReactiveConfig {
    /// Checks the ranges and that the counts and switches are whole numbers.
    pub fn validate_all(&self) -> Result<()> {
        self.validate()?;
        for (name, v) in [
            ("guidance_plans", self.guidance_plans),
            ("guidance_blocking", self.guidance_blocking),
            ("exact_filter", self.exact_filter),
            ("exact_policy", self.exact_policy),
            ("stall_filtered", self.stall_filtered),
            ("stall_unforced", self.stall_unforced),
        ] {
            if v.fract() != 0.0 {
                return Err(ControlError::InvalidArgument(format!(
                    "config '{name}': must be a whole number, got {v}"
                )));
            }
        }
        Ok(())
    }
}

impl PotentialFieldConfig {
    /// Checks the ranges and that the fields reach past the influence distance.
    pub fn validate_all(&self) -> Result<()> {
        self.validate()?;
        if self.field_padding < self.repulse_distance + self.field_resolution {
            return Err(ControlError::InvalidArgument(format!(
                "config 'field_padding' ({}) must be at least repulse_distance + field_resolution ({})",
                self.field_padding,
                self.repulse_distance + self.field_resolution
            )));
        }
        Ok(())
    }
}
