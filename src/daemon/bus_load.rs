//! The bus load the configuration asks for, computed before the daemon starts.

use super::config::{CommandKind, Config};
use super::profile_config::ProfileKind;
use crate::device::messages::{
    Message, COMMAND, FAULT_DIAGNOSIS, FAULT_STATE, HEARTBEAT_ACTUATOR, HEARTBEAT_CONTROLLER,
    LOOP_STATUS, SENSOR, SUPPLY_PRESSURE, SYNC, TUNED_GAINS, TUNED_PARAMETERS,
};

/// Worst-case bits on the wire of a classic standard-id frame with `dlc` data bytes, bit
/// stuffing and interframe space included: `8n + 47 + floor((34 + 8n - 1) / 4)` (Davis et al.,
/// "Controller Area Network schedulability analysis", 2007).
pub fn frame_bits(dlc: usize) -> f64 {
    let n = dlc as f64;
    8.0 * n + 47.0 + ((34.0 + 8.0 * n - 1.0) / 4.0).floor()
}

/// Bits per second the configured traffic needs, and the share of `bitrate_bps` it takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BusLoad {
    pub bits_per_s: f64,
    pub frames_per_s: f64,
    pub load: f64,
}

/// The periodic traffic of the controller and its actuator nodes (SDO and EMCY are sporadic).
pub fn bus_load(config: &Config) -> BusLoad {
    let cycle_hz = 1.0 / config.cycle.period_s;
    let status_hz = 1.0 / config.node.status_period_s.max(config.cycle.period_s);
    let heartbeat_hz = 1.0 / config.node.heartbeat_period_s.max(config.cycle.period_s);
    let mut traffic: Vec<(&Message, f64)> = vec![
        (&SYNC, cycle_hz),
        (&HEARTBEAT_CONTROLLER, heartbeat_hz),
        (&LOOP_STATUS, status_hz),
    ];
    // A standard node's synchronous PDOs as they will be mapped: (frames/s, bits/s).
    let mut mapped = (0.0, 0.0);
    for axis in &config.axis {
        if axis.profile != super::profile_config::ProfileKind::Actuatord {
            let pdos = super::profile_setup::planned_layout(axis)
                .unwrap_or_else(|_| super::profile_config::desired_pdos(axis));
            for p in pdos.iter().filter(|p| p.enabled && !p.objects.is_empty()) {
                if (1..=240).contains(&p.transmission_type) {
                    let hz = cycle_hz / f64::from(p.transmission_type);
                    mapped.0 += hz;
                    mapped.1 += frame_bits(p.len_bytes()) * hz;
                }
            }
        } else {
            traffic.push((&SENSOR, cycle_hz));
            traffic.push((&COMMAND, cycle_hz));
        }
        if axis.command == CommandKind::Duty && axis.profile == ProfileKind::Actuatord {
            traffic.push((&SUPPLY_PRESSURE, cycle_hz));
        }
        // Actuator nodes beat at the same rate as this node (as `actuator sim` does).
        traffic.push((&HEARTBEAT_ACTUATOR, heartbeat_hz));
        for m in [
            &FAULT_STATE,
            &FAULT_DIAGNOSIS,
            &TUNED_PARAMETERS,
            &TUNED_GAINS,
        ] {
            traffic.push((m, status_hz));
        }
    }
    let bits_per_s: f64 = traffic
        .iter()
        .map(|(m, hz)| frame_bits(m.dlc) * hz)
        .sum::<f64>()
        + mapped.1;
    let frames_per_s: f64 = traffic.iter().map(|(_, hz)| hz).sum::<f64>() + mapped.0;
    BusLoad {
        bits_per_s,
        frames_per_s,
        load: bits_per_s / config.bus.bitrate_bps as f64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn a_cia402_axis_counts_its_pdos_as_mapped() {
        let c = Config::load(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/config/cia402_linear_axis.toml"
        )))
        .expect("config");
        let l = bus_load(&c);
        // 500 Hz: SYNC (0 bytes) + RPDO1 (4) + TPDO1 (8) + TPDO2 (8), then the slower frames.
        let cyclic = 500.0 * (frame_bits(0) + frame_bits(4) + frame_bits(8) * 2.0);
        assert!(
            l.bits_per_s > cyclic && l.bits_per_s < cyclic * 1.1,
            "{l:?}"
        );
        assert!(l.frames_per_s > 2000.0 && l.frames_per_s < 2200.0, "{l:?}");
    }

    #[test]
    fn frame_lengths_match_the_worst_case_formula() {
        assert_eq!(frame_bits(0), 55.0);
        assert_eq!(frame_bits(8), 135.0);
    }

    #[test]
    fn the_solenoid_at_400_hz_needs_a_fraction_of_500_kbit() {
        let c = Config::load(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/config/solenoid.toml"
        )))
        .expect("config");
        let l = bus_load(&c);
        // SYNC (65 bits) + sensor (135) + command (105) at 400 Hz alone are 122 kbit/s.
        assert!(
            l.bits_per_s > 122_000.0 && l.bits_per_s < 145_000.0,
            "{l:?}"
        );
        assert!((l.load - l.bits_per_s / 500_000.0).abs() < 1e-12);
    }
}
