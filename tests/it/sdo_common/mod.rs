//! Shared by the `sdo_*` tests: the daemon's dictionary from the shipped configuration.
#![allow(dead_code)]

use actuatord::canopen::ObjectDictionary;
use actuatord::daemon::config::Config;
use std::path::Path;

/// `config/solenoid.toml` as a dictionary, built the way the daemon builds it.
pub fn solenoid_dictionary() -> (Config, ObjectDictionary) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml");
    let config = Config::load(&path).expect("shipped config is valid");
    let od = actuatord::daemon::dictionary::build(&config).expect("config fits the table");
    (config, od)
}
