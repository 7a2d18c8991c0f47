//! The collision checker: a robot's sphere model, its allowed-collision
//! matrix, attached objects and a world, answering single, batched and
//! motion queries through the lane kernel, and distances through exact
//! `f64` geometry.

use std::cell::RefCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use ferrobot_model::{Geometry, RobotModel, Shape};
use nalgebra::Isometry3;
use rayon::prelude::*;
use wide::f32x8;

use crate::acm::AllowedCollisions;
use crate::compiled::{CompiledRobot, CompiledWorld};
use crate::dispatch::SimdLevel;
use crate::error::{CollisionError, Result};
use crate::kernel::{Scratch, check};
use crate::lanes::Lanes;
use crate::robot_spheres::RobotSpheres;
use crate::single::OneScratch;
use crate::sphere::Sphere;
use crate::spherize::{SpherizeOptions, spherize_link};
use crate::world::{CollisionWorld, WorldObject, check_shape};
use crate::world_grid::WorldGrid;

/// Margin (m) above the checker's margin up to which the world grid's
/// candidate lists serve certifying checks
/// ([`CollisionChecker::curve_certified_until`]); larger margins test the
/// obstacles without the lists (same answers, slower).
const CERTIFY_REACH: f64 = 0.02;

/// An object attached to a robot link (a grasped part, a tool).
#[derive(Debug, Clone)]
pub struct Attached {
    /// Name (the world object's name when it came from the world).
    pub name: String,
    /// Link it moves with.
    pub link: usize,
    /// Pose of the object frame in the link frame.
    pub pose_in_link: Isometry3<f64>,
    /// Its shapes in the object frame.
    pub parts: Vec<(Shape, Isometry3<f64>)>,
    /// Links it may touch (besides `link`).
    pub touch_links: Vec<usize>,
    /// Its spheres in the link frame.
    pub spheres: Vec<Sphere>,
}

/// One collision, for explanations and error messages.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    /// Robot body: link name, or `attached:NAME`.
    pub body: String,
    /// The other side: world object name, or a robot body for self-collision.
    pub other: String,
    /// True for robot-robot contacts.
    pub self_collision: bool,
    /// Penetration depth (m) of the deepest sphere, margin included.
    pub depth: f64,
}

impl std::fmt::Display for Contact {
    /// "panda_hand hits table (3.2 mm deep)".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let verb = if self.self_collision {
            "hits robot link"
        } else {
            "hits"
        };
        write!(
            f,
            "{} {verb} {} ({:.1} mm deep)",
            self.body,
            self.other,
            self.depth * 1e3
        )
    }
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

thread_local! {
    static SCALAR_SCRATCH: RefCell<Option<(u64, OneScratch)>> = const { RefCell::new(None) };
    static MOTION_SCRATCH: RefCell<Option<(u64, Scratch<f32x8>)>> = const { RefCell::new(None) };
}

/// The immutable, per-robot part of collision checking (as Pinocchio's
/// `Model` is to its `Data`): the kinematic model, the sphere model, the
/// allowed-collision matrix of robot links, the links' exact geometry and
/// the robot compiled for the kernels (without attached objects, margin 0),
/// built once. Shared through `Arc` by every [`CollisionChecker`] (scene)
/// made from it, so several scenes and planners use one copy.
#[derive(Debug)]
pub struct RobotCollisionModel {
    pub(crate) model: Arc<RobotModel>,
    pub(crate) spheres: RobotSpheres,
    pub(crate) acm: AllowedCollisions,
    /// Exact geometry per link.
    exact_links: Arc<Vec<Option<crate::exact::ExactBody>>>,
    /// The compiled robot without attached objects at margin 0, with exact
    /// self-collision confirmation (index 1) or without (index 0), made on
    /// first use.
    compiled: [std::sync::OnceLock<Arc<CompiledRobot>>; 2],
}

impl RobotCollisionModel {
    /// The collision model of `model` with sphere model `spheres` and
    /// excluded link pairs `acm`.
    pub fn new(
        model: Arc<RobotModel>,
        spheres: RobotSpheres,
        acm: AllowedCollisions,
    ) -> Result<Self> {
        if spheres.links.len() != model.links().len() {
            return Err(CollisionError::InvalidArgument(format!(
                "the sphere model has {} links, the robot {}",
                spheres.links.len(),
                model.links().len()
            )));
        }
        Ok(Self {
            exact_links: Arc::new(CompiledRobot::exact_bodies(&model)),
            model,
            spheres,
            acm,
            compiled: Default::default(),
        })
    }

    /// The kinematic model.
    pub fn model(&self) -> &Arc<RobotModel> {
        &self.model
    }

    /// The sphere model.
    pub fn spheres(&self) -> &RobotSpheres {
        &self.spheres
    }

    /// The allowed-collision matrix of robot links.
    pub fn allowed_collisions(&self) -> &AllowedCollisions {
        &self.acm
    }

