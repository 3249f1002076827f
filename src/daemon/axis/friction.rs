//! The axis' friction compensation as one part: the feed-forward `U_comp = α F_C± / K sign(e)`
//! or its adaptive form with a reference model, the adapted values stored by operating point,
//! the dither, and the arrival relief of the controller's integral. Built once from `[axis.friction_compensation]`, `[axis.adaptive_friction]`,
//! `[axis.learned_table]` and `[axis.dither]`, stepped in the control stage, and able to hand
//! over and restore what it learned.

use super::super::config::AxisConfig;
use super::super::learned::OperatingPointMemory;
use crate::control::{
    AdaptiveFriction, ArrivalRelief, Dither, FrictionFeedForward, LearnedTable, OperatingPoint,
    ParamError,
};

pub struct FrictionCompensation {
    feed_forward: Option<FrictionFeedForward>,
    adaptive: Option<AdaptiveFriction>,
    operating_points: Option<OperatingPointMemory>,
    dither: Option<Dither>,
    arrival: Option<ArrivalRelief>,
    /// What was added to the command in the last cycle, command unit.
    applied: f64,
    applied_dither: f64,
}

impl FrictionCompensation {
    /// The part an axis configuration asks for (empty when it asks for none of it).
    pub fn new(cfg: &AxisConfig, period_s: f64) -> Result<Self, ParamError> {
        let feed_forward = cfg.friction_compensation.as_ref().map(|f| f.feed_forward());
        let adaptive = cfg
            .adaptive_friction_config(period_s)
            .map(AdaptiveFriction::new)
            .transpose()?;
        let operating_points = cfg
            .learned_table_config(period_s)
            .map(|(c, every)| LearnedTable::new(c).map(|t| OperatingPointMemory::new(t, every)))
            .transpose()?;
        let dither = cfg
            .dither
            .as_ref()
            .map(|d| Dither::new(d.config(period_s)))
            .transpose()?;
        let arrival = cfg
            .friction_compensation
            .as_ref()
            .and_then(|f| f.arrival_relief(period_s))
            .map(ArrivalRelief::new)
            .transpose()?;
        Ok(Self {
            feed_forward,
            adaptive,
            operating_points,
            dither,
            arrival,
            applied: 0.0,
            applied_dither: 0.0,
        })
    }

    /// One control cycle with the reference `r`, the position `y`, the error the controller sees,
    /// the supply (for the operating point) and the supply schedule's gain factor:
    /// `(U_comp, u_d)` to add to the command.
    pub fn step(
        &mut self,
        reference: f64,
        position: f64,
        error: f64,
        supply: f64,
        gain_factor: f64,
    ) -> (f64, f64) {
        if let (Some(m), Some(a)) = (self.operating_points.as_mut(), self.adaptive.as_mut()) {
            let op = OperatingPoint {
                position_m: position,
                load_n: 0.0,
                supply,
            };
            m.step(&op, a);
        }
        let compensation = match (self.adaptive.as_mut(), self.feed_forward) {
            (Some(a), _) => a.step(reference, position).compensation,
            (None, Some(f)) => f.compensation(error),
            (None, None) => 0.0,
        };
        let dither = self
            .dither
            .as_mut()
            .map_or(0.0, |d| d.step(reference, position));
        // U_comp± and the dither are forces in command units at the nominal supply: a lower
        // supply needs the command scaled as the controller's gains are, or the compensation
        // falls short of the same friction.
        self.applied = gain_factor * compensation;
        self.applied_dither = gain_factor * dither;
        (self.applied, self.applied_dither)
    }

    /// The arrival relief of this cycle for the set-point `w` (the target, not the rate-limited
    /// reference: a ramp would look like a new set-point every cycle): what to take out of the
    /// controller's stored output, 0 without a relief configured.
    pub fn arrival_relief(&mut self, setpoint: f64, position: f64) -> f64 {
        self.arrival
            .as_mut()
            .map_or(0.0, |a| a.step(setpoint, position).relief)
    }

    /// A cycle in which the command does not come from this part (fail-safe).
    pub fn idle(&mut self) {
        self.applied = 0.0;
        self.applied_dither = 0.0;
    }

    /// A cycle in which another control law makes the command and adds no compensation.
    pub fn no_compensation(&mut self) {
        self.applied = 0.0;
    }

    /// `(U_comp, u_d)` added in the last cycle.
    pub fn applied(&self) -> (f64, f64) {
        (self.applied, self.applied_dither)
    }

    /// `(U_comp+, U_comp-)` in use: adapted, or the feed-forward values.
    pub fn levels(&self) -> (f64, f64) {
        match (&self.adaptive, self.feed_forward) {
            (Some(a), _) => a.compensation_values(),
            (None, Some(f)) => (f.compensation(1.0), -f.compensation(-1.0)),
            (None, None) => (0.0, 0.0),
        }
    }

    /// The adapted `(U_comp+, U_comp-)`, when the compensation adapts.
    pub fn learned(&self) -> Option<(f64, f64)> {
        self.adaptive
            .as_ref()
            .map(AdaptiveFriction::compensation_values)
    }

    /// Start the adaptation from values learned before.
    pub fn restore(&mut self, levels: (f64, f64)) {
        if let Some(a) = self.adaptive.as_mut() {
            a.set_compensation_values(levels.0, levels.1);
        }
    }

    /// Carry over what the part it replaces learned (a reload).
    pub fn continue_from(&mut self, old: &Self) {
        if let Some(levels) = old.learned() {
            self.restore(levels);
        }
        if let (Some(new), Some(old)) = (self.arrival.as_mut(), &old.arrival) {
            let (pos, neg) = old.levels();
            new.set_levels(pos, neg);
        }
        if let (Some(new), Some(old)) = (self.operating_points.as_mut(), &old.operating_points) {
            new.restore(old.table());
        }
    }

    /// The learned table of tuned parameters by operating point, when configured.
    pub fn learned_table(&self) -> Option<&LearnedTable> {
        self.operating_points.as_ref().map(|m| m.table())
    }

    /// Take a stored learned table; false when there is none or it has another grid.
    pub fn restore_learned_table(&mut self, table: &LearnedTable) -> bool {
        self.operating_points
            .as_mut()
            .is_some_and(|m| m.restore(table))
    }

    /// After a fault reset the reference model restarts from where the axis rests; what was
    /// learned stays.
    pub fn reset_model(&mut self) {
        if let Some(a) = self.adaptive.as_mut() {
            a.reset_model();
        }
        if let Some(a) = self.arrival.as_mut() {
            a.reset();
        }
    }
}
