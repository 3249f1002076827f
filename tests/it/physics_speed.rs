//! Simulation speed, a measurement and not an assertion: run with
//! `cargo test --release --test physics_speed -- --ignored --nocapture`.

use actuatord::physics::load_plant;
use std::path::Path;
use std::time::Instant;

#[test]
#[ignore]
fn samples_per_second() {
    for (name, dt, u_hi, u_lo) in [
        ("solenoid", 0.0025, 14.0, 6.0),
        ("linear_axis", 0.001, 60.0, -60.0),
        ("pneumatic", 0.02, 0.5, -0.5),
        ("motor_gear", 0.001, 6.0, -6.0),
    ] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("config/plants/{name}.toml"));
        let mut p = load_plant(&path).unwrap();
        let n = 1_000_000usize;
        let start = Instant::now();
        let mut acc = 0.0;
        for k in 0..n {
            // Square wave with a 0.5 s period: stick-slip and reversals all the time.
            let u = if (k as f64 * dt) % 0.5 < 0.25 {
                u_hi
            } else {
                u_lo
            };
            p.step(u, dt);
            acc += p.measure().position;
        }
        let s = start.elapsed().as_secs_f64();
        println!(
            "{name}: {n} samples of {dt} s in {s:.3} s = {:.0} samples/s (checksum {acc:.3})",
            n as f64 / s
        );
    }
}
