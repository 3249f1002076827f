//! Every algorithm's per-cycle call allocates nothing after construction: a counting global
//! allocator (counter per thread, so parallel tests do not disturb each other) around the loops.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use actuatord::control::*;
use actuatord::ident::{
    ArxOrder, DirectionalRegressor, DirectionalSelection, Dsfi, DsfiConfig, RecursiveEstimator,
    Rls, RlsConfig, StateVariableFilter,
};
use actuatord::supervise::*;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations() -> u64 {
    ALLOCATIONS.with(|c| c.get())
}

/// Runs `f` for many steps and returns the allocations it made.
fn count(mut f: impl FnMut(usize)) -> u64 {
    let before = allocations();
    for k in 0..5000 {
        f(k);
    }
    allocations() - before
}

fn signal(k: usize) -> f64 {
    let t = k as f64 * 0.0025;
    0.005 + 0.002 * (7.0 * t).sin() + 0.001 * (23.0 * t).sin()
}

#[test]
fn the_counter_sees_an_allocation() {
    let n = count(|k| {
        std::hint::black_box(vec![k; 4]);
    });
    assert_eq!(n, 5000);
}

#[test]
fn existing_controller_friction_feed_forward_and_limits_do_not_allocate() {
    let mut c = DiscreteController::pidt1([2231.0, -4204.0, 2000.0], 0.616, 0.0, 24.0).expect("ok");
    let ff = FrictionFeedForward::from_forces(0.8, 0.2, 0.2, 1.63, 3e-6);
    let band = |lo, hi| {
        Some(Band {
            low: lo,
            high: hi,
            persistence_cycles: 3,
        })
    };
    let mut lim = LimitSupervisor::new(Limits {
        following_error: band(-1e-3, 1e-3),
        position: band(0.0, 0.025),
        current_a: band(-3.0, 3.0),
        supply_voltage_v: band(18.0, 30.0),
        supply_pressure_pa: None,
        sensor_timeout_cycles: 4,
        heartbeat_timeout_s: Some(0.5),
    });
    let n = count(|k| {
        let e = 0.005 - signal(k);
        let u = c.propose(e) + ff.compensation(e);
        c.commit(e, u);
        std::hint::black_box(c.step(e));
        std::hint::black_box(lim.step(&SupervisionInput {
            setpoint: 0.005,
            position: signal(k),
            supply_voltage_v: 24.0,
            sensor_fresh: true,
            node_operational: true,
            ..Default::default()
        }));
    });
    assert_eq!(n, 0);
}

#[test]
fn identification_steps_do_not_allocate() {
    let mut rls = Rls::new(3, RlsConfig::default()).expect("ok");
    let mut dsfi = Dsfi::new(3, DsfiConfig::default()).expect("ok");
    let mut dir = DirectionalRegressor::new(DirectionalSelection::new(ArxOrder {
        na: 2,
        nb: 1,
        delay: 0,
    }))
    .expect("ok");
    let mut svf = StateVariableFilter::new(4, 3, 150.0, 0.0025).expect("ok");
    let n = count(|k| {
        let psi = [signal(k), signal(k + 1), 1.0];
        let y = 0.3 * signal(k + 2);
        std::hint::black_box(rls.step(&psi, y).ok());
        std::hint::black_box(dsfi.step(&psi, y).ok());
        if let Some((_, p)) = dir.push(signal(k), 0.1) {
            std::hint::black_box(p[0]);
        }
        std::hint::black_box(svf.step(signal(k))[3]);
    });
    assert_eq!(n, 0);
}

