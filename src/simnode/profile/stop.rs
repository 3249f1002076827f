//! How the simulated drive stops on its own ramp: the command "quick stop" (quick stop option
//! code 605Ah picks the ramp, quick stop deceleration 6085h or profile deceleration 6084h) and
//! the halt (controlword bit 8, on 6084h). The drive follows a velocity reference that falls to
//! zero at the ramp's deceleration and the position it integrates to, so it comes to rest and
//! then holds where the ramp ended.

/// The quick stop option codes the simulated drive has (CiA 402 §6.3.3): 1 and 2 stop on the
/// profile or the quick stop deceleration and then switch the power stage off ("switch on
/// disabled"), 5 and 6 stop the same ways and hold in "quick stop active". A write of another
/// code is refused with SDO abort 0609 0030h.
pub const QUICK_STOP_OPTIONS: [i16; 4] = [1, 2, 5, 6];

/// Below this speed the axis counts as standing still, m/s (rad/s): a few counts of 606Ch.
pub const STANDSTILL_M_PER_S: f64 = 1e-3;

/// The option code stops on the quick stop deceleration 6085h (else on 6084h).
pub fn on_quick_stop_deceleration(option: i16) -> bool {
    matches!(option, 2 | 6)
}

/// The reference of a stop: a velocity ramped to zero and the position it leads to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopRamp {
    pub velocity_m_per_s: f64,
    pub position_m: f64,
}

impl StopRamp {
    /// A ramp from where the axis is and how fast it moves, so the stop starts without a step.
    pub fn new(position_m: f64, velocity_m_per_s: f64) -> Self {
        Self {
            velocity_m_per_s,
            position_m,
        }
    }

    /// One drive period at `deceleration` (m/s², at most 0 means at once).
    pub fn step(&mut self, deceleration_m_per_s2: f64, dt: f64) {
        let v0 = self.velocity_m_per_s;
        let dv = deceleration_m_per_s2 * dt;
        // v(k+1) = v(k) - sgn(v) min(|v|, a T): toward zero without crossing it.
        self.velocity_m_per_s = if dv > 0.0 {
            v0 - v0.signum() * v0.abs().min(dv)
        } else {
            0.0
        };
        // x(k+1) = x(k) + T (v(k) + v(k+1)) / 2: the position of the trapezoid.
        self.position_m += 0.5 * (v0 + self.velocity_m_per_s) * dt;
    }

    /// The reference has come to rest.
    pub fn stopped(&self) -> bool {
        self.velocity_m_per_s == 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ramp_falls_at_its_deceleration_and_rests_where_the_braking_distance_ends() {
        let mut r = StopRamp::new(0.01, -0.1);
        let mut steps = 0;
        while !r.stopped() {
            r.step(2.0, 0.001);
            steps += 1;
        }
        // 0.1 m/s at 2 m/s²: 50 ms, v²/(2a) = 2.5 mm.
        assert_eq!(steps, 50);
        assert!(
            (r.position_m - (0.01 - 0.0025)).abs() < 1e-9,
            "{}",
            r.position_m
        );
        r.step(2.0, 0.001);
        assert_eq!(r.velocity_m_per_s, 0.0);
        let mut at_once = StopRamp::new(0.0, 1.0);
        at_once.step(0.0, 0.001);
        assert!(at_once.stopped());
    }

    #[test]
    fn option_codes_pick_their_ramp() {
        assert!(on_quick_stop_deceleration(2) && on_quick_stop_deceleration(6));
        assert!(!on_quick_stop_deceleration(1) && !on_quick_stop_deceleration(5));
    }
}
