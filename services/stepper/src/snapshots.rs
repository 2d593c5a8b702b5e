//! The road saved every few simulated seconds, so that a restarted stepper
//! resumes from it instead of an empty road. Each save replaces the file
//! atomically (a crash mid-save leaves the previous one whole), on a thread
//! of its own so that a slow disk never delays a tick.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{SyncSender, TrySendError, sync_channel};

use anyhow::{Context, Result};
use trafficmesh_model::snapshot::RoadSnapshot;

/// The snapshot in `path`, if there is one.
pub fn load(path: &Path) -> Result<Option<RoadSnapshot>> {
    let text = match std::fs::read_to_string(path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(e).with_context(|| format!("cannot read the snapshot {}", path.display()));
        }
    };
    serde_json::from_str(&text).map(Some).with_context(|| {
        format!(
            "{} is not a stepper snapshot; move it away to start from an empty road",
            path.display()
        )
    })
}

/// Saves the snapshots it is offered, one at a time.
pub struct Saver {
    every: f64,
    next_due: f64,
    tx: SyncSender<RoadSnapshot>,
    thread: std::thread::JoinHandle<()>,
}

impl Saver {
    /// Saves to `path` every `every` simulated seconds from `now` on.
    pub fn start(path: PathBuf, every: f64, now: f64) -> Result<Saver> {
        // One waiting at most: a newer road replaces none that is being written.
        let (tx, rx) = sync_channel::<RoadSnapshot>(1);
        let thread = std::thread::Builder::new()
            .name("snapshots".into())
            .spawn(move || {
                for snapshot in rx {
                    let mut text = serde_json::to_vec(&snapshot).expect("a snapshot serialises");
                    text.push(b'\n');
                    if let Err(e) = trafficmesh_maps::write_atomic(&path, &text) {
                        tracing::warn!("cannot save the snapshot: {e}");
                    }
                }
            })
            .context("cannot start the snapshot thread")?;
        Ok(Saver {
            every,
            next_due: now + every,
            tx,
            thread,
        })
    }

    /// Whether a snapshot is due at simulation time `now`.
    pub fn due(&self, now: f64) -> bool {
        now >= self.next_due
    }

    /// Hands `snapshot` to the saving thread; skipped while it still writes
    /// the last one (the next is due soon).
    pub fn save(&mut self, snapshot: RoadSnapshot) {
        self.next_due = snapshot.time + self.every;
        match self.tx.try_send(snapshot) {
            Ok(()) | Err(TrySendError::Full(_)) => {}
            Err(TrySendError::Disconnected(_)) => tracing::warn!("the snapshot thread has stopped"),
        }
    }

    /// Saves `snapshot` after any save under way, and waits until it is on disk.
    pub fn save_last(self, snapshot: RoadSnapshot) {
        let time = snapshot.time;
        if self.tx.send(snapshot).is_ok() {
            drop(self.tx);
            let _ = self.thread.join();
            tracing::info!("saved the road at t={time:.2} s");
        }
    }
}
