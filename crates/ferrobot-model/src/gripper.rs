//! The one description of a parallel-jaw gripper: where its TCP is, how it
//! approaches and closes, which joints move its fingers and how their
//! position maps to the opening between the pads, and the finger geometry
//! grasp detection needs.
//!
//! A [`Gripper`] is independent of any arm: it names a hand link (the frame
//! the planner moves), its driver joint and mimic followers. The grasp
//! detector's `ferrobot_grasp::GripperGeometry` is derived from it, the
//! simulator's gripper commands read it, and Python's `to_hand` places hands
//! with it. Two are shipped ([`Gripper::panda_hand`], [`Gripper::robotiq_2f85`]);
//! [`Gripper::from_model`] finds them in a model or builds one from the
//! SRDF's `end_effector` and the finger joints' geometry.
//!
//! Frames: the gripper ("grasp") frame has x along the approach (palm to
//! fingertips), y along the closing axis, z = x × y (graspnetAPI's), with
//! its origin at the TCP, between the fingertips.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, Unit, UnitQuaternion, Vector3};

use crate::Shape;
use crate::error::{ModelError, Result};
use crate::joint::{JointCoupling, JointKind};
use crate::model::RobotModel;

/// How the driver joint's position `q` maps to the opening between the
/// fingers' inner faces (m).
#[derive(Debug, Clone, PartialEq)]
pub enum OpeningMap {
    /// `opening = scale * q + offset` (prismatic fingers; the Panda hand:
    /// scale 2, offset 0).
    Linear {
        /// d opening / d q.
        scale: f64,
        /// Opening at q = 0 (m).
        offset: f64,
    },
    /// A parallel four-bar finger linkage turning by `q` about the closing
    /// axis' normal: each pad's inner face lies at
    /// `offset + radius * cos(q + phase)` from the centre, so
    /// `opening = 2 (offset + radius cos(q + phase))` (the Robotiq 2F-85).
    FourBar {
        /// Distance (m) from the centre plane to a pad's inner face when the
        /// knuckle is along the closing normal (pivot offset plus the pad's
        /// offset from the distal pivot; may be negative).
        offset: f64,
        /// Knuckle length (m, > 0): pivot to distal pivot.
        radius: f64,
        /// Angle (rad) of the knuckle from the closing axis at q = 0.
        phase: f64,
    },
    /// Samples of (q, opening), q increasing, opening strictly monotone;
    /// linear in between (built from the model's geometry when no closed
    /// form is known).
    Table {
        /// Driver positions, increasing.
        q: Vec<f64>,
        /// Openings (m) at `q`.
        opening: Vec<f64>,
    },
}

impl OpeningMap {
    /// The opening (m) at driver position `q`.
    pub fn opening(&self, q: f64) -> f64 {
        match self {
            Self::Linear { scale, offset } => scale * q + offset,
            Self::FourBar {
                offset,
                radius,
                phase,
            } => 2.0 * (offset + radius * (q + phase).cos()),
            Self::Table { q: qs, opening } => {
                let n = qs.len();
                let k = qs.partition_point(|&x| x <= q).clamp(1, n - 1);
                let t = (q - qs[k - 1]) / (qs[k] - qs[k - 1]);
                opening[k - 1] + t * (opening[k] - opening[k - 1])
            }
        }
    }

    /// d opening / d q at `q`.
    pub fn derivative(&self, q: f64) -> f64 {
        match self {
            Self::Linear { scale, .. } => *scale,
            Self::FourBar { radius, phase, .. } => -2.0 * radius * (q + phase).sin(),
            Self::Table { q: qs, opening } => {
                let n = qs.len();
                let k = qs.partition_point(|&x| x <= q).clamp(1, n - 1);
                (opening[k] - opening[k - 1]) / (qs[k] - qs[k - 1])
            }
        }
    }

    /// The driver position in `[lo, hi]` giving `opening`, or `None` when
    /// no position in that range does (the map is monotone there).
    pub fn position(&self, opening: f64, lo: f64, hi: f64) -> Option<f64> {
        let (a, b) = (self.opening(lo), self.opening(hi));
        let (min, max) = (a.min(b), a.max(b));
        if !(opening >= min - 1e-12 && opening <= max + 1e-12) {
            return None;
        }
        let q = match self {
            Self::Linear { scale, offset } => (opening - offset) / scale,
            Self::FourBar {
                offset,
                radius,
                phase,
            } => ((opening / 2.0 - offset) / radius).clamp(-1.0, 1.0).acos() - phase,
            Self::Table { .. } => {
                // Bisection on the monotone piecewise-linear map.
                let increasing = b >= a;
                let (mut l, mut h) = (lo, hi);
                for _ in 0..100 {
                    let m = 0.5 * (l + h);
                    if (self.opening(m) < opening) == increasing {
                        l = m;
                    } else {
                        h = m;
                    }
                }
                0.5 * (l + h)
            }
        };
        Some(q.clamp(lo, hi))
    }

    fn validate(&self) -> Result<()> {
        let bad = |m: String| {
            Err(ModelError::InvalidArgument(format!(
                "gripper opening map: {m}"
            )))
        };
        match self {
            Self::Linear { scale, offset } => {
                if !(scale.is_finite() && *scale != 0.0 && offset.is_finite()) {
                    return bad(format!(
                        "scale must be finite and non-zero, offset finite; got {scale}, {offset}"
                    ));
                }
            }
            Self::FourBar {
                offset,
                radius,
                phase,
            } => {
                if !(offset.is_finite() && radius.is_finite() && *radius > 0.0 && phase.is_finite())
                {
                    return bad(format!(
                        "radius must be finite and > 0, offset and phase finite; got {offset}, {radius}, {phase}"
                    ));
                }
            }
            Self::Table { q, opening } => {
                if q.len() < 2 || q.len() != opening.len() {
                    return bad(format!(
                        "a table needs at least 2 (q, opening) samples of equal count, got {} and {}",
                        q.len(),
                        opening.len()
                    ));
                }
                if q.iter().chain(opening).any(|v| !v.is_finite()) {
                    return bad("non-finite sample".into());
                }
                if q.windows(2).any(|w| w[1] <= w[0]) {
                    return bad("q must be strictly increasing".into());
                }
                let d: Vec<f64> = opening.windows(2).map(|w| w[1] - w[0]).collect();
                if !(d.iter().all(|&x| x > 0.0) || d.iter().all(|&x| x < 0.0)) {
                    return bad("opening must be strictly monotone in q".into());
                }
            }
        }
        Ok(())
    }
}

