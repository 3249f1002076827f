//! `actuator demo`: the daemon's cycle and a simulated solenoid node in one process, on the
//! in-process bus. A scripted run of setpoint steps and injected faults, then a short summary.

use crate::bus::InProcBus;
use crate::daemon::config::SetpointStep;
use crate::daemon::record::{CycleRecord, Record};
use crate::daemon::recorder::{read_cycles, RecordSink, Recorder, RecorderError};
use crate::daemon::{run_cycle, ControllerNode, CycleReport, CycleSettings};
use crate::defaults::Source;
use crate::device::{messages, Emcy};
use crate::physics::{PhysicsError, ScheduledFault};
use crate::simnode::{run_sim_node, SimEvent, SimNode};
use crate::supervise::{FaultFlags, FaultKind, FaultState, SupervisedFault};
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

/// When the standard script's phases begin (s): nominal steps from 0, a friction increase,
/// a supply dip and its end, a real fault.
pub const FRICTION_AT_S: f64 = 5.0;
pub const DIP_AT_S: f64 = 12.0;
pub const DIP_END_S: f64 = 14.0;
pub const FAULT_AT_S: f64 = 15.5;

impl Script {
    /// The story in four phases: small and large steps at the nominal supply; a friction
    /// increase ×3 (F3), which the limit checks cannot see, the observer flags and the adaptive
    /// compensation takes up over the small steps that follow; a supply dip to 70 % (16.8 V,
    /// outside the scheduled band, inside the hard band), which scheduling rides out with a
    /// warning; then the supply collapses to 50 % (12 V), below the hard band: the safe state.
    pub fn standard() -> Result<Self, PhysicsError> {
        let step = |at_s, position_m| SetpointStep { at_s, position_m };
        let mut setpoints = vec![
            step(0.0, 0.005),
            step(1.0, 0.0052),
            step(2.0, 0.0050),
            step(3.0, 0.015),
            step(4.0, 0.010),
        ];
        // Friction: small steps, one a second, while the compensation adapts.
        for i in 0..7 {
            let at = FRICTION_AT_S + 0.5 + f64::from(i);
            setpoints.push(step(at, if i % 2 == 0 { 0.0102 } else { 0.0100 }));
        }
        // The dip and after it: the same small steps.
        setpoints.push(step(DIP_AT_S + 0.5, 0.0100));
        setpoints.push(step(DIP_AT_S + 1.25, 0.0102));
        setpoints.push(step(DIP_END_S + 0.5, 0.0100));
        setpoints.push(step(FAULT_AT_S + 0.5, 0.005));
        Ok(Self {
            setpoints,
            faults: vec![
                format!("friction_x3@{FRICTION_AT_S}s").parse()?,
                format!("supply_x0.7@{DIP_AT_S}s").parse()?,
                // 0.7 x 1/0.7: back to 24 V.
                format!("supply_x{}@{DIP_END_S}s", 1.0 / 0.7).parse()?,
                format!("supply_x0.5@{FAULT_AT_S}s").parse()?,
            ],
            duration_s: FAULT_AT_S + 1.5,
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
    /// Faults raised from the step until it settled (or, unsettled, until its window ended):
    /// never one that came after it settled.
    pub faults: FaultFlags,
}

#[derive(Debug, Clone, PartialEq)]
pub struct DemoSummary {
    pub steps: Vec<StepSummary>,
    /// Faults injected: plant time, SYNCs the node had seen, name.
    pub injected: Vec<(f64, u64, String)>,
    /// Faults raised: cycle time, cycle number (= SYNCs sent), kind.
    pub faults_raised: Vec<(f64, u64, FaultKind)>,
    /// EMCY frames the controller sent: cycle time, error code, state after the event.
    pub emcys: Vec<(f64, u16, FaultState)>,
    /// The story's figures, phase by phase (the standard script's phases).
    pub phases: PhaseFigures,
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

/// Run the script with a configuration and a plant from files or built in, in real time.
pub fn run_from(
    config_source: &Source,
    plant_source: &Source,
    script: &Script,
    recording: &Path,
) -> Result<DemoSummary, DemoError> {
    run_with(
        config_source,
        plant_source,
        script,
        recording,
        Clock::RealTime,
    )
}

/// How the demo advances.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clock {
    /// The daemon's real-time cycle and the simulated node in threads on the in-process bus.
    RealTime,
    /// Controller and node frame by frame, as fast as the machine goes, no clocks: the same
    /// run on any machine (tests).
    LockStep,
}

/// What the demo saw go by besides the cycles: EMCY frames (cycle time, error code, state).
type Emcys = Vec<(f64, u16, FaultState)>;

fn tap_emcy(record: &Record, controller_node: u8, emcys: &mut Emcys) {
    if let Record::Frame {
        t_s,
        frame,
        received: false,
    } = record
    {
        if frame.id() == messages::EMCY.cob_id(controller_node) {
            if let Ok(e) = Emcy::decode(frame) {
                emcys.push((*t_s, e.error_code, e.state));
            }
        }
    }
}

/// Run the script with the given clock.
pub fn run_with(
    config_source: &Source,
    plant_source: &Source,
    script: &Script,
    recording: &Path,
    clock: Clock,
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
                key: format!("[[{}]]", crate::param_key!(crate::daemon::Config, axis)),
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
    let sim = SimNode::new(node_id, plant, period_s, script.faults.clone());
    let controller = ControllerNode::new(&config)?;

    // EMCY frames must reach the recording: they tell the warnings apart from the faults.
    config.record.can_frames = true;
    let (injected, cycle, sensor_missed, records_dropped, emcys) = match clock {
        Clock::RealTime => run_real_time(&config, sim, controller, script, recording)?,
        Clock::LockStep => run_lock_step(&config, sim, controller, script, recording)?,
    };
    let records = read_cycles(recording)?;
    Ok(DemoSummary {
        steps: summarise_steps(
            &records,
            &script.setpoints,
            script.duration_s,
            &script.faults,
        ),
        phases: phase_figures(&records, script, &emcys),
        injected,
        faults_raised: faults_raised(&records),
        emcys,
        cycle,
        sensor_missed,
        records_dropped,
        recording: recording.to_path_buf(),
    })
}

type RunOutcome = (Vec<(f64, u64, String)>, CycleReport, u64, u64, Emcys);

fn run_real_time(
    config: &crate::daemon::config::Config,
    mut sim: SimNode,
    mut controller: ControllerNode,
    script: &Script,
    recording: &Path,
) -> Result<RunOutcome, DemoError> {
    let period_s = config.cycle.period_s;
    let controller_node = config.node.node_id;
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

    let (to_writer, recorder) = Recorder::spawn(Some(recording), config.record.queue_depth)?;
    // Between the cycle and the writer: a look at the EMCY frames on their way.
    let (sink, from_cycle) = RecordSink::channel(config.record.queue_depth);
    let tee = std::thread::spawn(move || {
        let mut emcys = Emcys::new();
        for r in from_cycle {
            tap_emcy(&r, controller_node, &mut emcys);
            to_writer.push(r);
        }
        (emcys, to_writer.dropped())
    });
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
    let dropped_at_tee = sink.dropped();
    drop(sink);
    let injected = sim_thread.join().map_err(|_| DemoError::Panicked)??;
    let (emcys, dropped_at_writer) = tee.join().map_err(|_| DemoError::Panicked)?;
    let cycle = cycle?;
    recorder.finish()?;
    Ok((
        injected,
        cycle,
        controller.counters().sensor_missed,
        dropped_at_tee + dropped_at_writer,
        emcys,
    ))
}

fn run_lock_step(
    config: &crate::daemon::config::Config,
    mut sim: SimNode,
    mut controller: ControllerNode,
    script: &Script,
    recording: &Path,
) -> Result<RunOutcome, DemoError> {
    let period_s = config.cycle.period_s;
    let controller_node = config.node.node_id;
    let cycles = (script.duration_s / period_s).round() as u64;
    // Nothing paces the cycles here: the queue holds the whole run (a cycle record and a
    // handful of frames per cycle), so the writer never falls behind into dropping records.
    let depth = (cycles as usize)
        .saturating_mul(12)
        .max(config.record.queue_depth);
    let (sink, recorder) = Recorder::spawn(Some(recording), depth)?;
    let mut emcys = Emcys::new();
    let mut injected = vec![];
    let push = |r: Record, emcys: &mut Emcys| {
        tap_emcy(&r, controller_node, emcys);
        sink.push(r);
    };
    let mut to_sim = vec![];
    sim.boot(&mut |_| {});
    controller.boot(&mut |f| to_sim.push(*f), &mut |r| push(r, &mut emcys));
    let heartbeat_every = ((0.1 / period_s).round() as u64).max(1);
    let on_sim = |e: SimEvent, injected: &mut Vec<(f64, u64, String)>| {
        if let SimEvent::FaultInjected {
            fault,
            plant_time_s,
            sync_count,
        } = e
        {
            injected.push((plant_time_s, sync_count, fault.fault.to_string()));
        }
    };
    for f in &to_sim {
        sim.handle(f, &mut |_| {}, &mut |e| on_sim(e, &mut injected));
    }
    let record_frames = config.record.can_frames;
    for k in 0..cycles {
        let t = k as f64 * period_s;
        let mut inbox = vec![];
        if k % heartbeat_every == 0 {
            inbox.push(sim.heartbeat());
        }
        controller.begin_cycle();
        let sync = controller.sync_frame();
        if record_frames {
            push(
                Record::Frame {
                    t_s: t,
                    frame: sync,
                    received: false,
                },
                &mut emcys,
            );
        }
        sim.handle(&sync, &mut |a| inbox.push(*a), &mut |e| {
            on_sim(e, &mut injected)
        });
        for f in &inbox {
            if record_frames {
                push(
                    Record::Frame {
                        t_s: t,
                        frame: *f,
                        received: true,
                    },
                    &mut emcys,
                );
            }
            controller.handle(f, t, &mut |r| push(r, &mut emcys));
        }
        let mut out = vec![];
        controller.finish_cycle(
            t,
            crate::daemon::node::CycleTiming::default(),
            &mut |f| out.push(*f),
            &mut |r| push(r, &mut emcys),
        );
        for f in &out {
            if record_frames {
                push(
                    Record::Frame {
                        t_s: t,
                        frame: *f,
                        received: false,
                    },
                    &mut emcys,
                );
            }
            sim.handle(f, &mut |_| {}, &mut |e| on_sim(e, &mut injected));
        }
    }
    let dropped = sink.dropped();
    drop(sink);
    recorder.finish()?;
    Ok((
        injected,
        CycleReport {
            cycles,
            overruns: 0,
            realtime: false,
            memory_locked: false,
        },
        controller.counters().sensor_missed,
        dropped,
        emcys,
    ))
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

/// Steady-state error and settling time of each step, from the recorded cycles. A step's window
/// ends at the next step or at the next fault the script injects, whichever comes first: a
/// step is judged under the conditions it began in.
pub fn summarise_steps(
    records: &[CycleRecord],
    steps: &[SetpointStep],
    end_s: f64,
    injected: &[ScheduledFault],
) -> Vec<StepSummary> {
    let mut out = vec![];
    for (i, s) in steps.iter().enumerate() {
        let next_step = steps.get(i + 1).map_or(end_s, |n| n.at_s);
        let next_fault = injected
            .iter()
            .map(|f| f.at_s)
            .filter(|&t| t > s.at_s)
            .fold(f64::INFINITY, f64::min);
        let until = next_step.min(next_fault);
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
            .map_or(window.first(), |last_out| window.get(last_out + 1))
            .map(|r| r.t_s - s.at_s);
        // Faults raised while the step was on its way: up to the settling, else to the end of
        // the whole step (next setpoint), so a step that never settles shows why.
        let judged_until = settle.map_or(next_step, |t| s.at_s + t);
        let before = records
            .iter()
            .rev()
            .find(|r| r.t_s < s.at_s)
            .map_or(FaultFlags::default(), |r| FaultFlags(r.fault_flags));
        let mut faults = FaultFlags::default();
        for r in records
            .iter()
            .filter(|r| r.t_s >= s.at_s && r.t_s <= judged_until)
        {
            faults = faults.union(FaultFlags(r.fault_flags));
        }
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
            faults: faults.union(before),
        });
    }
    out
}

/// The figures the story is told with.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PhaseFigures {
    /// Mean |steady-state error| and settling time of the small (0.2 mm) nominal steps.
    pub nominal_small_error_m: f64,
    pub nominal_small_settling_s: f64,
    /// First latch of the observer's friction finding after the friction rose, s after it.
    pub observer_flag_delay_s: Option<f64>,
    /// |steady-state error| of the first small step after the friction rose, and the mean of
    /// the last two small steps before the dip (adapted).
    pub friction_error_before_m: f64,
    pub friction_error_after_m: f64,
    /// Adapted friction compensation (up, down), command units, before the friction rose and
    /// before the dip.
    pub compensation_before: (f64, f64),
    pub compensation_after: (f64, f64),
    /// Lowest supply measured in the dip, V, and the gain factor the schedule used there.
    pub dip_supply_min: f64,
    pub dip_gain_factor_max: f64,
    /// The warning EMCY of the dip (error code, s after the dip began).
    pub dip_warning: Option<(u16, f64)>,
    /// The axis reached its safe state during the dip (it must not).
    pub dip_safe_state: bool,
    /// Mean |steady-state error| and settling of the small steps in the dip, and of the two
    /// small steps before it (same friction, same adaptation, 24 V).
    pub dip_error_m: f64,
    pub dip_settling_s: f64,
    pub pre_dip_error_m: f64,
    pub pre_dip_settling_s: f64,
    /// The real fault: the limit that latched, s after the injection, and when the axis was
    /// in its safe state.
    pub fault: Option<(FaultKind, f64)>,
    pub safe_state_after_s: Option<f64>,
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        sum / n as f64
    }
}

