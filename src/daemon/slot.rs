//! What the controller node holds for one axis: the axis itself (its algorithms, swapped whole on
//! a reload), the link to a standard node, and what the node remembers of the axis from one
//! cycle to the next. One slot per axis, so nothing about an axis lives in a vector of its own.

use std::ops::{Index, IndexMut};

use super::axis::Axis;
use super::profile_link::ProfileLink;
use super::profile_rejoin::Rejoin;
use crate::control::BandStatus;
use crate::supervise::{FaultState, Reaction};

pub struct AxisSlot {
    pub(super) axis: Axis,
    /// The link to a standard (CiA 402/401) actuator node; `None` for ours.
    pub(super) link: Option<ProfileLink>,
    /// Configures the standard node again when it reboots; `None` for ours, or a node whose
    /// start-up plan is not known (it is only started again).
    pub(super) rejoin: Option<Rejoin>,
    /// The rebooted node was configured and started: the axis resumes once the node is
    /// operational and its readings are fresh.
    pub(super) resume: bool,
    /// Fault state, latched limit faults and latched diagnoses sent last cycle.
    pub(super) last_fault_state: (FaultState, u16, u16),
    /// The reaction the latched faults called for last cycle.
    pub(super) last_reaction: Option<Reaction>,
    /// Where the supply was against its scheduled band last cycle.
    pub(super) last_supply_band: BandStatus,
    /// An EMCY "error reset" is due with the next cycle's frames.
    pub(super) announce_reset: bool,
    pub(super) faults_raised: u64,
    pub(super) sensor_missed: u64,
}

impl AxisSlot {
    pub(super) fn new(axis: Axis, link: Option<ProfileLink>) -> Self {
        Self {
            axis,
            link,
            rejoin: None,
            resume: false,
            last_fault_state: (FaultState::Ok, 0, 0),
            last_reaction: None,
            last_supply_band: BandStatus::Inside,
            announce_reset: false,
            faults_raised: 0,
            sensor_missed: 0,
        }
    }
}

/// The node's axes in configuration order, read-only: `axes[i]`, `len()`, `iter()`.
#[derive(Clone, Copy)]
pub struct Axes<'a>(pub(super) &'a [AxisSlot]);

impl<'a> Axes<'a> {
    pub fn len(&self) -> usize {
        self.0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    pub fn iter(&self) -> impl ExactSizeIterator<Item = &'a Axis> + 'a {
        self.0.iter().map(|s| &s.axis)
    }
}

impl<'a> IntoIterator for Axes<'a> {
    type Item = &'a Axis;
    type IntoIter = std::iter::Map<std::slice::Iter<'a, AxisSlot>, fn(&'a AxisSlot) -> &'a Axis>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.iter().map(|s| &s.axis)
    }
}

impl Index<usize> for Axes<'_> {
    type Output = Axis;
    fn index(&self, index: usize) -> &Axis {
        &self.0[index].axis
    }
}

/// The node's axes in configuration order, to give them what they learned before.
pub struct AxesMut<'a>(pub(super) &'a mut [AxisSlot]);

impl AxesMut<'_> {
    pub fn len(&self) -> usize {
        self.0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    pub fn iter_mut(&mut self) -> impl ExactSizeIterator<Item = &mut Axis> {
        self.0.iter_mut().map(|s| &mut s.axis)
    }
}

impl<'a> IntoIterator for AxesMut<'a> {
    type Item = &'a mut Axis;
    type IntoIter =
        std::iter::Map<std::slice::IterMut<'a, AxisSlot>, fn(&'a mut AxisSlot) -> &'a mut Axis>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.iter_mut().map(|s| &mut s.axis)
    }
}

impl Index<usize> for AxesMut<'_> {
    type Output = Axis;
    fn index(&self, index: usize) -> &Axis {
        &self.0[index].axis
    }
}

impl IndexMut<usize> for AxesMut<'_> {
    fn index_mut(&mut self, index: usize) -> &mut Axis {
        &mut self.0[index].axis
    }
}
