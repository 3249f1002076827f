//! The axis' parameter estimation as one part: windows of moving samples, each one short test
//! whose physical parameters are compared with the nominal ones (configured, or learned from the
//! first windows), and the diagnosis by the fault-symptom table, confirmed over windows. Built
//! once from `[axis.parameter_estimation]`, stepped in the estimation stage; it hands over and
//! restores the nominal values it learned.

use super::super::config::AxisConfig;
use super::unvalidated;
use crate::control::ControllerError;
use crate::supervise::{
    diagnose, symptoms, DiagnosedFault, FaultSymptomTable, Nominal, NominalLearner,
    ParameterEstimator, PhysicalParameters, Symptom, SymptomThresholds, PHYSICAL_PARAMS,
};

/// Windowed parameter estimation in operation: each window of moving samples is one short test;
/// the first windows give the nominal parameters (and the spread of a window's estimate) unless
/// they are configured.
pub struct Estimation {
    estimator: ParameterEstimator,
    window_updates: u64,
    nominal: Option<Nominal>,
    learner: NominalLearner,
    nominal_windows: u32,
    thresholds: SymptomThresholds,
    table: FaultSymptomTable,
    max_distance: usize,
    confirm_windows: u32,
    candidate: Option<DiagnosedFault>,
    candidate_windows: u32,
    /// The diagnosis confirmed by `confirm_windows` windows in a row.
    present: Option<DiagnosedFault>,
    confidence: f64,
    symptoms: [Symptom; PHYSICAL_PARAMS],
    last: Option<PhysicalParameters>,
}

impl Estimation {
    /// The part `[axis.parameter_estimation]` asks for; `None` without the section.
    pub fn new(cfg: &AxisConfig, period_s: f64) -> Result<Option<Self>, ControllerError> {
        let Some(p) = &cfg.parameter_estimation else {
            return Ok(None);
        };
        Ok(Some(Self {
            estimator: ParameterEstimator::new(p.estimator_config(period_s))
                .map_err(unvalidated)?,
            window_updates: p.window_updates,
            nominal: p
                .nominal
                .map(|n| Nominal::exact(PhysicalParameters { values: n.values() })),
            learner: NominalLearner::default(),
            nominal_windows: p.nominal_windows.max(1),
            thresholds: p.symptom_thresholds(),
            table: p
                .load_fault_table()
                .map_err(|e| ControllerError::File(e.to_string()))?,
            max_distance: usize::from(p.max_distance),
            confirm_windows: p.confirm_windows.max(1),
            candidate: None,
            candidate_windows: 0,
            present: None,
            confidence: 1.0,
            symptoms: [Symptom::Zero; PHYSICAL_PARAMS],
            last: None,
        }))
    }

    /// This sample follows an arrival relief of the same set-point: it stays out of the window.
    pub fn exclude_disturbed(&mut self) {
        self.estimator.exclude_disturbed();
    }

    /// One moving sample into the window; at the window's end, its estimate against the
    /// nominal values (or into them while they are learned).
    pub fn step(&mut self, position: f64, command: f64) {
        self.estimator.step(position, command);
        if self.estimator.updates() < self.window_updates {
            return;
        }
        let estimate = self.estimator.physical_with_deviation();
        self.estimator.reset();
        // A window whose polynomial has no physical reading tells nothing: skip it.
        let Some(estimate) = estimate else { return };
        self.last = Some(estimate.p);
        let Some(nominal) = self.nominal else {
            self.learner.add(&estimate);
            if self.learner.count() >= self.nominal_windows {
                self.nominal = self.learner.nominal();
            }
            return;
        };
        self.symptoms = symptoms(&estimate, &nominal, &self.thresholds);
        let d = diagnose(&self.table, &self.symptoms, self.max_distance);
        if d.fault == self.candidate {
            self.candidate_windows = self.candidate_windows.saturating_add(1);
        } else {
            self.candidate = d.fault;
            self.candidate_windows = 1;
        }
        self.confidence = d.confidence;
        self.present = if self.candidate_windows >= self.confirm_windows {
            self.candidate
        } else {
            None
        };
    }

    /// The nominal parameters, configured, learned or restored; `None` while still learned.
    pub fn nominal(&self) -> Option<Nominal> {
        self.nominal
    }

    /// Start from nominal values learned before, unless some are configured (they win) or the
    /// stored ones are not all finite.
    pub fn restore_nominal(&mut self, nominal: Nominal) {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if self.nominal.is_none()
            && finite(&nominal.p.values)
            && finite(&nominal.deviation)
            && finite(&nominal.window_spread)
        {
            self.nominal = Some(nominal);
        }
    }

    /// The diagnosis confirmed by enough windows in a row.
    pub fn present(&self) -> Option<DiagnosedFault> {
        self.present
    }

    /// Confidence of the last window's diagnosis.
    pub fn confidence(&self) -> f64 {
        self.confidence
    }

    /// Symptoms of the last window compared with the nominal parameters.
    pub fn symptoms(&self) -> [Symptom; PHYSICAL_PARAMS] {
        self.symptoms
    }

    /// Physical parameters of the last usable window.
    pub fn last(&self) -> Option<PhysicalParameters> {
        self.last
    }
}