/// Finger and hand-body dimensions (m) that grasp detection models as
/// boxes (see `ferrobot_grasp::GripperGeometry`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FingerGeometry {
    /// Length of the finger pads along the approach (> 0).
    pub depth: f64,
    /// Thickness of a finger along the closing axis (> 0).
    pub thickness: f64,
    /// Size of the pads along z = approach × closing (> 0).
    pub height: f64,
    /// Hand body (housing) size along the closing axis (> 0).
    pub palm_width: f64,
    /// Hand body size along z (> 0).
    pub palm_height: f64,
    /// Hand body size along the approach, behind the fingers (> 0).
    pub palm_depth: f64,
}

/// Extents (m) of a robot model's own collision geometry of a gripper in
/// the grasp frame (origin at the TCP, x approach, y closing, z = x × y),
/// over every opening from closed to open ([`Gripper::model_extents`]), in
/// the terms of the detector's boxes: fingers from the pads' inner faces
/// (± half the opening) outwards, a housing centred on the fingers behind
/// their base (x = -`fingers.depth`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandExtents {
    /// Largest reach of a finger link's geometry beyond its pad's inner
    /// face along the closing axis.
    pub thickness: f64,
    /// Twice the largest |z| of a finger link's geometry.
    pub height: f64,
    /// Twice the largest |y| of the hand's rigid geometry and of finger
    /// geometry reaching behind the fingers' base.
    pub palm_width: f64,
    /// Twice the largest |z| of the same.
    pub palm_height: f64,
    /// How far the same reaches behind the fingers' base.
    pub palm_depth: f64,
    /// How far finger geometry reaches beyond the TCP along the approach
    /// (>= 0; the detector's fingers end at the TCP).
    pub tip: f64,
    /// How far the hand's rigid geometry reaches in front of the fingers'
    /// base along the approach (>= 0; the detector's housing ends there).
    pub palm_front: f64,
}

/// A parallel-jaw gripper (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Gripper {
    /// Name (e.g. "panda_hand", "robotiq_2f85").
    pub name: String,
    /// The link the gripper is fixed to and the planner moves (the hand).
    pub hand_link: String,
    /// TCP position in the hand link frame: between the fingertips.
    pub tcp: Vector3<f64>,
    /// Approach direction (palm to fingertips) in the hand link frame.
    pub approach: Unit<Vector3<f64>>,
    /// Closing axis in the hand link frame (perpendicular to the approach).
    pub closing: Unit<Vector3<f64>>,
    /// The independent joint that drives the fingers.
    pub driver: String,
    /// Mimic joints that follow the driver (passive in simulation: the
    /// coupling moves them).
    pub followers: Vec<String>,
    /// Driver position with the fingers fully open.
    pub open_position: f64,
    /// Driver position with the fingers closed on nothing.
    pub closed_position: f64,
    /// Driver position to opening.
    pub map: OpeningMap,
    /// Finger geometry for grasp detection.
    pub fingers: FingerGeometry,
}

impl Gripper {
    /// The Franka hand as in the bundled Panda: `panda_hand`, TCP 0.1034 m
    /// along z (Franka's `panda_hand_tcp`), approach z, closing y, driver
    /// `panda_finger_joint1` (0 to 0.04 m) with `panda_finger_joint2` as its
    /// mimic; opening = 2 q (0 to 80 mm).
    pub fn panda_hand() -> Self {
        Self {
            name: "panda_hand".into(),
            hand_link: "panda_hand".into(),
            tcp: Vector3::new(0.0, 0.0, 0.1034),
            approach: Vector3::z_axis(),
            closing: Vector3::y_axis(),
            driver: "panda_finger_joint1".into(),
            followers: vec!["panda_finger_joint2".into()],
            open_position: 0.04,
            closed_position: 0.0,
            map: OpeningMap::Linear {
                scale: 2.0,
                offset: 0.0,
            },
            fingers: FingerGeometry {
                depth: 0.05,
                thickness: 0.01,
                height: 0.02,
                palm_width: 0.208,
                palm_height: 0.063,
                palm_depth: 0.092,
            },
        }
    }

    /// The Robotiq 2F-85 as in the bundled UR5e (`robotiq_85_base_link`):
    /// approach z, closing y, TCP 0.150 m along z; driver `finger_joint`
    /// (0 open, 0.8 rad closed) with five mimic followers; the four-bar map
    /// `2 (0.0049 + 0.05712 cos(q + 0.8523))`: 85 mm open, 0.5 mm at 0.8 rad.
    /// Pads 37.5 mm long, 22 mm wide, 7 mm thick; housing 90 x 65 x 60 mm.
    pub fn robotiq_2f85() -> Self {
        // Geometry of robots/ur5e_2f85.urdf (y, z in the gripper frame):
        // outer knuckle pivot (0.0306, 0.0549), knuckle vector at q = 0
        // (0.0376, 0.0430), pad inner face 0.0257 inside the distal pivot.
        let (pivot_y, vy, vz, pad) = (0.0306, 0.0376, 0.0430, 0.0257);
        Self {
            name: "robotiq_2f85".into(),
            hand_link: "robotiq_85_base_link".into(),
            tcp: Vector3::new(0.0, 0.0, 0.150),
            approach: Vector3::z_axis(),
            closing: Vector3::y_axis(),
            driver: "finger_joint".into(),
            followers: vec![
                "right_outer_knuckle_joint".into(),
                "left_inner_knuckle_joint".into(),
                "left_inner_finger_joint".into(),
                "right_inner_knuckle_joint".into(),
                "right_inner_finger_joint".into(),
            ],
            open_position: 0.0,
            closed_position: 0.8,
            map: OpeningMap::FourBar {
                offset: pivot_y - pad,
                radius: f64::hypot(vy, vz),
                phase: f64::atan2(vz, vy),
            },
            fingers: FingerGeometry {
                depth: 0.0375,
                thickness: 0.007,
                height: 0.022,
                palm_width: 0.09,
                palm_height: 0.065,
                palm_depth: 0.06,
            },
        }
    }

