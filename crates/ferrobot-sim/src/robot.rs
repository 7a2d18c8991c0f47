//! A robot in the world: a `RobotModel` built as a Rapier multibody
//! articulation with a fixed base, mimic joints as DOF couplings, and the
//! state accessors (joint positions, velocities, teleport).

use std::sync::Arc;

use ferrobot_model::{JointCoupling, JointKind, RobotModel, Shape};
use nalgebra::{Isometry3, Unit, UnitQuaternion, Vector3};
use rapier3d::dynamics::{Multibody, RigidBodySet};
use rapier3d::math::Vector;
use rapier3d::prelude::{
    ActiveHooks, ColliderBuilder, GenericJoint, JointAxesMask, JointAxis, MassProperties,
    MultibodyDofCoupling, MultibodyLinkId, RigidBodyBuilder, RigidBodyHandle, SharedShape,
};

use crate::convert::{from_pose, to_pose};
use crate::drives::Drive;
use crate::error::{Result, SimError, check_len};
use crate::gripper::ParallelGripper;
use crate::hooks::user_data;
use crate::state::PhysState;

/// Options for adding a robot to a world.
#[derive(Debug, Clone)]
pub struct RobotOptions {
    /// Unique name in the world.
    pub name: String,
    /// Pose of the model's base link in the world.
    pub pose: Isometry3<f64>,
    /// Initial joint positions (default: [`default_start`], a configuration
    /// free of self-collision).
    pub q: Option<Vec<f64>>,
    /// Whether gravity acts on the robot's links (false: perfect gravity
    /// compensation, as Isaac Sim's `disable_gravity` on articulation links).
    pub gravity_compensation: bool,
    /// Extra solver substeps for the robot's bodies while the robot touches
    /// something (see [`Robot::set_solver_iterations`]).
    pub solver_iterations: usize,
    /// Friction coefficient of the robot's link surfaces.
    pub friction: f64,
    /// Link pairs whose contacts are ignored, and skipped when the start
    /// configuration is chosen (default `None`:
    /// [`ferrobot_model::AllowedCollisions::from_model`], adjacent, rigidly
    /// attached and SRDF pairs). Give the planner's automatic matrix
    /// (`ferrobot_collision::acm::automatic_acm`) so that a robot without an
    /// SRDF does not push apart links that overlap by design.
    pub allowed_collisions: Option<ferrobot_model::AllowedCollisions>,
}

impl RobotOptions {
    /// Defaults: name "robot", identity pose, neutral configuration, gravity
    /// compensation on, 4 extra solver iterations, friction 1.
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            pose: Isometry3::identity(),
            q: None,
            gravity_compensation: true,
            solver_iterations: 4,
            friction: 1.0,
            allowed_collisions: None,
        }
    }
}

/// A movable joint of the articulation (a DOF or a mimic joint).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ArtJoint {
    /// Model joint index.
    pub joint: usize,
    /// The child body's multibody link.
    pub link: MultibodyLinkId,
    /// Whether it rotates.
    pub rotational: bool,
    /// The child body.
    pub child_body: RigidBodyHandle,
    /// The parent body.
    pub parent_body: RigidBodyHandle,
}

impl ArtJoint {
    /// Rapier's free axis of the joint.
    pub fn axis(&self) -> JointAxis {
        if self.rotational {
            JointAxis::AngX
        } else {
            JointAxis::LinX
        }
    }
    /// Index of the coordinate in `MultibodyJoint::coords`.
    pub fn coord(&self) -> usize {
        if self.rotational { 3 } else { 0 }
    }
}

