//! What both controllers share: the robot's spheres placed by forward
//! kinematics, point and end-effector Jacobians over the controlled joints,
//! the target, the posture, and the safety filter that turns a joint
//! acceleration into position/velocity targets within acceleration,
//! velocity and position limits.

use std::sync::Arc;

use ferrobot_collision::CollisionChecker;
use ferrobot_model::{JointKind, RobotModel};
use nalgebra::{Isometry3, Point3, Vector3};

use crate::error::{ControlError, Result, check_finite};
use crate::world::ControlWorld;

/// A robot sphere in its link frame.
#[derive(Debug, Clone, Copy)]
pub struct CtlSphere {
    /// Link it moves with.
    pub link: usize,
    /// Centre in the link frame.
    pub center: Point3<f64>,
    /// Radius (m).
    pub radius: f64,
}

/// What a step computed besides the targets (for monitoring and logs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepInfo {
    /// Smallest signed distance (m) between a robot sphere and a world
    /// shape among those within the world policy's reach (`inf` when no
    /// sphere is that close).
    pub world_clearance: f64,
    /// Smallest distance (m) between spheres of checked link pairs within
    /// the self policy's reach (`inf` otherwise).
    pub self_clearance: f64,
    /// Number of (sphere, shape) and (sphere, sphere) avoidance terms
    /// active this step.
    pub active_avoidance: usize,
    /// End-effector distance to the target position (m; `nan` without target).
    pub position_error: f64,
    /// End-effector angle to the target orientation (rad; `nan` without target).
    pub rotation_error: f64,
    /// Factor (<= 1) the acceleration was scaled by to respect `max_acceleration`.
    pub acceleration_scale: f64,
    /// Factor (<= 1) the velocity was scaled by to respect the velocity limits.
    pub velocity_scale: f64,
    /// Whether a joint's velocity was cut so it can stop before its limit.
    pub limit_braked: bool,
    /// Whether the end effector has made no progress towards the target
    /// for `stall_time` (reactive controller; see `ReactiveConfig`).
    pub stalled: bool,
    /// Waypoints of the global guidance still to pass (reactive controller).
    pub waypoints_remaining: usize,
    /// What global guidance is doing (reactive controller; see
    /// [`crate::guidance`]).
    pub guidance: crate::guidance::GuidanceStatus,
    /// Guidance plan attempts made for the current target.
    pub guidance_plans: usize,
    /// Sphere pairs (self and world) in the velocity filter this step
    /// (reactive controller; see `ReactiveConfig::self_hold` and
    /// `ReactiveConfig::collision_hold`).
    pub filtered: usize,
    /// Whether the velocity filter changed the commanded velocity this step
    /// (a filter row was binding: the arm is held at a hold, or an obstacle
    /// pushes it).
    pub filter_active: bool,
}

/// The result of one controller step, in `dof_names` order.
#[derive(Debug, Clone)]
pub struct StepOutput {
    /// Position targets `q + qd_target dt`.
    pub q_target: Vec<f64>,
    /// Velocity targets.
    pub qd_target: Vec<f64>,
    /// Joint accelerations `(qd_target - qd) / dt` (after the limits).
    pub qdd: Vec<f64>,
    /// Diagnostics.
    pub info: StepInfo,
}

/// The end-effector target.
#[derive(Debug, Clone, Copy)]
pub struct Target {
    /// Pose in the base frame.
    pub pose: Isometry3<f64>,
    /// Whether the orientation is controlled.
    pub orientation: bool,
}

/// Robot geometry and kinematics over the controlled joints.
#[derive(Debug, Clone)]
pub struct Core {
    pub(crate) model: Arc<RobotModel>,
    /// Controlled DOFs (model DOF indices).
    pub(crate) active: Vec<usize>,
    /// Per link: (joint index, column, gain) of each ancestor joint driven
    /// by a controlled DOF.
    link_joints: Vec<Vec<(usize, usize, f64)>>,
    pub(crate) spheres: Vec<CtlSphere>,
    /// Sphere index pairs checked for self-collision.
    pub(crate) self_pairs: Vec<(u32, u32)>,
    /// Link pairs checked for self-collision (robot links only).
    self_link_pairs: Vec<(usize, usize)>,
    root_in_base: Isometry3<f64>,
    pub(crate) ee_link: usize,
    lower: Vec<f64>,
    upper: Vec<f64>,
    vmax_urdf: Vec<f64>,
    pub(crate) world: ControlWorld,
    pub(crate) target: Option<Target>,
    pub(crate) posture: Option<Vec<f64>>,
    // Scratch, reused every step.
    pub(crate) poses: Vec<Isometry3<f64>>,
    pub(crate) centers: Vec<Point3<f64>>,
}

