//! The axis' linear controller: the general discrete transfer function, or a state-space
//! controller from a design file (e.g. the H-infinity controller of `control::robust`).

use super::discrete::DiscreteController;
use super::robust::StateSpaceController;

/// Either form behind one interface: propose, commit what was applied, limits, restart.
#[derive(Debug, Clone)]
pub enum LinearController {
    Discrete(Box<DiscreteController>),
    StateSpace(Box<StateSpaceController>),
}

impl LinearController {
    /// The unlimited output for error `e`, without committing the step.
    pub fn propose(&self, e: f64) -> f64 {
        match self {
            LinearController::Discrete(c) => c.propose(e),
            LinearController::StateSpace(c) => c.propose(e),
        }
    }

    /// Commit the step with the output really applied (anti-windup where the form has one).
    pub fn commit(&mut self, e: f64, u_applied: f64) {
        match self {
            LinearController::Discrete(c) => c.commit(e, u_applied),
            LinearController::StateSpace(c) => c.commit(e, u_applied),
        }
    }

    /// Lower or raise the stored output by `du` (the arrival relief). The discrete form moves
    /// its output history, which for an integrating controller is its integral; a state-space
    /// controller has no such handle and is left as it is.
    pub fn shift_output(&mut self, du: f64) {
        if let LinearController::Discrete(c) = self {
            c.shift_output(du);
        }
    }

    pub fn limits(&self) -> (f64, f64) {
        match self {
            LinearController::Discrete(c) => c.limits(),
            LinearController::StateSpace(c) => c.limits(),
        }
    }

    /// Restart from output `u0` with zero error; a state-space controller restarts from rest.
    pub fn preset(&mut self, u0: f64) {
        match self {
            LinearController::Discrete(c) => c.preset(u0),
            LinearController::StateSpace(c) => c.reset(),
        }
    }
}
