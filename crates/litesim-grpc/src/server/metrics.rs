//! Counters and call latencies, for the Prometheus endpoint.

use super::*;

/// Upper bounds of the call-latency histogram's buckets (s).
pub(super) const LATENCY_BUCKETS: [f64; 11] = [
    25e-6, 50e-6, 100e-6, 250e-6, 500e-6, 1e-3, 2.5e-3, 10e-3, 50e-3, 250e-3, 1.0,
];

/// One method's call latencies: counts per bucket (the last is +Inf),
/// their sum.
#[derive(Clone, Debug, Default)]
pub(super) struct Latency {
    pub(super) buckets: [u64; LATENCY_BUCKETS.len() + 1],
    pub(super) sum: f64,
    pub(super) count: u64,
}

/// What `--metrics` serves.
#[derive(Default)]
pub(super) struct Metrics {
    pub(super) created: AtomicU64,
    /// Freed by cause: Shutdown (or a StepStream's end), connection
    /// closed, idle timeout, after EndSimulation.
    pub(super) freed: [AtomicU64; 4],
    pub(super) steps: AtomicU64,
    pub(super) calls: Mutex<BTreeMap<&'static str, Latency>>,
}

impl Metrics {
    pub(super) fn freed(&self, why: &Ended) {
        let k = match why {
            Ended::Shutdown(_) => 0,
            Ended::ConnectionClosed(_) => 1,
            Ended::Idle(_) => 2,
            Ended::AfterEnd(_) => 3,
        };
        self.freed[k].fetch_add(1, Ordering::Relaxed);
    }

    pub(super) fn call(&self, method: &'static str, took: Duration) {
        let s = took.as_secs_f64();
        let mut calls = lock(&self.calls);
        let l = calls.entry(method).or_default();
        let b = LATENCY_BUCKETS
            .iter()
            .position(|&le| s <= le)
            .unwrap_or(LATENCY_BUCKETS.len());
        l.buckets[b] += 1;
        l.sum += s;
        l.count += 1;
    }
}

/// Serves `GET /metrics` (Prometheus text) on `listener`; anything else
/// is 404. One short HTTP/1.1 exchange per connection.
pub(super) async fn serve_metrics(listener: tokio::net::TcpListener, svc: SspService) {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    loop {
        let Ok((mut sock, _)) = listener.accept().await else {
            continue;
        };
        let svc = svc.clone();
        tokio::spawn(async move {
            let mut buf = vec![0u8; 8192];
            let mut n = 0;
            // The request line and headers: at most 8 KiB, within 5 s.
            let read = tokio::time::timeout(Duration::from_secs(5), async {
                while n < buf.len() {
                    let k = sock.read(&mut buf[n..]).await.ok()?;
                    if k == 0 {
                        return None;
                    }
                    n += k;
                    if buf[..n].windows(4).any(|w| w == b"\r\n\r\n") {
                        return Some(());
                    }
                }
                None
            })
            .await;
            if !matches!(read, Ok(Some(()))) {
                return;
            }
            let head = String::from_utf8_lossy(&buf[..n]);
            let path = head.split_whitespace().nth(1).unwrap_or("");
            let wanted = head.starts_with("GET ") && path.split('?').next() == Some("/metrics");
            let (status, body) = if wanted {
                ("200 OK", svc.metrics_text())
            } else {
                (
                    "404 Not Found",
                    "litesim serves its metrics at GET /metrics\n".to_string(),
                )
            };
            let reply = format!(
                "HTTP/1.1 {status}\r\nContent-Type: text/plain; version=0.0.4; charset=utf-8\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
                body.len()
            );
            let _ = sock.write_all(reply.as_bytes()).await;
            let _ = sock.shutdown().await;
        });
    }
}