impl Core {
    /// The spheres, self-collision pairs and world of `checker`, controlling
    /// the planning-group DOFs of its model with `ee_link` (default: the
    /// model's end effector).
    pub fn new(checker: &CollisionChecker, ee_link: Option<&str>) -> Result<Self> {
        let model = checker.model().clone();
        let ee_link = match ee_link {
            Some(name) => model.link(name)?,
            None => model.ee_link(),
        };
        let mut active: Vec<usize> = model.group_dofs().to_vec();
        if active.is_empty() {
            active = (0..model.num_dof()).collect();
        }
        let mut col_of_dof = vec![None; model.num_dof()];
        for (c, &d) in active.iter().enumerate() {
            col_of_dof[d] = Some(c);
        }
        let joints = model.joints();
        let link_joints = (0..model.links().len())
            .map(|l| {
                model
                    .path_to(l)
                    .into_iter()
                    .filter(|&j| joints[j].kind.is_movable())
                    .filter_map(|j| {
                        let (dof, gain) = joints[j].coupling.driver()?;
                        Some((j, col_of_dof[dof]?, gain))
                    })
                    .collect()
            })
            .collect();
        // Spheres per compiled body (links, then attached objects).
        let (robot, _) = checker.compiled();
        let mut spheres = Vec::new();
        let mut body_range = Vec::new();
        for body in &robot.bodies {
            let start = spheres.len();
            let list = match &body.attached {
                None => checker.spheres().links[body.link].clone(),
                Some(name) => checker
                    .attached()
                    .iter()
                    .find(|a| &a.name == name)
                    .map(|a| a.spheres.clone())
                    .unwrap_or_default(),
            };
            spheres.extend(list.iter().map(|s| CtlSphere {
                link: body.link,
                center: s.center,
                radius: s.radius,
            }));
            body_range.push(start..spheres.len());
        }
        let mut self_pairs = Vec::new();
        let mut self_link_pairs: Vec<(usize, usize)> = robot
            .pairs
            .iter()
            .filter(|&&(a, b)| {
                robot.bodies[a].attached.is_none() && robot.bodies[b].attached.is_none()
            })
            .map(|&(a, b)| (robot.bodies[a].link, robot.bodies[b].link))
            .collect();
        self_link_pairs.sort_unstable();
        self_link_pairs.dedup();
        for &(a, b) in &robot.pairs {
            for i in body_range[a].clone() {
                for j in body_range[b].clone() {
                    self_pairs.push((i as u32, j as u32));
                }
            }
        }
        let q0 = model.neutral_configuration();
        let root_in_base = model.fk_all(&q0)?[0];
        let all_lo = model.lower_limits();
        let all_hi = model.upper_limits();
        let all_v = model.velocity_limits();
        let n_links = model.links().len();
        Ok(Self {
            lower: active.iter().map(|&d| all_lo[d]).collect(),
            upper: active.iter().map(|&d| all_hi[d]).collect(),
            vmax_urdf: active.iter().map(|&d| all_v[d]).collect(),
            centers: vec![Point3::origin(); spheres.len()],
            active,
            link_joints,
            spheres,
            self_pairs,
            self_link_pairs,
            root_in_base,
            ee_link,
            world: ControlWorld::new(checker.world().clone()),
            target: None,
            posture: None,
            poses: vec![Isometry3::identity(); n_links],
            model,
        })
    }

    /// Number of controlled DOFs that move link `l`.
    pub(crate) fn link_dofs(&self, l: usize) -> usize {
        self.link_joints[l].len()
    }

    /// Lower position limit of controlled DOF number `col`.
    pub(crate) fn lower_limit(&self, col: usize) -> f64 {
        self.lower[col]
    }

    /// Upper position limit of controlled DOF number `col`.
    pub(crate) fn upper_limit(&self, col: usize) -> f64 {
        self.upper[col]
    }