/// A robot built in a world.
#[derive(Debug, Clone)]
pub struct Robot {
    pub(crate) name: String,
    pub(crate) model: Arc<RobotModel>,
    /// The fixed root body.
    pub(crate) root: RigidBodyHandle,
    /// Per model link: its body and its pose in the body frame.
    pub(crate) link_body: Vec<(RigidBodyHandle, Isometry3<f64>)>,
    /// Per DOF.
    pub(crate) dofs: Vec<ArtJoint>,
    /// Mimic joints with their DOF, multiplier and offset.
    pub(crate) mimics: Vec<(ArtJoint, usize, f64, f64)>,
    /// Per DOF drive.
    pub(crate) drives: Vec<Drive>,
    /// Per DOF effort applied every step (N·m or N).
    pub(crate) efforts: Vec<f64>,
    /// All bodies of the robot (root first).
    pub(crate) bodies: Vec<RigidBodyHandle>,
    /// The gripper, if any.
    pub(crate) gripper: Option<ParallelGripper>,
    /// Pose of the base link in the world.
    pub(crate) base_pose: Isometry3<f64>,
    /// Extra solver substeps while the robot touches something.
    pub(crate) solver_iterations: usize,
    /// Extra solver substeps currently set on the robot's bodies.
    pub(crate) applied_iterations: usize,
    /// Substeps the robot's bodies ran at in the last step (1 while it
    /// holds still and touches nothing).
    pub(crate) applied_substeps: usize,
    /// The world's substeps (for dynamic objects), as of the last step.
    pub(crate) world_substeps: usize,
    /// Command latency: drive targets and efforts wait here until due.
    pub(crate) latency: crate::latency::RobotLatency,
}

/// The rotation taking the x axis to `axis`.
fn x_to(axis: &Unit<Vector3<f64>>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(&Vector3::x(), axis).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI)
    })
}

/// Collision shape of a link geometry (meshes as convex hulls); None for
/// a shape parry cannot represent (a degenerate hull).
fn link_shape(shape: &Shape) -> Option<(SharedShape, Isometry3<f64>)> {
    shape.to_parry(ferrobot_geometry::MeshAs::ConvexHull).ok()
}

/// The configuration a robot starts at when none is given: the SRDF's first
/// named state (its group's joints set, the rest at the neutral
/// configuration), else the neutral configuration (zero clamped into the
/// limits); the first of these, then of the SRDF's other named states, that
/// is free of self-collision (links' collision geometry apart by more than
/// 0.1 mm, the allowed-collision matrix's pairs skipped). When every
/// candidate collides, the first candidate (the model cannot be started
/// free of itself without a search; give `q`).
pub fn default_start(model: &RobotModel) -> Vec<f64> {
    default_start_with(model, &ferrobot_model::AllowedCollisions::from_model(model))
}

/// [`default_start`] with the allowed-collision matrix `acm`.
pub fn default_start_with(model: &RobotModel, acm: &ferrobot_model::AllowedCollisions) -> Vec<f64> {
    let mut candidates = Vec::new();
    if let Some(srdf) = model.srdf() {
        for s in &srdf.group_states {
            if let Ok(q) = model.named_state(&s.name, Some(&s.group)) {
                candidates.push(q);
            }
        }
    }
    let neutral = model.neutral_configuration();
    candidates.insert(candidates.len().min(1), neutral);
    candidates
        .iter()
        .find(|q| !self_collides_with(model, q, acm))
        .unwrap_or(&candidates[0])
        .clone()
}

/// Whether any two links of `model` not allowed to touch overlap by more
/// than 0.1 mm at `q` (their collision geometry, meshes as convex hulls).
pub fn self_collides(model: &RobotModel, q: &[f64]) -> bool {
    self_collides_with(
        model,
        q,
        &ferrobot_model::AllowedCollisions::from_model(model),
    )
}

/// [`self_collides`] with the allowed-collision matrix `acm`.
pub fn self_collides_with(
    model: &RobotModel,
    q: &[f64],
    acm: &ferrobot_model::AllowedCollisions,
) -> bool {
    let Ok(poses) = model.fk_all(q) else {
        return false;
    };
    let shapes: Vec<Vec<(SharedShape, Isometry3<f64>)>> = model
        .links()
        .iter()
        .enumerate()
        .map(|(l, link)| {
            link.collisions
                .iter()
                .filter_map(|g| {
                    let (s, frame) = link_shape(&g.shape)?;
                    Some((s, poses[l] * g.origin * frame))
                })
                .collect()
        })
        .collect();
    for a in 0..shapes.len() {
        for b in a + 1..shapes.len() {
            if shapes[a].is_empty() || shapes[b].is_empty() || acm.is_allowed(a, b) {
                continue;
            }
            for (sa, pa) in &shapes[a] {
                for (sb, pb) in &shapes[b] {
                    let c = parry3d::query::contact(
                        &to_pose(pa),
                        sa.as_ref(),
                        &to_pose(pb),
                        sb.as_ref(),
                        0.0,
                    );
                    if matches!(c, Ok(Some(c)) if c.dist < -1e-4) {
                        return true;
                    }
                }
            }
        }
    }
    false
}

