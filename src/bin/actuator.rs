//! `actuator`: the user's tool. A simulated actuator node, the demo, the DBC.

#[path = "actuator/choice.rs"]
mod choice;
#[path = "actuator/faults.rs"]
mod faults;
#[path = "actuator/lab.rs"]
mod lab;

use choice::Choice;

use actuatord::bench::rt::{Load, RtBenchOptions};
use actuatord::bus::SocketCanBus;
use actuatord::daemon::Config;
use actuatord::defaults::{self, Source};
use actuatord::lockstep::{write_csv, LockStep};
use actuatord::physics::{CommandUnit, Family, ScheduledFault};
use actuatord::simnode::{run_sim_node, SimEvent, SimNode};
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

#[derive(Parser, Debug)]
#[command(
    version,
    about = "The engineer's tool: simulated actuator nodes, the demo, the model lab, controller design, benchmarks"
)]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// A simulated actuator node on a CAN interface: answers every SYNC with its sensor frame.
    /// With --record, runs offline instead: the controller of --config and the plant in
    /// lock-step, no CAN, and writes the data set as CSV (time,u,y,supply,i,setpoint).
    Sim {
        #[arg(long, default_value = "vcan0")]
        iface: String,
        /// Plant family; shorthand for --plant config/plants/FAMILY.toml (and, offline,
        /// --config config/FAMILY.toml), both built in.
        #[arg(long)]
        family: Option<actuatord::physics::Family>,
        /// Plant file (TOML); default the family's, built in: config/plants/solenoid.toml, or
        /// with --profile cia402 a plant the drive commands by force or torque (the linear
        /// axis of config/plants/linear_axis_drive.toml; --family motor_gear: its gear in
        /// torque mode).
        #[arg(long)]
        plant: Option<PathBuf>,
        /// Controller configuration for the offline run (--record); default: the family's,
        /// built in.
        #[arg(long)]
        config: Option<PathBuf>,
        #[arg(long, default_value_t = 16)]
        node_id: u8,
        /// Time the plant advances per SYNC; must match the controller's period
        /// (offline: the config's period).
        #[arg(long, default_value_t = 0.0025)]
        period_s: f64,
        #[arg(long, default_value_t = 0.1)]
        heartbeat_period_s: f64,
        /// Fault to inject, e.g. friction_x3@5s, supply_x0.5@2s, sensor_stuck@1s, spring_x0.73~10s@5s
        /// (time is the plant's: SYNCs received times the period). Repeatable.
        #[arg(long = "fault")]
        faults: Vec<ScheduledFault>,
        /// Stop by itself after this many seconds.
        #[arg(long)]
        duration_s: Option<f64>,
        /// Offline: write the closed-loop data set to this CSV file (and print the run's RMS
        /// following error from the first set-point change on).
        #[arg(long)]
        record: Option<PathBuf>,
        /// Offline: simulated seconds.
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
        /// Speak a standard profile instead of the actuatord frames: cia402 (a servo drive,
        /// CST/CSV; the plant takes force or torque) or cia401 (an analog I/O module wired to
        /// the plant: AI1 position 1 µm, AI2 current 1 mA, AI3 supply 1 mV or 100 Pa, AO1
        /// command 1 mV or 1e-4 duty, per count).
        #[arg(long)]
        profile: Option<actuatord::simnode::Profile>,
        /// A CiA 402 drive fault at a plant time, CODE@TIME, e.g. 0x4310@2s. Repeatable.
        #[arg(long = "drive-fault")]
        drive_faults: Vec<actuatord::simnode::DriveFault>,
        /// Reboot the node at this plant time (e.g. 3s): boot-up message, pre-operational,
        /// factory values (a standard node's mapping, watchdogs and home lost), as after a
        /// brown-out of its electronics; the plant keeps its state.
        #[arg(long = "reboot-at", value_parser = parse_duration_s)]
        reboot_at_s: Option<f64>,
        /// Print the simulated profile node's EDS (its factory dictionary) and exit.
        #[arg(long)]
        print_eds: bool,
    },
    /// Daemon and simulated solenoid in one process: no CAN hardware, no root.
    Demo {
        /// Controller configuration; default: config/solenoid.toml, built in.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Plant file; default: config/plants/solenoid.toml, built in.
        #[arg(long)]
        plant: Option<PathBuf>,
        /// Where the MCAP recording goes.
        #[arg(long, default_value = "demo.mcap")]
        record: PathBuf,
        /// Controller and simulated node frame by frame without clocks, as fast as the machine
        /// goes (the same figures on any machine), instead of the real-time cycle.
        #[arg(long)]
        lockstep: bool,
    },
    /// Benchmarks: measurements printed beside their reference figures.
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
    /// Controller design from a plant file.
    Design {
        #[command(subcommand)]
        what: DesignCommand,
    },
    /// From a fitted model (`actuator fit --out`) and an axis configuration, the configuration
    /// for the identified plant: controller designed per direction, margins, robustness over
    /// the fitted intervals, friction compensation, observer, estimation, supply schedule.
    Tune {
        /// The fitted model file, with its 95 % intervals.
        #[arg(long)]
        model: PathBuf,
        /// The axis configuration to start from.
        #[arg(long)]
        config: PathBuf,
        /// Where the tuned configuration goes.
        #[arg(long)]
        out: PathBuf,
        /// What to choose by: rms (the least RMS following error over the tour, predicted by
        /// running the daemon's node on the fitted model), settling (the slowest step's
        /// settling), overshoot, steady (the error held at the end of each dwell); or one
        /// linear design: bandwidth (the largest whose linear
        /// prediction keeps the command in the drive's range) or a goal such as
        /// bandwidth=30,damping=0.9,fast=3 (rad/s). Every outcome is predicted and held
        /// against the given configuration.
        #[arg(long, default_value = "rms")]
        goal: actuatord::tune::Aim,
        /// The tour to predict on (initial_setpoint_m, [[setpoints]] at_s and position_m,
        /// optionally seconds); default: the axis' own [[axis.setpoints]].
        #[arg(long)]
        tour: Option<PathBuf>,
        /// Largest half-width of a design parameter's 95 % interval, relative to its value.
        #[arg(long, default_value_t = 0.25)]
        max_spread: f64,
        /// The axis to tune (default: the first).
        #[arg(long)]
        axis: Option<String>,
        /// Also derive the fault-symptom table for the fitted plant (a solenoid) and write it
        /// here, beside --out; the tuned configuration names it. Takes a few minutes.
        #[arg(long)]
        fault_table: Option<PathBuf>,
        /// A motor_gear model: also write the fitted plant here as a plant file, for the
        /// H-infinity design `actuator design robust --plant FILE` (the command is printed).
        #[arg(long)]
        robust_plant: Option<PathBuf>,
    },
    /// The model lab: compare, diagnose, fit, report.
    #[command(flatten)]
    Lab(lab::LabCommand),
    /// Read or write an object of a running daemon over SDO (types from its configuration).
    Sdo {
        #[arg(long, default_value = "vcan0")]
        iface: String,
        /// The daemon's node id.
        #[arg(long, default_value_t = 1)]
        node: u8,
        /// The daemon's configuration, for the objects' names and types (raw hex without it).
        #[arg(long, default_value = "config/solenoid.toml")]
        config: PathBuf,
        #[arg(long, default_value_t = 1.0)]
        timeout_s: f64,
        #[command(subcommand)]
        op: SdoOp,
    },
    /// The daemon's error history (1003h, with each entry's time), newest first: read from a
    /// running daemon over SDO, or with --state from its state file.
    Faults {
        #[arg(long, default_value = "vcan0")]
        iface: String,
        /// The daemon's node id.
        #[arg(long, default_value_t = 1)]
        node: u8,
        #[arg(long, default_value_t = 1.0)]
        timeout_s: f64,
        /// Read the daemon's state file (`[state] file`) instead of asking the daemon.
        #[arg(long)]
        state: Option<PathBuf>,
    },
    /// Decode a candump log (`candump -L`) into named signals with the protocol's table.
    Decode {
        /// The log file; `-` reads standard input.
        #[arg(default_value = "-")]
        log: PathBuf,
        #[arg(long, default_value_t = 1)]
        controller_node: u8,
        #[arg(long, default_value_t = 16)]
        actuator_node: u8,
    },
    /// Print the EDS (CiA 306) of a configuration's object dictionary.
    Eds {
        /// Default: config/solenoid.toml, built in.
        #[arg(long)]
        config: Option<PathBuf>,
    },
    /// Print the configuration reference (docs/configuration.md): every declared key with its
    /// unit, range, default and access, and the dictionary entries of the configuration's
    /// first axis.
    ConfigDoc {
        /// Default: config/solenoid.toml, built in.
        #[arg(long)]
        config: Option<PathBuf>,
    },
    /// Print the DBC of the protocol for the given node ids (dbc/actuatord.dbc is 1 and 16).
    Dbc {
        #[arg(long, default_value_t = 1)]
        controller_node: u8,
        #[arg(long, default_value_t = 16)]
        actuator_node: u8,
        /// The whole bus of a configuration instead: its nodes and, for standard (CiA 402/401)
        /// nodes, their PDOs as mapped, with the axis' scaling.
        #[arg(long)]
        config: Option<PathBuf>,
    },
}

