//! Plant files: every family loads, errors name file, table, key and rule, and the lab's
//! parameter vector round-trips.

use actuatord::physics::{
    load_plant, load_spec, plant_from_str, EffectKind, Family, Plant, PlantSpec,
};
use std::path::{Path, PathBuf};

fn file(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("config/plants")
        .join(name)
}

/// Where a constant command `u` takes the plant of `spec` from rest at `y0` in 0.5 s, from its
/// constants alone.
fn expected_after_half_a_second(spec: &PlantSpec, u: f64, y0: f64) -> f64 {
    let get = |name: &str| spec.get(name).unwrap_or_else(|| panic!("{name}"));
    match spec.family {
        // Voltage clipped to the supply; settled (ζ = 0.2, ω0 = 45 rad/s: 1 % of the swing left
        // after 0.5 s) at the spring's balance, 240 N / 2000 N/m = 0.12 m.
        Family::LinearAxis => {
            let force =
                get("linear_axis.force_gain_n_per_v") * u.min(get("linear_axis.supply_voltage_v"));
            (force - get("spring.pretension_n")) / get("spring.stiffness_n_per_m")
        }
        // Settled (ζ = 0.35, ω0 = 58 rad/s) at the spring's balance,
        // (1.63 N/V · 12 V - 3 N) / 1650 N/m = 10.0 mm, give or take the stick band F_S / c = 0.5 mm.
        Family::Solenoid => {
            let force =
                get("solenoid.current_gain_a_per_v") * get("solenoid.force_constant_n_per_a") * u;
            (force - get("spring.pretension_n")) / get("spring.stiffness_n_per_m")
        }
        // The valve's speed up at the nominal supply: 0.022 m/s · 0.5 · 0.5 s = 5.5 mm.
        Family::Pneumatic => y0 + get("pneumatic.gain_up_m_per_s") * u * 0.5,
        // The motor's no-load speed, 12 V / 0.03 V s/rad / 20 = 20 rad/s at the load, reaches
        // the end stop at 1.2 rad within a tenth of a second.
        Family::MotorGear => get("motor_gear.angle_max_rad"),
    }
}

#[test]
fn every_family_has_a_plant_file_that_runs() {
    for fam in Family::ALL {
        let path = file(&format!("{fam}.toml"));
        let mut p = load_plant(&path).unwrap();
        let spec = load_spec(&path).unwrap();
        assert_eq!(p.family(), fam);
        let u = match fam {
            Family::Pneumatic => 0.5,
            Family::LinearAxis => 50.0,
            _ => 12.0,
        };
        let mut out = Vec::new();
        p.simulate(&vec![u; 500], 1e-3, &mut out);
        assert_eq!(out.len(), 500);
        assert!(out.iter().all(|m| m.position.is_finite()));
        assert!((p.time_s() - 0.5).abs() < 1e-9);
        // A positive command moves every family up, by what its constants say within 10 %
        // (measured: linear axis 0.1205 m, solenoid 9.90 mm, pneumatic 5.23 mm, motor_gear
        // 1.200 rad): thousands of sensor quanta, where noise and quantisation are one or two.
        let (from, to) = (out[0].position, out[499].position);
        let expected = expected_after_half_a_second(&spec, u, from);
        println!("{fam}: {from} -> {to}, expected {expected}");
        assert!(
            (to - expected).abs() < 0.1 * (expected - from).abs(),
            "{fam}: {from} -> {to}, expected {expected}"
        );
        let unit = if fam == Family::MotorGear { "rad" } else { "m" };
        let resolution = spec
            .get(&format!("sensor.position_quantum_{unit}"))
            .expect("quantum")
            .max(
                spec.get(&format!("sensor.position_noise_{unit}"))
                    .expect("noise"),
            );
        assert!(
            to - from > 1000.0 * resolution,
            "{fam}: moved {} with a sensor resolution of {resolution}",
            to - from
        );
    }
}