/// Moves the link bodies of `mb` to its links' poses (after its forward
/// kinematics) with `RigidBody::set_position`, which flags the change, so
/// the next step moves their colliders before its collision detection.
/// `Multibody::update_rigid_bodies` writes the body poses without that
/// flag: the colliders then kept their old poses through the next step's
/// contact update, where a recycled contact pair (a pair without a
/// contact-filter hook) passed Rapier's recycling test against those old
/// poses and was solved with its normal and lever arms frozen at the old
/// orientation around bodies at the new one: after a teleport of the
/// Panda's joint 4 by 2.6 rad, the link5-link7 pair (13.9 mm apart)
/// became a spurious penetration and kicked the arm.
fn move_link_bodies(mb: &Multibody, bodies: &mut RigidBodySet) {
    for link in mb.links() {
        if let Some(b) = bodies.get_mut(link.rigid_body_handle()) {
            b.set_position(*link.local_to_world(), true);
        }
    }
}

/// Minimum mass and inertia given to a movable body whose links carry no
/// inertial (a multibody needs positive inertia on every DOF).
const MIN_MASS: f32 = 1e-2;
const MIN_INERTIA: f32 = 1e-5;

impl Robot {
    /// Builds the articulation of `model` in `state`. `robot_index` and
    /// `seg_base` tag the colliders (robot link `l` gets segmentation id
    /// `seg_base + l`).
    pub(crate) fn build(
        state: &mut PhysState,
        model: Arc<RobotModel>,
        options: &RobotOptions,
        robot_index: usize,
        seg_base: u32,
    ) -> Result<Self> {
        if !crate::convert::pose_is_finite(&options.pose) {
            return Err(SimError::NonFinite(format!(
                "robot '{}': pose is not finite",
                options.name
            )));
        }
        let q0 = match &options.q {
            Some(q) => {
                check_len("q", q, model.num_dof())?;
                q.clone()
            }
            None => match &options.allowed_collisions {
                Some(acm) => default_start_with(&model, acm),
                None => default_start(&model),
            },
        };
        let links = model.links();
        let joints = model.joints();
        // Bodies: a new body at every movable joint; fixed joints merge the
        // child link into its parent's body.
        let mut body_of = vec![0usize; links.len()];
        let mut offset = vec![Isometry3::identity(); links.len()];
        let mut body_links: Vec<usize> = vec![0]; // the link whose frame is each body's frame
        for (l, link) in links.iter().enumerate().skip(1) {
            let j = &joints[link.parent_joint.expect("non-root link has a parent joint")];
            if j.kind.is_movable() {
                body_of[l] = body_links.len();
                body_links.push(l);
            } else {
                body_of[l] = body_of[j.parent];
                offset[l] = offset[j.parent] * j.origin;
            }
        }
        // World poses of the link frames at q0 (root pose from the base pose).
        let link_world: Vec<Isometry3<f64>> = model
            .fk_all(&q0)?
            .into_iter()
            .map(|p| options.pose * p)
            .collect();

        // Mass properties per body.
        let mut mprops: Vec<MassProperties> = vec![MassProperties::default(); body_links.len()];
        for (l, link) in links.iter().enumerate() {
            let inertial = &link.inertial;
            if inertial.mass <= 0.0 {
                continue;
            }
            mprops[body_of[l]] += crate::calibration::mass_props(inertial, &offset[l]);
        }

        let mut bodies = Vec::with_capacity(body_links.len());
        for (b, &l) in body_links.iter().enumerate() {
            let pose = to_pose(&link_world[l]);
            let builder = if b == 0 {
                RigidBodyBuilder::fixed()
            } else {
                let mut mp = mprops[b];
                if mp.mass() < MIN_MASS {
                    mp = MassProperties::new(mp.local_com, MIN_MASS, Vector::splat(MIN_INERTIA));
                }
                let pi = mp.principal_inertia();
                if pi.min_element() < MIN_INERTIA {
                    mp = MassProperties::with_principal_inertia_frame(
                        mp.local_com,
                        mp.mass(),
                        pi.max(Vector::splat(MIN_INERTIA)),
                        mp.principal_inertia_local_frame,
                    );
                }
                RigidBodyBuilder::dynamic()
                    .additional_mass_properties(mp)
                    .gravity_scale(if options.gravity_compensation {
                        0.0
                    } else {
                        1.0
                    })
                    .can_sleep(false)
            };
            bodies.push(state.bodies.insert(builder.pose(pose)));
        }

        // Colliders (density 0: the inertials give the mass).
        for (l, link) in links.iter().enumerate() {
            for (g, geom) in link.collisions.iter().enumerate() {
                let Some((shape, shape_frame)) = link_shape(&geom.shape) else {
                    return Err(SimError::InvalidArgument(format!(
                        "robot '{}': link '{}' collision {g}: the mesh has no volume (its convex hull is degenerate)",
                        options.name, link.name
                    )));
                };
                let collider = ColliderBuilder::new(shape)
                    .density(0.0)
                    .friction(options.friction as f32)
                    .position(to_pose(&(offset[l] * geom.origin * shape_frame)))
                    .active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS)
                    .user_data(user_data(seg_base + l as u32, Some(robot_index), l));
                let body = bodies[body_of[l]];
                state
                    .colliders
                    .insert_with_parent(collider, body, &mut state.bodies);
            }
        }

