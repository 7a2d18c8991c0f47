//! The world: time step, gravity, solver settings, a ground plane, rigid
//! objects and robots; stepping, reset and state access.

use std::collections::HashMap;
use std::sync::Arc;

use ferrobot_model::AllowedCollisions;
use ferrobot_model::RobotModel;
use nalgebra::{Isometry3, Vector3};
use rapier3d::prelude::{
    ActiveHooks, ColliderBuilder, ColliderHandle, FrictionModel, Group, IntegrationParameters,
    InteractionGroups, InteractionTestMode, PhysicsPipeline, RigidBodyBuilder, RigidBodyHandle,
    SharedShape,
};

use crate::convert::{from_pose, from_vec, pose_is_finite, to_pose, to_vec};
use crate::error::{Result, SimError, check_finite};
use crate::hooks::{LinkFilter, robot_link_of, user_data};
use crate::objects::{ObjectDesc, collider_for};
use crate::robot::{Robot, RobotOptions};
use crate::state::PhysState;

/// Settings of a world.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldConfig {
    /// Time step (s).
    pub dt: f64,
    /// Gravity (m/s², world frame; z is up).
    pub gravity: Vector3<f64>,
    /// Solver substeps per step (>= 1) for dynamic objects and for robots
    /// while they touch something or near a joint limit (plus the robot's
    /// own extra substeps, see `Robot::set_solver_iterations`). A robot that
    /// touches nothing runs at these while it moves and at 1 while it holds
    /// still, and the world's base step is 1 substep:
    /// substeps are spent only on the bodies that need them. (Rapier solves
    /// every awake body of a world with a multibody at the largest count
    /// among them.)
    pub solver_iterations: usize,
    /// Whether the world has a ground at z = 0: a fixed box
    /// [`GROUND_HALF_SIZE`] m either side of the origin in x and y,
    /// [`GROUND_THICKNESS`] m thick, its top face at z = 0 (a box rather
    /// than a half-space: a half-space's infinite bounds pair it with every
    /// body in the broad phase, so every robot link costs a narrow-phase
    /// test at every step).
    pub ground: bool,
    /// Friction coefficient of the ground.
    pub ground_friction: f64,
    /// Natural frequency (Hz) of the contact springs between moving bodies
    /// (twice this against fixed bodies); higher is stiffer.
    pub contact_frequency: f64,
    /// Penetration depth (m) the solver tolerates before pushing bodies apart.
    /// Also the contact recycling window: a contact pair whose relative pose
    /// moved less than this since its last full narrow-phase update keeps its
    /// contact points (see `World::new`).
    pub allowed_penetration: f64,
    /// Damping ratio of the contact springs (Rapier's own default is 10).
    pub contact_damping_ratio: f64,
    /// Whether friction also acts while penetrations are corrected (the
    /// stabilisation pass). On (default): a grasped box drifts < 0.5 mm
    /// instead of 2-5 mm, but stacks taller than about 5 boxes slowly
    /// topple (measured: 4 boxes hold for 10 s, 6 fall); turn it off for
    /// tall stacks.
    pub friction_in_stabilization: bool,
}

impl Default for WorldConfig {
    fn default() -> Self {
        Self {
            dt: 1.0 / 240.0,
            gravity: Vector3::new(0.0, 0.0, -9.81),
            solver_iterations: 4,
            ground: true,
            ground_friction: 0.8,
            contact_frequency: CONTACT_FREQUENCY,
            allowed_penetration: ALLOWED_PENETRATION,
            contact_damping_ratio: CONTACT_DAMPING_RATIO,
            friction_in_stabilization: true,
        }
    }
}

/// Default contact natural frequency (Hz); Rapier's own default is 30 Hz,
/// sized for large piles, too soft for fingers squeezing an object.
pub const CONTACT_FREQUENCY: f64 = 100.0;
/// Damping ratio of the contact springs.
pub const CONTACT_DAMPING_RATIO: f64 = 1.0;
/// Default allowed penetration (m); Rapier's own default is 5 mm at a
/// length unit of 1 m, too much for grasping centimetre-sized objects.
pub const ALLOWED_PENETRATION: f64 = 0.001;

/// Half the side (m) of the ground box in x and y.
pub const GROUND_HALF_SIZE: f32 = 1000.0;
/// Thickness (m) of the ground box (its top face is at z = 0).
pub const GROUND_THICKNESS: f32 = 1.0;

/// Segmentation id of "no object" (background).
pub const SEG_NONE: u32 = 0;
/// Segmentation id of the ground plane.
pub const SEG_GROUND: u32 = 1;

/// An object of the world.
#[derive(Debug, Clone)]
pub struct Object {
    /// Its description as added.
    pub desc: ObjectDesc,
    /// Its body.
    pub body: RigidBodyHandle,
    /// Its collider.
    pub collider: ColliderHandle,
    /// Its segmentation id.
    pub seg: u32,
}

