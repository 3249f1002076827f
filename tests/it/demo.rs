//! The README's first command: the scripted demo on the in-process bus, as a user runs it.

use actuatord::daemon::recorder::read_cycles;
use actuatord::defaults::{self, Source};
use actuatord::demo::{
    run_with, Clock, PhaseFigures, Script, DIP_END_S, FAULT_AT_S, FRICTION_AT_S,
};
use actuatord::physics::Family;
use actuatord::supervise::FaultKind;

/// The paper's upper figure for the small-step offset with adaptive friction compensation
/// (Isermann & Raab, Fig. 17: 25-50 µm).
const PAPER_ADAPTIVE_MAX_M: f64 = 50e-6;

/// The friction and dip phases of one run: after friction x3 the adapted steps end better than
/// the first one after the rise and inside the paper's band, the approach compensation learned
/// the tripled friction (at least twice its level at the rise; 3 F_C / K = 1.0 V), and the
/// dip's steps end inside the band.
fn assert_learns_the_friction_and_rides_out_the_dip(p: &PhaseFigures, run: &str) {
    assert!(
        p.friction_error_after_m < p.friction_error_before_m
            && p.friction_error_after_m < PAPER_ADAPTIVE_MAX_M,
        "{run}: adapted {} vs right after the rise {}",
        p.friction_error_after_m,
        p.friction_error_before_m
    );
    assert!(
        p.compensation_after.0 >= 2.0 * p.compensation_before.0,
        "{run}: U_comp+ {:?} -> {:?}",
        p.compensation_before,
        p.compensation_after
    );
    assert!(
        p.dip_error_m < PAPER_ADAPTIVE_MAX_M,
        "{run}: dip {}",
        p.dip_error_m
    );
}

#[test]
fn the_demo_tells_its_story_in_lockstep_from_any_directory() {
    let dir = tempfile::tempdir().expect("tempdir");
    // As a user runs it, in a folder without the sources: the built-in configuration and
    // plant, the recording written there.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
        .current_dir(dir.path())
        .args(["demo", "--lockstep"])
        .output()
        .expect("actuator runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{text}");
    let recording = dir.path().join("demo.mcap");
    let cycles = read_cycles(&recording).expect("demo.mcap written and readable");
    assert!(text.contains("the story, phase by phase"), "{text}");

    // The same run through the library, for its figures.
    let script = Script::standard().expect("script");
    let again = dir.path().join("again.mcap");
    let s = run_with(
        &Source::Builtin(defaults::config(Family::Solenoid)),
        &Source::Builtin(defaults::plant(Family::Solenoid)),
        &script,
        &again,
        Clock::LockStep,
    )
    .expect("demo runs");
    assert_eq!(s.records_dropped, 0);
    assert_eq!(
        s.cycle.cycles as usize,
        cycles.len(),
        "every cycle recorded"
    );
    assert_eq!(s.steps.len(), script.setpoints.len());
    assert_eq!(s.injected.len(), script.faults.len());
    let p = &s.phases;

    // 1. Nominal: every step settles, no fault; the guide's stiction (the paper's Fig. 17)
    // leaves a stick-slip offset, inside the paper's band with adaptive compensation.
    for st in s.steps.iter().filter(|st| st.at_s < FRICTION_AT_S) {
        assert!(
            st.steady_state_error_m.abs() < PAPER_ADAPTIVE_MAX_M,
            "{st:?}"
        );
        assert!(
            st.settling_time_s.is_some() && st.faults.is_empty(),
            "{st:?}"
        );
    }

    // 2. Friction x3: the limit checks see nothing, the observer flags it, the axis keeps
    // working (maintenance requested, no safe state).
    let flagged = p
        .observer_flag_delay_s
        .expect("the observer flags the friction");
    assert!(
        flagged > 0.0 && FRICTION_AT_S + flagged < FAULT_AT_S,
        "{flagged}"
    );
    for st in s.steps.iter().filter(|st| st.at_s < FAULT_AT_S) {
        assert!(st.faults.is_empty(), "{st:?}");
    }
    // The steady error right after the rise and once the compensation has adapted (the last
    // steps before the dip) are measured and printed as this run has them.
    let friction_line = format!(
        "steady error {:.1} µm on the first step, {:.1} µm on the last two before the dip",
        p.friction_error_before_m * 1e6,
        p.friction_error_after_m * 1e6
    );
    assert!(text.contains(&friction_line), "{friction_line}\n{text}");
    assert_learns_the_friction_and_rides_out_the_dip(p, "built-in plant");

    // 3. The dip: 16.8 V measured (24 V x 0.7), gains x24/16.8, the warning EMCY (mains
    // under-voltage) once, no safe state.
    assert!(
        (16.6..17.0).contains(&p.dip_supply_min),
        "{}",
        p.dip_supply_min
    );
    assert!(
        (p.dip_gain_factor_max - 24.0 / 16.8).abs() < 0.05,
        "{}",
        p.dip_gain_factor_max
    );
    let (code, after) = p.dip_warning.expect("a warning EMCY in the dip");
    assert_eq!(code, 0x3120);
    assert!(after < 0.05, "{after}");
    assert!(!p.dip_safe_state);
    // The warning ends with the dip: an "error reset" EMCY after it, before the real fault.
    assert!(s
        .emcys
        .iter()
        .any(|(t, code, _)| *code == 0 && *t >= DIP_END_S && *t < FAULT_AT_S));

    // 4. The real fault: the supply limit latches within its persistence (4 periods of 2.5 ms,
    // a few more for noise), and the axis is in its safe state.
    let (kind, after) = p.fault.expect("the supply collapse is detected");
    assert_eq!(kind, FaultKind::SupplyVoltage);
    assert!((0.0075..0.03).contains(&after), "{after}");
    assert!(p.safe_state_after_s.is_some());

    // No step's row carries a fault raised after it settled.
    for st in &s.steps {
        let Some(settle) = st.settling_time_s else {
            continue;
        };
        for k in st.faults.iter() {
            let raised = s
                .faults_raised
                .iter()
                .filter(|(_, _, kind)| *kind == k)
                .map(|(t, _, _)| *t)
                .fold(f64::INFINITY, f64::min);
            assert!(raised <= st.at_s + settle, "{st:?}: {k} at {raised}");
        }
    }
    // The step after the collapse never settles and carries the fault that stopped it.
    let last = s.steps.last().expect("steps");
    assert!(last.settling_time_s.is_none());
    assert!(last.faults.contains(FaultKind::SupplyVoltage), "{last:?}");
}

