//! The paper bench on the simulated plants: the figures point the way the paper's do.

use actuatord::bench::paper::{
    diagnose_paper_faults, observer_friction_rise, pneumatic_settling, solenoid_small_step_offset,
    PneumaticStrategy,
};
use actuatord::bench::{run_paper_bench, PaperTable};

#[test]
fn adaptive_friction_compensation_lowers_the_small_step_offset() {
    let (linear, _) = solenoid_small_step_offset(false).expect("runs");
    let (adaptive, (pos, neg)) = solenoid_small_step_offset(true).expect("runs");
    assert!(adaptive < linear, "adaptive {adaptive} vs linear {linear}");
    // The friction controller learned a compensation in both directions, below F_C / K = 0.12 V.
    assert!(
        pos > 0.0 && neg > 0.0 && pos < 0.12 && neg < 0.12,
        "{pos} {neg}"
    );
}

#[test]
fn scheduling_keeps_the_pneumatic_settling_time_across_supply_pressures() {
    let fixed_high = pneumatic_settling(PneumaticStrategy::Fixed, 80_000.0).expect("runs");
    let sched: Vec<(f64, f64)> = [40_000.0, 60_000.0, 80_000.0]
        .iter()
        .map(|&p| pneumatic_settling(PneumaticStrategy::Scheduled, p).expect("runs"))
        .collect();
    let adaptive_high = pneumatic_settling(PneumaticStrategy::Adaptive, 80_000.0).expect("runs");
    // At 800 mbar K_I is a quarter of the worst case: the fixed gain is slow and less accurate.
    assert!(sched[2].0 < fixed_high.0, "{sched:?} vs {fixed_high:?}");
    assert!(sched[2].1 < fixed_high.1, "{sched:?} vs {fixed_high:?}");
    // Adaptation without a pressure measurement does about as well as scheduling.
    assert!(
        adaptive_high.0 <= 1.5 * sched[2].0,
        "{adaptive_high:?} vs {sched:?}"
    );
}

#[test]
fn each_paper_fault_is_diagnosed_from_its_symptoms() {
    for (expected, d) in diagnose_paper_faults().expect("runs") {
        assert_eq!(d.fault, Some(expected), "{d:?}");
    }
}

#[test]
fn the_observer_flags_a_slow_friction_rise_before_the_position_error_shows_it() {
    let race = observer_friction_rise().expect("runs");
    let observer = race.observer_s.expect("observer detects the rise");
    if let Some(position) = race.position_error_s {
        assert!(observer < position, "{race:?}");
    }
}

#[test]
#[ignore = "prints the whole table (a few seconds); run with --ignored --nocapture"]
fn print_table() {
    let rows = run_paper_bench();
    println!("{}", PaperTable(&rows));
    println!("{}", serde_json::to_string_pretty(&rows).expect("json"));
}