#[derive(Subcommand, Debug)]
enum SdoOp {
    /// Read INDEX:SUB (hex, e.g. 2004:01) or a name (e.g. axis0_setpoint.setpoint_position).
    Read { object: String },
    /// Write VALUE to INDEX:SUB or a name; the value in the object's type (hex bytes if unknown).
    Write { object: String, value: String },
}

#[derive(Subcommand, Debug)]
enum DesignCommand {
    /// H-infinity mixed-sensitivity controller for a motor_gear plant (Bao et al. 2016, the
    /// weights of the paper's comparison), discretised for the cycle, written as a state-space
    /// controller file.
    Robust {
        #[arg(long, default_value = "config/plants/motor_gear.toml")]
        plant: PathBuf,
        #[arg(long, default_value = "controller.toml")]
        out: PathBuf,
    },
}

#[derive(Subcommand, Debug)]
enum BenchCommand {
    /// PID + friction compensation against the robust controller (weights of Bao et al. 2016's
    /// comparison) on a simulated motor_gear plant: sinusoids at 2 and 20 Hz, two amplitudes,
    /// bandwidth, beside the paper's figures.
    Robust {
        #[arg(long, default_value = "config/plants/motor_gear.toml")]
        plant: PathBuf,
        /// Print JSON (a list of rows) instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// The papers' experiments on the simulated plants, beside the papers' figures.
    Paper {
        /// Print JSON (a list of rows) instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Derive the fault-symptom table of the parameter diagnosis from the physics (the solenoid
    /// healthy and with each fault) and write it; --check compares with the file instead.
    FaultTable {
        #[arg(long, default_value = "config/fault_symptoms.toml")]
        out: PathBuf,
        /// Regenerate and compare with --out; exit non-zero when they differ.
        #[arg(long)]
        check: bool,
    },
    /// Minutes of the daemon against the simulated node (processes on a SocketCAN interface)
    /// with floods, bus outages, SIGHUPs, SDO writes, node stalls and fault resets; reports
    /// crashes, memory, periods held, faults and records. Needs CAP_NET_ADMIN for the outages.
    Soak {
        #[arg(long, default_value_t = 10.0)]
        minutes: f64,
        #[arg(long, default_value = "vcan0")]
        iface: String,
        #[arg(long, default_value = "config/solenoid.toml")]
        config: PathBuf,
        #[arg(long, default_value = "config/plants/solenoid.toml")]
        plant: PathBuf,
        /// The daemon's binary (default: actuatord beside this program).
        #[arg(long)]
        daemon: Option<PathBuf>,
        /// Keep the recordings and the daemon's log here (default: a temporary directory).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Parameter scheduling on the measured supply against fixed gains: a PWM-driven linear
    /// axis (12-34 V and a cranking dip) and the pneumatic drive (400-800 mbar), the daemon's
    /// axis code in lock-step with the simulated plants.
    Supply {
        /// Print JSON (a list of rows) instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// How the cycle keeps time: lateness histogram, deadline misses, latencies, compute per
    /// stage, against a naive tokio-interval loop doing the same work in the same run.
    Rt {
        #[arg(long, default_value = "config/solenoid.toml")]
        config: PathBuf,
        #[arg(long, default_value = "config/plants/solenoid.toml")]
        plant: PathBuf,
        /// Cycle period, e.g. 1ms, 2.5ms, 500us (default: the configuration's).
        #[arg(long, value_parser = parse_duration_s)]
        period: Option<f64>,
        /// Seconds per loop.
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
        #[arg(long, value_parser = Choice::<Load>::parser(), default_value = "none")]
        load: Load,
        /// Measure on this SocketCAN interface instead of the in-process bus.
        #[arg(long)]
        iface: Option<String>,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
}

/// "1ms", "2.5ms", "500us", "0.01s" or plain seconds.
fn parse_duration_s(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let (number, scale) = if let Some(n) = t.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = t.strip_suffix("us") {
        (n, 1e-6)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1.0)
    } else {
        (t, 1.0)
    };
    match number.trim().parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v * scale),
        _ => Err(format!(
            "not a positive duration: {text:?} (e.g. 1ms, 500us, 0.002s)"
        )),
    }
}

fn main() -> ExitCode {
    // A reader that goes away (`actuator dbc | head`) ends the command as it ends any Unix
    // filter, rather than panicking on the next print. Rust starts programs with SIGPIPE ignored.
    // SAFETY: called first in main, before any thread exists; SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("actuator: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// The plant `actuator sim` runs and its description: the file named, or the family's built-in
/// one. A CiA 402 drive applies a force or a torque, so without a file it takes the family's
/// plant commanded so (the linear axis by default); a family without such a command is refused
/// with the ones that have it.
fn sim_plant(
    plant: Option<PathBuf>,
    family: Option<actuatord::physics::Family>,
    profile: Option<actuatord::simnode::Profile>,
) -> anyhow::Result<(Source, actuatord::physics::PlantSpec)> {
    if plant.is_some() || profile != Some(actuatord::simnode::Profile::Cia402) {
        let source = Source::or_builtin(plant, defaults::plant(family.unwrap_or(Family::Solenoid)));
        let spec = source.plant_spec()?;
        return Ok((source, spec));
    }
    match family.unwrap_or(Family::LinearAxis) {
        Family::LinearAxis => {
            let source = Source::Builtin(defaults::drive_plant());
            let spec = source.plant_spec()?;
            Ok((source, spec))
        }
        Family::MotorGear => {
            let source = Source::Builtin(defaults::plant(Family::MotorGear));
            let mut spec = source.plant_spec()?;
            spec.set_command(CommandUnit::NewtonMetre)?;
            Ok((source, spec))
        }
        other => anyhow::bail!(
            "--profile cia402 is a servo drive, which applies a force or a torque: --family \
             linear_axis (the default) or motor_gear; the {other} plant has no such command \
             (it fits --profile cia401)"
        ),
    }
}

fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Sim {
            iface,
            family,
            plant,
            config,
            node_id,
            period_s,
            heartbeat_period_s,
            faults,
            duration_s,
            record,
            seconds,
            profile,
            drive_faults,
            reboot_at_s,
            print_eds,
        } => {
            if print_eds {
                let profile = profile.ok_or_else(|| {
                    anyhow::anyhow!("--print-eds needs --profile cia402 or cia401")
                })?;
                let od = actuatord::simnode::profile::dictionary(profile, node_id);
                let name = match profile {
                    actuatord::simnode::Profile::Cia402 => "drive",
                    actuatord::simnode::Profile::Cia401 => "I/O module",
                };
                let info = actuatord::canopen::EdsInfo {
                    file_name: format!("actuator-sim-{profile}.eds"),
                    description: format!("actuator sim --profile {profile}: simulated {name}"),
                    product_name: format!("actuator sim {profile}"),
                    ..Default::default()
                };
                print!("{}", actuatord::canopen::render_eds(&od, &info));
                return Ok(());
            }
            anyhow::ensure!(
                drive_faults.is_empty() || profile == Some(actuatord::simnode::Profile::Cia402),
                "--drive-fault needs --profile cia402"
            );
            let (plant, spec) = sim_plant(plant, family, profile)?;
            anyhow::ensure!(
                profile.is_some() || matches!(spec.command, CommandUnit::Volt | CommandUnit::Duty),
                "{}: command {:?} cannot be carried by the command frame (voltage or duty); set command = \"voltage\"",
                plant.name(),
                spec.command
            );
            let model = spec.build_named(&plant.name())?;
            if let Some(profile) = profile {
                let drive = profile == actuatord::simnode::Profile::Cia402;
                let takes_force =
                    matches!(spec.command, CommandUnit::Newton | CommandUnit::NewtonMetre);
                anyhow::ensure!(
                    drive == takes_force,
                    "{}: command {:?} does not fit --profile {profile}: a cia402 drive applies force or torque (command = \"force\" or \"torque\"), a cia401 module outputs voltage or duty",
                    plant.name(),
                    spec.command
                );
                anyhow::ensure!(record.is_none(), "--record runs offline without a profile");
            }
            if let Some(csv) = record {
                let config = Source::or_builtin(config, defaults::config(spec.family));
                return sim_offline(&config, model, faults, &csv, seconds);
            }
            anyhow::ensure!(
                (1..=127).contains(&node_id),
                "--node-id must be 1..=127, got {node_id}"
            );
            anyhow::ensure!(period_s > 0.0, "--period-s must be > 0, got {period_s}");
            anyhow::ensure!(
                heartbeat_period_s > 0.0,
                "--heartbeat-period-s must be > 0, got {heartbeat_period_s}"
            );
            let mut bus = SocketCanBus::open(&iface)?;
            // An actuator's firmware runs from RAM: its answer to a SYNC must not wait for a
            // page of code to be read in (where the limit allows; without it, it runs as is).
            let locked = actuatord::daemon::rt::lock_memory().is_ok();
            eprintln!(
                "actuator sim: {} node {node_id} on {iface}, {} ms per SYNC{}",
                model.family().name(),
                period_s * 1e3,
                if locked { "" } else { " (memory not locked)" }
            );
            let mut node = SimNode::new(node_id, model, period_s, faults);
            if let Some(t) = reboot_at_s {
                node = node.with_reboot_at(t);
            }
            if let Some(profile) = profile {
                eprintln!("actuator sim: speaking {profile}");
                node = node.with_profile(actuatord::simnode::ProfileNode::new(
                    profile,
                    node_id,
                    drive_faults,
                ));
            } else {
                // A standard node's PDO identifiers are whatever its master maps over SDO, so
                // only our own node can filter by a fixed list.
                bus.accept_only(&node.accepted_ids())?;
            }
            let stop = Arc::new(AtomicBool::new(false));
            watch_signals(stop.clone())?;
            run_sim_node(
                &mut bus,
                &mut node,
                Duration::from_secs_f64(heartbeat_period_s),
                duration_s.map(Duration::from_secs_f64),
                &stop,
                &mut |e| {
                    match e {
                    SimEvent::FaultInjected {
                        fault,
                        plant_time_s,
                        sync_count,
                    } => eprintln!(
                        "actuator sim: fault {} injected at plant time {plant_time_s:.4} s, after SYNC #{sync_count}",
                        fault.fault
                    ),
                    SimEvent::StateChanged(s) => eprintln!("actuator sim: node is {}", s.name()),
                    SimEvent::Rebooted { plant_time_s } => eprintln!("actuator sim: rebooted at plant time {plant_time_s:.4} s (factory values, pre-operational)"),
                    SimEvent::Malformed(f) => eprintln!("actuator sim: malformed frame ignored: {f}"),
                    SimEvent::BusLost(cause) => eprintln!("actuator sim: bus fault: {cause}; waiting for the bus"),
                    SimEvent::BusRestored { cause, outage_s } => eprintln!("actuator sim: bus back after {outage_s:.3} s of {cause}"),
                }
                },
            )?;
            let c = node.counters();
            eprintln!(
                "actuator sim: stopped after {} SYNCs, {} commands ({} late), {} malformed frames",
                c.syncs, c.commands, c.late_commands, c.malformed
            );
            Ok(())
        }
        Command::Demo {
            config,
            plant,
            record,
            lockstep,
        } => {
            let script = actuatord::demo::Script::standard()?;
            eprintln!(
                "actuator demo: {:.1} s of closed-loop control at 400 Hz on the in-process bus ...",
                script.duration_s
            );
            let summary = actuatord::demo::run_with(
                &Source::or_builtin(config, defaults::config(Family::Solenoid)),
                &Source::or_builtin(plant, defaults::plant(Family::Solenoid)),
                &script,
                &record,
                if lockstep {
                    actuatord::demo::Clock::LockStep
                } else {
                    actuatord::demo::Clock::RealTime
                },
            )?;
            println!("{summary}");
            Ok(())
        }
        Command::Lab(cmd) => lab::run(cmd),
        Command::Tune {
            model,
            config,
            out,
            goal,
            tour,
            max_spread,
            axis,
            fault_table,
            robust_plant,
        } => {
            let fitted = actuatord::tune::Fitted::load(&model)?;
            let text = std::fs::read_to_string(&config)
                .map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", config.display()))?;
            let options = actuatord::tune::TuneOptions {
                goal: actuatord::tune::Goal::default(),
                max_spread,
                axis,
            };
            let tour = tour
                .as_deref()
                .map(actuatord::tune::Tour::load)
                .transpose()?;
            if fitted.model.spec.family == actuatord::physics::Family::Pneumatic {
                let actuatord::tune::Aim::Search(objective) = goal else {
                    anyhow::bail!(
                        "{}: --goal bandwidth is the electromechanical drives' pole placement; a \
                         pneumatic axis is searched over its closed-loop pole (--goal rms, \
                         settling, overshoot or steady)",
                        model.display()
                    );
                };
                anyhow::ensure!(
                    fault_table.is_none() && robust_plant.is_none(),
                    "{}: --fault-table and --robust-plant are for the electromechanical drives; \
                     a pneumatic axis is tuned by its drive gains",
                    model.display()
                );
                let choice = actuatord::tune::choose_pneumatic(
                    &fitted, &text, &config, &options, objective, tour,
                )?;
                return write_choice(&choice, &text, &out);
            }
            // Checked before anything is written.
            let robust = robust_plant
                .as_ref()
                .map(|_| actuatord::tune::robust_plant_file(&fitted))
                .transpose()?;
            let mut choice =
                actuatord::tune::choose(&fitted, &text, &config, &options, goal, tour)?;
            if let (Some(table), Some(tuning)) = (&fault_table, choice.tuning_mut()) {
                // The configuration names the table relative to its own folder.
                let key = table
                    .file_name()
                    .map(|n| n.to_string_lossy().to_string())
                    .ok_or_else(|| anyhow::anyhow!("--fault-table needs a file name"))?;
                let beside = out.parent().unwrap_or(Path::new(".")).join(&key);
                anyhow::ensure!(
                    beside == *table || table.parent() == out.parent(),
                    "--fault-table {} must be in the folder of --out {}",
                    table.display(),
                    out.display()
                );
                let summary =
                    actuatord::tune::regenerate_fault_table(tuning, &fitted, &out, table, &key)?;
                print!("fault-symptom table for the fitted plant:\n{summary}");
            }
            if choice.tuning().is_none() && fault_table.is_some() {
                println!("no fault-symptom table written: the given configuration stays");
            }
            write_choice(&choice, &text, &out)?;
            if let (Some(path), Some(text)) = (&robust_plant, robust) {
                std::fs::write(path, text)
                    .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))?;
                println!(
                    "wrote {p}: the fitted plant; `actuator design robust --plant {p} --out \
                     controller.toml` designs the H-infinity controller on it, and \
                     [{axis}.{controller}] {file} = \"controller.toml\" runs it",
                    p = path.display(),
                    axis = actuatord::param_key!(Config, axis),
                    controller =
                        actuatord::param_key!(actuatord::daemon::config::AxisConfig, controller),
                    file = actuatord::param_key!(
                        actuatord::daemon::config::ControllerSection,
                        state_space_file
                    ),
                );
            }
            Ok(())
        }
        Command::Sdo {
            iface,
            node,
            config,
            timeout_s,
            op,
        } => sdo(&iface, node, &config, timeout_s, op),
        Command::Faults {
            iface,
            node,
            timeout_s,
            state,
        } => {
            let (source, entries) = match state {
                Some(file) => (file.display().to_string(), faults::from_state_file(&file)?),
                None => {
                    anyhow::ensure!(
                        timeout_s > 0.0 && timeout_s.is_finite(),
                        "--timeout-s must be > 0, got {timeout_s}"
                    );
                    let timeout = Duration::from_secs_f64(timeout_s);
                    (
                        format!("node {node} on {iface}"),
                        faults::from_daemon(&iface, node, timeout)?,
                    )
                }
            };
            print!("{}", faults::render(&source, &entries));
            Ok(())
        }
        Command::Decode {
            log,
            controller_node,
            actuator_node,
        } => decode(&log, controller_node, actuator_node),
        Command::Eds { config } => {
            let c = Source::or_builtin(config, defaults::config(Family::Solenoid)).config()?;
            let od = actuatord::daemon::dictionary::build(&c)?;
            print!(
                "{}",
                actuatord::canopen::render_eds(&od, &actuatord::canopen::EdsInfo::default())
            );
            Ok(())
        }
        Command::ConfigDoc { config } => {
            let source = Source::or_builtin(config, defaults::config(Family::Solenoid));
            let c = source.config()?;
            print!(
                "{}",
                actuatord::daemon::config_reference::render(&c, &format!("`{}`", source.name()))?
            );
            Ok(())
        }
        Command::Design {
            what: DesignCommand::Robust { plant, out },
        } => {
            let design = actuatord::design::design_robust(&plant)?;
            println!("{design}");
            actuatord::design::write_controller_toml(&design, &out)?;
            println!("controller written to {}", out.display());
            Ok(())
        }
        Command::Bench {
            what: BenchCommand::Robust { plant, json },
        } => {
            let design = actuatord::design::design_robust_with(
                &plant,
                actuatord::control::robust::DesignOptions::bao_2016(),
            )?;
            let rows = actuatord::design::run_comparison(
                &design,
                &actuatord::design::ComparisonConfig::default(),
            )?;
            if json {
                println!("{}", serde_json::to_string_pretty(&rows)?);
            } else {
                println!("{}", actuatord::design::ComparisonTable(&rows));
            }
            Ok(())
        }
        Command::Bench {
            what: BenchCommand::Paper { json },
        } => {
            let rows = actuatord::bench::run_paper_bench();
            if json {
                println!("{}", serde_json::to_string_pretty(&rows)?);
            } else {
                println!("{}", actuatord::bench::PaperTable(&rows));
            }
            Ok(())
        }
        Command::Bench {
            what: BenchCommand::Supply { json },
        } => {
            let rows = actuatord::bench::supply::run_supply_bench()?;
            if json {
                println!("{}", serde_json::to_string_pretty(&rows)?);
            } else {
                print!("{}", actuatord::bench::supply::SupplyTable(&rows));
            }
            Ok(())
        }
        Command::Bench {
            what: BenchCommand::FaultTable { out, check },
        } => {
            print!(
                "{}",
                actuatord::bench::fault_table::regenerate(&out, check)?
            );
            Ok(())
        }
        Command::Bench {
            what:
                BenchCommand::Rt {
                    config,
                    plant,
                    period,
                    seconds,
                    load,
                    iface,
                    json,
                },
        } => {
            let report = actuatord::bench::rt::run(&RtBenchOptions {
                config,
                plant,
                period_s: period,
                seconds,
                load,
                iface,
            })?;
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                println!("{report}");
            }
            Ok(())
        }
        Command::Bench {
            what:
                BenchCommand::Soak {
                    minutes,
                    iface,
                    config,
                    plant,
                    daemon,
                    out,
                    json,
                },
        } => {
            let report = actuatord::bench::soak::run(&actuatord::bench::soak::SoakOptions {
                config,
                plant,
                iface,
                minutes,
                daemon,
                out,
            })?;
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                println!("{report}");
            }
            anyhow::ensure!(
                report.crashes.is_empty(),
                "the soak saw a crash: {}",
                report.crashes.join("; ")
            );
            Ok(())
        }
        Command::Dbc {
            config: Some(config),
            ..
        } => {
            let c = Config::load(&config)?;
            let text = actuatord::daemon::profile_dbc::render_config_dbc(&c)
                .map_err(|e| anyhow::anyhow!("{}: {e}", config.display()))?;
            print!("{text}");
            Ok(())
        }
        Command::Dbc {
            controller_node,
            actuator_node,
            config: None,
        } => {
            print!(
                "{}",
                actuatord::device::dbc::render(controller_node, actuator_node)
            );
            Ok(())
        }
    }
}