/// A segmentation label: what an id in a segmentation image is.
#[derive(Debug, Clone, PartialEq)]
pub struct SegLabel {
    /// The id.
    pub id: u32,
    /// "ground", an object name, or "robot/link".
    pub name: String,
    /// The flat colour (0..1) used in RGB images.
    pub color: [f32; 3],
}

#[derive(Clone)]
struct Snapshot {
    state: PhysState,
    robots: Vec<Robot>,
    time: f64,
    steps: u64,
}

/// A physics world (Rapier): objects, robots, stepping and reset.
pub struct World {
    config: WorldConfig,
    params: IntegrationParameters,
    pipeline: PhysicsPipeline,
    pub(crate) state: PhysState,
    objects: Vec<Object>,
    object_index: HashMap<String, usize>,
    pub(crate) robots: Vec<Robot>,
    filter: LinkFilter,
    labels: Vec<SegLabel>,
    initial: Option<Snapshot>,
    time: f64,
    steps: u64,
    /// Per robot, whether it touches something (workspace of `step`).
    touching: Vec<bool>,
    /// Lighting of rendered RGB images (see `camera`).
    pub(crate) lighting: crate::camera::Lighting,
}

/// Largest speed (m/s) a body may reach before the simulation counts as
/// diverged (Rapier clamps speeds at 400 m/s, so a runaway body ends there).
pub const DIVERGENCE_SPEED: f32 = 300.0;
/// Largest angular speed (rad/s) before the simulation counts as diverged.
pub const DIVERGENCE_ANGULAR_SPEED: f32 = 1.0e4;
/// Largest distance (m) from the origin before the simulation counts as diverged.
pub const DIVERGENCE_DISTANCE: f32 = 1.0e4;

fn default_color(id: u32) -> [f32; 3] {
    // Distinct, reproducible colours (golden-angle hue walk).
    let h = (id as f32 * 0.618_034) % 1.0;
    let f = |n: f32| {
        let k = (n + h * 6.0) % 6.0;
        0.75 - 0.5 * (k.min(4.0 - k).clamp(0.0, 1.0))
    };
    [f(5.0), f(3.0), f(1.0)]
}

