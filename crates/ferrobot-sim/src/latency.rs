//! Command latency and command-stream faults: a buffer that delays
//! commands (issued at `t`, they take effect at `t + delay`), the two
//! compensations (linear extrapolation of a command stream; look-ahead in
//! a known trajectory), and a stream guard that holds on a dropout and
//! resumes without a jump.

use std::collections::VecDeque;

use crate::error::{Result, SimError, check_finite, check_len};

fn check_time(what: &str, t: f64) -> Result<()> {
    if t.is_finite() {
        Ok(())
    } else {
        Err(SimError::NonFinite(format!("{what}: non-finite time {t}")))
    }
}

/// Commands of a fixed width, delayed by a constant latency.
#[derive(Debug, Clone)]
pub struct CommandDelay {
    delay: f64,
    width: usize,
    queue: VecDeque<(f64, Vec<f64>)>,
    last_issue: f64,
}

impl CommandDelay {
    /// A buffer delaying commands of `width` values by `delay` seconds
    /// (finite, >= 0; 0 passes commands through).
    pub fn new(delay: f64, width: usize) -> Result<Self> {
        if !(delay.is_finite() && delay >= 0.0) {
            return Err(SimError::InvalidArgument(format!(
                "delay must be finite and >= 0 s, got {delay}"
            )));
        }
        if width == 0 {
            return Err(SimError::InvalidArgument("width must be >= 1".into()));
        }
        Ok(Self {
            delay,
            width,
            queue: VecDeque::new(),
            last_issue: f64::NEG_INFINITY,
        })
    }

    /// The latency (s).
    pub fn delay(&self) -> f64 {
        self.delay
    }

    /// Commands waiting.
    pub fn pending(&self) -> usize {
        self.queue.len()
    }

    /// Issues `command` at time `t` (times must not decrease).
    pub fn push(&mut self, t: f64, command: &[f64]) -> Result<()> {
        check_time("t", t)?;
        check_len("command", command, self.width)?;
        if t < self.last_issue {
            return Err(SimError::InvalidArgument(format!(
                "t: commands must be issued in time order ({t} < {})",
                self.last_issue
            )));
        }
        self.last_issue = t;
        self.queue.push_back((t + self.delay, command.to_vec()));
        Ok(())
    }

    /// The newest command that has taken effect by time `t` (issued at or
    /// before `t - delay`, up to 1e-9 s of rounding), removing it and every
    /// older one; `None` when none became due since the last call.
    pub fn pop_due(&mut self, t: f64) -> Result<Option<Vec<f64>>> {
        check_time("t", t)?;
        let mut out = None;
        while let Some((due, _)) = self.queue.front() {
            if *due <= t + 1e-9 {
                out = self.queue.pop_front().map(|(_, c)| c);
            } else {
                break;
            }
        }
        Ok(out)
    }

    /// Drops every pending command.
    pub fn clear(&mut self) {
        self.queue.clear();
        self.last_issue = f64::NEG_INFINITY;
    }
}

/// Linear extrapolation of a command stream by a horizon: from the last two
/// commands `c(t1)`, `c(t2)`, sends `c(t2) + horizon · (c(t2) − c(t1)) /
/// (t2 − t1)` (the first command is sent as is).
#[derive(Debug, Clone)]
pub struct LinearPredictor {
    horizon: f64,
    last: Option<(f64, Vec<f64>)>,
}

impl LinearPredictor {
    /// A predictor looking `horizon` seconds ahead (finite, >= 0).
    pub fn new(horizon: f64) -> Result<Self> {
        if !(horizon.is_finite() && horizon >= 0.0) {
            return Err(SimError::InvalidArgument(format!(
                "horizon must be finite and >= 0 s, got {horizon}"
            )));
        }
        Ok(Self {
            horizon,
            last: None,
        })
    }

    /// Feeds the command `c` issued at `t` (times strictly increasing) and
    /// returns the extrapolated command.
    pub fn update(&mut self, t: f64, c: &[f64]) -> Result<Vec<f64>> {
        check_time("t", t)?;
        check_finite("command", c)?;
        let out = match &self.last {
            Some((t1, c1)) => {
                check_len("command", c, c1.len())?;
                if t <= *t1 {
                    return Err(SimError::InvalidArgument(format!(
                        "t: times must increase ({t} <= {t1})"
                    )));
                }
                let s = self.horizon / (t - t1);
                c.iter().zip(c1).map(|(a, b)| a + s * (a - b)).collect()
            }
            None => c.to_vec(),
        };
        self.last = Some((t, c.to_vec()));
        Ok(out)
    }
}