/// Print every line of a candump log with its message and signals; say what does not decode.
fn decode(log: &Path, controller_node: u8, actuator_node: u8) -> anyhow::Result<()> {
    use std::io::BufRead;
    let reader: Box<dyn BufRead> = if log == Path::new("-") {
        Box::new(std::io::BufReader::new(std::io::stdin()))
    } else {
        Box::new(std::io::BufReader::new(std::fs::File::open(log).map_err(
            |e| anyhow::anyhow!("{}: cannot open: {e}", log.display()),
        )?))
    };
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for (n, line) in reader.lines().enumerate() {
        let line = line.map_err(|e| anyhow::anyhow!("{}:{}: {e}", log.display(), n + 1))?;
        if line.trim().is_empty() {
            continue;
        }
        let text = match actuatord::bus::parse_candump_line(&line) {
            Err(e) => format!("{line} :: not decoded: {e}"),
            Ok(rec) => {
                match actuatord::device::decode_frame(&rec.frame, controller_node, actuator_node) {
                    None => format!("{line} :: id not in the protocol"),
                    Some((m, Err(len))) => {
                        format!(
                            "{line} :: {} with {len} data bytes, expected {}",
                            m.name, m.dlc
                        )
                    }
                    Some((m, Ok(signals))) => {
                        let fields: Vec<String> = signals.iter().map(|s| s.to_string()).collect();
                        format!("{line} :: {}({})", m.name, fields.join(", "))
                    }
                }
            }
        };
        std::io::Write::write_all(&mut out, text.as_bytes())?;
        std::io::Write::write_all(&mut out, b"\n")?;
    }
    Ok(())
}