        // Joints, in depth-first order (parents first).
        let mut inserted = Vec::new();
        for (l, link) in links.iter().enumerate().skip(1) {
            let ji = link.parent_joint.expect("non-root link has a parent joint");
            let j = &joints[ji];
            if !j.kind.is_movable() {
                continue;
            }
            let rotational = j.kind.is_rotational();
            let r = x_to(&j.axis);
            let frame1 = offset[j.parent] * j.origin * r;
            let frame2 = Isometry3::from_parts(Default::default(), r);
            let mut gj = GenericJoint::new(if rotational {
                JointAxesMask::LOCKED_REVOLUTE_AXES
            } else {
                JointAxesMask::LOCKED_PRISMATIC_AXES
            });
            gj.set_local_frame1(to_pose(&frame1))
                .set_local_frame2(to_pose(&frame2))
                .set_contacts_enabled(false);
            let axis = if rotational {
                JointAxis::AngX
            } else {
                JointAxis::LinX
            };
            // Limits on independent joints; a mimic joint follows its driver.
            if j.kind != JointKind::Continuous
                && matches!(j.coupling, JointCoupling::Dof(_))
                && j.limits.lower.is_finite()
                && j.limits.upper.is_finite()
            {
                gj.set_limits(axis, [j.limits.lower as f32, j.limits.upper as f32]);
            }
            let parent_body = bodies[body_of[j.parent]];
            let child_body = bodies[body_of[l]];
            state
                .multibody_joints
                .insert(parent_body, child_body, gj, true)
                .ok_or_else(|| {
                    SimError::InvalidArgument(format!(
                        "robot '{}': joint '{}' cannot be added to the articulation",
                        options.name, j.name
                    ))
                })?;
            inserted.push((ji, rotational, child_body, parent_body));
        }
        // Resolve the multibody link ids now that the tree is complete.
        let mut art: Vec<Option<ArtJoint>> = vec![None; joints.len()];
        for (ji, rotational, child_body, parent_body) in inserted {
            art[ji] = Some(ArtJoint {
                joint: ji,
                link: *state
                    .multibody_joints
                    .rigid_body_link(child_body)
                    .expect("inserted above"),
                rotational,
                child_body,
                parent_body,
            });
        }
        let dofs: Vec<ArtJoint> = model
            .dof_joints()
            .iter()
            .map(|&j| art[j].expect("DOF joints are movable"))
            .collect();
        let mut mimics = Vec::new();
        for (ji, j) in joints.iter().enumerate() {
            if let (
                JointCoupling::Mimic {
                    dof,
                    multiplier,
                    offset,
                },
                Some(a),
            ) = (j.coupling, art[ji])
            {
                mimics.push((a, dof, multiplier, offset));
            }
        }
        let drives: Vec<Drive> = model
            .dof_joints()
            .iter()
            .zip(&q0)
            .map(|(&j, &q)| Drive::default_for(&joints[j], q))
            .collect();
        let gripper = ParallelGripper::detect(&model);
        let mut robot = Robot {
            name: options.name.clone(),
            efforts: vec![0.0; dofs.len()],
            model: model.clone(),
            root: bodies[0],
            link_body: (0..links.len())
                .map(|l| (bodies[body_of[l]], offset[l]))
                .collect(),
            dofs,
            mimics,
            drives,
            bodies,
            gripper,
            base_pose: options.pose,
            solver_iterations: options.solver_iterations,
            applied_iterations: 0,
            applied_substeps: 0,
            world_substeps: 1,
            latency: Default::default(),
        };
        if let Some(mb) = robot.multibody_mut(state) {
            // Joint damping and friction from the URDF's <dynamics> (Rapier
            // otherwise adds a default damping of 0.1 on rotational DOFs).
            let movable = robot.dofs.iter().chain(robot.mimics.iter().map(|m| &m.0));
            for a in movable {
                let j = &robot.model.joints()[a.joint];
                let id = mb.link(a.link.id).expect("link").assembly_id();
                mb.damping_mut()[id] = j.damping as f32;
                mb.frictions_mut()[id] = j.friction as f32;
            }
            for &(a, dof, coeff, off) in &robot.mimics {
                let d = robot.dofs[dof];
                mb.add_dof_coupling(MultibodyDofCoupling {
                    link1: d.link.id,
                    dof1: 0,
                    axis1: d.coord(),
                    link2: a.link.id,
                    dof2: 0,
                    axis2: a.coord(),
                    coeff: coeff as f32,
                    offset: off as f32,
                });
            }
        }
        robot.apply_drives(state);
        robot.set_joint_positions(state, &q0)?;
        Ok(robot)
    }

    /// The multibody of the robot (None for a robot without movable joints).
    pub(crate) fn multibody_mut<'a>(
        &self,
        state: &'a mut PhysState,
    ) -> Option<&'a mut rapier3d::prelude::Multibody> {
        let id = self.dofs.first()?.link.multibody;
        state.multibody_joints.get_multibody_mut(id)
    }

    pub(crate) fn multibody<'a>(
        &self,
        state: &'a PhysState,
    ) -> Option<&'a rapier3d::prelude::Multibody> {
        let id = self.dofs.first()?.link.multibody;
        state.multibody_joints.get_multibody(id)
    }

    /// The robot's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The model.
    pub fn model(&self) -> &Arc<RobotModel> {
        &self.model
    }

    /// Number of DOFs (the model's independent joints).
    pub fn num_dof(&self) -> usize {
        self.dofs.len()
    }

    /// The drive of each DOF.
    pub fn drives(&self) -> &[Drive] {
        &self.drives
    }

    /// The gripper, if one is configured.
    pub fn gripper(&self) -> Option<&ParallelGripper> {
        self.gripper.as_ref()
    }

    /// Joint positions in DOF order.
    pub fn joint_positions(&self, state: &PhysState) -> Vec<f64> {
        let Some(mb) = self.multibody(state) else {
            return Vec::new();
        };
        self.dofs
            .iter()
            .map(|d| mb.link(d.link.id).expect("link").joint().coords()[d.coord()] as f64)
            .collect()
    }

    /// Joint velocities in DOF order.
    pub fn joint_velocities(&self, state: &PhysState) -> Vec<f64> {
        let Some(mb) = self.multibody(state) else {
            return Vec::new();
        };
        self.dofs
            .iter()
            .map(|d| mb.joint_velocity(mb.link(d.link.id).expect("link"))[0] as f64)
            .collect()
    }

    /// The joint-space mass matrix `M(q)` at the current joint positions,
    /// `num_dof x num_dof` row-major in DOF order (mimic joints excluded,
    /// their coordinates held: the simulation couples them by a constraint,
    /// not through `M`), in kg·m² / kg·m / kg: the inertia the simulation
    /// uses (the link inertials, composite-rigid-body algorithm of the
    /// vendored Rapier multibody, f32 internally), without drive damping.
    /// Before the world's first step the link bodies' mass properties are
    /// computed here (Rapier computes them at the first step). Empty for a
    /// robot without movable joints.
    pub fn mass_matrix(&self, state: &mut PhysState) -> Vec<f64> {
        let Some(id) = self.dofs.first().map(|d| d.link.multibody) else {
            return Vec::new();
        };
        let PhysState {
            bodies,
            colliders,
            multibody_joints,
            ..
        } = state;
        let pending = self.bodies[1..]
            .iter()
            .any(|h| bodies.get(*h).is_some_and(|b| b.mass() == 0.0));
        if pending {
            for &h in &self.bodies[1..] {
                if let Some(b) = bodies.get_mut(h) {
                    b.recompute_mass_properties_from_colliders(colliders);
                }
            }
            if let Some(mb) = multibody_joints.get_multibody_mut(id) {
                mb.forward_kinematics(bodies, true);
                mb.update_rigid_bodies(bodies, true);
            }
        }
        let Some(mb) = multibody_joints.get_multibody(id) else {
            return Vec::new();
        };
        let m = mb.mass_matrix(bodies);
        let ids: Vec<usize> = self
            .dofs
            .iter()
            .map(|d| mb.link(d.link.id).expect("link").assembly_id())
            .collect();
        let mut out = Vec::with_capacity(ids.len() * ids.len());
        for &i in &ids {
            for &j in &ids {
                out.push(m[(i, j)] as f64);
            }
        }
        out
    }

    /// Positions of every movable joint (DOFs and mimics) for DOF vector `q`,
    /// as (joint, position).
    fn all_positions(&self, q: &[f64]) -> Vec<(ArtJoint, f64)> {
        let mut out: Vec<(ArtJoint, f64)> =
            self.dofs.iter().copied().zip(q.iter().copied()).collect();
        out.extend(
            self.mimics
                .iter()
                .map(|&(a, dof, m, o)| (a, m * q[dof] + o)),
        );
        out
    }

    /// Teleports the joints to `q` (DOF order) with zero velocity; mimic
    /// joints follow. Drive targets are not changed (as in Isaac Sim); the
    /// drives' servo setpoints restart from `q` and travel to the targets
    /// at the joints' velocity limits (see [`crate::drives`]).
    pub fn set_joint_positions(&mut self, state: &mut PhysState, q: &[f64]) -> Result<()> {
        check_len("joint positions", q, self.num_dof())?;
        for (d, &qi) in self.drives.iter_mut().zip(q) {
            d.setpoint = qi;
            d.setpoint_velocity = 0.0;
        }
        self.apply_drives(state);
        let targets = self.all_positions(q);
        let Some(id) = self.dofs.first().map(|d| d.link.multibody) else {
            return Ok(());
        };
        let PhysState {
            bodies,
            multibody_joints,
            ..
        } = state;
        let mb = multibody_joints
            .get_multibody_mut(id)
            .expect("robot multibody");
        let mut disp = vec![0.0f32; mb.ndofs()];
        for (a, target) in targets {
            let link = mb.link(a.link.id).expect("link");
            let current = link.joint().coords()[a.coord()];
            disp[link.assembly_id()] = target as f32 - current;
        }
        mb.apply_displacements(&disp);
        mb.generalized_velocity_mut().fill(0.0);
        mb.forward_kinematics(bodies, true);
        move_link_bodies(mb, bodies);
        for &h in &self.bodies[1..] {
            if let Some(b) = bodies.get_mut(h) {
                b.set_linvel(Vector::ZERO, true);
                b.set_angvel(Vector::ZERO, true);
            }
        }
        Ok(())
    }

    /// Sets the generalized velocities (DOF order; mimic joints follow).
    pub fn set_joint_velocities(&self, state: &mut PhysState, qd: &[f64]) -> Result<()> {
        check_len("joint velocities", qd, self.num_dof())?;
        let Some(id) = self.dofs.first().map(|d| d.link.multibody) else {
            return Ok(());
        };
        let mut vels: Vec<(ArtJoint, f64)> =
            self.dofs.iter().copied().zip(qd.iter().copied()).collect();
        vels.extend(self.mimics.iter().map(|&(a, dof, m, _)| (a, m * qd[dof])));
        let mb = state
            .multibody_joints
            .get_multibody_mut(id)
            .expect("robot multibody");
        let ids: Vec<(usize, f32)> = vels
            .iter()
            .map(|(a, v)| (mb.link(a.link.id).expect("link").assembly_id(), *v as f32))
            .collect();
        let mut gv = mb.generalized_velocity_mut();
        for (i, v) in ids {
            gv[i] = v;
        }
        Ok(())
    }

    /// World pose of model link `link`.
    pub fn link_pose(&self, state: &PhysState, link: usize) -> Isometry3<f64> {
        let (body, off) = &self.link_body[link];
        from_pose(state.bodies[*body].position()) * off
    }

    /// Pose of the base link in the world.
    pub fn world_pose(&self) -> Isometry3<f64> {
        self.base_pose
    }

    /// Moves the fixed base (and the whole robot with it) to `pose`; joint
    /// positions are kept.
    pub fn set_world_pose(&mut self, state: &mut PhysState, pose: Isometry3<f64>) -> Result<()> {
        if !crate::convert::pose_is_finite(&pose) {
            return Err(SimError::NonFinite("robot world pose is not finite".into()));
        }
        let root_in_base = self
            .model
            .chain(0)
            .pose(&self.model.neutral_configuration());
        self.base_pose = pose;
        state.bodies[self.root].set_position(to_pose(&(pose * root_in_base)), true);
        let PhysState {
            bodies,
            multibody_joints,
            ..
        } = state;
        if let Some(id) = self.dofs.first().map(|d| d.link.multibody)
            && let Some(mb) = multibody_joints.get_multibody_mut(id)
        {
            mb.forward_kinematics(bodies, true);
            move_link_bodies(mb, bodies);
        }
        Ok(())
    }

    /// Applies the per-DOF efforts as equal and opposite torques (revolute)
    /// or forces at the joint origin (prismatic) on the two bodies of each
    /// joint. Called before every step.
    pub(crate) fn apply_efforts(&self, state: &mut PhysState) {
        for &h in &self.bodies {
            // `get_mut` marks the body as modified, which costs the next step
            // a pass over it (and a new active set): only for bodies that
            // carry a force to clear.
            let pending = state.bodies.get(h).is_some_and(|b| {
                b.user_force() != Default::default() || b.user_torque() != Default::default()
            });
            if pending && let Some(b) = state.bodies.get_mut(h) {
                b.reset_forces(false);
                b.reset_torques(false);
            }
        }
        for (d, &e) in self.dofs.iter().zip(&self.efforts) {
            if e == 0.0 {
                continue;
            }
            let j = &self.model.joints()[d.joint];
            let child_link = j.child;
            let child_pose = self.link_pose(state, child_link);
            let axis = crate::convert::to_vec(&(child_pose.rotation * j.axis.into_inner()));
            let f = axis * e as f32;
            if d.rotational {
                state.bodies[d.child_body].add_torque(f, true);
                state.bodies[d.parent_body].add_torque(-f, true);
            } else {
                let p = crate::convert::to_vec(&child_pose.translation.vector);
                state.bodies[d.child_body].add_force_at_point(f, p, true);
                state.bodies[d.parent_body].add_force_at_point(-f, p, true);
            }
        }
    }
}

