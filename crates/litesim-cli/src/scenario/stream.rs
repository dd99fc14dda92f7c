//! `run --mcap`: the MCAP file written while the run steps, on a writer
//! thread kept off the run's CPU.

use super::*;

/// The MCAP file of `litesim run`, written on its own thread from the
/// moment the test has loaded and the run's stamp is on disk
/// ([`McapStreamer::map`] hands it the map):
/// header, schemas and the map's content, then the ticks — every 50 from the
/// run's observer, the rest when the run is over ([`McapStreamer::end`]). A
/// run that ends without a log (an error) leaves no file: dropping the
/// streamer stops the writer, which discards its temporary file, and waits
/// for it.
pub(super) struct McapStreamer {
    pub(super) state: std::sync::Arc<std::sync::Mutex<StreamState>>,
    pub(super) job: Option<StreamJob>,
}

/// The writer thread and the outcome it reports once its file is in place
/// (or given up).
pub(super) struct StreamJob {
    pub(super) thread: std::thread::JoinHandle<()>,
    pub(super) outcome: std::sync::mpsc::Receiver<Result<(), litesim_mcap::McapError>>,
}

impl StreamJob {
    /// Waits until the file is in place (or given up) and says how it went;
    /// the thread is left to wind down on its own.
    pub(super) fn wait(self) -> Result<(), litesim_mcap::McapError> {
        self.outcome
            .recv()
            .unwrap_or_else(|_| Err(litesim_mcap::McapError::Stopped("it panicked".into())))
    }
}

/// What the writer thread is handed, in this order: pieces of ticks, the
/// end.
pub(super) enum ToWriter {
    Piece(Box<litesim_log::SimulationLog>),
    Done,
}

pub(super) struct StreamState {
    /// `None` once the writer was told the run is over (or stopped).
    pub(super) tx: Option<std::sync::mpsc::Sender<ToWriter>>,
    /// Ticks handed over so far.
    pub(super) sent: usize,
    /// Metadata the CLI adds to the run's log (test, run), in every piece.
    pub(super) extra: Vec<(String, String)>,
}

impl StreamState {
    pub(super) fn send(&mut self, log: &litesim_log::SimulationLog) {
        let mut piece = log.ticks_from(self.sent);
        piece.meta.extend(self.extra.iter().cloned());
        self.sent = log.tick.len();
        if let Some(tx) = &self.tx {
            // A writer that stopped has its error waiting at `join`.
            let _ = tx.send(ToWriter::Piece(Box::new(piece)));
        }
    }
}

/// Ticks per piece handed to the writer: often enough that it keeps up
/// with the run, seldom enough that the copies cost nothing.
pub(super) const STREAM_PIECE: usize = 50;

impl McapStreamer {
    /// Starts the writer of `path` for a run on `net` (`None`: without a
    /// map) whose log carries `extra` in its metadata (test, run): every
    /// piece gets the same.
    pub(super) fn start(
        path: &Path,
        net: Option<std::sync::Arc<litesim_map::RoadNetwork>>,
        extra: Vec<(String, String)>,
    ) -> Result<McapStreamer> {
        let (tx, rx) = std::sync::mpsc::channel::<ToWriter>();
        let (done, outcome) = std::sync::mpsc::channel();
        let path = path.to_path_buf();
        let write = move || -> Result<(), litesim_mcap::McapError> {
            let mut made = Ok(());
            let written = litesim_log::write_atomic_seekable(&path, |w| {
                made = stream_pieces(&mut *w, net, &rx);
                made.as_ref()
                    .map(|_| ())
                    .map_err(|e| std::io::Error::other(e.to_string()))
            });
            made?;
            written?;
            Ok(())
        };
        let thread = std::thread::Builder::new()
            .name("mcap".into())
            // The outcome goes out as soon as the file is in place (or its
            // temporary is gone): the run need not wait for the thread to
            // wind down (−0.1 ms a run; BENCHMARKS.md, seventeenth session).
            .spawn(move || {
                let _ = done.send(write());
            })
            .map_err(|e| anyhow!("starting the MCAP writer: {e}"))?;
        let _ = placement::keep_off_this_cpu(&placement::others());
        let state = StreamState {
            tx: Some(tx),
            sent: 0,
            extra,
        };
        Ok(McapStreamer {
            state: std::sync::Arc::new(std::sync::Mutex::new(state)),
            job: Some(StreamJob { thread, outcome }),
        })
    }

    pub(super) fn lock(&self) -> std::sync::MutexGuard<'_, StreamState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The run's observer: a piece every [`STREAM_PIECE`] ticks.
    pub(super) fn observer(&self) -> litesim_scenario::TickObserver {
        let state = std::sync::Arc::clone(&self.state);
        litesim_scenario::TickObserver(std::sync::Arc::new(std::sync::Mutex::new(
            move |log: &litesim_log::SimulationLog| {
                let mut s = state.lock().unwrap_or_else(|e| e.into_inner());
                if log.tick.len() >= s.sent + STREAM_PIECE {
                    s.send(log);
                }
            },
        )))
    }

    /// Hands over the ticks not yet sent from the finished log and says it
    /// is complete; the returned job finishes the file.
    pub(super) fn end(mut self, log: &litesim_log::SimulationLog) -> Option<StreamJob> {
        {
            let mut s = self.lock();
            s.send(log);
            if let Some(tx) = s.tx.take() {
                let _ = tx.send(ToWriter::Done);
            }
        }
        self.job.take()
    }
}