/// One SDO transfer with a running daemon, printed as the object's type.
fn sdo(iface: &str, node: u8, config: &Path, timeout_s: f64, op: SdoOp) -> anyhow::Result<()> {
    use actuatord::canopen::sdo::{encode_text, format_bytes};
    anyhow::ensure!(
        (1..=127).contains(&node),
        "--node must be 1..=127, got {node}"
    );
    let od = Config::load(config)
        .ok()
        .and_then(|c| actuatord::daemon::dictionary::build(&c).ok());
    let object = match &op {
        SdoOp::Read { object } | SdoOp::Write { object, .. } => object.clone(),
    };
    let (id, data_type) = match actuatord::canopen::od::ObjectId::parse(&object) {
        Some(id) => (
            id,
            od.as_ref()
                .and_then(|od| od.find(id).ok().map(|h| od.entry(h).data_type)),
        ),
        None => {
            let od = od.as_ref().ok_or_else(|| {
                anyhow::anyhow!(
                    "{object}: names need a readable --config ({})",
                    config.display()
                )
            })?;
            let h = od
                .lookup(&object)
                .map_err(|e| anyhow::anyhow!("{object}: {e}"))?;
            (od.entry(h).id, Some(od.entry(h).data_type))
        }
    };
    let mut bus = SocketCanBus::open(iface)?;
    let timeout = Duration::from_secs_f64(timeout_s);
    let write = matches!(op, SdoOp::Write { .. });
    let outcome = match op {
        SdoOp::Read { .. } => actuatord::client::sdo_read(&mut bus, node, id, timeout)?,
        SdoOp::Write { value, .. } => {
            let bytes = encode_text(data_type, &value)
                .map_err(|e| anyhow::anyhow!("{object}: value {value:?}: {e}"))?;
            actuatord::client::sdo_write(&mut bus, node, id, &bytes, timeout)?
        }
    };
    match outcome {
        Ok(_) if write => {
            println!("{id}: written");
            Ok(())
        }
        Ok(bytes) => {
            println!("{}", format_bytes(data_type, &bytes));
            Ok(())
        }
        Err(e) => Err(anyhow::anyhow!("{e}")),
    }
}