/// The trajectory `positions` (`(N, n)` row-major, sampled every `dt`
/// from time 0) at time `t`, linearly interpolated; held at the ends.
/// Trajectory look-ahead sends `sample(t + delay)` at time `t`.
pub fn trajectory_sample(positions: &[f64], n: usize, dt: f64, t: f64) -> Result<Vec<f64>> {
    if n == 0 || positions.is_empty() || !positions.len().is_multiple_of(n) {
        return Err(SimError::Shape {
            what: "positions".into(),
            expected: format!("(N, {n}) with N >= 1"),
            got: format!("{} values", positions.len()),
        });
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(SimError::InvalidArgument(format!(
            "dt must be finite and > 0, got {dt}"
        )));
    }
    check_time("t", t)?;
    let rows = positions.len() / n;
    let s = (t / dt).clamp(0.0, (rows - 1) as f64);
    let i = (s.floor() as usize).min(rows - 1);
    let j = (i + 1).min(rows - 1);
    let f = s - i as f64;
    Ok((0..n)
        .map(|k| positions[i * n + k] * (1.0 - f) + positions[j * n + k] * f)
        .collect())
}

/// What a [`StreamGuard`] did at one control tick.
#[derive(Debug, Clone, PartialEq)]
pub struct GuardOutput {
    /// The command to apply.
    pub command: Vec<f64>,
    /// True while holding (no fresh command within the timeout): the
    /// command is the last one applied, and velocity targets should be 0.
    pub holding: bool,
    /// True while catching up with the stream after a hold (the command is
    /// rate-limited and differs from the stream's).
    pub catching_up: bool,
    /// Largest |change| of the command from the previous tick.
    pub step: f64,
}

/// Watches a command stream: when no command arrives for `timeout`
/// seconds it holds the last applied command; every output moves at most
/// `max_velocity · dt` per joint from the previous one, so the stream
/// resumes without a jump (the guard catches up at that rate).
#[derive(Debug, Clone)]
pub struct StreamGuard {
    timeout: f64,
    max_velocity: Vec<f64>,
    last_output: Option<Vec<f64>>,
    target: Option<Vec<f64>>,
    last_rx: f64,
    last_t: f64,
}

impl StreamGuard {
    /// A guard with `timeout` (s, > 0) and per-joint `max_velocity` (> 0).
    pub fn new(timeout: f64, max_velocity: &[f64]) -> Result<Self> {
        if !(timeout.is_finite() && timeout > 0.0) {
            return Err(SimError::InvalidArgument(format!(
                "timeout must be finite and > 0 s, got {timeout}"
            )));
        }
        if max_velocity.is_empty() {
            return Err(SimError::InvalidArgument(
                "max_velocity: at least one joint".into(),
            ));
        }
        if let Some(v) = max_velocity.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
            return Err(SimError::InvalidArgument(format!(
                "max_velocity must be finite and > 0, got {v}"
            )));
        }
        Ok(Self {
            timeout,
            max_velocity: max_velocity.to_vec(),
            last_output: None,
            target: None,
            last_rx: f64::NEG_INFINITY,
            last_t: f64::NEG_INFINITY,
        })
    }

    /// One control tick at time `t` (increasing), with the command that
    /// arrived since the last tick, if any. `current` is the measured
    /// position, used only before any command was applied.
    pub fn update(
        &mut self,
        t: f64,
        incoming: Option<&[f64]>,
        current: &[f64],
    ) -> Result<GuardOutput> {
        check_time("t", t)?;
        let n = self.max_velocity.len();
        check_len("current", current, n)?;
        if t <= self.last_t {
            return Err(SimError::InvalidArgument(format!(
                "t: ticks must increase ({t} <= {})",
                self.last_t
            )));
        }
        let dt = if self.last_t.is_finite() {
            t - self.last_t
        } else {
            0.0
        };
        self.last_t = t;
        if let Some(c) = incoming {
            check_len("command", c, n)?;
            self.target = Some(c.to_vec());
            self.last_rx = t;
        }
        let prev = self.last_output.clone().unwrap_or_else(|| current.to_vec());
        let holding = t - self.last_rx > self.timeout || self.target.is_none();
        let goal = if holding {
            prev.clone()
        } else {
            self.target.clone().expect("target set")
        };
        let first = self.last_output.is_none();
        let command: Vec<f64> = goal
            .iter()
            .zip(&prev)
            .zip(&self.max_velocity)
            .map(|((g, p), v)| {
                if first {
                    *g
                } else {
                    p + (g - p).clamp(-v * dt, v * dt)
                }
            })
            .collect();
        let step = if first {
            0.0
        } else {
            command
                .iter()
                .zip(&prev)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        };
        let catching_up = !holding
            && command
                .iter()
                .zip(&goal)
                .any(|(a, b)| (a - b).abs() > 1e-12);
        self.last_output = Some(command.clone());
        Ok(GuardOutput {
            command,
            holding,
            catching_up,
            step,
        })
    }
}