    /// The robot compiled with `attached` bodies, exact self-collision
    /// confirmation or not, and its self pairs' clearance maps for `margin`;
    /// the shared copy when nothing is attached and the margin is 0.
    fn compile(&self, attached: &[Attached], exact_self: bool, margin: f64) -> Arc<CompiledRobot> {
        if attached.is_empty() && margin == 0.0 {
            return self.compiled[exact_self as usize]
                .get_or_init(|| Arc::new(self.compile_fresh(attached, exact_self, margin)))
                .clone();
        }
        Arc::new(self.compile_fresh(attached, exact_self, margin))
    }

    fn compile_fresh(&self, atts: &[Attached], exact_self: bool, margin: f64) -> CompiledRobot {
        let attached: Vec<(usize, String, Vec<Sphere>)> = atts
            .iter()
            .map(|a| (a.link, a.name.clone(), a.spheres.clone()))
            .collect();
        let acm = &self.acm;
        let exact: &[Option<crate::exact::ExactBody>] =
            if exact_self { &self.exact_links } else { &[] };
        let mut robot = CompiledRobot::new(
            &self.model,
            &self.spheres.links,
            &attached,
            exact,
            |a, b| match (&a.attached, &b.attached) {
                (None, None) => !acm.is_allowed(a.link, b.link),
                (Some(_), Some(_)) => true,
                (Some(name), None) | (None, Some(name)) => {
                    let att = atts
                        .iter()
                        .find(|x| &x.name == name)
                        .expect("attached body");
                    let other = if a.attached.is_some() { b.link } else { a.link };
                    other != att.link && !att.touch_links.contains(&other)
                }
            },
        );
        set_pair_maps(&self.model, &mut robot, margin);
        robot
    }
}

/// Builds (or takes from the process cache) the joint-space clearance maps
/// of `robot`'s self pairs for `margin` (see [`crate::pair_map`]).
fn set_pair_maps(model: &RobotModel, robot: &mut CompiledRobot, margin: f64) {
    let limits: Vec<(f64, f64)> = model
        .lower_limits()
        .into_iter()
        .zip(model.upper_limits())
        .collect();
    robot.pair_maps = crate::pair_map::maps_for(robot, margin as f32, &limits);
    robot.collide_maps = crate::pair_map::collide_maps(&robot.pair_maps);
}

/// Collision queries for one robot in one world: the per-scene state (world,
/// ignored objects, attached objects, margin, compiled world, world grid)
/// over a shared [`RobotCollisionModel`]. Cloning shares the robot model.
#[derive(Debug, Clone)]
pub struct CollisionChecker {
    /// The shared robot collision model.
    pub(crate) shared: Arc<RobotCollisionModel>,
    pub(crate) attached: Vec<Attached>,
    pub(crate) world: CollisionWorld,
    pub(crate) margin: f64,
    /// The robot compiled with the attached objects and the margin (the
    /// shared model's copy when there are none and the margin is 0).
    pub(crate) robot: Arc<CompiledRobot>,
    pub(crate) compiled_world: CompiledWorld,
    /// Names of world objects the robot ignores (MoveIt's allowed-collision
    /// entries for world objects): kept in the world, left out of every
    /// query. Changing it recompiles the world from the shapes it holds.
    pub(crate) disabled: std::collections::BTreeSet<String>,
    /// Whether bodies fixed to the base touch the world (true for every q).
    static_hit: bool,
    id: u64,
    exact_self: bool,
    /// Distance bounds to the world and per-cell candidate obstacles for
    /// the kernels (see [`crate::world_grid`]), made by the first query
    /// after a change of robot, margin or world (cells fill on use).
    grid: std::sync::OnceLock<Option<Arc<WorldGrid>>>,
    /// Instruction set of the kernels (see [`crate::dispatch`]).
    simd: SimdLevel,
    /// Per body, per DOF: how far the body's spheres move per unit of the
    /// DOF ([`crate::certify::displacement_rates`]), for
    /// [`CollisionChecker::curve_certified_until`].
    rates: Arc<crate::certify::Rates>,
    /// The robot without self pairs: the grown-margin checks of
    /// [`CollisionChecker::curve_certified_until`] certify world contacts.
    world_only: Arc<CompiledRobot>,
}

impl CollisionChecker {
    /// A checker for `model` with sphere model `spheres`, excluded pairs
    /// `acm` and obstacles `world` (a new [`RobotCollisionModel`]; use
    /// [`CollisionChecker::with_model`] to share one).
    pub fn new(
        model: Arc<RobotModel>,
        spheres: RobotSpheres,
        acm: AllowedCollisions,
        world: CollisionWorld,
    ) -> Result<Self> {
        let shared = Arc::new(RobotCollisionModel::new(model, spheres, acm)?);
        Ok(Self::with_model(shared, world))
    }

