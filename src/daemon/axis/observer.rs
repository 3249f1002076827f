//! The axis' disturbance observer as one part: the observer of `[axis.observer]` and what it
//! said in the last cycle. Built once from its section, stepped in the observer stage; it hands
//! over and restores the `x4` bands it learned.

use super::super::config::AxisConfig;
use super::unvalidated;
use crate::control::ControllerError;
use crate::supervise::{DisturbanceObserver, ObserverOutput};

pub struct Observer {
    observer: Option<DisturbanceObserver>,
    out: ObserverOutput,
}

impl Observer {
    /// The part `[axis.observer]` asks for (empty without the section).
    pub fn new(cfg: &AxisConfig, period_s: f64) -> Result<Self, ControllerError> {
        let observer = cfg
            .observer_config(period_s)
            .map(DisturbanceObserver::new)
            .transpose()
            .map_err(unvalidated)?;
        Ok(Self {
            observer,
            out: ObserverOutput {
                x4_pos: f64::NAN,
                x4_neg: f64::NAN,
                ..Default::default()
            },
        })
    }

    /// This cycle's position with the command applied during the period that led to it.
    pub fn step(&mut self, position: f64, command: f64) {
        if let Some(o) = self.observer.as_mut() {
            self.out = o.step(position, command);
        }
    }

    /// What the observer said in the last cycle (`x4` NaN until a direction has been seen).
    pub fn output(&self) -> &ObserverOutput {
        &self.out
    }

    /// The learned nominal `x4` bands per direction, once learned.
    pub fn bands(&self) -> Option<[(f64, f64); 2]> {
        self.observer.as_ref().and_then(DisturbanceObserver::bands)
    }

    /// Start from bands learned before; nothing without an observer.
    pub fn restore_bands(&mut self, bands: [(f64, f64); 2]) {
        if let Some(o) = self.observer.as_mut() {
            o.restore_bands(bands);
        }
    }
}