/// The built-in configurations and plant files: `actuator sim --family F` runs in a folder with
/// no `config/` in sight, as after `cargo install`; a file named on the command line still wins.
#[test]
fn sim_runs_from_any_directory_on_the_built_in_files_and_a_named_file_wins() {
    let dir = tempfile::tempdir().expect("tempdir");
    for family in ["motor_gear", "linear_axis", "pneumatic", "solenoid"] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
            .current_dir(dir.path())
            .args([
                "sim",
                "--family",
                family,
                "--record",
                "run.csv",
                "--seconds",
                "0.5",
            ])
            .output()
            .expect("actuator runs");
        assert!(
            out.status.success(),
            "{family}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let csv = std::fs::read_to_string(dir.path().join("run.csv")).expect("csv written");
        assert!(csv.lines().count() > 10, "{family}: {csv}");
    }
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
        .current_dir(dir.path())
        .args(["sim", "--family", "motor_gear", "--plant", "mine.toml"])
        .args(["--record", "run.csv", "--seconds", "0.5"])
        .output()
        .expect("actuator runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("mine.toml: cannot read"), "{err}");
}

/// The story's claims hold for plants drawn with other seeds (sensor noise, the stick-slip
/// cycle), and the supply schedule is what rides out the dip: with fixed gains the same dip's
/// steps settle much later.
#[test]
fn over_plant_seeds_the_compensation_learns_and_the_schedule_rides_out_the_dip() {
    let dir = tempfile::tempdir().expect("tempdir");
    let plant = defaults::plant(Family::Solenoid).text;
    let config = defaults::config(Family::Solenoid).text;
    let scheduled_gains = "gain_factor = [1.6, 1.5, 1.3333, 1.1429, 1.0, 0.8571, 0.75]";
    assert!(config.contains(scheduled_gains));
    let fixed = config.replace(
        scheduled_gains,
        "gain_factor = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]",
    );
    let write = |name: &str, text: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).expect("write");
        Source::File(path)
    };
    let scheduled_config = write("scheduled.toml", config);
    let fixed_config = write("fixed.toml", &fixed);
    let script = Script::standard().expect("script");
    let settling = |s: f64| if s.is_finite() { s } else { f64::INFINITY };
    for seed in 1..=8 {
        let plant = write(
            &format!("plant{seed}.toml"),
            &plant.replacen("seed = 1", &format!("seed = {seed}"), 1),
        );
        let run = |config: &Source| {
            run_with(
                config,
                &plant,
                &script,
                &dir.path().join("run.mcap"),
                Clock::LockStep,
            )
            .expect("demo runs")
            .phases
        };
        let p = run(&scheduled_config);
        let f = run(&fixed_config);
        println!(
            "seed {seed}: nominal {:.1} µm; friction {:.1} -> {:.1} µm, U_comp+ {:.2} -> {:.2} V; dip {:.1} µm, settling {:.0} ms scheduled, {:.0} ms fixed",
            p.nominal_small_error_m * 1e6,
            p.friction_error_before_m * 1e6,
            p.friction_error_after_m * 1e6,
            p.compensation_before.0,
            p.compensation_after.0,
            p.dip_error_m * 1e6,
            p.dip_settling_s * 1e3,
            f.dip_settling_s * 1e3,
        );
        assert!(
            p.nominal_small_error_m < PAPER_ADAPTIVE_MAX_M,
            "seed {seed}: {p:?}"
        );
        assert_learns_the_friction_and_rides_out_the_dip(&p, &format!("seed {seed}"));
        assert!(
            1.5 * settling(p.dip_settling_s) < settling(f.dip_settling_s),
            "seed {seed}: dip settling {} scheduled vs {} fixed",
            p.dip_settling_s,
            f.dip_settling_s
        );
    }
}