/// Joint speed (rad/s or m/s) above which a robot counts as moving.
pub const MOVING_SPEED: f64 = 1e-2;
/// Distance (rad or m) of a DOF from its drive's position target above which
/// a robot counts as moving.
pub const MOVING_TARGET_ERROR: f64 = 1e-3;

impl Robot {
    /// Sets the extra solver substeps (over the world's) of the robot's
    /// moving bodies, used while the robot touches something other than
    /// itself (a contact within Rapier's prediction distance, 2 cm): grasped
    /// objects need them to stay put (a box carried at 1 m/s drifts 30 mm
    /// with none, 0.45 mm with 4). They are also used while a joint nears
    /// one of its limits. Otherwise the robot runs at the world's substeps
    /// while it moves and at 1 while it holds still (see
    /// [`Robot::active_substeps`]).
    /// `n` in [`ferrobot_model::ranges::sim::ROBOT_SOLVER_ITERATIONS`] (0 to 256).
    pub fn set_solver_iterations(&mut self, state: &mut PhysState, n: usize) -> Result<()> {
        ferrobot_model::ranges::sim::ROBOT_SOLVER_ITERATIONS.check(n as f64)?;
        self.solver_iterations = n;
        if self.applied_iterations != 0 {
            self.apply_substeps(state, self.world_substeps + n);
        }
        Ok(())
    }

