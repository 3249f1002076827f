//! The robust controller in the daemon: `actuator design robust` output loaded through
//! `[axis.controller] state_space_file`, run by the controller node against the simulated
//! motor_gear node, frame by frame through the codec (lock-step, no clocks).

use crate::robust_common;

use actuatord::daemon::Config;
use actuatord::lockstep::LockStep;
use std::path::Path;

#[test]
fn the_designed_controller_runs_in_the_daemon_and_tracks_the_schedule() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("tempdir");
    let plant_file = root.join("config/plants/motor_gear.toml");
    let design = actuatord::design::design_robust(&plant_file).expect("design");
    let controller = dir.path().join("controller.toml");
    actuatord::design::write_controller_toml(&design, &controller).expect("write controller");

    let text = std::fs::read_to_string(root.join("config/motor_gear.toml")).expect("config");
    let text = robust_common::motor_gear_with_state_space_controller(&text);
    let config_path = dir.path().join("motor_gear_robust.toml");
    std::fs::write(&config_path, &text).expect("write config");
    let config = Config::load(&config_path).expect("config with the state-space controller");
    assert!(config.axis[0].controller.state_space_file.is_some());

    let plant = actuatord::physics::load_plant(&plant_file).expect("plant");
    let mut rig = LockStep::new(&config, plant, vec![]).expect("rig");
    let mut samples = vec![];
    rig.run(4.0, &mut |s| samples.push(*s));
    // Mean true load angle over the 0.1 s before `t`.
    let at = |t: f64| {
        let window: Vec<f64> = samples
            .iter()
            .filter(|s| s.record.t_s > t - 0.1 && s.record.t_s <= t)
            .map(|s| s.truth.position)
            .collect();
        assert!(!window.is_empty(), "no samples before {t} s");
        window.iter().sum::<f64>() / window.len() as f64
    };
    // Schedule of config/motor_gear.toml: 0.2 rad at 1 s, 0.21 at 2 s, -0.3 at 3 s (2 rad/s
    // ramps). Each target is judged against a band smaller than the step that reached it: the
    // gear's 5 mrad backlash leaves the load up to 2.5 mrad from where the motor holds it
    // (measured: +2.0, -0.9, -2.1 mrad), and a loop that ignored the 10 mrad step to 0.21 rad
    // would stay about 8 mrad from it.
    let band = 0.003;
    let mut previous = 0.0;
    for (t, target) in [(1.95, 0.2), (2.95, 0.21), (3.95, -0.3)] {
        let y = at(t);
        eprintln!("robust in the daemon: {target} rad -> {y:.5} rad at {t} s");
        assert!(
            band < 0.5 * f64::abs(target - previous),
            "the band must tell the target from the one before"
        );
        assert!(
            (y - target).abs() < band,
            "at {t} s: {y} rad for {target} (from {previous})"
        );
        previous = target;
    }
    assert_eq!(rig.controller().counters().faults_raised, 0);
}