#[test]
fn new_control_algorithms_do_not_allocate() {
    let mut p = DirectionalP::new(DirectionalPConfig {
        gain_neg_per_m: 500.0,
        gain_pos_per_m: 700.0,
        deadband_m: 1e-6,
        output_min: -1.0,
        output_max: 1.0,
    })
    .expect("ok");
    let mut sf = StateFeedback::new(&[100.0, 20.0], 100.0, -10.0, 10.0).expect("ok");
    let mut nl = NonlinearCorrection::new(NonlinearCorrectionConfig {
        pole_m: 0.026,
        c0: 1.53,
        c1_per_m: -30.0,
        c2_per_m2: 0.0,
        reference_position_m: 0.0,
        min_gain_ratio: 0.2,
        output_min: 0.0,
        output_max: 24.0,
    })
    .expect("ok");
    let mut dither = Dither::new(DitherConfig {
        period_s: 0.0025,
        amplitude: 0.2,
        frequency_hz: 50.0,
        adapt: true,
        amplitude_min: 0.0,
        amplitude_max: 1.0,
        frequency_min_hz: 20.0,
        frequency_max_hz: 200.0,
        amplitude_rate_per_s: 1.0,
        frequency_rate_per_s: 1.0,
        error_tolerance_m: 20e-6,
        ripple_moving_m: 1e-6,
        ripple_max_m: 10e-6,
        ripple_time_constant_s: 0.02,
    })
    .expect("ok");
    let mut af = AdaptiveFriction::new(AdaptiveFrictionConfig {
        period_s: 0.0025,
        params: actuatord::control::AdaptiveFrictionSection {
            model_time_constant_s: 0.03,
            adaptation_gain_per_m_s: 2000.0,
            compensation_max: 0.4,
            error_deadband_m: 3e-6,
            model_deadband_m: 10e-6,
            settled_band_m: 20e-6,
            step_max_m: 1e-3,
        },
        initial_pos: 0.0,
        initial_neg: 0.0,
    })
    .expect("ok");
    let point = |s: f64, k: f64| SchedulePoint {
        supply: s,
        params: vec![k, 0.7 * k],
    };
    let mut sched =
        GainSchedule::new(&[point(40_000.0, 0.05), point(80_000.0, 0.012)]).expect("ok");
    let mut table = LearnedTable::new(LearnedTableConfig {
        position_edges_m: vec![0.0, 0.01, 0.02],
        load_edges_n: vec![-10.0, 10.0],
        supply_edges: vec![40_000.0, 60_000.0, 80_000.0],
        param_names: vec!["q01_per_m".into(), "q02_per_m".into()],
        averaging_count: 10,
        min_count: 1,
    })
    .expect("ok");
    let mut ad = PneumaticAdaptive::new(&PneumaticAdaptiveConfig::membrane_drive(
        0.02,
        vec![point(60_000.0, 0.03)],
        1e-7,
        true,
    ))
    .expect("ok");
    let mut y_pn = 0.008;
    let n = count(|k| {
        let y = signal(k);
        let w = if (k / 200) % 2 == 0 { 0.006 } else { 0.004 };
        std::hint::black_box(p.step(w, y));
        std::hint::black_box(sf.step(&[y, 0.0], w));
        std::hint::black_box(nl.step(6.0, y));
        std::hint::black_box(dither.step(w, y));
        std::hint::black_box(af.step(w, y));
        std::hint::black_box(sched.step(50_000.0 + k as f64)[0]);
        let op = OperatingPoint {
            position_m: y,
            load_n: 0.0,
            supply: 60_000.0,
        };
        table.learn(&op, &[500.0, 600.0]);
        std::hint::black_box(table.lookup(&op));
        let out = ad.step(w, y_pn, 60_000.0);
        y_pn += 0.03 * 0.02 * out.duty;
    });
    assert_eq!(n, 0);
}

#[test]
fn supervision_algorithms_do_not_allocate() {
    let mut obs =
        DisturbanceObserver::new(actuatord::bench::paper::solenoid_observer_config()).expect("ok");
    let mut est = ParameterEstimator::new(ParameterEstimatorConfig {
        period_s: 0.0025,
        filter_omega_rad_s: 150.0,
        forgetting: 0.999,
        mass_kg: 0.4956,
        nominal_current_time_constant_s: 0.00859,
        moving_speed_m_per_s: 1e-3,
        min_moving_samples: 8,
        disturbed_moving_samples: 8,
    })
    .expect("ok");
    let mut sup = EstimatorSupervisor::new(&EstimatorSupervisorConfig {
        min_input: 0.1,
        min_output_step: 1e-6,
        min_updates: 4,
        eigenvalue_valid: 0.5,
        plausible: vec![(0.005, 0.1)],
    })
    .expect("ok");
    let mut machine = FaultMachine::new(&FaultMachineConfig::default()).expect("ok");
    let nominal = Nominal::exact(PhysicalParameters {
        values: [1.0; PHYSICAL_PARAMS],
    });
    let thresholds = SymptomThresholds {
        sigmas: 3.0,
        relative_floor: [0.1; PHYSICAL_PARAMS],
    };
    let table = FaultSymptomTable::shipped().expect("shipped table");
    let mut learner = NominalLearner::default();
    let n = count(|k| {
        let y = signal(k);
        std::hint::black_box(obs.step(y, 6.0 + 1000.0 * (y - 0.005)));
        est.step(y, 6.0 + 1000.0 * (y - 0.005));
        let update = actuatord::ident::RecursiveUpdate {
            prediction_error: 0.0,
            posterior_error: 0.0,
            eigenvalue: 0.9,
            guarded: false,
        };
        std::hint::black_box(sup.observe(&update, &[0.03]));
        let mut present = SupervisedFaults::default();
        if k % 100 == 0 {
            present.insert(SupervisedFault::EstimatorImplausible);
        }
        std::hint::black_box(machine.step(present));
        if let Some(p) = est.physical_with_deviation() {
            learner.add(&p);
            std::hint::black_box(learner.nominal());
            let s = symptoms(&p, &nominal, &thresholds);
            std::hint::black_box(diagnose(&table, &s, 1));
        }
    });
    assert_eq!(n, 0);
}

