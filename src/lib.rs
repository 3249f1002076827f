//! `actuatord`: intelligent actuator control over CAN, after Isermann & Raab (1993)
//! and Bao, Mao & Luo (2016).
//!
//! Layers, lowest first; a module uses only modules on the lines above its own (never one on its
//! own line or below). `tests/it/layering.rs` reads this list and every `crate::` path in `src/`,
//! and fails on an import that breaks it.
//! - [`param`]: the parameters' error and checks, shared by every algorithm.
//! - [`canopen`]: the CANopen-style protocol stack (frame, NMT, SYNC, heartbeat, SDO, object
//!   dictionary, EDS), bytes in and bytes out; it knows no actuator.
//! - [`bus`]: frames on SocketCAN or an in-process bus; the only code touching sockets.
//! - [`physics`]: plant families and physical effects, pure maths.
//! - [`ident`]: parameter estimation, sans-I/O.
//! - [`supervise`]: faults, limits, observer and diagnosis, sans-I/O.
//! - [`control`]: control laws, scheduling and adaptation, sans-I/O (uses estimation and supervision).
//! - [`design`]: controller design and comparison, offline.
//! - [`device`]: the actuatord device profile on the stack: message table, PDOs, EMCY codes,
//!   the objects of an axis, the DBC, the CiA 401/402 profiles.
//! - [`recording`]: the recording format (cycle records, events, MCAP topics) and its reader.
//! - [`client`]: SDO and NMT tools for a node on the bus.
//! - [`simnode`]: a simulated actuator node speaking the protocol.
//! - [`lab`]: comparing models with measurements and recordings.
//! - [`daemon`]: the real-time cycle, configuration, the recorder's writer.
//! - [`defaults`]: the reference configurations and plant files, built in.
//! - [`lockstep`]: the daemon's node and simulated nodes stepped together, without a clock.
//! - [`demo`]: the self-contained demonstration.
//! - [`bench`]: the benchmarks and their reports.
//! - [`tune`]: from a fitted model to an axis configuration (uses the lab and the fault table).

pub mod bench;
pub mod bus;
pub mod canopen;
pub mod client;
pub mod control;
pub mod daemon;
pub mod defaults;
pub mod demo;
pub mod design;
pub mod device;
pub mod ident;
pub mod lab;
pub mod lockstep;
pub mod param;
pub mod physics;
pub mod recording;
pub mod simnode;
pub mod supervise;
pub mod tune;
