//! `actuatord`: intelligent actuator control over CAN, after Isermann & Raab (1993)
//! and Bao, Mao & Luo (2016).
//!
//! Layers, lowest first; a layer only uses layers listed above it:
//! - [`physics`]: plant families and physical effects, pure maths.
//! - [`control`], [`ident`], [`supervise`]: sans-I/O algorithms run once per cycle.
//! - [`canopen`]: the CANopen-style codec, bytes in and bytes out.
//! - [`bus`]: frames on SocketCAN or an in-process bus; the only code touching sockets.
//! - [`simnode`]: a simulated actuator node speaking the protocol.
//! - [`daemon`]: the real-time cycle, configuration, recording.
//! - [`lab`]: comparing models with measurements.
//! - [`tune`]: from a fitted model to an axis configuration.
//! - [`defaults`]: the reference configurations and plant files, built in.

pub mod bench;
pub mod bus;
pub mod canopen;
pub mod client;
pub mod control;
pub mod daemon;
pub mod defaults;
pub mod demo;
pub mod design;
pub mod ident;
pub mod lab;
pub mod lockstep;
pub mod physics;
pub mod simnode;
pub mod supervise;
pub mod tune;
