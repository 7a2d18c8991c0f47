//! Scene sync bindings: a planner collision world from a simulated world
//! (`CollisionWorld.from_sim`, `Planner.update_world(sim_world, ...)`).

use ferrobot_collision::CollisionWorld;
use ferrobot_pipeline::{SyncOptions, collision_world_from_sim};
use pyo3::prelude::*;

use crate::arrays::read_pose;
use crate::collision::PyCollisionWorld;
use crate::errors::{InvalidArgumentError, collision_err};
use crate::sim::PyWorld;

/// Ignore substrings from Python: None, one string, or a list of strings.
pub fn ignore_list(ignore: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<String>> {
    let Some(obj) = ignore else {
        return Ok(Vec::new());
    };
    if let Ok(s) = obj.extract::<String>() {
        return Ok(vec![s]);
    }
    obj.extract::<Vec<String>>().map_err(|_| {
        InvalidArgumentError::new_err(format!(
            "ignore: expected a string or a list of strings, got {}",
            obj.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default()
        ))
    })
}

/// The collision world of a simulated world, or of a collision world
/// without the ignored objects. `extra` names (attached objects) are left
/// out by exact name.
pub fn world_from_any(
    world: &Bound<'_, PyAny>,
    ignore: Vec<String>,
    base_pose: Option<&Bound<'_, PyAny>>,
    extra: &[String],
) -> PyResult<CollisionWorld> {
    if let Ok(sim) = world.cast::<PyWorld>() {
        let base = match base_pose {
            Some(p) => read_pose(p, "base_pose")?,
            None => nalgebra::Isometry3::identity(),
        };
        let opts = SyncOptions { ignore, base };
        let shared = sim.borrow().shared();
        let mut out = {
            let w = crate::sim::lock(&shared)?;
            collision_world_from_sim(&w, &opts).map_err(collision_err)?
        };
        for name in extra {
            if out.contains(name) {
                out.remove(name).map_err(collision_err)?;
            }
        }
        return Ok(out);
    }
    if let Ok(cw) = world.cast::<PyCollisionWorld>() {
        if base_pose.is_some() {
            return Err(InvalidArgumentError::new_err(
                "base_pose applies to a simulated ferrobot.World; a CollisionWorld is already in the planner's base frame",
            ));
        }
        let opts = SyncOptions {
            ignore,
            ..Default::default()
        };
        let mut out = cw.borrow().inner.clone();
        let drop_names: Vec<String> = out
            .objects()
            .iter()
            .map(|o| o.name.clone())
            .filter(|n| opts.ignores(n) || extra.contains(n))
            .collect();
        for n in drop_names {
            out.remove(&n).map_err(collision_err)?;
        }
        return Ok(out);
    }
    Err(InvalidArgumentError::new_err(format!(
        "world: expected a ferrobot.CollisionWorld or a simulated ferrobot.World, got {}",
        world
            .get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_default()
    )))
}