/// The shipped solenoid configuration with a learned table and a state file.
fn solenoid_node() -> (actuatord::daemon::Config, actuatord::daemon::ControllerNode) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml");
    let text = std::fs::read_to_string(&path).expect("config")
        + "[axis.learned_table]\nposition_edges_m = [0.0, 0.006, 0.012, 0.025]\n\
           supply_voltage_edges_v = [18.0, 24.0, 32.0]\nlearn_interval_s = 0.01\n";
    let config = actuatord::daemon::Config::from_toml(&text, &path).expect("valid");
    let node = actuatord::daemon::ControllerNode::new(&config).expect("node");
    (config, node)
}

#[test]
fn the_learned_table_the_state_offer_and_a_prepared_reload_do_not_allocate() {
    use actuatord::daemon::learned::{OperatingPointMemory, FRICTION_TABLE_PARAMS};
    use actuatord::daemon::node::PreparedReload;
    use actuatord::daemon::state::StateWriter;

    let table = LearnedTable::new(LearnedTableConfig {
        position_edges_m: vec![0.0, 0.005, 0.01],
        load_edges_n: vec![0.0, 1.0],
        supply_edges: vec![20.0, 30.0],
        param_names: FRICTION_TABLE_PARAMS.map(String::from).to_vec(),
        averaging_count: 10,
        min_count: 2,
    })
    .expect("valid");
    let mut memory = OperatingPointMemory::new(table, 3);
    let mut friction = AdaptiveFriction::new(AdaptiveFrictionConfig {
        period_s: 0.0025,
        params: actuatord::control::AdaptiveFrictionSection {
            model_time_constant_s: 0.03,
            adaptation_gain_per_m_s: 2000.0,
            compensation_max: 0.4,
            error_deadband_m: 3e-6,
            model_deadband_m: 1e-5,
            settled_band_m: 2e-5,
            step_max_m: 1e-3,
        },
        initial_pos: 0.1,
        initial_neg: 0.1,
    })
    .expect("valid");
    let n = count(|k| {
        let w = if (k / 500) % 2 == 0 { 0.003 } else { 0.008 };
        friction.step(w, signal(k));
        let op = OperatingPoint {
            position_m: signal(k),
            load_n: 0.0,
            supply: 24.0,
        };
        memory.step(&op, &mut friction);
    });
    assert_eq!(n, 0);
    assert!(memory.table().populated_cells() > 0, "it learned");

    let (config, mut node) = solenoid_node();
    let dir = tempfile::tempdir().expect("tempdir");
    let (sink, writer) = StateWriter::spawn(&dir.path().join("s.toml"), &node, 1).expect("spawn");
    let n = count(|_| sink.offer(&node));
    assert_eq!(n, 0);
    drop(sink);
    assert!(writer.finish().writes >= 1);

    let mut changed = config.clone();
    changed.axis[0].limits.following_error_m = Some(0.004);
    let prepared = Box::new(PreparedReload::build(changed).expect("valid"));
    let before = allocations();
    let replaced = node.apply_reload(prepared, 1.0, &mut |_| {});
    assert_eq!(allocations() - before, 0);
    drop(replaced);
}