    /// A checker (a scene) over the shared robot collision model `shared`
    /// with obstacles `world`: the robot's compiled data is not copied.
    pub fn with_model(shared: Arc<RobotCollisionModel>, world: CollisionWorld) -> Self {
        let compiled_world = CompiledWorld::new(&world);
        let mut checker = Self {
            // Set by `update_static` below.
            world_only: shared.compile(&[], true, 0.0),
            robot: shared.compile(&[], true, 0.0),
            shared,
            attached: Vec::new(),
            world,
            margin: 0.0,
            compiled_world,
            disabled: Default::default(),
            static_hit: false,
            id: 0,
            exact_self: true,
            grid: Default::default(),
            simd: crate::dispatch::level(),
            rates: Default::default(),
        };
        checker.id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        checker.update_static();
        checker
    }

    /// The shared robot collision model.
    pub fn robot_model(&self) -> &Arc<RobotCollisionModel> {
        &self.shared
    }

    fn recompile_robot(&mut self) {
        self.robot = self
            .shared
            .compile(&self.attached, self.exact_self, self.margin);
        self.id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        self.update_static();
    }

    /// Whether self-collisions found by spheres are confirmed on the links'
    /// exact geometry (see [`crate::exact`]); true by default.
    pub fn exact_self_collision(&self) -> bool {
        self.exact_self
    }

    /// Decides self-collision by exact geometry after the spheres (true) or
    /// by the spheres alone (false, as cuRobo and VAMP do).
    pub fn set_exact_self_collision(&mut self, exact: bool) {
        self.exact_self = exact;
        self.recompile_robot();
    }

    fn recompile_world(&mut self) {
        let enabled = self.enabled_mask();
        self.compiled_world = CompiledWorld::with_mask(&self.world, |i| enabled[i]);
        self.update_static();
    }

    /// Per world object (in `world().objects()` order): whether the robot
    /// collides with it.
    pub(crate) fn enabled_mask(&self) -> Vec<bool> {
        self.world
            .objects()
            .iter()
            .map(|o| !self.disabled.contains(&o.name))
            .collect()
    }

    /// Tests the bodies fixed to the base against the world once.
    fn update_static(&mut self) {
        self.grid = Default::default();
        let model = &self.shared.model;
        let mut world_only = CompiledRobot::clone(&self.robot);
        world_only.pairs.clear();
        world_only.pair_maps.clear();
        world_only.collide_maps.clear();
        world_only.pair_reach.clear();
        self.world_only = Arc::new(world_only);
        self.rates = Arc::new(crate::certify::displacement_rates(
            &self.robot,
            &model.lower_limits(),
            &model.upper_limits(),
        ));
        let mut only_static = CompiledRobot::clone(&self.robot);
        only_static.bodies.retain(|b| b.frame == 0);
        only_static.pairs.clear();
        only_static.pair_maps.clear();
        only_static.collide_maps.clear();
        only_static.pair_reach.clear();
        let q = vec![0.0f32; self.robot.num_dof];
        let mut scratch = Scratch::<f32>::new(&only_static);
        self.static_hit = check(
            &only_static,
            &self.compiled_world,
            None,
            &q,
            self.margin as f32,
            1,
            false,
            &mut scratch,
        ) != 0;
    }

    /// The robot model.
    pub fn model(&self) -> &Arc<RobotModel> {
        &self.shared.model
    }

    /// The sphere model.
    pub fn spheres(&self) -> &RobotSpheres {
        &self.shared.spheres
    }

    /// The allowed-collision matrix.
    pub fn allowed_collisions(&self) -> &AllowedCollisions {
        &self.shared.acm
    }

    /// Replaces the allowed-collision matrix: this checker gets its own
    /// robot collision model (others sharing the old one keep it).
    pub fn set_allowed_collisions(&mut self, acm: AllowedCollisions) {
        let m = &self.shared;
        self.shared = Arc::new(RobotCollisionModel {
            model: m.model.clone(),
            spheres: m.spheres.clone(),
            acm,
            exact_links: m.exact_links.clone(),
            compiled: Default::default(),
        });
        self.recompile_robot();
    }

    /// The world.
    pub fn world(&self) -> &CollisionWorld {
        &self.world
    }

    /// Replaces the world (every object enabled).
    pub fn set_world(&mut self, world: CollisionWorld) {
        self.world = world;
        self.disabled.clear();
        self.recompile_world();
    }

    /// Changes the world through `f` and recompiles it.
    pub fn update_world<T>(
        &mut self,
        f: impl FnOnce(&mut CollisionWorld) -> Result<T>,
    ) -> Result<T> {
        let out = f(&mut self.world);
        self.recompile_world();
        out
    }

