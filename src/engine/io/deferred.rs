//! Image files written on background threads while the next frame is evaluated
//! (`tyndall render`, Python's `tyndall.render`): [`defer`] turns [`super::write_image`] on the
//! calling thread into a queued job — the raster
//! is handed over, encoded (EXR compression and PNG encoding included) and written atomically by
//! one of a few writer threads — and [`wait`] waits for every queued write and returns the
//! failures. The bytes of each file are the same as a synchronous write's; at most one write per
//! writer thread runs and one more waits (a frame's raster each: 5 × 133 MB at 4K RGBA32F with 4
//! writers), so memory stays bounded.

use std::cell::Cell;
use std::path::PathBuf;
use std::sync::mpsc::{channel, Sender};
use std::sync::{Arc, Condvar, Mutex, OnceLock};

use super::IoError;

/// Writes queued or running beyond one per writer thread.
const WAITING: usize = 1;

type Job = Box<dyn FnOnce() -> Result<(), IoError> + Send>;

/// Writes queued or running, and the failures not yet returned by [`wait`], with the condition
/// writers signal when one finishes.
type State = Arc<(Mutex<(usize, Vec<IoError>)>, Condvar)>;

struct Pool {
    tx: Mutex<Sender<(PathBuf, Job)>>,
    state: State,
    limit: usize,
}

thread_local! {
    /// Whether this thread's image writes are deferred: per thread, so a render deferring its
    /// writes leaves another evaluation of the same process (a Python thread, the editor)
    /// writing synchronously.
    static ON: Cell<bool> = const { Cell::new(false) };
}
static POOL: OnceLock<Pool> = OnceLock::new();

fn pool() -> &'static Pool {
    POOL.get_or_init(|| {
        let threads = std::thread::available_parallelism()
            .map_or(2, |n| n.get())
            .clamp(1, 4);
        let (tx, rx) = channel::<(PathBuf, Job)>();
        let rx = Arc::new(Mutex::new(rx));
        let state: State = Arc::default();
        for i in 0..threads {
            let (rx, state) = (rx.clone(), state.clone());
            let _ = std::thread::Builder::new()
                .name(format!("tyndall-write-{i}"))
                .spawn(move || loop {
                    let job = match rx.lock() {
                        Ok(r) => r.recv(),
                        Err(_) => return,
                    };
                    let Ok((path, job)) = job else { return };
                    // A panic in an encoder is a failed write, not a writer gone (which would
                    // leave `wait` waiting for it).
                    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(job))
                        .unwrap_or_else(|_| {
                            Err(IoError::Write {
                                path,
                                reason: "the encoder panicked".into(),
                            })
                        });
                    let (lock, cv) = &*state;
                    let mut s = lock.lock().unwrap_or_else(|e| e.into_inner());
                    s.0 -= 1;
                    if let Err(e) = result {
                        s.1.push(e);
                    }
                    cv.notify_all();
                });
        }
        Pool {
            tx: Mutex::new(tx),
            state,
            limit: threads + WAITING,
        }
    })
}

/// Write this thread's image files on background threads from now on (`true`), or
/// synchronously again.
pub fn defer(on: bool) {
    ON.with(|d| d.set(on));
}

/// Whether this thread's image writes are deferred.
pub fn deferred() -> bool {
    ON.with(Cell::get)
}

/// Queue `job` (a write of `path`), waiting while the queue is full; runs it here when no
/// writer thread could be started.
pub(super) fn submit(path: PathBuf, job: Job) -> Result<(), IoError> {
    let p = pool();
    let (lock, cv) = &*p.state;
    let mut s = lock.lock().unwrap_or_else(|e| e.into_inner());
    while s.0 >= p.limit {
        s = cv.wait(s).unwrap_or_else(|e| e.into_inner());
    }
    s.0 += 1;
    drop(s);
    let sent = p.tx.lock().map(|tx| tx.send((path.clone(), job)));
    match sent {
        Ok(Ok(())) => Ok(()),
        Ok(Err(unsent)) => {
            let mut s = lock.lock().unwrap_or_else(|e| e.into_inner());
            s.0 -= 1;
            drop(s);
            (unsent.0 .1)()
        }
        Err(_) => {
            let mut s = lock.lock().unwrap_or_else(|e| e.into_inner());
            s.0 -= 1;
            Err(IoError::Write {
                path,
                reason: "the background writer is gone".into(),
            })
        }
    }
}

/// Wait until every queued write has finished (every thread's); the writes that failed since
/// the last call.
pub fn wait() -> Vec<IoError> {
    let Some(p) = POOL.get() else {
        return Vec::new();
    };
    let (lock, cv) = &*p.state;
    let mut s = lock.lock().unwrap_or_else(|e| e.into_inner());
    while s.0 > 0 {
        s = cv.wait(s).unwrap_or_else(|e| e.into_inner());
    }
    std::mem::take(&mut s.1)
}