    /// Hard velocity limit of controlled DOF number `col`.
    pub(crate) fn velocity_limit(&self, col: usize, scale: f64, default: f64) -> f64 {
        let v = self.vmax_urdf[col];
        if v.is_finite() && v > 0.0 {
            v * scale
        } else {
            default
        }
    }

    /// The model.
    pub fn model(&self) -> &Arc<RobotModel> {
        &self.model
    }

    /// Controlled DOFs (indices into `dof_names`).
    pub fn active_dofs(&self) -> &[usize] {
        &self.active
    }

    /// Number of robot spheres.
    pub fn num_spheres(&self) -> usize {
        self.spheres.len()
    }

    /// Radii of the robot spheres (m), in the controller's sphere order.
    pub fn sphere_radii(&self) -> Vec<f64> {
        self.spheres.iter().map(|s| s.radius).collect()
    }

    /// Link pairs (link indices) checked for self-collision: those the
    /// checker's allowed-collision matrix leaves enabled, between links
    /// that have spheres.
    pub fn self_link_pairs(&self) -> &[(usize, usize)] {
        &self.self_link_pairs
    }

    /// Number of sphere pairs checked for self-collision.
    pub fn num_self_pairs(&self) -> usize {
        self.self_pairs.len()
    }

    /// The world.
    pub fn world(&self) -> &ControlWorld {
        &self.world
    }

    /// Sets the end-effector target (base frame); `orientation: false`
    /// controls the position alone.
    pub fn set_target(&mut self, pose: Isometry3<f64>, orientation: bool) -> Result<()> {
        check_finite("target", pose.translation.vector.as_slice())?;
        check_finite("target", pose.rotation.coords.as_slice())?;
        self.target = Some(Target { pose, orientation });
        Ok(())
    }

    /// Removes the target: the controller holds its posture.
    pub fn clear_target(&mut self) {
        self.target = None;
    }

    /// The target, if any.
    pub fn target(&self) -> Option<Target> {
        self.target
    }

    /// Sets the posture the c-space policy pulls towards (full DOF vector;
    /// DOFs outside the controlled group are held at it).
    pub fn set_posture(&mut self, q: &[f64]) -> Result<()> {
        self.model.check_configuration("posture", q)?;
        self.posture = Some(q.to_vec());
        Ok(())
    }

    /// The posture (`None` until set or until the first step, which takes
    /// the first measured configuration).
    pub fn posture(&self) -> Option<&[f64]> {
        self.posture.as_deref()
    }

    /// Checks the inputs of a step and makes sure there is a posture.
    pub(crate) fn check_step(&mut self, q: &[f64], qd: &[f64], dt: f64) -> Result<()> {
        self.model.check_configuration("q", q)?;
        if qd.len() != q.len() {
            return Err(ControlError::InvalidArgument(format!(
                "qd: expected {} values (dof_names order), got {}",
                q.len(),
                qd.len()
            )));
        }
        check_finite("qd", qd)?;
        if !(dt.is_finite() && dt > 0.0 && dt <= 1.0) {
            return Err(ControlError::InvalidArgument(format!(
                "dt: must be in (0, 1] s, got {dt}"
            )));
        }
        if self.posture.is_none() {
            self.posture = Some(q.to_vec());
        }
        Ok(())
    }

    /// Forward kinematics of every link and sphere at `q` into the scratch.
    pub(crate) fn forward(&mut self, q: &[f64]) {
        let joints = self.model.joints();
        self.poses[0] = self.root_in_base;
        for joint in joints {
            let local = joint.local_transform(joint.coupling.position(q).unwrap_or(0.0));
            self.poses[joint.child] = self.poses[joint.parent] * local;
        }
        for (c, s) in self.centers.iter_mut().zip(&self.spheres) {
            *c = self.poses[s.link] * s.center;
        }
    }

    /// Linear-velocity Jacobian (3 x k, row-major, k controlled DOFs) of a
    /// point `p` (base frame) fixed to `link`, after [`Core::forward`].
    pub(crate) fn point_jacobian(&self, link: usize, p: &Point3<f64>, out: &mut [f64]) {
        let k = self.active.len();
        out[..3 * k].fill(0.0);
        let joints = self.model.joints();
        for &(j, c, gain) in &self.link_joints[link] {
            let joint = &joints[j];
            let frame = &self.poses[joint.child];
            let axis = frame.rotation * joint.axis.into_inner();
            let col = if joint.kind == JointKind::Prismatic {
                axis
            } else {
                axis.cross(&(p.coords - frame.translation.vector))
            } * gain;
            out[c] += col.x;
            out[k + c] += col.y;
            out[2 * k + c] += col.z;
        }
    }

