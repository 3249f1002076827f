//! `actuator demo`: the daemon's cycle and a simulated solenoid node in one process, on the
//! in-process bus. A scripted run of setpoint steps and injected faults, then a short summary.

use crate::bus::InProcBus;
use crate::daemon::config::SetpointStep;
use crate::daemon::record::CycleRecord;
use crate::daemon::recorder::{read_cycles, Recorder, RecorderError};
use crate::daemon::{run_cycle, ControllerNode, CycleReport, CycleSettings};
use crate::defaults::Source;
use crate::physics::{PhysicsError, ScheduledFault};
use crate::simnode::{run_sim_node, SimEvent, SimNode};
use crate::supervise::{FaultFlags, FaultKind};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

/// The script: setpoint steps (small and large), then faults.
pub struct Script {
    pub setpoints: Vec<SetpointStep>,
    pub faults: Vec<ScheduledFault>,
    pub duration_s: f64,
}

impl Script {
    /// Small and large steps, a friction increase (F3) the limit checks cannot see, more steps,
    /// and finally a supply drop that they must see.
    pub fn standard() -> Result<Self, PhysicsError> {
        let step = |at_s, position_m| SetpointStep { at_s, position_m };
        Ok(Self {
            setpoints: vec![
                step(0.0, 0.005),
                step(1.0, 0.0052),
                step(2.0, 0.0050),
                step(3.0, 0.015),
                step(4.0, 0.010),
                step(5.5, 0.0102),
                step(6.5, 0.0100),
                step(7.5, 0.018),
            ],
            faults: vec!["friction_x3@5s".parse()?, "supply_x0.6@8.5s".parse()?],
            duration_s: 9.5,
        })
    }
}

/// Steady-state figures of one setpoint step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepSummary {
    pub at_s: f64,
    pub from_m: f64,
    pub to_m: f64,
    /// Mean of setpoint - position over the window's last 200 ms.
    pub steady_state_error_m: f64,
    /// First time after the step from which |error| stays below 5 % of the step (or 50 µm).
    pub settling_time_s: Option<f64>,
    /// Faults active at the end of the window.
    pub faults: FaultFlags,
}

#[derive(Debug, Clone, PartialEq)]
pub struct DemoSummary {
    pub steps: Vec<StepSummary>,
    /// Faults injected: plant time, SYNCs the node had seen, name.
    pub injected: Vec<(f64, u64, String)>,
    /// Faults raised: cycle time, cycle number (= SYNCs sent), kind.
    pub faults_raised: Vec<(f64, u64, FaultKind)>,
    pub cycle: CycleReport,
    pub sensor_missed: u64,
    pub records_dropped: u64,
    pub recording: PathBuf,
}