    /// The extra solver substeps set by [`Robot::set_solver_iterations`].
    pub fn solver_iterations(&self) -> usize {
        self.solver_iterations
    }

    /// The extra solver substeps over the world's the last step used (0
    /// while the robot touched nothing and no joint neared a limit).
    pub fn active_solver_iterations(&self) -> usize {
        self.applied_iterations
    }

    /// The substeps the robot's bodies ran at in the last step: the world's
    /// plus [`Robot::solver_iterations`] while it touches something or nears
    /// a limit, the world's while it moves otherwise (a drive target not
    /// reached, a joint speed or target speed above [`MOVING_SPEED`]), 1
    /// while it holds still (0 before the first step). Fewer substeps while
    /// moving cost tracking accuracy: on the simulation benchmark's planned
    /// motion (Panda, kp 1e4, kd 1e2, 240 Hz, velocity feed-forward) the peak
    /// PD tracking error is 13.5 mrad at 1 substep, 7.3 at 2, 5.3 at 4.
    pub fn active_substeps(&self) -> usize {
        self.applied_substeps
    }

    /// Chooses the robot's substeps for the next step (see
    /// [`Robot::active_substeps`]): the extra substeps are on while the
    /// robot touches something or a joint may reach one of its limits within
    /// the next step (Rapier enforces a limit once crossed, so an impact
    /// overshoots by about the distance covered in a substep). Called before
    /// every step with the step length `dt` and the world's substeps.
    pub(crate) fn update_solver_iterations(
        &mut self,
        state: &mut PhysState,
        touching: bool,
        dt: f64,
        world_substeps: usize,
    ) {
        self.world_substeps = world_substeps;
        let want = if touching || self.near_limit(state, dt) {
            world_substeps + self.solver_iterations
        } else if self.moving(state) {
            world_substeps
        } else {
            1
        };
        if want != self.applied_substeps {
            self.apply_substeps(state, want);
        }
    }

