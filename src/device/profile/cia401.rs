//! CiA 401 generic I/O modules: the object numbers and default PDO assignment of analog inputs
//! and outputs, and the scaling from raw 16-bit values to SI units.

/// Digital inputs, 8 bits per subindex (UNSIGNED8).
pub const DIGITAL_INPUTS_8: u16 = 0x6000;
/// Digital outputs, 8 bits per subindex (UNSIGNED8).
pub const DIGITAL_OUTPUTS_8: u16 = 0x6200;
/// Analog inputs, 16 bits per channel (INTEGER16), subindex = channel.
pub const ANALOG_INPUTS_16: u16 = 0x6401;
/// Analog outputs, 16 bits per channel (INTEGER16), subindex = channel.
pub const ANALOG_OUTPUTS_16: u16 = 0x6411;
/// Analog input global interrupt enable (BOOLEAN): event-driven TPDOs of analog inputs only
/// when set (CiA 401 §6.3).
pub const ANALOG_INPUT_INTERRUPT_ENABLE: u16 = 0x6423;
/// Device type 1000h of an I/O module: profile 401 in the low 16 bits, analog inputs and
/// outputs present (bits 18 and 19 of the additional information).
pub const DEVICE_TYPE: u32 = 0x000C_0191;

/// A raw channel value and its meaning in SI units: `value = offset + scale · raw`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scaling {
    /// SI unit per count.
    pub scale: f64,
    /// SI value at count 0.
    pub offset: f64,
}

impl Scaling {
    /// `value = offset + scale · raw`: the input channel's reading in SI units.
    pub fn to_si(self, raw: i16) -> f64 {
        self.offset + self.scale * f64::from(raw)
    }

    /// `raw = (value - offset) / scale`, rounded and saturated to the 16-bit range.
    pub fn to_raw(self, value: f64) -> i16 {
        let raw = ((value - self.offset) / self.scale).round();
        if raw.is_nan() {
            0
        } else {
            raw.clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaling_round_trips_and_saturates() {
        let s = Scaling {
            scale: 1e-6,
            offset: -0.001,
        };
        assert!((s.to_si(s.to_raw(0.0125)) - 0.0125).abs() < 1e-9);
        assert_eq!(s.to_raw(1.0), i16::MAX);
        assert_eq!(s.to_raw(-1.0), i16::MIN);
        assert_eq!(s.to_raw(f64::NAN), 0);
    }
}