    /// Changes the world in place through `f` and sets the names of the
    /// ignored world objects to `disabled`, recompiling once, and only if
    /// the world (its revision) or the set changed: the incremental update
    /// of a scene (poses moved, objects added or removed, objects ignored
    /// or enabled by name), with every unchanged shape kept as it is.
    /// Returns `f`'s value and whether anything changed.
    pub fn sync_world<T>(
        &mut self,
        disabled: std::collections::BTreeSet<String>,
        f: impl FnOnce(&mut CollisionWorld) -> Result<T>,
    ) -> Result<(T, bool)> {
        let revision = self.world.revision();
        let out = f(&mut self.world);
        let changed = self.world.revision() != revision || disabled != self.disabled;
        self.disabled = disabled;
        if changed {
            self.recompile_world();
        }
        Ok((out?, changed))
    }

    /// Ignores (false) or enables (true) world object `name` for every
    /// query, without rebuilding the world (MoveIt's allowed-collision
    /// entry for a world object). The name must be in the world.
    pub fn set_object_enabled(&mut self, name: &str, enabled: bool) -> Result<()> {
        self.world.get(name)?;
        let changed = if enabled {
            self.disabled.remove(name)
        } else {
            self.disabled.insert(name.to_string())
        };
        if changed {
            self.recompile_world();
        }
        Ok(())
    }

    /// Whether the robot collides with world object `name` (false when it
    /// is ignored; an error when there is no such object).
    pub fn is_object_enabled(&self, name: &str) -> Result<bool> {
        self.world.get(name)?;
        Ok(!self.disabled.contains(name))
    }

    /// Names of the world objects the robot ignores, sorted.
    pub fn disabled_objects(&self) -> impl Iterator<Item = &str> {
        self.disabled.iter().map(String::as_str)
    }

    /// The world without its ignored objects: what queries see.
    pub fn enabled_world(&self) -> CollisionWorld {
        let mut out = CollisionWorld::new();
        for o in self.world.objects() {
            if !self.disabled.contains(&o.name) {
                out.add(&o.name, o.pose, o.parts.clone())
                    .expect("names and shapes of a valid world");
            }
        }
        out
    }

    /// Attached objects.
    pub fn attached(&self) -> &[Attached] {
        &self.attached
    }

    /// Clearance (m) added to every sphere: a configuration collides when
    /// any distance is below the margin. Default 0.
    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// Sets the margin (finite, may be negative to allow slight contact).
    pub fn set_margin(&mut self, margin: f64) -> Result<()> {
        ferrobot_model::ranges::MARGIN.check(margin)?;
        self.margin = margin;
        self.recompile_robot();
        Ok(())
    }

    /// Whether the kernels have made their world grid (see
    /// [`crate::world_grid`]; made by the first query after a change of
    /// robot, margin or world, when the world is not empty), for
    /// diagnostics.
    pub fn has_world_grid(&self) -> bool {
        self.grid.get().is_some_and(|g| g.is_some())
    }

    /// The world grid, made on first use.
    #[inline]
    fn world_grid(&self) -> Option<&WorldGrid> {
        self.grid
            .get_or_init(|| {
                // Candidate lists also cover the margins of certifying
                // checks (up to CERTIFY_REACH above the margin).
                WorldGrid::for_robot(
                    &self.robot,
                    &self.compiled_world,
                    (self.margin + CERTIFY_REACH) as f32,
                )
                .map(Arc::new)
            })
            .as_deref()
    }

    /// Compiled data (for benchmarks and diagnostics).
    pub fn compiled(&self) -> (&CompiledRobot, &CompiledWorld) {
        (&self.robot, &self.compiled_world)
    }

    /// The instruction-set level the kernels run at: the best the CPU
    /// supports unless `FERROBOT_SIMD` or [`CollisionChecker::set_simd_level`]
    /// chose a lower one.
    pub fn simd_level(&self) -> SimdLevel {
        self.simd
    }

    /// Runs the kernels at `level` (every level gives the same answers; this
    /// is for tests and benchmarks). Fails if the CPU lacks the level.
    pub fn set_simd_level(&mut self, level: SimdLevel) -> Result<()> {
        if !level.supported() {
            return Err(CollisionError::InvalidArgument(format!(
                "level: this CPU does not support {} (best: {})",
                level.name(),
                crate::dispatch::detected().name()
            )));
        }
        self.simd = level;
        Ok(())
    }

    fn check_q(&self, what: &str, q: &[f64]) -> Result<()> {
        self.shared
            .model
            .check_configuration(what, q)
            .map_err(Into::into)
    }

    /// Whether configuration `q` (num_dof values) collides with the world or
    /// itself. Uses the scalar lane.
    pub fn in_collision(&self, q: &[f64]) -> Result<bool> {
        self.check_q("q", q)?;
        Ok(self.in_collision_unchecked(q))
    }

