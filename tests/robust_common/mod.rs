//! Shared by the robust-controller tests: the shipped motor_gear configuration with its PID
//! replaced by the state-space controller `actuator design robust` writes.

/// `config/motor_gear.toml`'s text without the PID gains, its `[axis.controller]` reading
/// `controller.toml` from the configuration's folder.
pub fn motor_gear_with_state_space_controller(text: &str) -> String {
    text.lines()
        .filter(|l| !l.starts_with("q_per_m") && !l.starts_with("p = "))
        .map(|l| {
            if l == "[axis.controller]" {
                format!("{l}\nstate_space_file = \"controller.toml\"\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect()
}