/// Which drive input a delayed command sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandKind {
    /// Drive position targets.
    Position,
    /// Drive velocity targets.
    Velocity,
    /// Joint efforts.
    Effort,
}

/// A robot's command latency: drive targets and efforts set on a
/// [`crate::robot::Robot`] at world time `t` take effect at the first step
/// starting at or after `t + delay` (a real arm's command path: network,
/// controller cycle). Owned by the robot and applied by
/// [`crate::world::World::step`]; 0 (the default) applies commands at once.
#[derive(Debug, Clone, Default)]
pub struct RobotLatency {
    delay: f64,
    /// World time of the robot's clock (updated by the world).
    pub(crate) clock: f64,
    queue: VecDeque<(f64, CommandKind, Vec<usize>, Vec<f64>)>,
}

impl RobotLatency {
    /// The delay (s).
    pub fn delay(&self) -> f64 {
        self.delay
    }

    /// Sets the delay (finite, in [0, 10] s). Commands already waiting keep
    /// their due times.
    pub fn set_delay(&mut self, delay: f64) -> Result<()> {
        if !(delay.is_finite() && (0.0..=10.0).contains(&delay)) {
            return Err(SimError::InvalidArgument(format!(
                "command latency must be finite and in [0, 10] s, got {delay}"
            )));
        }
        self.delay = delay;
        Ok(())
    }

    /// Commands waiting.
    pub fn pending(&self) -> usize {
        self.queue.len()
    }

    /// Queues a command (already validated) if there is a delay; gives it
    /// back when it must be applied at once.
    pub(crate) fn defer(
        &mut self,
        kind: CommandKind,
        indices: Vec<usize>,
        values: Vec<f64>,
    ) -> Option<(Vec<usize>, Vec<f64>)> {
        if self.delay > 0.0 || !self.queue.is_empty() {
            self.queue
                .push_back((self.clock + self.delay, kind, indices, values));
            None
        } else {
            Some((indices, values))
        }
    }

    /// Removes and returns, in issue order, the commands due at time `t`
    /// (up to 1e-9 s of rounding).
    pub(crate) fn due(&mut self, t: f64) -> Vec<(CommandKind, Vec<usize>, Vec<f64>)> {
        let mut out = Vec::new();
        while let Some((due, ..)) = self.queue.front() {
            if *due <= t + 1e-9 {
                let (_, k, i, v) = self.queue.pop_front().expect("front exists");
                out.push((k, i, v));
            } else {
                break;
            }
        }
        out
    }

    /// Drops every waiting command.
    pub fn clear(&mut self) {
        self.queue.clear();
    }
}

/// Look-ahead for a known trajectory under a robot's latency: the command
/// to issue at `t` is the trajectory's sample at `t + delay`, so it takes
/// effect when the plan wants it ([`trajectory_sample`]).
pub fn lookahead_sample(
    positions: &[f64],
    n: usize,
    dt: f64,
    t: f64,
    latency: &RobotLatency,
) -> Result<Vec<f64>> {
    trajectory_sample(positions, n, dt, t + latency.delay())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delay_releases_at_t_plus_delay() {
        let mut d = CommandDelay::new(0.05, 1).unwrap();
        d.push(0.0, &[1.0]).unwrap();
        d.push(0.01, &[2.0]).unwrap();
        assert_eq!(d.pop_due(0.04).unwrap(), None);
        assert_eq!(d.pop_due(0.05).unwrap(), Some(vec![1.0]));
        assert_eq!(d.pop_due(0.1).unwrap(), Some(vec![2.0]));
    }

    #[test]
    fn robot_latency_defers_in_order() {
        let mut l = RobotLatency::default();
        assert!(l.defer(CommandKind::Position, vec![0], vec![1.0]).is_some());
        l.set_delay(0.05).unwrap();
        assert!(l.set_delay(f64::NAN).is_err());
        l.clock = 0.0;
        assert!(l.defer(CommandKind::Position, vec![0], vec![1.0]).is_none());
        l.clock = 0.01;
        assert!(l.defer(CommandKind::Velocity, vec![0], vec![2.0]).is_none());
        assert!(l.due(0.04).is_empty());
        assert_eq!(l.due(0.05).len(), 1);
        assert_eq!(l.due(0.06)[0].0, CommandKind::Velocity);
        assert_eq!(l.pending(), 0);
    }

    #[test]
    fn guard_rate_limits_after_hold() {
        let mut g = StreamGuard::new(0.05, &[1.0]).unwrap();
        let out = g.update(0.0, Some(&[0.0]), &[0.0]).unwrap();
        assert_eq!(out.command, vec![0.0]);
        let out = g.update(0.2, None, &[0.0]).unwrap();
        assert!(out.holding);
        let out = g.update(0.21, Some(&[1.0]), &[0.0]).unwrap();
        assert!((out.command[0] - 0.01).abs() < 1e-12 && out.catching_up);
    }
}
