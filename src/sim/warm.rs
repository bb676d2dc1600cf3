//! One MuJoCo harness kept running across the simulations of a session: `keypose sim` over
//! several files, the studio's Simulate pressed again. Python and MuJoCo start once (about a
//! third of a second, as long as a minute of physics takes); each simulation then only loads
//! its model and runs.
//!
//! A harness that died between or during simulations (killed, crashed) is started again once
//! and the simulation run again from its start; one that dies again is
//! [`SimError::DiedAgain`], so a harness that cannot run a model is not restarted forever.

use super::{MjcfModel, SimError, Simulation};
use crate::python::HarnessError;
use crate::robot::Robot;

/// The harness of a session's simulations, started on first use.
#[derive(Default)]
pub struct WarmSimulation {
    current: Option<Simulation>,
}

impl WarmSimulation {
    /// No harness yet: the first simulation starts it.
    pub fn new() -> WarmSimulation {
        WarmSimulation::default()
    }

    /// Runs `work` on `robot`'s model (or `mjcf`) loaded in the session's harness, which is
    /// started if none runs. If the harness has died (it exited while spoken to), it is
    /// started again and `work` runs again from the start; if it dies again, the error says
    /// both deaths.
    pub fn with_simulation<T>(
        &mut self,
        robot: &Robot,
        mjcf: Option<&MjcfModel>,
        mut work: impl FnMut(&mut Simulation) -> Result<T, SimError>,
    ) -> Result<T, SimError> {
        let first = match self.attempt(robot, mjcf, &mut work) {
            Err(SimError::Harness(died @ HarnessError::Exited { .. })) => died,
            other => return other,
        };
        match self.attempt(robot, mjcf, &mut work) {
            Err(SimError::Harness(second @ HarnessError::Exited { .. })) => {
                Err(SimError::DiedAgain {
                    first: first.to_string(),
                    second,
                })
            }
            other => other,
        }
    }

    /// One try: the model loaded in the running harness (or a new one), then `work`. The
    /// harness is kept unless the failure leaves it unusable.
    fn attempt<T>(
        &mut self,
        robot: &Robot,
        mjcf: Option<&MjcfModel>,
        work: &mut impl FnMut(&mut Simulation) -> Result<T, SimError>,
    ) -> Result<T, SimError> {
        let mut simulation = match self.current.take() {
            Some(mut simulation) => match simulation.load(robot, mjcf) {
                Ok(()) => simulation,
                Err(error) => return Err(self.keep_if_usable(simulation, error)),
            },
            None => Simulation::start(robot, mjcf, None)?,
        };
        match work(&mut simulation) {
            Ok(value) => {
                self.current = Some(simulation);
                Ok(value)
            }
            Err(error) => Err(self.keep_if_usable(simulation, error)),
        }
    }

    /// Keeps `simulation` for the next try when `error` left its harness answering requests as
    /// before (it refused one, or the failure was not the harness's); a harness that exited,
    /// fell silent or answered out of turn is dropped, which ends its process.
    fn keep_if_usable(&mut self, simulation: Simulation, error: SimError) -> SimError {
        let usable = match &error {
            SimError::Harness(HarnessError::Failed { .. })
            | SimError::Model { .. }
            | SimError::ServoProfile(_)
            | SimError::Env(_)
            | SimError::Render(_) => true,
            SimError::Harness(_)
            | SimError::Reply { .. }
            | SimError::TraceBytes(_)
            | SimError::DiedAgain { .. } => false,
        };
        if usable {
            self.current = Some(simulation);
        }
        error
    }
}
