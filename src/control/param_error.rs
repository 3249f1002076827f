//! The constructors' error and its checks live in [`crate::param`], below every algorithm layer
//! (supervision uses them too); control keeps its old paths.

pub use crate::param::ParamError;
pub(crate) use crate::param::{finite, non_negative, positive, range};