#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    #[error(transparent)]
    Config(#[from] crate::daemon::config::ConfigError),
    #[error(transparent)]
    Plant(#[from] PhysicsError),
    #[error(transparent)]
    Node(#[from] crate::daemon::node::NodeError),
    #[error(transparent)]
    Recorder(#[from] RecorderError),
    #[error(transparent)]
    Bus(#[from] crate::bus::BusError),
    #[error("a demo thread panicked")]
    Panicked,
}

/// Run the script against the plant in `plant_path`, with the controller of `config_path`.
pub fn run(
    config_path: &Path,
    plant_path: &Path,
    script: &Script,
    recording: &Path,
) -> Result<DemoSummary, DemoError> {
    run_from(
        &Source::File(config_path.to_path_buf()),
        &Source::File(plant_path.to_path_buf()),
        script,
        recording,
    )
}

/// Run the script with a configuration and a plant from files or built in.
pub fn run_from(
    config_source: &Source,
    plant_source: &Source,
    script: &Script,
    recording: &Path,
) -> Result<DemoSummary, DemoError> {
    let config_path = &PathBuf::from(config_source.name());
    let mut config = config_source.config()?;
    config.cycle.realtime_priority = 0;
    config.cycle.lock_memory = false;
    let axis =
        config
            .axis
            .first_mut()
            .ok_or_else(|| crate::daemon::config::ConfigError::Invalid {
                file: config_path.to_path_buf(),
                key: "[[axis]]".into(),
                rule: "needs at least one axis".into(),
            })?;
    axis.setpoints = script.setpoints.clone();
    if let Some(first) = script.setpoints.first() {
        axis.initial_setpoint_m = first.position_m;
    }
    config.validate(config_path)?;
    let node_id = config.axis[0].actuator_node_id;
    let period_s = config.cycle.period_s;
    let plant = plant_source.plant()?;
    let mut sim = SimNode::new(node_id, plant, period_s, script.faults.clone());
    let mut controller = ControllerNode::new(&config)?;

    let mut endpoints = InProcBus::endpoints(2);
    let mut sim_bus = endpoints.pop().ok_or(DemoError::Panicked)?;
    let mut daemon_bus = endpoints.pop().ok_or(DemoError::Panicked)?;
    let stop = Arc::new(AtomicBool::new(false));
    let sim_stop = stop.clone();
    let sim_thread = std::thread::spawn(move || {
        let mut injected = vec![];
        let result = run_sim_node(
            &mut sim_bus,
            &mut sim,
            Duration::from_millis(100),
            None,
            &sim_stop,
            &mut |e| {
                if let SimEvent::FaultInjected {
                    fault,
                    plant_time_s,
                    sync_count,
                } = e
                {
                    injected.push((plant_time_s, sync_count, fault.fault.to_string()));
                }
            },
        );
        result.map(|()| injected)
    });

    let (sink, recorder) = Recorder::spawn(Some(recording), config.record.queue_depth)?;
    let settings = CycleSettings {
        period_s,
        sensor_deadline_s: config.cycle.sensor_deadline_s,
        realtime_priority: 0,
        lock_memory: false,
        duration_s: Some(script.duration_s),
        record_frames: config.record.can_frames,
    };
    let cycle = run_cycle(
        &mut daemon_bus,
        &mut controller,
        settings,
        &stop,
        &std::sync::atomic::AtomicU64::new(0),
        &sink,
    );
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let records_dropped = sink.dropped();
    drop(sink);
    let injected = sim_thread.join().map_err(|_| DemoError::Panicked)??;
    let cycle = cycle?;
    recorder.finish()?;

    let records = read_cycles(recording)?;
    Ok(DemoSummary {
        steps: summarise_steps(&records, &script.setpoints, script.duration_s),
        injected,
        faults_raised: faults_raised(&records),
        cycle,
        sensor_missed: controller.counters().sensor_missed,
        records_dropped,
        recording: recording.to_path_buf(),
    })
}

fn faults_raised(records: &[CycleRecord]) -> Vec<(f64, u64, FaultKind)> {
    let mut out = vec![];
    let mut before = FaultFlags::default();
    for r in records {
        let now = FaultFlags(r.fault_flags);
        for k in now.added_since(before).iter() {
            out.push((r.t_s, r.cycle, k));
        }
        before = now;
    }
    out
}

/// Steady-state error and settling time of each step, from the recorded cycles.
pub fn summarise_steps(
    records: &[CycleRecord],
    steps: &[SetpointStep],
    end_s: f64,
) -> Vec<StepSummary> {
    let mut out = vec![];
    for (i, s) in steps.iter().enumerate() {
        let until = steps.get(i + 1).map_or(end_s, |n| n.at_s);
        let window: Vec<_> = records
            .iter()
            .filter(|r| r.t_s >= s.at_s && r.t_s < until && r.sensor_fresh)
            .collect();
        if window.is_empty() {
            continue;
        }
        let tail: Vec<f64> = window
            .iter()
            .filter(|r| r.t_s >= until - 0.2)
            .map(|r| r.setpoint_position - r.position)
            .collect();
        let from = if i == 0 { 0.0 } else { steps[i - 1].position_m };
        let band = (0.05 * (s.position_m - from).abs()).max(50e-6);
        let settle = window
            .iter()
            .rposition(|r| (r.setpoint_position - r.position).abs() > band)
            .and_then(|last_out| window.get(last_out + 1))
            .map(|r| r.t_s - s.at_s);
        out.push(StepSummary {
            at_s: s.at_s,
            from_m: from,
            to_m: s.position_m,
            steady_state_error_m: if tail.is_empty() {
                f64::NAN
            } else {
                tail.iter().sum::<f64>() / tail.len() as f64
            },
            settling_time_s: settle,
            faults: FaultFlags(window.last().map_or(0, |r| r.fault_flags)),
        });
    }
    out
}

impl std::fmt::Display for DemoSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "setpoint steps (steady-state error = mean of setpoint - position over the last 200 ms):")?;
        writeln!(
            f,
            "   t/s   from/mm   to/mm   steady-state error/µm   settling/ms   faults"
        )?;
        for s in &self.steps {
            writeln!(
                f,
                "{:6.2}  {:8.3}  {:6.3}   {:>21.1}   {:>11}   {}",
                s.at_s,
                s.from_m * 1e3,
                s.to_m * 1e3,
                s.steady_state_error_m * 1e6,
                s.settling_time_s
                    .map_or("-".to_string(), |t| format!("{:.0}", t * 1e3)),
                s.faults,
            )?;
        }
        writeln!(f, "faults injected into the simulated actuator:")?;
        for (t, sync, name) in &self.injected {
            writeln!(f, "  t={t:.3} s (SYNC #{sync})  {name}")?;
        }
        if self.faults_raised.is_empty() {
            writeln!(f, "faults raised by the controller: none")?;
        } else {
            writeln!(
                f,
                "faults raised by the controller (EMCY sent, axis to safe state):"
            )?;
            for (t, cycle, k) in &self.faults_raised {
                // Latency counted in SYNCs from the injection that could have caused it.
                let after = self
                    .injected
                    .iter()
                    .filter(|(_, sync, _)| sync <= cycle)
                    .map(|(_, sync, _)| cycle - sync)
                    .min();
                match after {
                    Some(n) => writeln!(
                        f,
                        "  t={t:.4} s  {k}  ({n} periods after the last fault injected)"
                    )?,
                    None => writeln!(f, "  t={t:.4} s  {k}")?,
                }
            }
        }
        writeln!(
            f,
            "cycles: {}  overruns: {}  sensor frames missed: {}  SCHED_FIFO: {}  records dropped: {}",
            self.cycle.cycles,
            self.cycle.overruns,
            self.sensor_missed,
            if self.cycle.realtime { "yes" } else { "no" },
            self.records_dropped
        )?;
        write!(f, "recording: {}", self.recording.display())
    }
}