/// The figures of the standard script's phases from the recorded cycles and the EMCY frames.
pub fn phase_figures(
    records: &[CycleRecord],
    script: &Script,
    emcys: &[(f64, u16, FaultState)],
) -> PhaseFigures {
    let steps = summarise_steps(
        records,
        &script.setpoints,
        script.duration_s,
        &script.faults,
    );
    let small = |s: &&StepSummary| (s.to_m - s.from_m).abs() < 0.5e-3;
    let in_range = |lo: f64, hi: f64| move |s: &&StepSummary| s.at_s >= lo && s.at_s < hi;
    let err = |s: &&StepSummary| s.steady_state_error_m.abs();
    let settle = |s: &&StepSummary| s.settling_time_s.unwrap_or(f64::NAN);
    let nominal: Vec<_> = steps
        .iter()
        .filter(small)
        .filter(in_range(0.0, FRICTION_AT_S))
        .collect();
    let friction: Vec<_> = steps
        .iter()
        .filter(small)
        .filter(in_range(FRICTION_AT_S, DIP_AT_S))
        .collect();
    let dip: Vec<_> = steps
        .iter()
        .filter(small)
        .filter(in_range(DIP_AT_S, DIP_END_S))
        .collect();
    let pre_dip = &friction[friction.len().saturating_sub(2)..];
    let at = |t: f64| records.iter().find(|r| r.t_s >= t);
    let compensation = |t: f64| {
        at(t).map_or((f64::NAN, f64::NAN), |r| {
            (r.friction_compensation_pos, r.friction_compensation_neg)
        })
    };
    let observer_bit = SupervisedFault::ObserverFriction.bit();
    let dip_records: Vec<_> = records
        .iter()
        .filter(|r| r.t_s >= DIP_AT_S && r.t_s < DIP_END_S && r.sensor_fresh)
        .collect();
    let fault = records
        .iter()
        .filter(|r| r.t_s >= FAULT_AT_S)
        .find_map(|r| {
            FaultFlags(r.fault_flags)
                .iter()
                .next()
                .map(|k| (k, r.t_s - FAULT_AT_S))
        });
    PhaseFigures {
        nominal_small_error_m: mean(nominal.iter().map(err)),
        nominal_small_settling_s: mean(nominal.iter().map(settle)),
        observer_flag_delay_s: records
            .iter()
            .find(|r| r.t_s >= FRICTION_AT_S && r.supervised_faults & observer_bit != 0)
            .map(|r| r.t_s - FRICTION_AT_S),
        friction_error_before_m: friction.first().map_or(f64::NAN, err),
        friction_error_after_m: mean(pre_dip.iter().map(err)),
        compensation_before: compensation(FRICTION_AT_S - 0.01),
        compensation_after: compensation(DIP_AT_S - 0.01),
        dip_supply_min: dip_records
            .iter()
            .map(|r| r.supply_voltage)
            .fold(f64::INFINITY, f64::min),
        dip_gain_factor_max: dip_records
            .iter()
            .map(|r| r.gain_schedule_factor)
            .fold(0.0, f64::max),
        dip_warning: emcys
            .iter()
            .find(|(t, code, _)| *t >= DIP_AT_S && *t < DIP_END_S && *code != 0)
            .map(|(t, code, _)| (*code, t - DIP_AT_S)),
        dip_safe_state: records.iter().any(|r| {
            r.t_s >= DIP_AT_S && r.t_s < FAULT_AT_S && r.fault_state == FaultState::Fault.code()
        }),
        dip_error_m: mean(dip.iter().map(err)),
        dip_settling_s: mean(dip.iter().map(settle)),
        pre_dip_error_m: mean(pre_dip.iter().map(err)),
        pre_dip_settling_s: mean(pre_dip.iter().map(settle)),
        fault,
        safe_state_after_s: records
            .iter()
            .find(|r| r.t_s >= FAULT_AT_S && r.fault_state == FaultState::Fault.code())
            .map(|r| r.t_s - FAULT_AT_S),
    }
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
        let p = &self.phases;
        let um = |x: f64| x * 1e6;
        let ms = |x: f64| x * 1e3;
        writeln!(f, "the story, phase by phase:")?;
        writeln!(
            f,
            "  1 nominal: small steps settle in {:.0} ms to within {:.1} µm",
            ms(p.nominal_small_settling_s),
            um(p.nominal_small_error_m)
        )?;
        writeln!(
            f,
            "  2 friction x3 at {FRICTION_AT_S} s: the observer flags it {}; steady error {:.1} µm on the first step, {:.1} µm on the last two before the dip ({:.2}x nominal); adapted compensation up/down {:.3}/{:.3} V -> {:.3}/{:.3} V",
            p.observer_flag_delay_s
                .map_or("never".to_string(), |t| format!("{:.2} s after", t)),
            um(p.friction_error_before_m),
            um(p.friction_error_after_m),
            p.friction_error_after_m / p.nominal_small_error_m,
            p.compensation_before.0,
            p.compensation_before.1,
            p.compensation_after.0,
            p.compensation_after.1,
        )?;
        writeln!(
            f,
            "  3 supply dip at {DIP_AT_S} s to {:.1} V: {}; gains x{:.2}; small steps settle in {:.0} ms to within {:.1} µm (before the dip: {:.0} ms, {:.1} µm); safe state: {}",
            p.dip_supply_min,
            p.dip_warning.map_or("no warning".to_string(), |(code, t)| format!(
                "warning EMCY {code:#06x} {:.0} ms after",
                ms(t)
            )),
            p.dip_gain_factor_max,
            ms(p.dip_settling_s),
            um(p.dip_error_m),
            ms(p.pre_dip_settling_s),
            um(p.pre_dip_error_m),
            if p.dip_safe_state { "yes" } else { "no" },
        )?;
        writeln!(
            f,
            "  4 real fault at {FAULT_AT_S} s (supply collapses to 12 V, below the hard band): {}; safe state {}",
            p.fault.map_or("not detected".to_string(), |(k, t)| format!(
                "{k} latched {:.1} ms after",
                ms(t)
            )),
            p.safe_state_after_s
                .map_or("never".to_string(), |t| format!("{:.1} ms after", ms(t))),
        )?;
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