    /// [`CollisionChecker::in_collision`] without argument checks (the
    /// caller has checked length and finiteness).
    pub fn in_collision_unchecked(&self, q: &[f64]) -> bool {
        // Up to 64 DOFs on the stack (no allocation on the hot path).
        let mut stack = [0.0f32; 64];
        let heap: Vec<f32>;
        let q32: &[f32] = if q.len() <= stack.len() {
            for (d, &v) in stack.iter_mut().zip(q) {
                *d = v as f32;
            }
            &stack[..q.len()]
        } else {
            heap = q.iter().map(|&v| v as f32).collect();
            &heap
        };
        SCALAR_SCRATCH.with(|cell| {
            let mut slot = cell.borrow_mut();
            if slot.as_ref().is_none_or(|(id, _)| *id != self.id) {
                *slot = Some((self.id, OneScratch::new(&self.robot)));
            }
            let scratch = &mut slot.as_mut().expect("set above").1;
            let grid = self.world_grid();
            self.static_hit
                || crate::dispatch::check_one(
                    self.simd,
                    &self.robot,
                    &self.compiled_world,
                    grid,
                    q32,
                    self.margin as f32,
                    true,
                    scratch,
                )
        })
    }

    /// Collision flags for `n` configurations stored row-major in `qs`,
    /// eight per SIMD pack, packs spread over the rayon pool.
    pub fn in_collision_batch(&self, qs: &[f64]) -> Result<Vec<bool>> {
        let dof = self.shared.model.num_dof();
        if dof == 0 || !qs.len().is_multiple_of(dof) {
            return Err(CollisionError::Model(ferrobot_model::ModelError::Shape {
                what: "q".into(),
                expected: format!("(N, {dof})"),
                got: format!("{} values", qs.len()),
            }));
        }
        ferrobot_model::error::check_finite("q", qs)?;
        let mut out = vec![false; qs.len() / dof];
        self.in_collision_batch_into(qs, &mut out);
        Ok(out)
    }

    /// [`CollisionChecker::in_collision_batch`] into `out` for checked input.
    pub fn in_collision_batch_into(&self, qs: &[f64], out: &mut [bool]) {
        let dof = self.shared.model.num_dof();
        const CHUNK: usize = 8 * 64;
        if self.static_hit {
            out.iter_mut().for_each(|o| *o = true);
            return;
        }
        let grid = self.world_grid();
        out.par_chunks_mut(CHUNK)
            .zip(qs.par_chunks(CHUNK * dof))
            .for_each(|(o, q)| {
                let mut scratch = Scratch::<f32x8>::new(&self.robot);
                crate::dispatch::check_packs(
                    self.simd,
                    &self.robot,
                    &self.compiled_world,
                    grid,
                    q,
                    dof,
                    self.margin as f32,
                    self.margin as f32,
                    o,
                    &mut scratch,
                );
            });
    }

    /// [`CollisionChecker::in_collision_batch_into`] on the calling thread
    /// (no hand-off to the rayon pool): for the few hundred configurations
    /// of one plan's re-check, where waking pool threads on a busy machine
    /// costs more than the checks.
    pub fn in_collision_batch_serial_into(&self, qs: &[f64], out: &mut [bool]) {
        let dof = self.shared.model.num_dof();
        if self.static_hit {
            out.iter_mut().for_each(|o| *o = true);
            return;
        }
        let grid = self.world_grid();
        let mut scratch = Scratch::<f32x8>::new(&self.robot);
        crate::dispatch::check_packs(
            self.simd,
            &self.robot,
            &self.compiled_world,
            grid,
            &qs[..out.len() * dof],
            dof,
            self.margin as f32,
            self.margin as f32,
            out,
            &mut scratch,
        );
    }

    /// Whether the straight joint-space motion from `q0` to `q1` is free:
    /// configurations are checked so that no DOF moves more than
    /// `resolution` between neighbours (endpoints included), eight at a time
    /// spread along the motion, stopping at the first collision.
    pub fn motion_valid(&self, q0: &[f64], q1: &[f64], resolution: f64) -> Result<bool> {
        self.check_q("q0", q0)?;
        self.check_q("q1", q1)?;
        use ferrobot_model::ranges::{MAX_MOTION_CHECKS, RESOLUTION, step_count};
        RESOLUTION.check(resolution)?;
        let span = q0
            .iter()
            .zip(q1)
            .map(|(a, b)| (b - a).abs())
            .fold(0.0, f64::max);
        step_count("motion_valid", span, resolution, MAX_MOTION_CHECKS)?;
        Ok(self.motion_valid_unchecked(q0, q1, resolution))
    }

    /// [`CollisionChecker::motion_valid`] for checked input.
    pub fn motion_valid_unchecked(&self, q0: &[f64], q1: &[f64], resolution: f64) -> bool {
        // Without a deadline there is always an answer.
        self.motion_valid_until(q0, q1, resolution, None)
            .unwrap_or(false)
    }

