//! The scans of a file, read in a thread of its own: `host_bridge::input`'s
//! reader is not `Send` (a boxed `BufRead`), so it lives in the thread that
//! opens it, which reads a few scans ahead, applies a function to each (the
//! pipeline, for `extract_log`) and hands the results over a bounded
//! channel. The iterators built on a [`Stream`] can then be used from any
//! Python thread, and they wait for the next scan without the GIL.

use std::path::PathBuf;
use std::sync::mpsc::{sync_channel, Receiver};
use std::sync::Mutex;

use host_bridge::input::{self, InputScan};
use host_bridge::options::UnitArg;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

use crate::convert::{host_error, warn};

/// Scans read ahead of the caller.
const READ_AHEAD: usize = 4;

/// What the reading thread hands over.
enum Message<T> {
    /// The next scan's result.
    Item(T),
    /// The error that ends the scans (a damaged scan, a file without scans).
    Failed(anyhow::Error),
    /// The scans ended; where and why the file is cut, if it is.
    End { cut: Option<String> },
}

struct State<T> {
    rx: Receiver<Message<T>>,
    finished: bool,
}

/// The results of `each` on the scans of a file, in order.
pub struct Stream<T> {
    state: Mutex<State<T>>,
    source: String,
}

impl<T: Send + 'static> Stream<T> {
    /// Open `path` (a log in `unit`, or a capture) in a new thread and read
    /// it there, applying `each` to every scan. An error of opening is
    /// returned here, as `input::open` gives it.
    pub fn open<F>(path: PathBuf, unit: UnitArg, mut each: F) -> PyResult<Stream<T>>
    where
        F: FnMut(InputScan) -> anyhow::Result<T> + Send + 'static,
    {
        let (opened_tx, opened_rx) = sync_channel::<anyhow::Result<String>>(1);
        let (tx, rx) = sync_channel(READ_AHEAD);
        let reader = move || {
            let mut file = match input::open(&path, unit) {
                Ok(file) => file,
                Err(e) => {
                    let _ = opened_tx.send(Err(e));
                    return;
                }
            };
            let source = format!("{} ({})", file.path().display(), file.describe());
            if opened_tx.send(Ok(source)).is_err() {
                return;
            }
            for scan in file.by_ref() {
                let (message, last) = match scan.and_then(&mut each) {
                    Ok(item) => (Message::Item(item), false),
                    Err(e) => (Message::Failed(e), true),
                };
                // A closed channel: the iterator was dropped.
                if tx.send(message).is_err() || last {
                    return;
                }
            }
            let _ = tx.send(Message::End { cut: file.cut() });
        };
        std::thread::Builder::new()
            .name("lms_features reader".into())
            .spawn(reader)
            .map_err(|e| PyRuntimeError::new_err(format!("cannot start a reader thread: {e}")))?;
        let source = opened_rx
            .recv()
            .map_err(|_| PyRuntimeError::new_err("the reader thread stopped"))?
            .map_err(host_error)?;
        Ok(Stream {
            state: Mutex::new(State {
                rx,
                finished: false,
            }),
            source,
        })
    }

    /// The file and what it was read as, e.g. `PATH (CARMEN log, cm ranges …)`.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// The next result, waited for without the GIL; `None` after the last
    /// (a cut file then gives its `UserWarning`). The error that ends the
    /// scans is raised once, then `None`.
    pub fn next(&self, py: Python<'_>) -> PyResult<Option<T>> {
        let message = py.detach(|| {
            let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
            if state.finished {
                return None;
            }
            let message = state.rx.recv().ok();
            state.finished = !matches!(message, Some(Message::Item(_)));
            Some(message)
        });
        match message {
            None => Ok(None),
            Some(Some(Message::Item(item))) => Ok(Some(item)),
            Some(Some(Message::Failed(e))) => Err(host_error(e)),
            Some(Some(Message::End { cut })) => {
                if let Some(cut) = cut {
                    warn(py, &cut)?;
                }
                Ok(None)
            }
            Some(None) => Err(PyRuntimeError::new_err("the reader thread stopped")),
        }
    }
}
