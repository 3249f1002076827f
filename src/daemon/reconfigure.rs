//! One way to reconfigure. A SIGHUP reload and a batch of SDO parameter writes are both built
//! here, into a [`PreparedReload`], off the cycle thread; the cycle only swaps in what was built
//! ([`ControllerNode::apply_built`](super::node::ControllerNode::apply_built)) and hands back
//! what it replaced, to be dropped here. Reading files, validating and building axes (which
//! allocates) never happen on the cycle thread.
//!
//! The builder keeps the configuration in force: one build is out at a time, and the next
//! request waits until the cycle has said whether it took the last one.

use super::config::Config;
use super::dictionary;
use super::node::PreparedReload;
use crate::canopen::od::PendingWrite;
use std::collections::VecDeque;
use std::path::Path;
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::thread::JoinHandle;

/// Where the configuration file of a reload is read from (SIGHUP), on the builder's thread.
pub type LoadConfig = Box<dyn FnMut() -> anyhow::Result<Config> + Send>;

/// What the builder is asked for, or told.
pub enum BuildInput {
    /// Read the configuration file again (SIGHUP).
    Reload,
    /// SDO writes staged on the dictionary, to apply to the configuration in force. The vector
    /// is the node's own buffer; it comes back in [`Built::batch`].
    Writes(Vec<PendingWrite>),
    /// The cycle is done with a build: what it replaced (or the build itself, when refused),
    /// to be dropped here, and whether the configuration it carried is now in force.
    Done { built: Box<Built>, applied: bool },
}

/// Which request a build answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BuildKind {
    Reload,
    Parameters,
}

/// A build for the cycle to swap in.
pub struct Built {
    pub kind: BuildKind,
    /// The configuration, dictionary and axes, or why the writes cannot be applied.
    pub result: Result<PreparedReload, String>,
    /// The writes of a parameter build (the node's buffer, going home); empty for a reload.
    pub batch: Vec<PendingWrite>,
}

/// Apply staged SDO writes to a copy of `in_force`, validate it and build what it needs: the
/// same path as a reload. Allocates and may read files (validation): not for the cycle thread.
pub fn build_parameters(in_force: &Config, batch: Vec<PendingWrite>) -> Built {
    let mut config = in_force.clone();
    let mut refused = None;
    for w in &batch {
        if let Err(e) = dictionary::apply_write(&mut config, w) {
            refused.get_or_insert(e);
        }
    }
    let result = match refused {
        Some(reason) => Err(reason),
        None => config
            .validate(Path::new("SDO write"))
            .map_err(|e| e.to_string())
            .and_then(|()| PreparedReload::build(config)),
    };
    Built {
        kind: BuildKind::Parameters,
        result,
        batch,
    }
}

/// The builder thread of one bus, and the ends of its channels.
pub struct Builder {
    /// Requests (SIGHUP) from the runtime.
    pub input: SyncSender<BuildInput>,
    thread: JoinHandle<()>,
}

/// The cycle's ends: builds to swap in, and the way back (SDO writes, what was replaced).
pub struct BuilderLink {
    pub built: Receiver<Box<Built>>,
    pub input: SyncSender<BuildInput>,
}

impl Builder {
    /// Start the builder with the configuration the node was made from. `name` (the file) goes
    /// into the log lines of reloads.
    pub fn spawn(
        in_force: Config,
        name: String,
        load: LoadConfig,
    ) -> std::io::Result<(Self, BuilderLink)> {
        // Requests are few and the builder answers them in order; a full queue refuses one.
        let (input, rx) = sync_channel::<BuildInput>(8);
        let (out, built) = sync_channel::<Box<Built>>(1);
        let thread = std::thread::Builder::new()
            .name("reconfigure".into())
            .spawn(move || run(in_force, name, load, rx, out))?;
        Ok((
            Self {
                input: input.clone(),
                thread,
            },
            BuilderLink { built, input },
        ))
    }

    /// Ask for a reload (SIGHUP); false when requests are piling up and this one was dropped.
    pub fn reload(&self) -> bool {
        self.input.try_send(BuildInput::Reload).is_ok()
    }

    /// Wait for the thread, once the cycle and the runtime have dropped their senders.
    pub fn join(self) {
        drop(self.input);
        let _ = self.thread.join();
    }
}

fn run(
    mut in_force: Config,
    name: String,
    mut load: LoadConfig,
    rx: Receiver<BuildInput>,
    out: SyncSender<Box<Built>>,
) {
    // The configuration of the build the cycle has, until it says whether it took it.
    let mut out_for_cycle: Option<Config> = None;
    let mut queue = VecDeque::new();
    while let Ok(input) = rx.recv() {
        match input {
            BuildInput::Done { built, applied } => {
                if let Some(sent) = out_for_cycle.take() {
                    if applied {
                        in_force = sent;
                    }
                }
                drop(built);
            }
            request => queue.push_back(request),
        }
        while out_for_cycle.is_none() {
            let Some(request) = queue.pop_front() else {
                break;
            };
            let built = match request {
                BuildInput::Reload => {
                    let prepared = load().and_then(|new| {
                        PreparedReload::build(new).map_err(|e| anyhow::anyhow!("{name}: {e}"))
                    });
                    match prepared {
                        Ok(p) => {
                            tracing::info!("SIGHUP: {name} read, taking effect at the next cycle");
                            Built {
                                kind: BuildKind::Reload,
                                result: Ok(p),
                                batch: Vec::new(),
                            }
                        }
                        Err(e) => {
                            tracing::error!("SIGHUP: {e:#}; keeping the running configuration");
                            continue;
                        }
                    }
                }
                BuildInput::Writes(batch) => build_parameters(&in_force, batch),
                BuildInput::Done { .. } => continue,
            };
            let sent = built.result.as_ref().ok().map(|p| p.config().clone());
            if out.send(Box::new(built)).is_err() {
                return; // the cycle has ended
            }
            // A refused parameter build comes back too, so the queue waits for it either way.
            out_for_cycle = Some(sent.unwrap_or_else(|| in_force.clone()));
        }
    }
}
