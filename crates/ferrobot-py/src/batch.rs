//! `ferrobot._core.step_worlds`: several worlds stepped together, in
//! parallel on rayon's pool, with the GIL released.

use std::sync::Arc;

use pyo3::prelude::*;
use rayon::prelude::*;

use ferrobot_sim::SimError;

use crate::errors::{InternalError, InvalidArgumentError, guard};
use crate::sim::{PyWorld, Shared, sim_err};

/// Advances each of `worlds` by `n` physics steps (holding each robot's
/// current drive targets), the worlds in parallel on all cores, the GIL
/// released. The worlds must be distinct objects. Every world is stepped
/// even when one fails; the first failure (in list order) is raised
/// afterwards (`SimulationDiverged` for a world that blew up).
#[pyfunction]
#[pyo3(signature = (worlds, n=1))]
pub fn step_worlds(py: Python<'_>, worlds: Vec<PyRef<'_, PyWorld>>, n: usize) -> PyResult<()> {
    let shared: Vec<Shared> = worlds.iter().map(|w| w.shared()).collect();
    for (i, a) in shared.iter().enumerate() {
        if let Some(j) = shared[..i].iter().position(|b| Arc::ptr_eq(a, b)) {
            return Err(InvalidArgumentError::new_err(format!(
                "worlds: entries {j} and {i} are the same world; each world may appear once"
            )));
        }
    }
    drop(worlds);
    guard(|| {
        let results: Vec<Option<Result<(), SimError>>> = py.detach(|| {
            shared
                .par_iter()
                .map(|w| w.lock().ok().map(|mut world| world.step(n)))
                .collect()
        });
        for r in results {
            match r {
                None => {
                    return Err(InternalError::new_err(
                        "a world's lock is poisoned by an earlier panic",
                    ));
                }
                Some(Err(e)) => return Err(sim_err(e)),
                Some(Ok(())) => {}
            }
        }
        Ok(())
    })
}
