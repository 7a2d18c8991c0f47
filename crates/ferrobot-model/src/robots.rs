//! Robots bundled with ferrobot, written by this project (no mesh files).

use crate::error::Result;
use crate::model::{LoadOptions, RobotModel, SrdfSource};

/// URDF of the bundled Franka Panda with its hand (primitive geometry).
pub const PANDA_URDF: &str = include_str!("../robots/panda.urdf");
/// SRDF of the bundled Panda: groups `panda_arm` and `hand`, named states.
pub const PANDA_SRDF: &str = include_str!("../robots/panda.srdf");

/// The bundled Panda: end effector `panda_hand`, SRDF loaded.
pub fn panda() -> Result<RobotModel> {
    RobotModel::from_urdf_str(
        PANDA_URDF,
        &LoadOptions {
            srdf: Some(SrdfSource::Text(PANDA_SRDF.to_string())),
            ee_link: Some("panda_hand".into()),
            ..Default::default()
        },
    )
}
