//! Connections: the bearer-token check, and the tracking that tells a
//! session's owner connection closed (its sessions are then detached).

use super::*;

/// Checks each call's `authorization: Bearer <token>` against the
/// server's token (every call passes when it has none).
#[derive(Clone)]
pub(super) struct BearerCheck {
    pub(super) expected: Option<Arc<str>>,
}

impl tonic::service::Interceptor for BearerCheck {
    fn call(&mut self, req: Request<()>) -> Result<Request<()>, Status> {
        let Some(want) = &self.expected else {
            return Ok(req);
        };
        let given = req
            .metadata()
            .get("authorization")
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.strip_prefix("Bearer "))
            .unwrap_or("");
        // Compared in time independent of where they differ.
        let same = given.len() == want.len()
            && given
                .bytes()
                .zip(want.bytes())
                .fold(0u8, |acc, (a, b)| acc | (a ^ b))
                == 0;
        if same {
            Ok(req)
        } else {
            Err(Status::unauthenticated(
                "this server needs `authorization: Bearer <token>` on every call (litesim serve --auth-token-file)",
            ))
        }
    }
}

/// The connection a request came on (none when the service is called
/// without one).
pub(super) fn conn_of<T>(req: &Request<T>) -> Option<u64> {
    let ext = req.extensions();
    ext.get::<ConnId>()
        .or_else(|| {
            ext.get::<tonic::transport::server::TlsConnectInfo<ConnId>>()
                .map(|t| t.get_ref())
        })
        .map(|c| c.0)
}

/// A connection's number, in each request's extensions.
#[derive(Clone, Copy, Debug)]
pub struct ConnId(pub u64);

/// An accepted TCP connection that tells the service when it closes
/// (hyper drops it when the client closes, is killed, or misses the
/// keepalive).
pub(super) struct TrackedConn {
    pub(super) io: tokio::net::TcpStream,
    pub(super) id: u64,
    pub(super) svc: SspService,
}

impl Drop for TrackedConn {
    fn drop(&mut self) {
        self.svc.connection_closed(self.id);
    }
}

impl tonic::transport::server::Connected for TrackedConn {
    type ConnectInfo = ConnId;
    fn connect_info(&self) -> ConnId {
        ConnId(self.id)
    }
}

impl tokio::io::AsyncRead for TrackedConn {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
        buf: &mut tokio::io::ReadBuf<'_>,
    ) -> std::task::Poll<std::io::Result<()>> {
        Pin::new(&mut self.io).poll_read(cx, buf)
    }
}

impl tokio::io::AsyncWrite for TrackedConn {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
        buf: &[u8],
    ) -> std::task::Poll<std::io::Result<usize>> {
        Pin::new(&mut self.io).poll_write(cx, buf)
    }
    fn poll_flush(
        mut self: Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<std::io::Result<()>> {
        Pin::new(&mut self.io).poll_flush(cx)
    }
    fn poll_shutdown(
        mut self: Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<std::io::Result<()>> {
        Pin::new(&mut self.io).poll_shutdown(cx)
    }
    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
        bufs: &[std::io::IoSlice<'_>],
    ) -> std::task::Poll<std::io::Result<usize>> {
        Pin::new(&mut self.io).poll_write_vectored(cx, bufs)
    }
    fn is_write_vectored(&self) -> bool {
        self.io.is_write_vectored()
    }
}

/// Accepted connections, numbered and tracked by `svc`.
pub(super) fn tracked_incoming(
    listener: tokio::net::TcpListener,
    svc: SspService,
) -> impl tokio_stream::Stream<Item = std::io::Result<TrackedConn>> {
    let next = AtomicU64::new(1);
    nodelay_incoming(listener).map(move |conn| {
        conn.map(|io| {
            let id = next.fetch_add(1, Ordering::SeqCst);
            svc.connection_opened(id);
            TrackedConn {
                io,
                id,
                svc: svc.clone(),
            }
        })
    })
}

pub(crate) fn nodelay_incoming(
    listener: tokio::net::TcpListener,
) -> impl tokio_stream::Stream<Item = std::io::Result<tokio::net::TcpStream>> {
    tokio_stream::wrappers::TcpListenerStream::new(listener).map(|conn| {
        conn.inspect(|s| {
            let _ = s.set_nodelay(true);
        })
    })
}