    /// Opening (m) at driver position `q`.
    pub fn opening(&self, q: f64) -> f64 {
        self.map.opening(q)
    }

    /// Largest opening (m): at the open position.
    pub fn max_opening(&self) -> f64 {
        self.opening(self.open_position)
    }

    /// Opening (m) when closed on nothing.
    pub fn min_opening(&self) -> f64 {
        self.opening(self.closed_position)
    }

    /// Driver position for `opening` (m), which must lie in
    /// `[min_opening, max_opening]`.
    pub fn driver_position(&self, opening: f64) -> Result<f64> {
        let (lo, hi) = (
            self.open_position.min(self.closed_position),
            self.open_position.max(self.closed_position),
        );
        if !opening.is_finite() {
            return Err(ModelError::InvalidArgument(format!(
                "gripper opening must be finite, got {opening}"
            )));
        }
        self.map.position(opening, lo, hi).ok_or_else(|| {
            ModelError::InvalidArgument(format!(
                "gripper opening {opening} m is outside '{}''s range [{:.4}, {:.4}] m",
                self.name,
                self.min_opening(),
                self.max_opening()
            ))
        })
    }

    /// The driver effort (N or N·m) that squeezes with `force` N per finger
    /// at driver position `q`, by virtual work over the two fingers each
    /// moving half the opening: `force · |d opening / d q| / 2` (for the
    /// Panda hand, `force` itself).
    pub fn driver_effort(&self, force: f64, q: f64) -> f64 {
        force * self.map.derivative(q).abs() / 2.0
    }