impl World {
    /// A new world.
    pub fn new(config: WorldConfig) -> Result<Self> {
        if !(config.dt.is_finite() && config.dt > 0.0 && config.dt <= 0.1) {
            return Err(SimError::InvalidArgument(format!(
                "time step must be in (0, 0.1] s, got {}",
                config.dt
            )));
        }
        check_finite("gravity", config.gravity.as_slice())?;
        if config.solver_iterations == 0 {
            return Err(SimError::InvalidArgument(
                "solver_iterations must be >= 1".into(),
            ));
        }
        ferrobot_model::ranges::sim::WORLD_SOLVER_ITERATIONS
            .check(config.solver_iterations as f64)?;
        check_finite("ground friction", &[config.ground_friction])?;
        if config.ground_friction < 0.0 {
            return Err(SimError::InvalidArgument(format!(
                "ground friction must be >= 0, got {}",
                config.ground_friction
            )));
        }
        let mut params = IntegrationParameters {
            dt: config.dt as f32,
            friction_model: FrictionModel::Coulomb,
            ..IntegrationParameters::default()
        };
        for (n, v) in [
            ("contact_frequency", config.contact_frequency),
            ("allowed_penetration", config.allowed_penetration),
            ("contact_damping_ratio", config.contact_damping_ratio),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(SimError::InvalidArgument(format!(
                    "{n} must be finite and > 0, got {v}"
                )));
            }
        }
        // One base substep; dynamic objects and busy robots get theirs as
        // per-body additional substeps (see `WorldConfig::solver_iterations`).
        params.num_solver_iterations = 1;
        params.contact_softness.natural_frequency = config.contact_frequency as f32;
        params.static_contact_softness.natural_frequency = 2.0 * config.contact_frequency as f32;
        params.normalized_allowed_linear_error = config.allowed_penetration as f32;
        // Critically damped contacts and friction in the stabilisation pass:
        // with Rapier's defaults (zeta = 10, friction only in the relax pass)
        // a squeezed object creeps out of a gripper at ~1 cm/s.
        params.contact_softness.damping_ratio = config.contact_damping_ratio as f32;
        params.static_contact_softness.damping_ratio = config.contact_damping_ratio as f32;
        params.friction_in_bias_pass = config.friction_in_stabilization;
        // Resting small objects (issue 18, BENCHMARKS.md "Small mesh objects at rest"):
        // Rapier's contact recycling keeps a pair's contact points, normal and
        // solver lever arms frozen while the pair moves less than 5 cm and
        // turns less than 11.5 degrees: more than a facet of a few-centimetre
        // convex hull, so a hull resting near a facet edge rocks on stale
        // contacts and never sleeps. The recycle window is now the allowed
        // penetration (the contact error the solver tolerates anyway).
        params.normalized_contact_recycle_distance = config.allowed_penetration as f32;
        // Contact clustering merges the per-part manifolds of a convex
        // decomposition into one manifold of at most 4 points; with it, a
        // decomposition resting on the table on two or more parts kept
        // rocking at 1-10 rad/s and crept by cm (measured, with or without
        // recycling); without it, it sleeps.
        params.contact_clustering = false;
        // Robot links against objects (and other robots' links) are never
        // recycled: recycling freezes a pair's normal and lever arms in world
        // space, and a hand turning while it holds an object keeps the pair's
        // relative pose, so the frozen arms give it a relative velocity it
        // does not have and the object walks out of the hand (a Panda turning
        // a held box by 90 degrees: 16 mm of slip, 0.2 mm without; the
        // pick-and-place episodes dropped their objects in transport). With
        // the contact-filter hook on every robot collider these pairs were
        // never recycled either; with collision groups
        // (`use_collision_groups`) only the robot's own pairs and its pairs
        // with fixed bodies are.
        params.recycle_multibody_dynamic_contacts = false;
        let mut world = Self {
            config,
            params,
            pipeline: PhysicsPipeline::new(),
            state: PhysState::default(),
            objects: Vec::new(),
            object_index: HashMap::new(),
            robots: Vec::new(),
            filter: LinkFilter::default(),
            labels: vec![SegLabel {
                id: SEG_NONE,
                name: "background".into(),
                color: [0.0, 0.0, 0.0],
            }],
            initial: None,
            time: 0.0,
            steps: 0,
            touching: Vec::new(),
            lighting: Default::default(),
        };
        if world.config.ground {
            let body = world
                .state
                .bodies
                .insert(
                    RigidBodyBuilder::fixed().translation(rapier3d::math::Vector::new(
                        0.0,
                        0.0,
                        -0.5 * GROUND_THICKNESS,
                    )),
                );
            let collider = ColliderBuilder::new(SharedShape::cuboid(
                GROUND_HALF_SIZE,
                GROUND_HALF_SIZE,
                0.5 * GROUND_THICKNESS,
            ))
            .friction(world.config.ground_friction as f32)
            .user_data(user_data(SEG_GROUND, None, 0));
            world
                .state
                .colliders
                .insert_with_parent(collider, body, &mut world.state.bodies);
            world.labels.push(SegLabel {
                id: SEG_GROUND,
                name: "ground".into(),
                color: [0.55, 0.55, 0.5],
            });
        }
        Ok(world)
    }

    /// The settings.
    pub fn config(&self) -> &WorldConfig {
        &self.config
    }

    /// Simulated time since creation or the last reset (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Steps taken since creation or the last reset.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The physics state (read only).
    pub fn state(&self) -> &PhysState {
        &self.state
    }

    fn next_seg(&self) -> u32 {
        self.labels.last().map_or(1, |l| l.id + 1)
    }

    fn check_name(&self, name: &str) -> Result<()> {
        if self.object_index.contains_key(name) || self.robots.iter().any(|r| r.name == name) {
            return Err(SimError::Duplicate(format!(
                "the world has an object or robot named '{name}' already"
            )));
        }
        Ok(())
    }

    /// Adds an object; returns its index.
    pub fn add_object(&mut self, desc: ObjectDesc) -> Result<usize> {
        desc.validate()?;
        self.check_name(&desc.name)?;
        let shape = crate::objects::shared_shape(&desc.shape, &format!("object '{}'", desc.name))?;
        let seg = self.next_seg();
        let builder = if desc.is_static {
            RigidBodyBuilder::fixed()
        } else {
            RigidBodyBuilder::dynamic()
                .additional_solver_iterations(self.config.solver_iterations - 1)
        };
        let body = self.state.bodies.insert(builder.pose(to_pose(&desc.pose)));
        let collider = collider_for(&desc, shape)?.user_data(user_data(seg, None, 0));
        let collider =
            self.state
                .colliders
                .insert_with_parent(collider, body, &mut self.state.bodies);
        let c = desc.color;
        self.labels.push(SegLabel {
            id: seg,
            name: desc.name.clone(),
            color: [c[0] as f32, c[1] as f32, c[2] as f32],
        });
        self.object_index
            .insert(desc.name.clone(), self.objects.len());
        self.objects.push(Object {
            desc,
            body,
            collider,
            seg,
        });
        self.initial = None;
        Ok(self.objects.len() - 1)
    }

    /// Adds a robot built from `model`; returns its index.
    pub fn add_robot(&mut self, model: Arc<RobotModel>, options: &RobotOptions) -> Result<usize> {
        self.check_name(&options.name)?;
        if options.name.is_empty() {
            return Err(SimError::InvalidArgument(
                "robot name must not be empty".into(),
            ));
        }
        ferrobot_model::ranges::sim::ROBOT_SOLVER_ITERATIONS
            .check(options.solver_iterations as f64)?;
        check_finite("robot friction", &[options.friction])?;
        if options.friction < 0.0 {
            return Err(SimError::InvalidArgument(format!(
                "robot friction must be >= 0, got {}",
                options.friction
            )));
        }
        let index = self.robots.len();
        let seg_base = self.next_seg();
        // Work on a copy so that a failure leaves the world untouched.
        let mut state = self.state.clone();
        let robot = Robot::build(&mut state, model.clone(), options, index, seg_base)?;
        self.state = state;
        for (l, link) in model.links().iter().enumerate() {
            self.labels.push(SegLabel {
                id: seg_base + l as u32,
                name: format!("{}/{}", options.name, link.name),
                color: default_color(seg_base + l as u32),
            });
        }
        let acm = options
            .allowed_collisions
            .clone()
            .unwrap_or_else(|| AllowedCollisions::from_model(&model));
        for (a, b, _) in acm.pairs() {
            self.filter.allowed.insert((index, a.min(b), a.max(b)));
        }
        if index == 0 {
            self.use_collision_groups(&model, &acm);
        }
        let mut robot = robot;
        robot.latency.clock = self.time;
        self.robots.push(robot);
        self.initial = None;
        Ok(index)
    }

    /// Replaces the contact-filter hook of the first robot's colliders by
    /// collision groups when it has at most 31 links with collision geometry:
    /// one group bit per such link, each link's filter without the bits of
    /// the links the allowed-collision matrix excludes (and its own); bit 31
    /// stays in every filter, so a link always meets what holds every bit. Pairs
    /// filtered by groups are dropped by the broad phase, and robot pairs
    /// without a hook keep Rapier's contact recycling, except those with
    /// dynamic bodies (objects, other robots), which `World::new` excludes
    /// from recycling as the hook did. Everything else (the
    /// ground, objects, later robots) keeps every group bit, so it meets
    /// every link as before; later robots keep the hook, which also lets
    /// their links meet the first robot's (the hook passes pairs of two
    /// robots), so the result is exactly the matrix's for any number of robots.
    fn use_collision_groups(&mut self, model: &RobotModel, acm: &AllowedCollisions) {
        let links = model.links();
        let colliding: Vec<usize> = (0..links.len())
            .filter(|&l| !links[l].collisions.is_empty())
            .collect();
        if colliding.len() > 31 {
            return;
        }
        let mut bit = vec![None; links.len()];
        for (k, &l) in colliding.iter().enumerate() {
            bit[l] = Some(1u32 << k);
        }
        let mut filter: Vec<u32> = bit.iter().map(|b| !b.unwrap_or(0)).collect();
        for (a, b, _) in acm.pairs() {
            if let (Some(ba), Some(bb)) = (bit[a], bit[b]) {
                filter[a] &= !bb;
                filter[b] &= !ba;
            }
        }
        for (_, c) in self.state.colliders.iter_mut() {
            if let Some((0, l)) = robot_link_of(c.user_data)
                && let Some(b) = bit[l]
            {
                c.set_collision_groups(InteractionGroups::new(
                    Group::from_bits_truncate(b),
                    Group::from_bits_truncate(filter[l]),
                    InteractionTestMode::And,
                ));
                c.set_active_hooks(ActiveHooks::empty());
            }
        }
    }

    /// Objects in the order they were added.
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// Index of the object named `name`.
    pub fn object_index(&self, name: &str) -> Result<usize> {
        self.object_index.get(name).copied().ok_or_else(|| {
            let mut names: Vec<&str> = self.objects.iter().map(|o| o.desc.name.as_str()).collect();
            names.sort_unstable();
            SimError::UnknownName(format!(
                "no object named '{name}'; objects: [{}]",
                names.join(", ")
            ))
        })
    }

    /// Robots in the order they were added.
    pub fn robots(&self) -> &[Robot] {
        &self.robots
    }

    /// Index of the robot named `name`.
    pub fn robot_index(&self, name: &str) -> Result<usize> {
        self.robots
            .iter()
            .position(|r| r.name == name)
            .ok_or_else(|| SimError::UnknownName(format!("no robot named '{name}'")))
    }

    /// Runs `f` on robot `index` and the physics state.
    pub fn with_robot<T>(
        &mut self,
        index: usize,
        f: impl FnOnce(&mut Robot, &mut PhysState) -> Result<T>,
    ) -> Result<T> {
        let robot = self
            .robots
            .get_mut(index)
            .ok_or_else(|| SimError::UnknownName(format!("no robot with index {index}")))?;
        f(robot, &mut self.state)
    }

    /// Robot `index` (read only).
    pub fn robot(&self, index: usize) -> Result<&Robot> {
        self.robots
            .get(index)
            .ok_or_else(|| SimError::UnknownName(format!("no robot with index {index}")))
    }

    /// Segmentation labels: background, ground, objects, robot links.
    pub fn labels(&self) -> &[SegLabel] {
        &self.labels
    }

    /// World pose of object `index`.
    pub fn object_pose(&self, index: usize) -> Isometry3<f64> {
        from_pose(self.state.bodies[self.objects[index].body].position())
    }

    /// Teleports object `index` to `pose`.
    pub fn set_object_pose(&mut self, index: usize, pose: &Isometry3<f64>) -> Result<()> {
        if !pose_is_finite(pose) {
            return Err(SimError::NonFinite(format!(
                "object '{}': pose is not finite",
                self.objects[index].desc.name
            )));
        }
        self.state.bodies[self.objects[index].body].set_position(to_pose(pose), true);
        Ok(())
    }

    /// Linear and angular velocity of object `index` (world frame).
    pub fn object_velocity(&self, index: usize) -> (Vector3<f64>, Vector3<f64>) {
        let b = &self.state.bodies[self.objects[index].body];
        (from_vec(b.linvel()), from_vec(b.angvel()))
    }

    /// Sets the linear and angular velocity of object `index`.
    pub fn set_object_velocity(
        &mut self,
        index: usize,
        linear: &Vector3<f64>,
        angular: &Vector3<f64>,
    ) -> Result<()> {
        check_finite("linear velocity", linear.as_slice())?;
        check_finite("angular velocity", angular.as_slice())?;
        let o = &self.objects[index];
        if o.desc.is_static {
            return Err(SimError::InvalidArgument(format!(
                "object '{}' is static: it cannot have a velocity",
                o.desc.name
            )));
        }
        let b = &mut self.state.bodies[o.body];
        b.set_linvel(to_vec(linear), true);
        b.set_angvel(to_vec(angular), true);
        Ok(())
    }

    /// Makes the current state the one `reset()` returns to.
    pub fn mark_initial_state(&mut self) {
        self.initial = Some(Snapshot {
            state: self.state.clone(),
            robots: self.robots.clone(),
            time: self.time,
            steps: self.steps,
        });
    }

    /// Returns to the initial state: the state at the first step after the
    /// last object or robot was added (or the last `mark_initial_state`).
    /// Without any step yet, the current state is the initial state.
    pub fn reset(&mut self) {
        match &self.initial {
            Some(s) => {
                self.state = s.state.clone();
                self.robots = s.robots.clone();
                self.time = s.time;
                self.steps = s.steps;
                self.pipeline = PhysicsPipeline::new();
            }
            None => self.mark_initial_state(),
        }
    }

    /// Advances the simulation by `n` steps. Fails with
    /// [`SimError::Diverged`] (and leaves the diverged state for inspection)
    /// when a body's pose or velocity becomes non-finite or runaway.
    pub fn step(&mut self, n: usize) -> Result<()> {
        if self.initial.is_none() {
            self.mark_initial_state();
        }
        let gravity = to_vec(&self.config.gravity);
        for _ in 0..n {
            let now = self.time;
            for r in &mut self.robots {
                r.apply_due_commands(&mut self.state, now);
                r.advance_drives(&mut self.state, self.config.dt);
            }
            self.update_robot_substeps();
            for r in &self.robots {
                r.apply_efforts(&mut self.state);
            }
            let s = &mut self.state;
            self.pipeline.step(
                gravity,
                &self.params,
                &mut s.islands,
                &mut s.broad_phase,
                &mut s.narrow_phase,
                &mut s.bodies,
                &mut s.colliders,
                &mut s.impulse_joints,
                &mut s.multibody_joints,
                &mut s.soft_bodies,
                &mut s.ccd,
                &self.filter,
                &(),
            );
            self.steps += 1;
            self.time += self.config.dt;
            let now = self.time;
            for r in &mut self.robots {
                r.latency.clock = now;
            }
            self.check_diverged()?;
        }
        Ok(())
    }

    /// Gives each robot its extra solver substeps while it touches
    /// something other than itself (by the contacts of the last step,
    /// within the prediction distance) or nears a joint limit, none
    /// otherwise: with a
    /// multibody in the world Rapier runs every awake body at the largest
    /// substep count, so a robot holding a pose over a table would otherwise
    /// double the cost of the whole scene.
    fn update_robot_substeps(&mut self) {
        if self.robots.is_empty() {
            return;
        }
        let mut touching = std::mem::take(&mut self.touching);
        touching.clear();
        touching.resize(self.robots.len(), false);
        let robot_of = |c| {
            self.state
                .colliders
                .get(c)
                .and_then(|c| robot_link_of(c.user_data))
                .map(|(r, _)| r)
        };
        for pair in self.state.narrow_phase.contact_pairs() {
            let (r1, r2) = (robot_of(pair.collider1), robot_of(pair.collider2));
            // Contacts of a robot with itself do not count (the extra
            // substeps are for what it holds or pushes).
            if (r1.is_none() && r2.is_none()) || r1 == r2 || !pair.has_any_active_contact() {
                continue;
            }
            for r in [r1, r2].into_iter().flatten() {
                if let Some(t) = touching.get_mut(r) {
                    *t = true;
                }
            }
        }
        for (r, &t) in self.robots.iter_mut().zip(&touching) {
            r.update_solver_iterations(
                &mut self.state,
                t,
                self.config.dt,
                self.config.solver_iterations,
            );
        }
        self.touching = touching;
    }

    fn check_diverged(&self) -> Result<()> {
        for (_, b) in self.state.bodies.iter() {
            if !b.is_dynamic() {
                continue;
            }
            let p = b.position();
            let ok = p.translation.is_finite()
                && p.rotation.is_finite()
                && b.linvel().is_finite()
                && b.angvel().is_finite()
                && b.linvel().length() < DIVERGENCE_SPEED
                && b.angvel().length() < DIVERGENCE_ANGULAR_SPEED
                && p.translation.length() < DIVERGENCE_DISTANCE;
            if !ok {
                let name = self.body_name(b.colliders().first().copied());
                return Err(SimError::Diverged(format!(
                    "simulation diverged at step {} (t = {:.4} s): body '{name}' has position {:?}, velocity {:?}; reduce the time step, raise solver iterations or check masses and gains",
                    self.steps,
                    self.time,
                    p.translation,
                    b.linvel()
                )));
            }
        }
        Ok(())
    }

    fn body_name(&self, collider: Option<ColliderHandle>) -> String {
        collider
            .and_then(|c| self.state.colliders.get(c))
            .map(|c| crate::hooks::seg_of(c.user_data))
            .and_then(|id| self.labels.iter().find(|l| l.id == id))
            .map_or_else(|| "?".into(), |l| l.name.clone())
    }
}

