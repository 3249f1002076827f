//! Standard device profiles on top of the generic stack: CiA 402 drives and CiA 401 I/O
//! modules, and the PDO communication and mapping parameters of CiA 301 that both are
//! configured through ([`mapping`]), read from an EDS when a node's file is given ([`eds`]).

pub mod cia401;
pub mod cia402;
pub mod eds;
pub mod mapping;
