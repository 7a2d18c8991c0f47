//! Robots bundled with ferrobot, written by this project (no mesh files).

use crate::error::Result;
use crate::model::{LoadOptions, RobotModel, SrdfSource};

/// URDF of the bundled Franka Panda with its hand (primitive geometry).
pub const PANDA_URDF: &str = include_str!("../robots/panda.urdf");
/// SRDF of the bundled Panda: groups `panda_arm` and `hand`, named states.
pub const PANDA_SRDF: &str = include_str!("../robots/panda.srdf");
/// URDF of the bundled UR5e with a Robotiq 2F-85 (primitive geometry; the
/// gripper is one driver joint and five mimic followers).
pub const UR5E_URDF: &str = include_str!("../robots/ur5e_2f85.urdf");
/// SRDF of the bundled UR5e: groups `manipulator` and `gripper`, named
/// states, the gripper's end effector and its linkage's disabled pairs.
pub const UR5E_SRDF: &str = include_str!("../robots/ur5e_2f85.srdf");

/// Names of the bundled robots, for [`bundled`].
pub const BUNDLED: [&str; 2] = ["panda", "ur5e"];

/// (URDF, SRDF, end-effector link) of the bundled robot `name` (one of
/// [`BUNDLED`]), or `None`.
pub fn bundled(name: &str) -> Option<(&'static str, &'static str, &'static str)> {
    match name {
        "panda" => Some((PANDA_URDF, PANDA_SRDF, "panda_hand")),
        "ur5e" => Some((UR5E_URDF, UR5E_SRDF, "robotiq_85_base_link")),
        _ => None,
    }
}

fn load(name: &str) -> Result<RobotModel> {
    let (urdf, srdf, ee) = bundled(name).expect("a bundled robot");
    RobotModel::from_urdf_str(
        urdf,
        &LoadOptions {
            srdf: Some(SrdfSource::Text(srdf.to_string())),
            ee_link: Some(ee.into()),
            ..Default::default()
        },
    )
}

/// The bundled Panda: end effector `panda_hand`, SRDF loaded.
pub fn panda() -> Result<RobotModel> {
    load("panda")
}

/// The bundled UR5e + Robotiq 2F-85: end effector `robotiq_85_base_link`
/// (the gripper frame; its TCP is `robotiq_85_tcp`), SRDF loaded.
pub fn ur5e() -> Result<RobotModel> {
    load("ur5e")
}