#[test]
fn error_names_file_table_key_and_rule() {
    let text = std::fs::read_to_string(file("solenoid.toml")).unwrap();
    let bad = text.replace("stiffness_n_per_m = 1650.0", "stiffness_n_per_m = -3");
    let err = plant_from_str(&bad, "config/plants/solenoid.toml")
        .err()
        .unwrap();
    assert_eq!(
        err.to_string(),
        "config/plants/solenoid.toml: [spring] stiffness_n_per_m must be > 0, got -3"
    );
    let bad = text.replace("coulomb_pos_n = 0.55", "coulomb_pos_newton = 0.55");
    let msg = plant_from_str(&bad, "x.toml").err().unwrap().to_string();
    assert!(
        msg.contains("x.toml: [coulomb]") && msg.contains("coulomb_pos_newton"),
        "{msg}"
    );
    let msg = plant_from_str("family = \"solenoid\"\n[frobnicate]\n", "y.toml")
        .err()
        .unwrap()
        .to_string();
    assert!(
        msg.contains("frobnicate") && msg.contains("stribeck"),
        "{msg}"
    );
    let msg = plant_from_str("family = \"solenoid\"\n[backlash]\n", "y.toml")
        .err()
        .unwrap()
        .to_string();
    assert!(msg.contains("backlash"), "{msg}");
    let msg = plant_from_str("family = \"rocket\"\n", "z.toml")
        .err()
        .unwrap()
        .to_string();
    assert!(msg.contains("rocket"), "{msg}");
    let msg = plant_from_str(
        "family = \"solenoid\"\n[saturation]\nmin_v = 5\nmax_v = 1\n",
        "s.toml",
    )
    .err()
    .unwrap()
    .to_string();
    assert_eq!(msg, "s.toml: [saturation] max_v must be >= min (5), got 1");
    let msg = load_plant(Path::new("/nonexistent/plant.toml"))
        .err()
        .unwrap()
        .to_string();
    assert!(
        msg.starts_with("/nonexistent/plant.toml: cannot read"),
        "{msg}"
    );
    let msg = plant_from_str(
        "family = \"solenoid\"\nfaults = [\"friction_x3\"]\n",
        "f.toml",
    )
    .err()
    .unwrap()
    .to_string();
    assert!(msg.contains("faults"), "{msg}");
}

#[test]
fn spec_round_trips_through_toml() {
    for fam in Family::ALL {
        let spec = load_spec(&file(&format!("{fam}.toml"))).unwrap();
        let again = PlantSpec::from_toml(&spec.to_toml(), "round trip").unwrap();
        assert_eq!(spec.params().len(), again.params().len());
        for ((n1, p1), (n2, p2)) in spec.params().iter().zip(again.params().iter()) {
            assert_eq!(n1, n2);
            assert_eq!(p1.value, p2.value);
        }
    }
}

#[test]
fn lab_parameter_vector() {
    let mut spec = PlantSpec::new(Family::Solenoid);
    spec.add_effect(EffectKind::Spring).unwrap();
    spec.add_effect(EffectKind::Coulomb).unwrap();
    spec.fix_all();
    spec.set_free("spring.stiffness_n_per_m", true).unwrap();
    spec.set_free("coulomb.coulomb_pos_n", true).unwrap();
    assert_eq!(
        spec.free_names(),
        vec!["spring.stiffness_n_per_m", "coulomb.coulomb_pos_n"]
    );
    spec.set_free_values(&[1200.0, 0.5]).unwrap();
    assert_eq!(spec.get("spring.stiffness_n_per_m"), Some(1200.0));
    assert_eq!(spec.free_values(), vec![1200.0, 0.5]);
    assert!(spec.set_free_values(&[-1.0, 0.5]).is_err());
    assert!(spec.set_free_values(&[1.0]).is_err());
    assert_eq!(spec.free_bounds()[0].0, 0.0);
    let units: Vec<&str> = spec.params().iter().map(|(_, p)| p.unit).collect();
    assert!(units.contains(&"N/m"));
    assert_eq!(spec.effect_names(), vec!["spring", "coulomb"]);
    let _plant: Box<dyn Plant> = spec.build().unwrap();
    // Rotary family: keys carry rotary units.
    let mut mg = PlantSpec::new(Family::MotorGear);
    mg.add_effect(EffectKind::Coulomb).unwrap();
    assert!(mg.get("coulomb.coulomb_pos_nm").is_some());
}

#[test]
fn scheduled_faults_in_a_plant_file_fire_on_time() {
    let text = std::fs::read_to_string(file("linear_axis.toml"))
        .unwrap()
        .replace("seed = 1", "seed = 1\nfaults = [\"jamming@100ms\"]");
    let mut p = plant_from_str(&text, "jam.toml").unwrap();
    for _ in 0..100 {
        p.step(50.0, 1e-3);
    }
    let y = p.truth().position;
    assert!(y > 0.0);
    for _ in 0..100 {
        p.step(50.0, 1e-3);
    }
    // Jammed from 0.1 s: stopped and stays.
    let y2 = p.truth().position;
    for _ in 0..100 {
        p.step(-50.0, 1e-3);
    }
    assert_eq!(p.truth().position, y2);
}

#[test]
fn same_seed_same_measurements_different_seed_different() {
    let text = std::fs::read_to_string(file("pneumatic.toml")).unwrap();
    let run = |t: &str| {
        let mut p = plant_from_str(t, "p").unwrap();
        let mut out = Vec::new();
        p.simulate(&[0.3; 50], 0.02, &mut out);
        out
    };
    assert_eq!(run(&text), run(&text));
    assert_ne!(run(&text), run(&text.replace("seed = 1", "seed = 2")));
}