/// Offline closed loop: the controller of `config` against `plant`, written as CSV.
/// Print a choice of `tune` (the chosen tuning's report, the designs tried and the predictions)
/// and write what it chose to `out`: the tuned configuration, or the given one unchanged.
fn write_choice<T: actuatord::tune::choice::Tuned + std::fmt::Display>(
    choice: &actuatord::tune::Choice<T>,
    given: &str,
    out: &Path,
) -> anyhow::Result<()> {
    if let Some(tuning) = choice.tuning() {
        print!("{tuning}");
    }
    print!("{choice}");
    std::fs::write(out, choice.text(given))
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", out.display()))?;
    println!(
        "wrote {}{}",
        out.display(),
        if choice.accepted {
            ""
        } else {
            " (the given configuration, unchanged)"
        }
    );
    Ok(())
}

fn sim_offline(
    config_source: &Source,
    plant: Box<dyn actuatord::physics::Plant>,
    faults: Vec<ScheduledFault>,
    csv: &Path,
    seconds: f64,
) -> anyhow::Result<()> {
    anyhow::ensure!(seconds > 0.0, "--seconds must be > 0, got {seconds}");
    let config = config_source.config()?;
    let command = config
        .axis
        .first()
        .map(|a| a.command)
        .ok_or_else(|| anyhow::anyhow!("{}: no [[axis]]", config_source.name()))?;
    let pressure = plant.family() == actuatord::physics::Family::Pneumatic;
    // A gear's positions are load angles.
    let length_unit = if plant.family() == actuatord::physics::Family::MotorGear {
        "µrad"
    } else {
        "µm"
    };
    let mut rig = LockStep::new(&config, plant, faults)?;
    let mut samples = Vec::with_capacity((seconds / config.cycle.period_s) as usize + 1);
    rig.run(seconds, &mut |s| samples.push(*s));
    let file = std::fs::File::create(csv)
        .map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", csv.display()))?;
    let mut out = std::io::BufWriter::new(file);
    write_csv(&mut out, &samples, command, pressure)
        .and_then(|()| std::io::Write::flush(&mut out))
        .map_err(|e| anyhow::anyhow!("{}: {e}", csv.display()))?;
    let c = rig.controller().counters();
    // The tracking of the run, figured as `tune` predicts it: the following error against the
    // reference the axis applied (after its rate limit), from the first set-point change on.
    let axis = &config.axis[0];
    let start = axis.setpoints.first().map_or(0.0, |s| s.at_s);
    let records: Vec<_> = samples.iter().map(|s| s.record).collect();
    let figures = actuatord::lockstep::TourFigures::of(&records, axis)
        .map(|f| f.line(1e6, length_unit))
        .unwrap_or_else(|| "no record after the first set-point change".to_string());
    eprintln!(
        "actuator sim: {} samples ({seconds} s at {} ms) written to {}; faults raised: {}; \
         tracking from {start} s: {figures}",
        samples.len(),
        config.cycle.period_s * 1e3,
        csv.display(),
        c.faults_raised,
    );
    Ok(())
}

/// Raise `stop` on SIGTERM or SIGINT, from a helper thread with a small runtime of its own.
fn watch_signals(stop: Arc<AtomicBool>) -> anyhow::Result<()> {
    use tokio::signal::unix::{signal, SignalKind};
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    // Register before returning, so a signal sent right after start-up is not missed.
    let (mut term, mut int) = rt.block_on(async {
        anyhow::Ok((
            signal(SignalKind::terminate())?,
            signal(SignalKind::interrupt())?,
        ))
    })?;
    std::thread::spawn(move || {
        rt.block_on(async {
            tokio::select! {
                _ = term.recv() => {}
                _ = int.recv() => {}
            }
        });
        stop.store(true, Ordering::Relaxed);
    });
    Ok(())
}
