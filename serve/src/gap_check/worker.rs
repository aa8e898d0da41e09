//! The gap checks' queue and worker: one check at a time in the whole process, on a thread of
//! its own with its own rayon pool, fed by a queue of due drives in which each drive is at most
//! once. The engine only pushes jobs and collects outcomes; it never waits on a check.

use std::collections::VecDeque;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Instant;

use twin::measured::DataSet;

use super::sample::{LabelSource, Trigger};
use crate::config::DriveModel;

/// One due check: the drive, its model, the data set its sample made and where each label
/// comes from.
pub struct GapJob {
    pub drive: String,
    pub model: Arc<DriveModel>,
    pub set: DataSet,
    pub sources: Vec<LabelSource>,
    pub trigger: Trigger,
    /// End of the latest segment read, s on the drive's clock.
    pub at_s: f64,
}

/// What a check gave: the report's JSON (`twin::gap::GapReport`'s, as `rom gap --format json`
/// writes it) or why it failed.
pub struct GapOutcome {
    pub drive: String,
    pub sources: Vec<LabelSource>,
    pub trigger: Trigger,
    pub at_s: f64,
    pub result: Result<serde_json::Value, String>,
    /// Wall time the check took, s.
    pub elapsed_s: f64,
}

/// The function a worker runs on each job: `real_check` in the server, something slower or
/// failing in tests.
pub type CheckFn = Box<dyn FnMut(&GapJob) -> Result<serde_json::Value, String> + Send>;

#[derive(Default)]
struct QueueState {
    pending: VecDeque<GapJob>,
    running: Option<String>,
    stop: bool,
}

/// The queue shared by the engine and the worker.
#[derive(Default)]
pub struct Queue {
    state: Mutex<QueueState>,
    changed: Condvar,
    /// Raised on every change of what waits or runs (read without the lock).
    version: AtomicU64,
}

impl Queue {
    fn lock(&self) -> MutexGuard<'_, QueueState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Wakes the waiters after a change, and raises the version.
    fn changed(&self) {
        self.version.fetch_add(1, Ordering::Relaxed);
        self.changed.notify_all();
    }

    /// A number that changes whenever what waits or runs may have changed.
    pub fn version(&self) -> u64 {
        self.version.load(Ordering::Relaxed)
    }

    /// Queues `job`; a drive already waiting keeps its place and takes the newer job. Returns
    /// whether the drive was newly queued.
    pub fn push(&self, job: GapJob) -> bool {
        let mut s = self.lock();
        let fresh = match s.pending.iter_mut().find(|j| j.drive == job.drive) {
            Some(j) => {
                *j = job;
                false
            }
            None => {
                s.pending.push_back(job);
                true
            }
        };
        self.changed();
        fresh
    }

    /// The drives waiting, in order.
    pub fn pending(&self) -> Vec<String> {
        self.lock()
            .pending
            .iter()
            .map(|j| j.drive.clone())
            .collect()
    }

    /// The drive whose check runs now.
    pub fn running(&self) -> Option<String> {
        self.lock().running.clone()
    }

    /// The next job (marked running), or none once stopped.
    fn take(&self) -> Option<GapJob> {
        let mut s = self.lock();
        loop {
            if s.stop {
                return None;
            }
            if let Some(j) = s.pending.pop_front() {
                s.running = Some(j.drive.clone());
                self.changed();
                return Some(j);
            }
            s = self.changed.wait(s).unwrap_or_else(|e| e.into_inner());
        }
    }

    fn done(&self) {
        self.lock().running = None;
        self.changed();
    }

    fn stop(&self) {
        self.lock().stop = true;
        self.changed();
    }
}

/// The worker thread and its queue.
pub struct Worker {
    pub queue: Arc<Queue>,
    pub outcomes: Receiver<GapOutcome>,
    thread: Option<JoinHandle<()>>,
}

impl Worker {
    /// Starts the worker with a rayon pool of `threads` threads running `check`.
    pub fn start(threads: usize, mut check: CheckFn) -> std::io::Result<Worker> {
        let queue = Arc::new(Queue::default());
        let (tx, outcomes): (Sender<GapOutcome>, _) = channel();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.max(1))
            .thread_name(|i| format!("gap-check-{i}"))
            .start_handler(|_| lower_priority())
            .build()
            .map_err(std::io::Error::other)?;
        let q = queue.clone();
        let thread = std::thread::Builder::new()
            .name("gap-check".into())
            .spawn(move || {
                lower_priority();
                while let Some(job) = q.take() {
                    let started = Instant::now();
                    // A panic in a check is a failed check, never a stopped worker.
                    let result =
                        std::panic::catch_unwind(AssertUnwindSafe(|| pool.install(|| check(&job))))
                            .unwrap_or_else(|p| {
                                Err(format!("the gap check panicked: {}", panic_text(&p)))
                            });
                    let outcome = GapOutcome {
                        drive: job.drive,
                        sources: job.sources,
                        trigger: job.trigger,
                        at_s: job.at_s,
                        result,
                        elapsed_s: started.elapsed().as_secs_f64(),
                    };
                    // The outcome is on the channel before the queue says idle.
                    let gone = tx.send(outcome).is_err();
                    q.done();
                    if gone {
                        return;
                    }
                }
            })?;
        Ok(Worker {
            queue,
            outcomes,
            thread: Some(thread),
        })
    }
}

impl Drop for Worker {
    /// Stops taking jobs; a check under way is left to finish on its own (the process may end
    /// first: a check cut short is simply not stored, and is due again later).
    fn drop(&mut self) {
        self.queue.stop();
        if let Some(t) = self.thread.take() {
            if t.is_finished() {
                let _ = t.join();
            }
        }
    }
}

/// A panic's message, if it carries one.
fn panic_text(p: &Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "no message".into())
}

/// Niceness of the gap check's threads: the engine's thread (niceness 0) gets about ten times
/// their CPU share when they compete for a core (Linux CFS weights, sched(7)).
pub const CHECK_NICENESS: i32 = 10;

/// Lowers the calling thread's scheduling priority to `CHECK_NICENESS` (on Linux a thread is a
/// task with its own niceness); elsewhere, or if refused, the thread keeps its priority.
fn lower_priority() {
    #[cfg(target_os = "linux")]
    // SAFETY: gettid and setpriority take no pointers; a failure only leaves the priority.
    unsafe {
        let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
        libc::setpriority(libc::PRIO_PROCESS, tid, CHECK_NICENESS);
    }
}

/// The real check: `rom gap`'s diagnosis (`twin::gap::gap`, default options) on the job's data
/// set with the drive's surrogate and configuration, as the JSON `rom gap --format json`
/// writes.
pub fn real_check(job: &GapJob) -> Result<serde_json::Value, String> {
    let m = &job.model;
    let r = twin::gap::gap(
        &m.file.surrogate,
        &m.cfg,
        &job.set,
        &twin::gap::GapOptions::default(),
    )
    .map_err(|e| e.to_string())?;
    serde_json::to_value(&r).map_err(|e| e.to_string())
}