    /// [`CollisionChecker::motion_valid_unchecked`] that gives up at
    /// `deadline`: `None` when the deadline passed before the motion was
    /// found free or colliding (the clock is read every 64 packs of eight
    /// configurations, so the overrun is a few hundred checks at most). The
    /// configurations checked are those of the check without a deadline.
    #[inline]
    pub fn motion_valid_until(
        &self,
        q0: &[f64],
        q1: &[f64],
        resolution: f64,
        deadline: Option<Instant>,
    ) -> Option<bool> {
        if self.static_hit {
            return Some(false);
        }
        let dof = q0.len();
        let span = q0
            .iter()
            .zip(q1)
            .map(|(a, b)| (b - a).abs())
            .fold(0.0, f64::max);
        // `as` saturates; callers bound the resolution (ranges::RESOLUTION).
        let steps = ((span / resolution).ceil() as usize).max(1);
        // Up to 64 DOFs on the stack (no allocation on the hot path).
        let mut stack = [f32x8::splat(0.0); 64];
        let mut heap: Vec<f32x8> = Vec::new();
        let lanes: &mut [f32x8] = if dof <= stack.len() {
            &mut stack[..dof]
        } else {
            heap.resize(dof, f32x8::splat(0.0));
            &mut heap
        };
        MOTION_SCRATCH.with(|cell| {
            let mut slot = cell.borrow_mut();
            if slot.as_ref().is_none_or(|(id, _)| *id != self.id) {
                *slot = Some((self.id, Scratch::new(&self.robot)));
            }
            let scratch = &mut slot.as_mut().expect("set above").1;
            crate::dispatch::motion_free(
                self.simd,
                &self.robot,
                &self.compiled_world,
                self.world_grid(),
                q0,
                q1,
                steps,
                lanes,
                self.margin as f32,
                deadline,
                scratch,
            )
        })
    }

    /// A bound (m) on how far any point of the robot's spheres moves (for a
    /// self pair: the two bodies together) between configurations whose
    /// DOF `d` differs by at most `delta[d]` (model DOF order): see
    /// [`crate::certify`]. Infinite when a DOF that moves has no finite
    /// bound (a prismatic joint without limits between it and a body).
    pub fn motion_margin(&self, delta: &[f64]) -> f64 {
        crate::certify::motion_margin(&self.robot, &self.rates, delta)
    }

    /// Whether every configuration of the curve `point(u)`, `u` in
    /// `[0, 1]` (model DOF order, written into the slice), is free of the
    /// world with every sphere grown by `tube` (m) on top of the margin,
    /// *continuously*, not only at samples (see [`crate::certify`]); and free
    /// of self-collision at samples (the midpoints of the `steps`
    /// intervals): self pairs that stay in near-contact over a motion (links
    /// whose exact geometry touches where their spheres overlap) could not
    /// be certified with a margin. `rate[d]` bounds
    /// `|dq_d/du|` over the curve (0 for DOFs that do not move); the curve
    /// is first cut into `steps` equal intervals (e.g. so that no DOF moves
    /// more than the motion-check resolution over one), each certified by
    /// its midpoint with the margin grown by what the robot can move over
    /// half an interval, and split where that fails. `Some(false)` when a
    /// configuration collides (or the curve cannot be proven free within
    /// [`crate::certify::MAX_LEVELS`] halvings or
    /// [`crate::certify::CHECKS_PER_INTERVAL`] configurations per starting
    /// interval: it passes within micrometres of a collision); `None` when
    /// `deadline` passed first.
    /// Curves along which a moving DOF has no finite displacement bound
    /// (see [`CollisionChecker::motion_margin`]) are checked at the samples
    /// of the `steps` intervals only (the motion check's guarantee). The
    /// configurations checked are added to `tested`.
    ///
    /// The first intervals' midpoints are tested in one kernel pass per
    /// eight (one forward kinematics): self pairs at the margin (+ `tube`),
    /// the world at the grown margin ([`crate::kernel::check_margins`]);
    /// the few that fail are tested again at the margin to tell a collision
    /// from an interval to split.
    pub fn curve_certified_until(
        &self,
        point: &mut dyn FnMut(f64, &mut [f64]),
        rate: &[f64],
        steps: usize,
        tube: f64,
        deadline: Option<Instant>,
        tested: &mut usize,
    ) -> Option<bool> {
        self.curve_certified(point, rate, steps, tube, deadline, tested, true)
    }

    /// [`CollisionChecker::curve_certified_until`] with the first
    /// intervals' midpoints tested in two kernel passes, the whole robot at
    /// the margin then the world alone at the grown margin (the scheme
    /// before the one-pass kernel mode): the same answers, more kernel
    /// work. Kept as the reference of the tests that the two agree and for
    /// A/B measurements; not for use.
    #[doc(hidden)]
    pub fn curve_certified_two_pass_until(
        &self,
        point: &mut dyn FnMut(f64, &mut [f64]),
        rate: &[f64],
        steps: usize,
        tube: f64,
        deadline: Option<Instant>,
        tested: &mut usize,
    ) -> Option<bool> {
        self.curve_certified(point, rate, steps, tube, deadline, tested, false)
    }