#[cfg(test)]
mod collision_group_tests {
    use super::*;

    /// Whether two colliders can make contacts: their groups, then the hook
    /// when either collider asks for it (as Rapier's narrow phase decides).
    fn can_touch(
        w: &World,
        a: &rapier3d::geometry::Collider,
        b: &rapier3d::geometry::Collider,
    ) -> bool {
        if !a.collision_groups().test(b.collision_groups()) {
            return false;
        }
        let hooked =
            (a.active_hooks() | b.active_hooks()).contains(ActiveHooks::FILTER_CONTACT_PAIRS);
        if !hooked {
            return true;
        }
        let (ra, la) = robot_link_of(a.user_data).unwrap_or((usize::MAX, 0));
        let (rb, lb) = robot_link_of(b.user_data).unwrap_or((usize::MAX - 1, 0));
        !(ra == rb && (la == lb || w.filter.allowed.contains(&(ra, la.min(lb), la.max(lb)))))
    }

    /// Puts every robot collider back on the contact-filter hook with the
    /// default groups: the filtering every robot had before groups.
    fn hook_only(w: &mut World) {
        for (_, c) in w.state.colliders.iter_mut() {
            if robot_link_of(c.user_data).is_some() {
                c.set_collision_groups(InteractionGroups::all());
                c.set_active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS);
            }
        }
    }

    /// Two copies of `model` (the second 1 m away) over the ground.
    fn two_robots(model: &Arc<RobotModel>) -> World {
        let mut w = World::new(WorldConfig::default()).unwrap();
        w.add_robot(model.clone(), &RobotOptions::new("a")).unwrap();
        let mut second = RobotOptions::new("b");
        second.pose = Isometry3::translation(1.0, 0.0, 0.0);
        w.add_robot(model.clone(), &second).unwrap();
        w
    }

    /// The first robot uses groups exactly when `grouped`, and groups plus
    /// hook allow exactly the pairs the hook alone allows, which are the
    /// allowed-collision matrix's (read from the model, not from the
    /// groups): no contact for a disabled pair or within one link, contact
    /// for every other pair of one robot, between the two robots, and with
    /// the ground.
    fn check_same_pairs_as_hook(model: RobotModel, grouped: bool) {
        let model = Arc::new(model);
        let acm = AllowedCollisions::from_model(&model);
        let w = two_robots(&model);
        let mut h = two_robots(&model);
        hook_only(&mut h);
        let first: Vec<_> = w
            .state
            .colliders
            .iter()
            .filter(|(_, c)| matches!(robot_link_of(c.user_data), Some((0, _))))
            .map(|(_, c)| c)
            .collect();
        assert!(!first.is_empty());
        assert!(
            first.iter().all(|c| c.active_hooks().is_empty() == grouped),
            "the first robot should use {}",
            if grouped { "groups" } else { "the hook" }
        );
        let second_hooked = w
            .state
            .colliders
            .iter()
            .filter(|(_, c)| matches!(robot_link_of(c.user_data), Some((1, _))))
            .all(|(_, c)| c.active_hooks().contains(ActiveHooks::FILTER_CONTACT_PAIRS));
        assert!(second_hooked, "the second robot must keep the hook");
        let cw: Vec<_> = w.state.colliders.iter().map(|(_, c)| c).collect();
        let ch: Vec<_> = h.state.colliders.iter().map(|(_, c)| c).collect();
        assert_eq!(cw.len(), ch.len());
        let (mut checked, mut excluded) = (0, 0);
        for i in 0..cw.len() {
            assert_eq!(cw[i].user_data, ch[i].user_data);
            for j in i + 1..cw.len() {
                let (a, b) = (cw[i], cw[j]);
                let expected = match (robot_link_of(a.user_data), robot_link_of(b.user_data)) {
                    (Some((ra, la)), Some((rb, lb))) if ra == rb => !acm.is_allowed(la, lb),
                    _ => true,
                };
                let what = (robot_link_of(a.user_data), robot_link_of(b.user_data));
                assert_eq!(can_touch(&h, ch[i], ch[j]), expected, "hook: {what:?}");
                assert_eq!(can_touch(&w, a, b), expected, "groups: {what:?}");
                checked += 1;
                excluded += usize::from(!expected);
            }
        }
        assert!(
            checked > 100 && excluded > 10,
            "{checked} pairs, {excluded} excluded"
        );
    }

    #[test]
    fn panda_groups_allow_the_same_pairs_as_the_hook() {
        check_same_pairs_as_hook(ferrobot_model::robots::panda().unwrap(), true);
    }

    #[test]
    fn ur5e_2f85_groups_allow_the_same_pairs_as_the_hook() {
        check_same_pairs_as_hook(ferrobot_model::robots::ur5e().unwrap(), true);
    }

    /// A serial chain of `n` box links (each with collision geometry).
    fn chain(n: usize) -> RobotModel {
        let mut urdf = String::from("<robot name=\"chain\">\n");
        for l in 0..n {
            urdf.push_str(&format!(
                "<link name=\"l{l}\"><inertial><mass value=\"0.1\"/><inertia ixx=\"1e-4\" iyy=\"1e-4\" izz=\"1e-4\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial>\
                 <collision><origin xyz=\"0 0 0.025\"/><geometry><box size=\"0.02 0.02 0.04\"/></geometry></collision></link>\n"
            ));
            if l > 0 {
                urdf.push_str(&format!(
                    "<joint name=\"j{l}\" type=\"revolute\"><parent link=\"l{}\"/><child link=\"l{l}\"/>\
                     <origin xyz=\"0 0 0.05\"/><axis xyz=\"{}\"/><limit lower=\"-1\" upper=\"1\" effort=\"10\" velocity=\"1\"/></joint>\n",
                    l - 1,
                    if l % 2 == 0 { "0 1 0" } else { "1 0 0" }
                ));
            }
        }
        urdf.push_str("</robot>\n");
        RobotModel::from_urdf_str(&urdf, &Default::default()).unwrap()
    }

    #[test]
    fn thirty_one_colliding_links_use_groups() {
        check_same_pairs_as_hook(chain(31), true);
    }

    #[test]
    fn more_than_thirty_one_colliding_links_fall_back_to_the_hook() {
        check_same_pairs_as_hook(chain(32), false);
    }

    /// The (link, link) pairs of robot 0 with an active contact, sorted.
    fn contacting_link_pairs(w: &World) -> Vec<(usize, usize)> {
        let link =
            |c: ColliderHandle| robot_link_of(w.state.colliders[c].user_data).map(|(_, l)| l);
        let mut out: Vec<_> = w
            .state
            .narrow_phase
            .contact_pairs()
            .filter(|p| p.has_any_active_contact())
            .map(|p| {
                let (a, b) = (link(p.collider1), link(p.collider2));
                let (a, b) = (a.unwrap_or(usize::MAX), b.unwrap_or(usize::MAX));
                (a.min(b), a.max(b))
            })
            .collect();
        out.sort_unstable();
        out
    }

    /// Rust's version of `ferrobot.calibration.friction_sweep` for the
    /// Panda's joint 4 (the sweep whose identified friction went wrong):
    /// velocity drive from the far end of the range at each speed, joint
    /// teleported between speeds. Returns per step the contacting link
    /// pairs and the largest contact impulse between the robot's links,
    /// and per speed the mean velocity and drive effort.
    type Sweep = (Vec<Vec<(usize, usize)>>, Vec<f32>, Vec<(f64, f64)>);
    fn joint4_sweep(hook: bool) -> Sweep {
        let model = Arc::new(ferrobot_model::robots::panda().unwrap());
        let mut w = World::new(WorldConfig {
            dt: 1.0 / 240.0,
            ground: false,
            ..Default::default()
        })
        .unwrap();
        w.add_robot(model.clone(), &RobotOptions::new("panda"))
            .unwrap();
        if hook {
            hook_only(&mut w);
        }
        let q0 = model.named_state("ready", None).unwrap();
        let dof = 3;
        let (lo, hi) = (model.lower_limits()[dof], model.upper_limits()[dof]);
        w.with_robot(0, |r, s| {
            r.set_joint_positions(s, &q0)?;
            r.set_position_targets(s, &q0, None)?;
            r.set_joint_dynamics(s, dof, 2.0, 1.5)
        })
        .unwrap();
        let (mut pairs, mut impulses, mut means) = (Vec::new(), Vec::new(), Vec::new());
        for v in [-0.8, -0.5, -0.25, 0.25, 0.5, 0.8] {
            let mut q = q0.clone();
            q[dof] = if v > 0.0 {
                lo + 0.05 * (hi - lo)
            } else {
                hi - 0.05 * (hi - lo)
            };
            let mut vt = vec![0.0; q.len()];
            vt[dof] = v;
            w.with_robot(0, |r, s| {
                r.set_joint_positions(s, &q)?;
                r.set_position_targets(s, &q, None)?;
                r.set_drive_gains(s, &[0.0], &[30.0], None, Some(&[dof]))?;
                r.set_velocity_targets(s, &vt, None)?;
                r.set_joint_velocities(s, &vt)
            })
            .unwrap();
            let (mut sum_v, mut sum_e) = (0.0, 0.0);
            for k in 0..96 {
                w.step(1).unwrap();
                pairs.push(contacting_link_pairs(&w));
                let impulse = w
                    .state
                    .narrow_phase
                    .contact_pairs()
                    .flat_map(|p| p.manifolds())
                    .flat_map(|m| m.points.iter().map(|p| p.data.impulse))
                    .fold(0.0f32, f32::max);
                impulses.push(impulse);
                if k >= 36 {
                    sum_v += w.robots[0].joint_velocities(&w.state)[dof];
                    sum_e += w.robots[0].applied_efforts(&w.state)[dof];
                }
            }
            means.push((sum_v / 60.0, sum_e / 60.0));
        }
        (pairs, impulses, means)
    }

    /// During the friction sweep of the Panda's joint 4, groups and the hook
    /// give the same contacting pairs at every step, no impulse between the
    /// robot's links, and the same sweep. Before link bodies were moved with
    /// `set_position` on a teleport, the recycled link5-link7 pair (13.9 mm
    /// apart, a pair only groups leave to recycling) got a 54 N·s impulse at
    /// the jump to the far end of the range, and the +0.25 rad/s sweep read
    /// -0.11 N·m instead of 1.88.
    #[test]
    fn friction_sweep_contacts_are_the_same_with_groups_and_hook() {
        let (pg, ig, mg) = joint4_sweep(false);
        let (ph, ih, mh) = joint4_sweep(true);
        assert_eq!(pg.len(), ph.len());
        for (k, (a, b)) in pg.iter().zip(&ph).enumerate() {
            assert_eq!(a, b, "step {k}: contacting link pairs differ");
        }
        // The sweep does touch something: link5-link7 stay within the
        // prediction distance the whole time.
        assert!(pg.iter().all(|p| !p.is_empty()));
        assert!(
            ig.iter().chain(&ih).all(|&i| i == 0.0),
            "self-contact impulse"
        );
        for ((vg, eg), (vh, eh)) in mg.iter().zip(&mh) {
            assert!(
                (vg - vh).abs() < 1e-4 && (eg - eh).abs() < 1e-3,
                "{mg:?} vs {mh:?}"
            );
        }
        // Independent check: at constant speed the drive balances the
        // friction law exactly, 2.0 * v + 1.5 * sign(v) (N·m).
        for &(v, e) in &mg {
            let law = 2.0 * v + 1.5 * v.signum();
            assert!(
                (e - law).abs() < 0.1 * law.abs(),
                "v {v}: effort {e}, law {law}"
            );
        }
    }
}