    /// The rotation whose columns are the grasp frame's axes (approach,
    /// closing, approach × closing) in the hand link frame.
    pub fn grasp_axes(&self) -> Rotation3<f64> {
        let (a, c) = (self.approach.into_inner(), self.closing.into_inner());
        Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[a, c, a.cross(&c)]))
    }

    /// Pose of the hand link in the grasp frame (origin at the TCP): a hand
    /// for a grasp at pose `G` (x approach, y closing, origin between the
    /// fingertips) is at `G * grasp_to_hand()`.
    pub fn grasp_to_hand(&self) -> Isometry3<f64> {
        let r = self.grasp_axes().inverse();
        let t = -(r * self.tcp);
        Isometry3::from_parts(
            Translation3::from(t),
            UnitQuaternion::from_rotation_matrix(&r),
        )
    }

    /// Checks the numbers: finite, axes perpendicular, positive dimensions,
    /// a valid monotone map, the opening larger when open (and > 0).
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| {
            Err(ModelError::InvalidArgument(format!(
                "gripper '{}': {m}",
                self.name
            )))
        };
        if self.tcp.iter().any(|v| !v.is_finite()) {
            return bad(format!("tcp must be finite, got {:?}", self.tcp.as_slice()));
        }
        if self.approach.dot(&self.closing).abs() > 1e-6 {
            return bad("approach and closing axes must be perpendicular".into());
        }
        if !(self.open_position.is_finite() && self.closed_position.is_finite())
            || self.open_position == self.closed_position
        {
            return bad(format!(
                "open and closed positions must be finite and differ, got {} and {}",
                self.open_position, self.closed_position
            ));
        }
        self.map.validate()?;
        let f = &self.fingers;
        for (what, v) in [
            ("finger depth", f.depth),
            ("finger thickness", f.thickness),
            ("finger height", f.height),
            ("palm width", f.palm_width),
            ("palm height", f.palm_height),
            ("palm depth", f.palm_depth),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{what} must be finite and > 0, got {v}"));
            }
        }
        let (wo, wc) = (self.max_opening(), self.min_opening());
        // The closed opening may be slightly negative: primitive finger
        // geometry that encloses the pads can overlap when closed.
        if !(wo > wc && wo > 0.0) {
            return bad(format!(
                "the opening must grow from closed to open and be > 0 when open: {wc} m closed, {wo} m open"
            ));
        }
        Ok(())
    }

    /// Checks that `model` has this gripper: the hand link, the driver as an
    /// independent joint within its limits' range, the followers as mimics
    /// of the driver.
    pub fn check_model(&self, model: &RobotModel) -> Result<()> {
        self.validate()?;
        model.link(&self.hand_link)?;
        let j = model.joint(&self.driver)?;
        let joint = &model.joints()[j];
        if !matches!(joint.coupling, JointCoupling::Dof(_)) {
            return Err(ModelError::InvalidArgument(format!(
                "gripper '{}': driver joint '{}' is not an independent joint",
                self.name, self.driver
            )));
        }
        let l = &joint.limits;
        for q in [self.open_position, self.closed_position] {
            if q < l.lower - 1e-9 || q > l.upper + 1e-9 {
                return Err(ModelError::InvalidArgument(format!(
                    "gripper '{}': driver position {q} outside joint '{}''s limits [{}, {}]",
                    self.name, self.driver, l.lower, l.upper
                )));
            }
        }
        let JointCoupling::Dof(dof) = joint.coupling else {
            unreachable!()
        };
        for f in &self.followers {
            let fj = &model.joints()[model.joint(f)?];
            if !matches!(fj.coupling, JointCoupling::Mimic { dof: d, .. } if d == dof) {
                return Err(ModelError::InvalidArgument(format!(
                    "gripper '{}': follower '{f}' is not a mimic of driver '{}'",
                    self.name, self.driver
                )));
            }
        }
        Ok(())
    }

    /// The gripper of `model`: a shipped instance when the model has its
    /// links and joints (Panda hand, Robotiq 2F-85), else one built from the
    /// SRDF's first `end_effector` ([`Self::from_end_effector`]). Its
    /// detection boxes are the description's; [`Self::covering`] grows them
    /// to the model's own collision geometry (not the default: with the
    /// bundled Panda's primitives it left the bin demo almost no grasps,
    /// BENCHMARKS.md, branch `hand18h`).
    pub fn from_model(model: &RobotModel) -> Result<Self> {
        for g in [Self::panda_hand(), Self::robotiq_2f85()] {
            if g.check_model(model).is_ok() {
                return Ok(g);
            }
        }
        Self::from_end_effector(model)
    }

    /// How far `model`'s own collision geometry of this gripper (the hand
    /// link and every link below it, the fingers at every opening from
    /// closed to open) reaches in the grasp frame, as the detector's box
    /// model needs it ([`HandExtents`]). Errors when `model` does not have
    /// this gripper ([`Self::check_model`]).
    pub fn model_extents(&self, model: &RobotModel) -> Result<HandExtents> {
        self.check_model(model)?;
        let hand = model.link(&self.hand_link)?;
        let dof = match model.joints()[model.joint(&self.driver)?].coupling {
            JointCoupling::Dof(d) => d,
            _ => unreachable!("check_model: the driver is independent"),
        };
        let to_grasp = self.grasp_to_hand();
        let links: Vec<usize> = subtree_links(model, hand);
        let mut q = model.neutral_configuration();
        // Link poses in the grasp frame with the driver at `x`.
        let mut poses_at = |x: f64| -> Result<Vec<Isometry3<f64>>> {
            q[dof] = x;
            let all = model.fk_all(&q)?;
            let inv = to_grasp * all[hand].inverse();
            Ok(all.iter().map(|p| inv * p).collect())
        };
        let (qo, qc) = (self.open_position, self.closed_position);
        let (po, pc) = (poses_at(qo)?, poses_at(qc)?);
        // A link the driver moves is a finger; one rigid with the hand is
        // part of the hand's body.
        let moves = |l: usize| {
            let d = po[l].inverse() * pc[l];
            d.translation.vector.norm() > 1e-9 || d.rotation.angle() > 1e-9
        };
        let (x, y, z) = (Vector3::x(), Vector3::y(), Vector3::z());
        let base = -self.fingers.depth;
        let mut e = HandExtents {
            thickness: 0.0,
            height: 0.0,
            palm_width: 0.0,
            palm_height: 0.0,
            palm_depth: 0.0,
            tip: f64::NEG_INFINITY,
            palm_front: f64::NEG_INFINITY,
        };
        // The openings are sampled; between two samples a finger point moves
        // along each axis at most `slack` (translation plus rotation times
        // the shape's reach; across, also the change of half the opening),
        // added to the finger extents so that they bound the whole range.
        let n = 129;
        let mut slack = Vector3::<f64>::zeros();
        let mut prev: Option<(Vec<Isometry3<f64>>, f64)> = None;
        for k in 0..n {
            let qk = qc + (qo - qc) * k as f64 / (n - 1) as f64;
            let poses = if k == n - 1 {
                po.clone()
            } else {
                poses_at(qk)?
            };
            let half = self.opening(qk) / 2.0;
            if let Some((pp, ph)) = &prev {
                for &l in &links {
                    for g in &model.links()[l].collisions {
                        let (a, b) = (pp[l] * g.origin, poses[l] * g.origin);
                        let r = [x, y, z, -x, -y, -z]
                            .iter()
                            .map(|d| support(&g.shape, &Isometry3::identity(), d))
                            .fold(0.0f64, |m, v| m.max(v.abs()))
                            * 3f64.sqrt();
                        let turn = (a.rotation.inverse() * b.rotation).angle() * r;
                        let step = (b.translation.vector - a.translation.vector).abs()
                            + Vector3::repeat(turn)
                            + Vector3::new(0.0, (half - ph).abs(), 0.0);
                        slack = slack.sup(&step);
                    }
                }
            }
            for &l in &links {
                let finger = moves(l);
                for g in &model.links()[l].collisions {
                    let p = poses[l] * g.origin;
                    let s = |d: &Vector3<f64>| support(&g.shape, &p, d);
                    let (x_lo, x_hi) = (-s(&-x), s(&x));
                    let (y_lo, y_hi) = (-s(&-y), s(&y));
                    let (z_lo, z_hi) = (-s(&-z), s(&z));
                    let z_abs = z_hi.max(-z_lo);
                    let y_abs = y_hi.max(-y_lo);
                    if finger {
                        // The side is that of the shape's centre at this
                        // opening; the finger box reaches from the inner
                        // face (half the opening) outwards.
                        let outer = if p.translation.y >= 0.0 { y_hi } else { -y_lo };
                        e.thickness = e.thickness.max(outer - half);
                        e.height = e.height.max(2.0 * z_abs);
                        e.tip = e.tip.max(x_hi);
                        if x_lo < base {
                            // Behind the fingers' base: the housing covers it.
                            e.palm_width = e.palm_width.max(2.0 * y_abs);
                            e.palm_height = e.palm_height.max(2.0 * z_abs);
                            e.palm_depth = e.palm_depth.max(base - x_lo);
                        }
                    } else {
                        e.palm_width = e.palm_width.max(2.0 * y_abs);
                        e.palm_height = e.palm_height.max(2.0 * z_abs);
                        e.palm_depth = e.palm_depth.max(base - x_lo);
                        e.palm_front = e.palm_front.max(x_hi - base);
                    }
                }
            }
            prev = Some((poses, half));
        }
        e.thickness += slack.y;
        e.height += 2.0 * slack.z;
        e.tip += slack.x;
        e.tip = e.tip.max(0.0);
        e.palm_front = e.palm_front.max(0.0);
        Ok(e)
    }

    /// This gripper with its finger and housing boxes grown to cover
    /// `model`'s own collision geometry of the hand and finger links
    /// ([`Self::model_extents`]): each of finger thickness, finger height,
    /// palm width, height and depth is the larger of this description's and
    /// the model's. What the planner and the simulator collide with is then
    /// what grasp detection keeps out of the cloud, walls and neighbours.
    /// The pad length (`fingers.depth`), TCP, axes and opening map are kept.
    pub fn covering(&self, model: &RobotModel) -> Result<Self> {
        let e = self.model_extents(model)?;
        let f = self.fingers;
        let mut g = self.clone();
        g.fingers = FingerGeometry {
            depth: f.depth,
            thickness: f.thickness.max(e.thickness),
            height: f.height.max(e.height),
            palm_width: f.palm_width.max(e.palm_width),
            palm_height: f.palm_height.max(e.palm_height),
            palm_depth: f.palm_depth.max(e.palm_depth),
        };
        g.validate()?;
        Ok(g)
    }

    /// A gripper built from the SRDF's first `end_effector`: its parent link
    /// is the hand; the driver is the one independent joint of the end
    /// effector's group (or, when the group has none, of the links below the
    /// hand); the followers are the driver's mimics. The finger links are
    /// the links below the hand that the driver moves and that have
    /// collision geometry; on each side of the closing axis the one reaching
    /// furthest along the approach is the pad. From their geometry at the open and closed
    /// positions: the closing axis (along which the fingers' inner faces
    /// approach each other), the approach (hand origin towards the fingers,
    /// made perpendicular), the opening map (33 samples of the gap between
    /// the inner faces; linear for a prismatic driver), the finger
    /// dimensions and the TCP (between the pads, 20% of the pad length
    /// inside the fingertips). The palm is the hand link's collision
    /// geometry. Errors name what is missing.
    pub fn from_end_effector(model: &RobotModel) -> Result<Self> {
        let srdf = model.srdf().ok_or_else(|| {
            ModelError::InvalidArgument(
                "no gripper found: the model has no SRDF end_effector; describe the gripper explicitly"
                    .into(),
            )
        })?;
        let ee = srdf.end_effectors.first().ok_or_else(|| {
            ModelError::InvalidArgument(
                "no gripper found: the SRDF has no end_effector; describe the gripper explicitly"
                    .into(),
            )
        })?;
        let hand = model.link(&ee.parent_link)?;
        let below = subtree_joints(model, hand);
        let mut dofs: Vec<usize> = model
            .group_joints(&ee.group)?
            .into_iter()
            .chain(below.iter().copied())
            .filter_map(|j| match model.joints()[j].coupling {
                JointCoupling::Dof(d) if below.contains(&j) => Some(d),
                _ => None,
            })
            .collect();
        dofs.sort_unstable();
        dofs.dedup();
        if dofs.len() != 1 {
            let names: Vec<&str> = dofs
                .iter()
                .map(|&d| model.dof_names()[d].as_str())
                .collect();
            return Err(ModelError::InvalidArgument(format!(
                "end effector '{}': expected one finger driver joint below '{}', found {:?}; describe the gripper explicitly",
                ee.name, ee.parent_link, names
            )));
        }
        let dof = dofs[0];
        let driver_joint = model.dof_joints()[dof];
        let followers: Vec<String> = model
            .joints()
            .iter()
            .filter(|j| matches!(j.coupling, JointCoupling::Mimic { dof: d, .. } if d == dof))
            .map(|j| j.name.clone())
            .collect();
        let moved: Vec<usize> = below
            .iter()
            .copied()
            .filter(|&j| model.joints()[j].coupling.driver().map(|(d, _)| d) == Some(dof))
            .collect();
        // Finger links: below a moved joint, with collision geometry.
        let mut fingers: Vec<usize> = Vec::new();
        for &j in &moved {
            for l in subtree_links(model, model.joints()[j].child) {
                if !model.links()[l].collisions.is_empty() && !fingers.contains(&l) {
                    fingers.push(l);
                }
            }
        }
        if fingers.len() < 2 {
            return Err(ModelError::InvalidArgument(format!(
                "end effector '{}': the driver '{}' moves {} link(s) with collision geometry, need two fingers",
                ee.name,
                model.joints()[driver_joint].name,
                fingers.len()
            )));
        }
        let limits = model.joints()[driver_joint].limits;
        let (lo, hi) = (limits.lower, limits.upper);
        if !(lo.is_finite() && hi.is_finite() && hi > lo) {
            return Err(ModelError::InvalidArgument(format!(
                "finger driver '{}' needs finite limits",
                model.joints()[driver_joint].name
            )));
        }
        let mut q = model.neutral_configuration();
        let poses_at = |x: f64, q: &mut Vec<f64>| -> Result<Vec<Isometry3<f64>>> {
            q[dof] = x;
            let all = model.fk_all(q)?;
            let inv = all[hand].inverse();
            Ok(all.iter().map(|p| inv * p).collect())
        };
        let geo_centres = |poses: &[Isometry3<f64>], l: usize| -> Vec<Vector3<f64>> {
            model.links()[l]
                .collisions
                .iter()
                .map(|g| (poses[l] * g.origin).translation.vector)
                .collect()
        };
        let (pa, pb) = (poses_at(lo, &mut q)?, poses_at(hi, &mut q)?);
        // Closing axis: the direction of the largest motion of a finger
        // geometry between the two limits, made perpendicular to the line
        // from the hand origin to the fingers.
        let mut motion = Vector3::zeros();
        let mut centre = Vector3::zeros();
        let mut count = 0.0;
        for &l in &fingers {
            for (a, b) in geo_centres(&pa, l).into_iter().zip(geo_centres(&pb, l)) {
                let m = b - a;
                let m = if motion.dot(&m) < 0.0 { -m } else { m };
                if m.norm() > motion.norm() {
                    motion = m;
                }
                centre += a + b;
                count += 2.0;
            }
        }
        centre /= count;
        if motion.norm() < 1e-6 || centre.norm() < 1e-6 {
            return Err(ModelError::InvalidArgument(format!(
                "end effector '{}': the finger links do not move or sit at the hand origin",
                ee.name
            )));
        }
        let approach = Unit::new_normalize(centre);
        let side = {
            let c = motion - approach.into_inner() * approach.dot(&motion);
            if c.norm() < 1e-6 {
                return Err(ModelError::InvalidArgument(format!(
                    "end effector '{}': the fingers move along the approach, not across it",
                    ee.name
                )));
            }
            c
        };
        // Orient the closing axis along the "+" finger: the finger link
        // whose geometry lies furthest along `side`.
        let closing = Unit::new_normalize(side);
        let (plus, minus): (Vec<usize>, Vec<usize>) = fingers.iter().partition(|&&l| {
            let c = geo_centres(&pa, l);
            c.iter().map(|p| (p - centre).dot(&closing)).sum::<f64>() > 0.0
        });
        if plus.is_empty() || minus.is_empty() {
            return Err(ModelError::InvalidArgument(format!(
                "end effector '{}': the finger links are all on one side of the closing axis",
                ee.name
            )));
        }
        // On each side, the pad is the link reaching furthest along the
        // approach (the fingertip); knuckles behind it do not touch objects.
        let tip = |links: &[usize]| -> Vec<usize> {
            let reach = |l: usize| {
                model.links()[l]
                    .collisions
                    .iter()
                    .map(|g| support(&g.shape, &(pa[l] * g.origin), &approach.into_inner()))
                    .fold(f64::NEG_INFINITY, f64::max)
            };
            let best = links
                .iter()
                .copied()
                .max_by(|&a, &b| reach(a).total_cmp(&reach(b)));
            best.into_iter().collect()
        };
        let (plus, minus) = (tip(&plus), tip(&minus));
        let gap = |poses: &[Isometry3<f64>]| -> f64 {
            let inner_plus = plus
                .iter()
                .flat_map(|&l| {
                    model.links()[l].collisions.iter().map(move |g| {
                        -support(&g.shape, &(poses[l] * g.origin), &-closing.into_inner())
                    })
                })
                .fold(f64::INFINITY, f64::min);
            let inner_minus = minus
                .iter()
                .flat_map(|&l| {
                    model.links()[l].collisions.iter().map(move |g| {
                        support(&g.shape, &(poses[l] * g.origin), &closing.into_inner())
                    })
                })
                .fold(f64::NEG_INFINITY, f64::max);
            inner_plus - inner_minus
        };
        let n = 33;
        let mut qs = Vec::with_capacity(n);
        let mut openings = Vec::with_capacity(n);
        for k in 0..n {
            let x = lo + (hi - lo) * k as f64 / (n - 1) as f64;
            qs.push(x);
            openings.push(gap(&poses_at(x, &mut q)?));
        }
        let (open_position, closed_position) = if openings[n - 1] > openings[0] {
            (hi, lo)
        } else {
            (lo, hi)
        };
        let widest = openings.iter().cloned().fold(0.0, f64::max);
        let map = if model.joints()[driver_joint].kind == JointKind::Prismatic {
            let scale = (openings[n - 1] - openings[0]) / (hi - lo);
            OpeningMap::Linear {
                scale,
                offset: openings[0] - scale * lo,
            }
        } else {
            OpeningMap::Table {
                q: qs,
                opening: openings,
            }
        };
        // Finger dimensions from the "+" finger at the open position, in the
        // grasp axes; the palm from the hand link's own geometry.
        let po = poses_at(open_position, &mut q)?;
        let binormal = approach.cross(&closing);
        let extent = |links: &[usize], poses: &[Isometry3<f64>], d: &Vector3<f64>| -> (f64, f64) {
            let mut lo = f64::INFINITY;
            let mut hi = f64::NEG_INFINITY;
            for &l in links {
                for g in &model.links()[l].collisions {
                    let p = poses[l] * g.origin;
                    hi = hi.max(support(&g.shape, &p, d));
                    lo = lo.min(-support(&g.shape, &p, &-d));
                }
            }
            (lo, hi)
        };
        let (a0, a1) = extent(&plus, &po, &approach.into_inner());
        let (c0, c1) = extent(&plus, &po, &closing.into_inner());
        let (b0, b1) = extent(&plus, &po, &binormal);
        let depth = (a1 - a0).max(1e-3);
        let (mid_plus, _) = extent(&plus, &po, &closing.into_inner());
        let (_, mid_minus) = extent(&minus, &po, &closing.into_inner());
        let mid = 0.5 * (mid_plus + mid_minus);
        let tcp_a = a1 - 0.2 * depth;
        let tcp =
            approach.into_inner() * tcp_a + closing.into_inner() * mid + binormal * 0.5 * (b0 + b1);
        let hand_links = [hand];
        let has_palm = !model.links()[hand].collisions.is_empty();
        let (pw, ph, pd) = if has_palm {
            let (c0, c1) = extent(&hand_links, &po, &closing.into_inner());
            let (b0, b1) = extent(&hand_links, &po, &binormal);
            let (a0, _) = extent(&hand_links, &po, &approach.into_inner());
            let base = a1 - depth;
            (c1 - c0, b1 - b0, (base - a0).max(1e-3))
        } else {
            (widest + 2.0 * (c1 - c0), b1 - b0, 0.02)
        };
        let g = Self {
            name: ee.name.clone(),
            hand_link: ee.parent_link.clone(),
            tcp,
            approach,
            closing,
            driver: model.joints()[driver_joint].name.clone(),
            followers,
            open_position,
            closed_position,
            map,
            fingers: FingerGeometry {
                depth,
                thickness: (c1 - c0).max(1e-3),
                height: (b1 - b0).max(1e-3),
                palm_width: pw.max(1e-3),
                palm_height: ph.max(1e-3),
                palm_depth: pd,
            },
        };
        g.validate()?;
        Ok(g)
    }
}