    /// Angular-velocity Jacobian (3 x k) of `link`, after [`Core::forward`].
    pub(crate) fn angular_jacobian(&self, link: usize, out: &mut [f64]) {
        let k = self.active.len();
        out[..3 * k].fill(0.0);
        let joints = self.model.joints();
        for &(j, c, gain) in &self.link_joints[link] {
            let joint = &joints[j];
            if joint.kind == JointKind::Prismatic {
                continue;
            }
            let axis = self.poses[joint.child].rotation * joint.axis.into_inner() * gain;
            out[c] += axis.x;
            out[k + c] += axis.y;
            out[2 * k + c] += axis.z;
        }
    }

    /// Per sphere: smallest signed distance to the world (exact shapes),
    /// its unit gradient in the base frame, and the gradient with respect
    /// to the full DOF vector (`num_dof` values; zero for DOFs outside the
    /// group). Spheres farther than `reach` from every shape get `inf`.
    #[allow(clippy::type_complexity)]
    pub fn sphere_distances(
        &mut self,
        q: &[f64],
        reach: f64,
    ) -> Result<(Vec<f64>, Vec<Vector3<f64>>, Vec<Vec<f64>>, Vec<Point3<f64>>)> {
        self.model.check_configuration("q", q)?;
        self.forward(q);
        let k = self.active.len();
        let n = self.model.num_dof();
        let mut jp = vec![0.0; 3 * k];
        let mut dist = Vec::new();
        let mut dirs = Vec::new();
        let mut grads = Vec::new();
        for (s, c) in self.spheres.iter().zip(&self.centers) {
            let mut best = (f64::INFINITY, Vector3::zeros());
            for part in self.world.parts() {
                if !ControlWorld::near(part, c, s.radius, reach) {
                    continue;
                }
                let (d, g) = ControlWorld::exact_distance(part, c);
                if d - s.radius < best.0 {
                    best = (d - s.radius, g);
                }
            }
            let mut grad = vec![0.0; n];
            if best.0.is_finite() {
                self.point_jacobian(s.link, c, &mut jp);
                for (col, &dof) in self.active.iter().enumerate() {
                    grad[dof] = (0..3).map(|r| best.1[r] * jp[r * k + col]).sum();
                }
            }
            dist.push(best.0);
            dirs.push(best.1);
            grads.push(grad);
        }
        Ok((dist, dirs, grads, self.centers.clone()))
    }

    /// Position and rotation errors of the end effector to the target, its
    /// pose at the last [`Core::forward`].
    pub(crate) fn target_errors(&self) -> (f64, f64) {
        match &self.target {
            None => (f64::NAN, f64::NAN),
            Some(t) => {
                let ee = &self.poses[self.ee_link];
                let dp = (ee.translation.vector - t.pose.translation.vector).norm();
                let dr = if t.orientation {
                    ee.rotation.angle_to(&t.pose.rotation)
                } else {
                    f64::NAN
                };
                (dp, dr)
            }
        }
    }

