//! A server on a loopback port in this process (tests, the CLI's
//! in-process `grpc://` runs).

use super::*;

/// A server on an ephemeral loopback port, run on its own thread with its
/// own runtime; stopped (gracefully) when dropped. For tests, benchmarks,
/// the demo and anything else that needs a real socket in one process.
pub struct LoopbackServer {
    /// The address it listens on.
    pub addr: std::net::SocketAddr,
    pub(super) stop: Option<tokio::sync::oneshot::Sender<()>>,
    pub(super) thread: Option<std::thread::JoinHandle<Result<(), LoopbackError>>>,
}

impl LoopbackServer {
    /// Binds 127.0.0.1:0 and serves with `cfg` on `workers` runtime threads.
    pub fn start(cfg: ServerConfig, workers: usize) -> std::io::Result<Self> {
        let (tx, rx) = std::sync::mpsc::channel();
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::spawn(move || -> Result<(), LoopbackError> {
            let rt = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(workers.max(1))
                .enable_all()
                .build()
                .map_err(LoopbackError::Runtime)?;
            rt.block_on(async move {
                let l = match tokio::net::TcpListener::bind("127.0.0.1:0").await {
                    Ok(l) => l,
                    Err(e) => {
                        let _ = tx.send(Err(e));
                        return Ok(());
                    }
                };
                let _ = tx.send(l.local_addr());
                serve(l, cfg, async {
                    let _ = stopped.await;
                })
                .await
                .map_err(LoopbackError::from)
            })
        });
        let addr = rx
            .recv()
            .map_err(|_| std::io::Error::other("the server thread ended before binding"))??;
        Ok(Self {
            addr,
            stop: Some(stop),
            thread: Some(thread),
        })
    }

    /// Stops the server and waits for it; reports a serving error.
    pub fn stop(mut self) -> Result<(), LoopbackError> {
        self.shutdown()
    }

    pub(super) fn shutdown(&mut self) -> Result<(), LoopbackError> {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        match self.thread.take() {
            Some(t) => t.join().map_err(|_| LoopbackError::Panicked)?,
            None => Ok(()),
        }
    }
}

impl Drop for LoopbackServer {
    fn drop(&mut self) {
        let _ = self.shutdown();
    }
}