    #[allow(clippy::too_many_arguments)]
    fn curve_certified(
        &self,
        point: &mut dyn FnMut(f64, &mut [f64]),
        rate: &[f64],
        steps: usize,
        tube: f64,
        deadline: Option<Instant>,
        tested: &mut usize,
        one_pass: bool,
    ) -> Option<bool> {
        use crate::certify::{CERTIFY_SLACK, CHECKS_PER_INTERVAL, MAX_LEVELS};
        if self.static_hit {
            return Some(false);
        }
        let dof = self.shared.model.num_dof();
        let steps = steps.max(1);
        let per_u = self.motion_margin(rate);
        let grid = self.world_grid();
        let mut q = vec![0.0; dof];
        MOTION_SCRATCH.with(|cell| {
            let mut slot = cell.borrow_mut();
            if slot.as_ref().is_none_or(|(id, _)| *id != self.id) {
                *slot = Some((self.id, Scratch::new(&self.robot)));
            }
            let scratch = &mut slot.as_mut().expect("set above").1;
            // Flags of up to eight configurations (row-major in `qs`): the
            // world at `margin`, self pairs at `self_margin` (`None`: the
            // robot without self pairs).
            let mut check =
                |qs: &[f64], margin: f64, self_margin: Option<f64>, out: &mut [bool]| {
                    *tested += out.len();
                    crate::dispatch::check_packs(
                        self.simd,
                        if self_margin.is_some() {
                            &self.robot
                        } else {
                            &self.world_only
                        },
                        &self.compiled_world,
                        grid,
                        qs,
                        dof,
                        margin as f32,
                        self_margin.unwrap_or(margin) as f32,
                        out,
                        scratch,
                    )
                };
            let base = self.margin + tube;
            let mut qs = Vec::with_capacity(8 * dof);
            let mut flags = [false; 8];
            if !per_u.is_finite() {
                // No continuous bound: the samples at the interval ends.
                let us: Vec<f64> = (0..=steps).map(|k| k as f64 / steps as f64).collect();
                for (c, chunk) in us.chunks(8).enumerate() {
                    if c % 64 == 63 && deadline.is_some_and(|d| Instant::now() >= d) {
                        return None;
                    }
                    qs.clear();
                    for &u in chunk {
                        point(u, &mut q);
                        qs.extend_from_slice(&q);
                    }
                    check(&qs, base, Some(base), &mut flags[..chunk.len()]);
                    if flags[..chunk.len()].iter().any(|&f| f) {
                        return Some(false);
                    }
                }
                return Some(true);
            }
            // Intervals of the current level: their starts, all `width` wide.
            let mut width = 1.0 / steps as f64;
            let mut starts: Vec<f64> = (0..steps).map(|k| k as f64 * width).collect();
            let mut next = Vec::new();
            let mut checked = 0usize;
            let budget = steps.saturating_mul(CHECKS_PER_INTERVAL);
            for level in 0..MAX_LEVELS {
                if starts.is_empty() {
                    return Some(true);
                }
                let grown = base + per_u * 0.5 * width + CERTIFY_SLACK;
                for (c, chunk) in starts.chunks(8).enumerate() {
                    if c % 64 == 63 && deadline.is_some_and(|d| Instant::now() >= d) {
                        return None;
                    }
                    checked += chunk.len();
                    if checked > budget {
                        return Some(false);
                    }
                    qs.clear();
                    for &u0 in chunk {
                        point(u0 + 0.5 * width, &mut q);
                        qs.extend_from_slice(&q);
                    }
                    let n = chunk.len();
                    if level == 0 && one_pass {
                        // Self-collision at the samples (midpoints
                        // `resolution` apart) at the margin and the world
                        // at the grown margin, in one pass: a midpoint that
                        // collides with the world at the margin collides
                        // at the grown one, so the failures below (tested
                        // again at the margin, self pairs included) hold
                        // every collision of the two-pass scheme.
                        check(&qs, grown, Some(base), &mut flags[..n]);
                    } else {
                        if level == 0 {
                            // Self-collision at the samples, with the world.
                            check(&qs, base, Some(base), &mut flags[..n]);
                            if flags[..n].iter().any(|&f| f) {
                                return Some(false);
                            }
                        }
                        check(&qs, grown, None, &mut flags[..n]);
                    }
                    if !flags[..n].iter().any(|&f| f) {
                        continue;
                    }
                    // Not proven: a collision at the midpoint itself ends
                    // it, otherwise the interval is split.
                    let failed: Vec<usize> = (0..n).filter(|&i| flags[i]).collect();
                    let mut sub = Vec::with_capacity(failed.len() * dof);
                    for &i in &failed {
                        sub.extend_from_slice(&qs[i * dof..(i + 1) * dof]);
                    }
                    check(&sub, base, Some(base), &mut flags[..failed.len()]);
                    if flags[..failed.len()].iter().any(|&f| f) {
                        return Some(false);
                    }
                    for &i in &failed {
                        next.push(chunk[i]);
                        next.push(chunk[i] + 0.5 * width);
                    }
                }
                std::mem::swap(&mut starts, &mut next);
                next.clear();
                width *= 0.5;
            }
            Some(starts.is_empty())
        })
    }