/// The whole controller node in operation against the simulated solenoid, frame by frame:
/// SYNC, sensor frames, control, supervision, status, heartbeats, and an SDO setpoint write
/// (segmented: a REAL64) applied at a cycle boundary. Only the controller's calls are counted.
#[test]
fn the_controller_nodes_cycle_and_an_sdo_setpoint_write_do_not_allocate() {
    use actuatord::bus::Frame;
    use actuatord::canopen::{ObjectId, SdoClient};
    use actuatord::daemon::node::CycleTiming;
    use actuatord::simnode::SimNode;

    let (config, mut node) = solenoid_node();
    let plant = actuatord::physics::PlantSpec::from_toml(
        include_str!("../config/plants/solenoid.toml"),
        "config/plants/solenoid.toml",
    )
    .and_then(|s| s.build_named("config/plants/solenoid.toml"))
    .expect("plant");
    let period_s = config.cycle.period_s;
    let mut sim = SimNode::new(config.axis[0].actuator_node_id, plant, period_s, Vec::new());
    let mut to_sim: Vec<Frame> = Vec::with_capacity(256);
    let mut to_node: Vec<Frame> = Vec::with_capacity(256);
    sim.boot(&mut |_| {});
    node.boot(&mut |f| to_sim.push(*f), &mut |_| {});
    let mut client = SdoClient::new(node.node_id());
    let sdo_response = 0x580 + u32::from(node.node_id());
    let mut request: Option<Frame> = None;
    let (warm_up, write_at, cycles) = (800, 2000, 3200);
    let mut counted = 0;
    for k in 0..cycles {
        let t = k as f64 * period_s;
        to_node.clear();
        for f in to_sim.drain(..) {
            sim.handle(&f, &mut |a| to_node.push(*a), &mut |_| {});
        }
        if k % 40 == 0 {
            to_node.push(sim.heartbeat());
        }
        if k == write_at {
            let bytes = 0.011f64.to_le_bytes();
            request = Some(client.start_download(
                ObjectId {
                    index: 0x2004,
                    sub: 1,
                },
                &bytes,
                t,
            ));
        }
        to_node.extend(request.take());
        let before = allocations();
        for f in &to_node {
            node.handle(f, t, &mut |_| {});
        }
        node.begin_cycle();
        let sync = node.sync_frame();
        let after_node = allocations();
        to_node.clear();
        sim.handle(&sync, &mut |a| to_node.push(*a), &mut |_| {});
        let resumed = allocations();
        for a in &to_node {
            node.handle(a, t, &mut |_| {});
        }
        node.finish_cycle(
            t,
            CycleTiming::default(),
            &mut |f| to_sim.push(*f),
            &mut |_| {},
        );
        if k >= warm_up {
            counted += (after_node - before) + (allocations() - resumed);
        }
        let mut i = 0;
        while i < to_sim.len() {
            if to_sim[i].id() == sdo_response {
                let f = to_sim.remove(i);
                request = client.handle(&f, t);
            } else {
                i += 1;
            }
        }
    }
    assert!(
        matches!(client.outcome(), Some(Ok(_))),
        "the write was answered: {:?}",
        client.outcome()
    );
    assert_eq!(node.axes()[0].setpoint(), 0.011, "the write took effect");
    assert_eq!(counted, 0, "allocations in {} cycles", cycles - warm_up);
}