/// Joints below link `link` (its subtree), in model order.
fn subtree_joints(model: &RobotModel, link: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut todo = vec![link];
    while let Some(l) = todo.pop() {
        for &j in &model.links()[l].child_joints {
            out.push(j);
            todo.push(model.joints()[j].child);
        }
    }
    out.sort_unstable();
    out
}

/// `link` and the links below it.
fn subtree_links(model: &RobotModel, link: usize) -> Vec<usize> {
    let mut out = vec![link];
    let mut k = 0;
    while k < out.len() {
        for &j in &model.links()[out[k]].child_joints {
            out.push(model.joints()[j].child);
        }
        k += 1;
    }
    out
}

/// Largest `d · p` over the points `p` of `shape` placed at `pose` (`d` a
/// unit vector in the frame of `pose`).
fn support(shape: &Shape, pose: &Isometry3<f64>, d: &Vector3<f64>) -> f64 {
    let centre = pose.translation.vector.dot(d);
    let l = pose.rotation.inverse() * d;
    let ext = match shape {
        Shape::Box { half_extents: h } => h.x * l.x.abs() + h.y * l.y.abs() + h.z * l.z.abs(),
        Shape::Sphere { radius } => *radius,
        Shape::Cylinder {
            radius,
            half_height,
        } => radius * l.x.hypot(l.y) + half_height * l.z.abs(),
        Shape::Capsule {
            radius,
            half_height,
        } => radius + half_height * l.z.abs(),
        Shape::ConvexHull(h) => h
            .points()
            .iter()
            .map(|p| p.coords.dot(&l))
            .fold(f64::NEG_INFINITY, f64::max),
        Shape::Mesh(m) | Shape::ConvexDecomposition(m) => m
            .vertices()
            .map(|p| p.coords.dot(&l))
            .fold(f64::NEG_INFINITY, f64::max),
        Shape::PointCloud(_) => {
            let (lo, hi) = shape.local_aabb();
            let h = (hi - lo) / 2.0;
            let c = (hi.coords + lo.coords) / 2.0;
            c.dot(&l) + h.x * l.x.abs() + h.y * l.y.abs() + h.z * l.z.abs()
        }
    };
    centre + ext
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_grippers_match_the_bundled_models() {
        let panda = crate::robots::panda().unwrap();
        let ur = crate::robots::ur5e().unwrap();
        Gripper::panda_hand().check_model(&panda).unwrap();
        Gripper::robotiq_2f85().check_model(&ur).unwrap();
        assert_eq!(Gripper::from_model(&panda).unwrap().name, "panda_hand");
        assert_eq!(Gripper::from_model(&ur).unwrap().name, "robotiq_2f85");
        assert!(Gripper::robotiq_2f85().check_model(&panda).is_err());
    }

    /// Points on the surface of a primitive in its own frame, dense enough
    /// that their extremes along any axis are within 0.1 mm of the shape's.
    fn surface_samples(shape: &Shape) -> Vec<Vector3<f64>> {
        let ring = |r: f64, z: f64| {
            (0..512).map(move |k| {
                let t = k as f64 * std::f64::consts::TAU / 512.0;
                Vector3::new(r * t.cos(), r * t.sin(), z)
            })
        };
        match shape {
            Shape::Box { half_extents: h } => (0..8)
                .map(|k| {
                    Vector3::new(
                        if k & 1 == 0 { -h.x } else { h.x },
                        if k & 2 == 0 { -h.y } else { h.y },
                        if k & 4 == 0 { -h.z } else { h.z },
                    )
                })
                .collect(),
            Shape::Cylinder {
                radius,
                half_height,
            } => ring(*radius, *half_height)
                .chain(ring(*radius, -*half_height))
                .collect(),
            Shape::Capsule {
                radius,
                half_height,
            } => {
                // Both end spheres: rings at every latitude.
                let mut v = Vec::new();
                for c in [-*half_height, *half_height] {
                    for i in 0..=64 {
                        let phi =
                            -std::f64::consts::FRAC_PI_2 + i as f64 * std::f64::consts::PI / 64.0;
                        v.extend(ring(radius * phi.cos(), c + radius * phi.sin()));
                    }
                }
                v
            }
            other => panic!("no samples for {other:?}"),
        }
    }

    #[test]
    fn model_extents_bound_the_sampled_primitives_tightly() {
        // Reference: every primitive of the hand and the links below it,
        // sampled on its surface and placed by FK at 41 driver positions,
        // measured in the grasp frame; the extents must bound the samples
        // and be reached by them to 0.1 mm.
        for (m, g) in [
            (crate::robots::panda().unwrap(), Gripper::panda_hand()),
            (crate::robots::ur5e().unwrap(), Gripper::robotiq_2f85()),
        ] {
            let e = g.model_extents(&m).unwrap();
            let hand = m.link(&g.hand_link).unwrap();
            let dof = m.dof_names().iter().position(|n| *n == g.driver).unwrap();
            let links = subtree_links(&m, hand);
            let to_grasp = g.grasp_to_hand();
            let mut q = m.neutral_configuration();
            let rel = |q: &[f64]| {
                let all = m.fk_all(q).unwrap();
                let inv = to_grasp * all[hand].inverse();
                all.iter().map(|p| inv * p).collect::<Vec<_>>()
            };
            q[dof] = g.open_position;
            let open = rel(&q);
            q[dof] = g.closed_position;
            let closed = rel(&q);
            let base = -g.fingers.depth;
            let (mut thick, mut height, mut tip) = (0.0f64, 0.0f64, f64::NEG_INFINITY);
            let (mut pw, mut ph, mut pd, mut front) = (0.0f64, 0.0f64, 0.0f64, f64::NEG_INFINITY);
            for k in 0..=40 {
                let x = g.closed_position + (g.open_position - g.closed_position) * k as f64 / 40.0;
                q[dof] = x;
                let poses = rel(&q);
                let half = g.opening(x) / 2.0;
                for &l in &links {
                    let finger = (open[l].translation.vector - closed[l].translation.vector).norm()
                        > 1e-9
                        || (open[l].rotation.inverse() * closed[l].rotation).angle() > 1e-9;
                    for geo in &m.links()[l].collisions {
                        let p = poses[l] * geo.origin;
                        let pts: Vec<Vector3<f64>> = surface_samples(&geo.shape)
                            .iter()
                            .map(|v| p * nalgebra::Point3::from(*v))
                            .map(|v| v.coords)
                            .collect();
                        let max = |f: &dyn Fn(&Vector3<f64>) -> f64| {
                            pts.iter().map(f).fold(f64::NEG_INFINITY, f64::max)
                        };
                        let ya = max(&|v| v.y.abs());
                        let za = max(&|v| v.z.abs());
                        let x_lo = -max(&|v| -v.x);
                        if finger {
                            let outer = if p.translation.y >= 0.0 {
                                max(&|v| v.y)
                            } else {
                                max(&|v| -v.y)
                            };
                            thick = thick.max(outer - half);
                            height = height.max(2.0 * za);
                            tip = tip.max(max(&|v| v.x));
                            if x_lo < base {
                                pw = pw.max(2.0 * ya);
                                ph = ph.max(2.0 * za);
                                pd = pd.max(base - x_lo);
                            }
                        } else {
                            pw = pw.max(2.0 * ya);
                            ph = ph.max(2.0 * za);
                            pd = pd.max(base - x_lo);
                            front = front.max(max(&|v| v.x) - base);
                        }
                    }
                }
            }
            for (what, got, want) in [
                ("thickness", e.thickness, thick),
                ("height", e.height, height),
                ("tip", e.tip, tip.max(0.0)),
                ("palm width", e.palm_width, pw),
                ("palm height", e.palm_height, ph),
                ("palm depth", e.palm_depth, pd),
                ("palm front", e.palm_front, front.max(0.0)),
            ] {
                assert!(
                    got >= want - 1e-9 && got <= want + 1e-3,
                    "{}: {what} {got} vs sampled {want}",
                    g.name
                );
            }
            // Covering: the larger of the description and the model, again
            // the same; from_model gives the covered gripper.
            let c = g.covering(&m).unwrap();
            assert_eq!(c.fingers.thickness, g.fingers.thickness.max(e.thickness));
            assert_eq!(c.fingers.palm_width, g.fingers.palm_width.max(e.palm_width));
            assert_eq!(c.fingers.palm_depth, g.fingers.palm_depth.max(e.palm_depth));
            assert_eq!(c.fingers.depth, g.fingers.depth);
            assert_eq!(c.covering(&m).unwrap(), c);
            assert_eq!(Gripper::from_model(&m).unwrap(), g);
        }
        // A gripper the model does not have is refused.
        let ur = crate::robots::ur5e().unwrap();
        assert!(Gripper::panda_hand().model_extents(&ur).is_err());
    }

    #[test]
    fn four_bar_inverse_and_range() {
        let g = Gripper::robotiq_2f85();
        assert!(
            (g.max_opening() - 0.085).abs() < 2e-4,
            "{}",
            g.max_opening()
        );
        assert!(g.min_opening() >= 0.0 && g.min_opening() < 0.002);
        for w in [0.001, 0.02, 0.05, 0.084] {
            let q = g.driver_position(w).unwrap();
            assert!((g.opening(q) - w).abs() < 1e-12);
        }
        assert!(g.driver_position(0.09).is_err());
        assert!(g.driver_position(f64::NAN).is_err());
    }

    #[test]
    fn grasp_to_hand_puts_the_tcp_at_the_grasp_origin() {
        for g in [Gripper::panda_hand(), Gripper::robotiq_2f85()] {
            let h = g.grasp_to_hand();
            // The TCP (hand frame) maps to the grasp origin.
            let tcp = h * nalgebra::Point3::from(g.tcp);
            assert!(tcp.coords.norm() < 1e-12);
            // The hand's approach axis maps to grasp x, closing to grasp y.
            assert!((h.rotation * g.approach.into_inner() - Vector3::x()).norm() < 1e-12);
            assert!((h.rotation * g.closing.into_inner() - Vector3::y()).norm() < 1e-12);
        }
    }

    #[test]
    fn auto_built_grippers_agree_with_the_shipped_ones() {
        // Built from the SRDF end effector and the finger geometry alone.
        let panda = crate::robots::panda().unwrap();
        let auto = Gripper::from_end_effector(&panda).unwrap();
        let shipped = Gripper::panda_hand();
        assert_eq!(auto.driver, shipped.driver);
        assert_eq!(auto.followers, shipped.followers);
        assert!((auto.approach.dot(&shipped.approach) - 1.0).abs() < 1e-9);
        assert!(auto.closing.dot(&shipped.closing).abs() > 1.0 - 1e-9);
        for q in [0.0, 0.01, 0.04] {
            // The bundled fingers' pads are 2q apart plus the pad gap of the
            // primitive geometry.
            let d = auto.opening(q) - auto.opening(0.0);
            assert!((d - 2.0 * q).abs() < 1e-9, "{q}: {d}");
        }
        let ur = crate::robots::ur5e().unwrap();
        let auto = Gripper::from_end_effector(&ur).unwrap();
        let shipped = Gripper::robotiq_2f85();
        assert_eq!(auto.driver, "finger_joint");
        assert_eq!(auto.followers.len(), 5);
        for q in [0.0, 0.2, 0.4, 0.6, 0.8] {
            assert!(
                (auto.opening(q) - shipped.opening(q)).abs() < 1e-9,
                "{q}: {} vs {}",
                auto.opening(q),
                shipped.opening(q)
            );
        }
    }
}