impl Drop for McapStreamer {
    /// A run that failed: the writer sees its channel close, abandons the
    /// temporary file, and is waited for (a thread cut off at exit would
    /// leave it behind).
    fn drop(&mut self) {
        self.lock().tx = None;
        if let Some(job) = self.job.take() {
            let _ = job.thread.join();
        }
    }
}

/// Where the MCAP writer runs: on a CPU other than the run's.
///
/// Left to itself, the scheduler queues a new thread on the CPU of the
/// thread that made it, and wakes it there again each time the run hands
/// it a piece: on a two-CPU machine the writer then starts only when the
/// run first waits for the disk (delaying that very wait by its start-up)
/// and later preempts the run while the other CPU idles (traced with `perf
/// sched`: the run waited 0.3–2 ms a run with a CPU idle; BENCHMARKS.md,
/// seventeenth session). So the writer is kept off the CPU the run is on
/// when it starts; with one CPU allowed nothing changes.
#[cfg(target_os = "linux")]
mod placement {
    use rustix::thread::{Pid, gettid, sched_getaffinity, sched_getcpu, sched_setaffinity};

    /// This process's threads, from the kernel's list: std cannot say
    /// which system thread a `JoinHandle` is before that thread has run.
    pub(super) fn threads() -> Vec<Pid> {
        std::fs::read_dir("/proc/self/task")
            .map(|rd| {
                rd.flatten()
                    .filter_map(|e| e.file_name().to_str()?.parse().ok())
                    .filter_map(Pid::from_raw)
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Every thread of this process but the caller: as the MCAP writer
    /// starts, the writer alone (a SUT client's helper, were there one,
    /// is as well kept apart from the run).
    pub(super) fn others() -> Vec<Pid> {
        let me = gettid();
        threads().into_iter().filter(|&p| p != me).collect()
    }

    /// Keeps `others` off the calling thread's CPU, which it returns
    /// (`None`: the caller may use no other CPU; nothing changed). Best
    /// effort: a placement that cannot be set is left as it was.
    pub(super) fn keep_off_this_cpu(others: &[Pid]) -> Option<usize> {
        let mut set = sched_getaffinity(None).ok()?;
        let cpu = sched_getcpu();
        set.unset(cpu);
        if set.count() == 0 {
            return None;
        }
        for &p in others {
            let _ = sched_setaffinity(Some(p), &set);
        }
        Some(cpu)
    }
}

/// Elsewhere the scheduler places the writer.
#[cfg(not(target_os = "linux"))]
mod placement {
    pub(super) fn others() -> Vec<u32> {
        Vec::new()
    }

    pub(super) fn keep_off_this_cpu(_others: &[u32]) -> Option<usize> {
        None
    }
}

/// Writes the MCAP file of a run on `net` from what arrives on `rx`:
/// header, schemas and the map's content at once, the first piece's
/// actors, then each piece until the run is over.
pub(super) fn stream_pieces<W: std::io::Write + std::io::Seek>(
    w: W,
    net: Option<std::sync::Arc<litesim_map::RoadNetwork>>,
    rx: &std::sync::mpsc::Receiver<ToWriter>,
) -> Result<(), litesim_mcap::McapError> {
    let stopped = || litesim_mcap::McapError::Stopped("the run ended without a log".into());
    let prelude = litesim_mcap::McapPrelude::new(w)?;
    let map = net.map(|n| litesim_mcap::McapMap::new(&n));
    let prelude = prelude.map(map.as_ref());
    let Ok(ToWriter::Piece(first)) = rx.recv() else {
        return Err(stopped());
    };
    let mut stream = prelude.start(&first)?;
    stream.push(&first)?;
    loop {
        match rx.recv() {
            Ok(ToWriter::Piece(piece)) => stream.push(&piece)?,
            Ok(ToWriter::Done) => return stream.finish().map(|_| ()),
            Err(_) => return Err(stopped()),
        }
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use rustix::thread::sched_getaffinity;

    #[test]
    fn a_thread_started_for_the_writer_keeps_off_the_cpu_it_was_started_from() {
        let mine = sched_getaffinity(None).unwrap();
        // The thread reports where it may run once it has been placed.
        let (go_tx, go_rx) = std::sync::mpsc::channel::<()>();
        let (tx, rx) = std::sync::mpsc::channel();
        let before = super::placement::threads();
        let worker = std::thread::spawn(move || {
            let _ = go_rx.recv();
            tx.send(sched_getaffinity(None).unwrap()).unwrap();
        });
        // Only the threads started since (other tests run beside this one).
        let new: Vec<_> = super::placement::threads()
            .into_iter()
            .filter(|p| !before.contains(p))
            .collect();
        let kept_off = super::placement::keep_off_this_cpu(&new);
        go_tx.send(()).unwrap();
        let theirs = rx.recv().unwrap();
        worker.join().unwrap();
        // The caller's own placement never changes.
        assert_eq!(sched_getaffinity(None).unwrap(), mine);
        match kept_off {
            // One CPU allowed: nothing moves.
            None => {
                assert_eq!(mine.count(), 1);
                assert_eq!(theirs, mine);
            }
            Some(cpu) => {
                assert!(mine.is_set(cpu) && mine.count() >= 2);
                assert!(
                    !theirs.is_set(cpu),
                    "the new thread may still run on CPU {cpu}"
                );
                assert_eq!(theirs.count(), mine.count() - 1);
            }
        }
    }
}