    /// Whether a DOF moves faster than [`MOVING_SPEED`], has a drive target
    /// speed above it, or is farther than [`MOVING_TARGET_ERROR`] from its
    /// drive's position target.
    fn moving(&self, state: &PhysState) -> bool {
        let Some(mb) = self.multibody(state) else {
            return false;
        };
        if mb.generalized_velocity().amax() as f64 > MOVING_SPEED {
            return true;
        }
        self.dofs.iter().zip(&self.drives).any(|(d, drive)| {
            if drive.target_velocity.abs() > MOVING_SPEED {
                return true;
            }
            let q = mb.link(d.link.id).expect("link").joint().coords()[d.coord()] as f64;
            drive.stiffness > 0.0 && (q - drive.target_position).abs() > MOVING_TARGET_ERROR
        })
    }

    /// Whether a DOF is within 5 mm or 5 mrad (plus two steps' travel) of a
    /// limit, unless its drive holds it there: target inside the limits and
    /// reached to 1 mm or 1 mrad (the open Panda fingers rest at their limit).
    fn near_limit(&self, state: &PhysState, dt: f64) -> bool {
        let Some(mb) = self.multibody(state) else {
            return false;
        };
        let joints = self.model.joints();
        self.dofs.iter().zip(&self.drives).any(|(d, drive)| {
            let limits = &joints[d.joint].limits;
            if joints[d.joint].kind == JointKind::Continuous
                || !(limits.lower.is_finite() && limits.upper.is_finite())
            {
                return false;
            }
            let link = mb.link(d.link.id).expect("link");
            let q = link.joint().coords()[d.coord()] as f64;
            let v = mb.joint_velocity(link)[0] as f64;
            let margin = 0.005 + 2.0 * v.abs() * dt;
            let near = q < limits.lower + margin || q > limits.upper - margin;
            let held = drive.stiffness > 0.0
                && (limits.lower..=limits.upper).contains(&drive.target_position)
                && (q - drive.target_position).abs() < 1e-3;
            near && !held
        })
    }

    /// Runs the robot's bodies at `n` substeps (the world's Rapier base is
    /// 1 substep; the rest are per-body additional substeps).
    fn apply_substeps(&mut self, state: &mut PhysState, n: usize) {
        let n = n.max(1);
        for &h in &self.bodies[1..] {
            if let Some(b) = state.bodies.get_mut(h) {
                b.set_additional_solver_iterations(n - 1);
            }
        }
        self.applied_substeps = n;
        self.applied_iterations = n.saturating_sub(self.world_substeps);
    }
}