    /// Attaches an object made of `parts` (object frame) at `pose_in_link`
    /// to `link`; it may touch `touch_links`. Its spheres come from the
    /// automatic spherizer (1 mm tolerance).
    pub fn attach(
        &mut self,
        name: &str,
        link: &str,
        pose_in_link: Isometry3<f64>,
        parts: Vec<(Shape, Isometry3<f64>)>,
        touch_links: &[&str],
    ) -> Result<()> {
        if self.attached.iter().any(|a| a.name == name) {
            return Err(CollisionError::Duplicate(format!(
                "an object named '{name}' is attached already"
            )));
        }
        let l = self.shared.model.link(link)?;
        let touch = touch_links
            .iter()
            .map(|t| self.shared.model.link(t))
            .collect::<std::result::Result<Vec<_>, _>>()?;
        if parts.is_empty() {
            return Err(CollisionError::InvalidShape(format!(
                "attached object '{name}': no shapes"
            )));
        }
        for (k, (shape, _)) in parts.iter().enumerate() {
            check_shape(&format!("attached object '{name}' shape {k}"), shape)?;
        }
        let geoms: Vec<Geometry> = parts
            .iter()
            .map(|(shape, local)| geometry_of(shape, pose_in_link * local))
            .collect::<Result<_>>()?;
        let (spheres, _) = spherize_link(name, &geoms, None, &SpherizeOptions::default())?;
        self.attached.push(Attached {
            name: name.to_string(),
            link: l,
            pose_in_link,
            parts,
            touch_links: touch,
            spheres,
        });
        self.recompile_robot();
        Ok(())
    }

    /// The links an object held by `link` may touch by default: `link`
    /// and every link below it in the tree (a hand's fingers), in link
    /// order.
    pub fn default_touch_links(&self, link: usize) -> Vec<String> {
        let model = &self.shared.model;
        model
            .links()
            .iter()
            .enumerate()
            .filter(|(i, _)| {
                *i == link
                    || model
                        .path_to(*i)
                        .iter()
                        .any(|&j| model.joints()[j].parent == link)
            })
            .map(|(_, l)| l.name.clone())
            .collect()
    }

    /// Moves world object `name` onto `link` at configuration `q` (it keeps
    /// its current world pose relative to the link).
    pub fn attach_world_object(
        &mut self,
        name: &str,
        link: &str,
        q: &[f64],
        touch_links: &[&str],
    ) -> Result<()> {
        self.check_q("q", q)?;
        let l = self.shared.model.link(link)?;
        let obj: WorldObject = self.world.get(name)?.clone();
        let link_pose = self.shared.model.fk(q, Some(l))?;
        let pose_in_link = link_pose.inverse() * obj.pose;
        self.attach(name, link, pose_in_link, obj.parts.clone(), touch_links)?;
        self.world.remove(name)?;
        // Attached, it is part of the robot: no world entry ignores it.
        self.disabled.remove(name);
        self.recompile_world();
        Ok(())
    }

    /// Detaches `name`; with `q` it goes back into the world at its pose at
    /// `q`, without it it is dropped. Returns the object.
    pub fn detach(&mut self, name: &str, q: Option<&[f64]>) -> Result<Attached> {
        let i = self
            .attached
            .iter()
            .position(|a| a.name == name)
            .ok_or_else(|| CollisionError::Name(format!("no attached object named '{name}'")))?;
        if let Some(q) = q {
            self.check_q("q", q)?;
            let a = &self.attached[i];
            let pose = self.shared.model.fk(q, Some(a.link))? * a.pose_in_link;
            self.world.add(name, pose, a.parts.clone())?;
            self.recompile_world();
        }
        let a = self.attached.remove(i);
        self.recompile_robot();
        Ok(a)
    }
}

/// Packs `n` configurations (row-major, `dof` each) into DOF-major lanes;
/// lanes past `n` repeat the last configuration.
#[inline(always)]
pub(crate) fn pack(q: &[f64], dof: usize, n: usize) -> Vec<f32x8> {
    (0..dof)
        .map(|d| f32x8::from_fn(|i| q[i.min(n - 1) * dof + d] as f32))
        .collect()
}

/// A model geometry for an obstacle shape (for the spherizer): the same
/// shape placed at `origin`; a point cloud cannot be attached.
pub(crate) fn geometry_of(shape: &Shape, origin: Isometry3<f64>) -> Result<Geometry> {
    if let Shape::PointCloud(_) = shape {
        return Err(CollisionError::InvalidShape(
            "a point cloud cannot be attached to the robot".into(),
        ));
    }
    let s = shape.clone();
    Ok(Geometry {
        name: None,
        origin,
        shape: s,
        rgba: None,
    })
}