/// An SDO parameter write (pre-operational, segmented REAL64) with the builder attached: the
/// boundary hands the staged writes to the builder and, cycles later, swaps in what it built.
/// Neither allocates; the build itself happens outside the counted calls, as on its own thread.
#[test]
fn an_sdo_parameter_write_is_handed_off_and_swapped_in_without_allocating() {
    use actuatord::bus::Frame;
    use actuatord::canopen::{NmtCommand, ObjectId, SdoClient};
    use actuatord::daemon::node::CycleTiming;
    use actuatord::daemon::reconfigure::{build_parameters, BuildInput};
    use actuatord::simnode::SimNode;

    let (config, mut node) = solenoid_node();
    let (builder, requests) = std::sync::mpsc::sync_channel::<BuildInput>(8);
    node.attach_builder(builder);
    let plant = actuatord::physics::PlantSpec::from_toml(
        include_str!("../config/plants/solenoid.toml"),
        "config/plants/solenoid.toml",
    )
    .and_then(|s| s.build_named("config/plants/solenoid.toml"))
    .expect("plant");
    let period_s = config.cycle.period_s;
    let mut sim = SimNode::new(config.axis[0].actuator_node_id, plant, period_s, Vec::new());
    let mut to_sim: Vec<Frame> = Vec::with_capacity(256);
    let mut to_node: Vec<Frame> = Vec::with_capacity(256);
    let mut events: Vec<String> = Vec::new();
    sim.boot(&mut |_| {});
    node.boot(&mut |f| to_sim.push(*f), &mut |_| {});
    let mut client = SdoClient::new(node.node_id());
    let sdo_response = 0x580 + u32::from(node.node_id());
    let q0 = ObjectId::new(0x2001, 1);
    let q0_before = node.dictionary().read(q0).expect("q0");
    let mut request: Option<Frame> = None;
    let mut built = None;
    let mut returned = 0;
    let (warm_up, write_at, cycles) = (800, 1000, 1400);
    let mut counted = 0;
    for k in 0..cycles {
        let t = k as f64 * period_s;
        to_node.clear();
        for f in to_sim.drain(..) {
            sim.handle(&f, &mut |a| to_node.push(*a), &mut |_| {});
        }
        if k % 40 == 0 {
            to_node.push(sim.heartbeat());
        }
        if k == write_at {
            to_node.push(NmtCommand::EnterPreOperational.encode(node.node_id()));
            request = Some(client.start_download(q0, &2300.0f64.to_le_bytes(), t));
        }
        to_node.extend(request.take());
        let before = allocations();
        if let Some(b) = built.take() {
            let back = node.apply_built(b, t, &mut |_| {});
            assert!(
                back.is_none(),
                "with a builder, what was replaced goes back to it"
            );
        }
        for f in &to_node {
            node.handle(f, t, &mut |_| {});
        }
        node.begin_cycle();
        let sync = node.sync_frame();
        let after_node = allocations();
        to_node.clear();
        sim.handle(&sync, &mut |a| to_node.push(*a), &mut |_| {});
        let resumed = allocations();
        for a in &to_node {
            node.handle(a, t, &mut |_| {});
        }
        node.finish_cycle(
            t,
            CycleTiming::default(),
            &mut |f| to_sim.push(*f),
            &mut |_| {},
        );
        if k >= warm_up {
            counted += (after_node - before) + (allocations() - resumed);
        }
        // The builder's side, not counted: build from the staged writes, drop what came back.
        while let Ok(input) = requests.try_recv() {
            match input {
                BuildInput::Writes(batch) => {
                    // Until the build is swapped in, reads tell what the node runs with.
                    assert_eq!(node.dictionary().read(q0), Ok(q0_before));
                    let b = build_parameters(&config, batch);
                    assert!(b.result.is_ok(), "{:?}", b.result.as_ref().err());
                    built = Some(Box::new(b));
                }
                BuildInput::Done { applied, .. } => {
                    assert!(applied);
                    returned += 1;
                }
                BuildInput::Reload => events.push("reload".into()),
            }
        }
        let mut i = 0;
        while i < to_sim.len() {
            if to_sim[i].id() == sdo_response {
                let f = to_sim.remove(i);
                request = client.handle(&f, t);
            } else {
                i += 1;
            }
        }
    }
    assert!(
        matches!(client.outcome(), Some(Ok(_))),
        "the write was answered: {:?}",
        client.outcome()
    );
    assert!(events.is_empty());
    assert_eq!(returned, 1, "one build swapped in and handed back");
    assert_eq!(node.dictionary().read(q0), Ok(2300.0f64.into()));
    assert_eq!(counted, 0, "allocations in {} cycles", cycles - warm_up);
}

/// A rebooted node configured again on the cycle thread: every request, answer and the NMT
/// start, over and over, without allocating.
#[test]
fn configuring_a_rebooted_node_again_does_not_allocate() {
    use actuatord::canopen::od::{EntrySpec, ObjectDictionary, ObjectId};
    use actuatord::canopen::{NmtState, SdoServer};
    use actuatord::daemon::profile_rejoin::{Rejoin, RejoinProgress};
    use actuatord::daemon::profile_setup::SetupStep;
    let mut od = ObjectDictionary::builder()
        .var(0x1000, EntrySpec::ro("device_type", 0x0002_0192u32))
        .var(0x2000, EntrySpec::rw("value", 0u32))
        .build()
        .expect("dictionary");
    let mut server = SdoServer::new(9);
    let mut rejoin = Rejoin::new(
        9,
        vec![
            SetupStep::check(ObjectId::new(0x1000, 0), 402, 0xFFFF, "device type"),
            SetupStep::write(ObjectId::new(0x2000, 0), &7u32.to_le_bytes(), "value"),
            SetupStep::check(ObjectId::new(0x2000, 0), 7, u32::MAX, "value"),
        ],
    );
    let mut started = 0;
    let n = count(|k| {
        if !rejoin.is_running() {
            rejoin.begin();
        }
        let mut out = [None; 2];
        let mut i = 0;
        let told = rejoin.poll(k as f64 * 0.002, &mut |f| {
            out[i] = Some(*f);
            i += 1;
        });
        started += usize::from(matches!(told, RejoinProgress::Started { .. }));
        for f in out.iter().flatten() {
            if let Some(a) = server.handle(f, 0.0, &mut od, NmtState::PreOperational) {
                rejoin.handle(&a);
            }
            od.take_pending_writes().for_each(drop);
        }
    });
    assert_eq!(n, 0);
    // Four cycles a round: three transfers and the start.
    assert_eq!(started, 5000 / 4);
}
