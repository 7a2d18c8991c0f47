//! `ferrobot._core.step_worlds` and `execute_trajectories`: several worlds
//! stepped together, in parallel on rayon's pool, with the GIL released.

use std::sync::Arc;

use pyo3::prelude::*;
use rayon::prelude::*;

use ferrobot_sim::{SimError, execute_trajectory};

use crate::arrays::read_array;
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
    let shared = distinct(&worlds)?;
    drop(worlds);
    guard(|| {
        let results: Vec<Option<Result<(), SimError>>> = py.detach(|| {
            shared
                .par_iter()
                .map(|w| w.lock().ok().map(|mut world| world.step(n)))
                .collect()
        });
        first_error(results)
    })
}

/// One deferred `Robot.execute_trajectory` call per world, run in
/// parallel on rayon's pool with the GIL released: world `i`'s robot
/// `robots[i]` tracks `positions[i]` (rows of `joint_indices[i]` sampled
/// every `dt` s, as `Robot.execute_trajectory(positions, dt,
/// joint_indices=...)` with no velocities and no settle time). The worlds
/// must be distinct; every world runs even when one fails, and the first
/// failure (in list order) is raised afterwards.
#[pyfunction]
pub fn execute_trajectories(
    py: Python<'_>,
    worlds: Vec<PyRef<'_, PyWorld>>,
    robots: Vec<String>,
    positions: Vec<Bound<'_, PyAny>>,
    dt: f64,
    joint_indices: Vec<Vec<usize>>,
) -> PyResult<()> {
    let n = worlds.len();
    if robots.len() != n || positions.len() != n || joint_indices.len() != n {
        return Err(InvalidArgumentError::new_err(format!(
            "execute_trajectories: {n} worlds but {} robots, {} positions, {} joint_indices",
            robots.len(),
            positions.len(),
            joint_indices.len()
        )));
    }
    let shared = distinct(&worlds)?;
    drop(worlds);
    let mut rows = Vec::with_capacity(n);
    for (p, ix) in positions.iter().zip(&joint_indices) {
        rows.push(
            read_array(p, "positions", 2, &[Some(ix.len())])?
                .data()
                .to_vec(),
        );
    }
    guard(|| {
        let jobs: Vec<_> = shared
            .iter()
            .zip(&robots)
            .zip(&rows)
            .zip(&joint_indices)
            .collect();
        let results: Vec<Option<Result<(), SimError>>> = py.detach(|| {
            jobs.par_iter()
                .map(|(((w, name), p), ix)| {
                    w.lock().ok().map(|mut world| {
                        let index = world.robot_index(name)?;
                        execute_trajectory(&mut world, index, p, dt, None, Some(ix), 0.0)
                            .map(|_| ())
                    })
                })
                .collect()
        });
        first_error(results)
    })
}

/// The worlds' shared handles, or an error naming two entries that are the
/// same world.
fn distinct(worlds: &[PyRef<'_, PyWorld>]) -> PyResult<Vec<Shared>> {
    let shared: Vec<Shared> = worlds.iter().map(|w| w.shared()).collect();
    for (i, a) in shared.iter().enumerate() {
        if let Some(j) = shared[..i].iter().position(|b| Arc::ptr_eq(a, b)) {
            return Err(InvalidArgumentError::new_err(format!(
                "worlds: entries {j} and {i} are the same world; each world may appear once"
            )));
        }
    }
    Ok(shared)
}

/// The first failure of per-world results (`None`: a poisoned lock).
fn first_error(results: Vec<Option<Result<(), SimError>>>) -> PyResult<()> {
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
}