    /// Turns the controlled DOFs' acceleration `qdd` into targets: scales
    /// the acceleration uniformly to `max_acc`, integrates the velocity,
    /// scales it uniformly to the velocity limits (`vel_scale` times the
    /// URDF's, `default_vel` where it states none), applies the velocity
    /// filter (rows and gaps, see `ReactiveConfig::self_hold`), cuts any joint velocity
    /// that could not stop before its position limit at `max_acc`, then
    /// integrates the position (semi-implicit Euler). Other DOFs are held
    /// at the posture.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn integrate(
        &self,
        q: &[f64],
        qd: &[f64],
        qdd: &mut [f64],
        dt: f64,
        max_acc: f64,
        vel_scale: f64,
        default_vel: f64,
        filter: Option<(&[f64], &[f64])>,
        info: &mut StepInfo,
    ) -> StepOutput {
        let posture = self.posture.as_deref().unwrap_or(q);
        let peak = qdd.iter().fold(0.0f64, |m, a| m.max(a.abs()));
        let sa = if peak > max_acc { max_acc / peak } else { 1.0 };
        qdd.iter_mut().for_each(|a| *a *= sa);
        let mut v: Vec<f64> = self
            .active
            .iter()
            .zip(qdd.iter())
            .map(|(&d, a)| qd[d] + a * dt)
            .collect();
        let mut sv = 1.0f64;
        for (i, vi) in v.iter().enumerate() {
            let lim = self.velocity_limit(i, vel_scale, default_vel);
            if vi.abs() * sv > lim {
                sv = lim / vi.abs();
            }
        }
        v.iter_mut().for_each(|x| *x *= sv);
        // Velocity filter: rows `a` (k values each) with lower bounds `b`:
        // keep `a·v >= b`, changing v least in the Euclidean norm, by
        // cyclic projections onto the half-spaces. The self-collision
        // bounds are never positive, so scaling v down afterwards keeps
        // them; a world bound is positive only while an obstacle closes in
        // on a sphere already within `collision_hold`.
        if let Some((rows, bounds)) = filter {
            let k = v.len();
            for pass in 0..50 {
                let mut worst = 0.0f64;
                for (a, &bound) in rows.chunks_exact(k).zip(bounds) {
                    let av: f64 = a.iter().zip(v.iter()).map(|(x, y)| x * y).sum();
                    let miss = bound - av;
                    if miss > 0.0 {
                        let aa: f64 = a.iter().map(|x| x * x).sum();
                        if aa > 1e-18 {
                            v.iter_mut().zip(a).for_each(|(x, y)| *x += miss / aa * y);
                            worst = worst.max(miss);
                        }
                    }
                }
                if worst <= 1e-9 {
                    break;
                }
                if pass == 0 {
                    info.filter_active = true;
                }
            }
            info.filtered = rows.len() / k.max(1);
            // The projection may have raised a joint's speed: scale to the
            // limits again (this keeps the constraints, see above).
            let mut s2 = 1.0f64;
            for (i, vi) in v.iter().enumerate() {
                let lim = self.velocity_limit(i, vel_scale, default_vel);
                if vi.abs() * s2 > lim {
                    s2 = lim / vi.abs();
                }
            }
            v.iter_mut().for_each(|x| *x *= s2);
            sv *= s2;
        }
        let mut braked = false;
        for (i, vi) in v.iter_mut().enumerate() {
            let qi = q[self.active[i]];
            if self.upper[i].is_finite() {
                let room = (self.upper[i] - qi).max(0.0);
                let cap = (2.0 * max_acc * room).sqrt().min(room / dt);
                if *vi > cap {
                    *vi = cap;
                    braked = true;
                }
            }
            if self.lower[i].is_finite() {
                let room = (qi - self.lower[i]).max(0.0);
                let cap = (2.0 * max_acc * room).sqrt().min(room / dt);
                if *vi < -cap {
                    *vi = -cap;
                    braked = true;
                }
            }
        }
        let n = q.len();
        let mut q_target = posture.to_vec();
        let mut qd_target = vec![0.0; n];
        let mut qdd_out = vec![0.0; n];
        for (i, &d) in self.active.iter().enumerate() {
            qd_target[d] = v[i];
            q_target[d] = q[d] + v[i] * dt;
            qdd_out[d] = (v[i] - qd[d]) / dt;
        }
        info.acceleration_scale = sa;
        info.velocity_scale = sv;
        info.limit_braked = braked;
        StepOutput {
            q_target,
            qd_target,
            qdd: qdd_out,
            info: info.clone(),
        }
    }
}

/// What every controller shares through its [`Core`]: one definition of
/// the accessors (the model, the target and posture, the obstacles' poses)
/// instead of a copy per controller.
pub trait ControllerCore {
    /// The shared core (target, posture, world, geometry).
    fn core(&self) -> &Core;

    /// The shared core, mutable.
    fn core_mut(&mut self) -> &mut Core;

    /// The model.
    fn model(&self) -> &Arc<RobotModel> {
        self.core().model()
    }

    /// Moves one world object, with its velocity if known (a potential
    /// field moves with its object).
    fn set_obstacle_pose(
        &mut self,
        name: &str,
        pose: Isometry3<f64>,
        velocity: Option<[f64; 6]>,
    ) -> Result<()> {
        self.core_mut().world.set_pose(name, pose, velocity)
    }
}
