//! The server's settings: limits, timeouts, map roots, TLS, tokens.

use super::*;

/// A TLS identity: certificate chain and private key, PEM.
#[derive(Clone)]
pub struct TlsPem {
    /// The certificate chain.
    pub cert: Vec<u8>,
    /// The private key.
    pub key: Vec<u8>,
}

impl std::fmt::Debug for TlsPem {
    /// The key never goes into a message.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "TlsPem({} bytes of certificate, key hidden)",
            self.cert.len()
        )
    }
}

/// Server settings.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// Profile for `Init` requests that name none.
    pub default_profile: String,
    /// Model for `Init` requests that name none.
    pub default_model: String,
    /// Sessions alive at once.
    pub max_sessions: usize,
    /// Per-session limits.
    pub limits: SessionLimits,
    /// A session unused this long is ended: the lease every call — or an
    /// explicit `KeepAlive` — renews. Off (`None`) by default: sessions
    /// live as long as their connection.
    pub idle_timeout: Option<Duration>,
    /// HTTP/2 keepalive: pings every this long, and a connection that
    /// does not answer one within it is closed (its sessions detached).
    pub keepalive: Duration,
    /// How long a session outlives its closed connection, for `Attach`.
    pub attach_grace: Duration,
    /// The folders `Init`'s `map_path` may read from (empty: the folder
    /// the server was started in).
    pub map_roots: Vec<PathBuf>,
    /// Every call but health's must carry `authorization: Bearer <this>`
    /// (UNAUTHENTICATED otherwise).
    pub auth_token: Option<String>,
    /// Serve Prometheus text metrics (`GET /metrics`) on this address.
    pub metrics: Option<std::net::SocketAddr>,
    /// Serve over TLS with this certificate chain and key (PEM).
    pub tls: Option<TlsPem>,
    /// Largest request accepted (bytes).
    pub max_message_bytes: usize,
    /// JSON-lines trace of every call.
    pub trace_rpc: Option<PathBuf>,
}

impl Default for ServerConfig {
    fn default() -> Self {
        Self {
            default_profile: "dummy".into(),
            default_model: "dummy".into(),
            max_sessions: 64,
            limits: SessionLimits::default(),
            idle_timeout: None,
            keepalive: Duration::from_secs(10),
            attach_grace: Duration::from_secs(30),
            map_roots: Vec::new(),
            auth_token: None,
            metrics: None,
            tls: None,
            max_message_bytes: 16 * 1024 * 1024,
            trace_rpc: None,
        }
    }
}
