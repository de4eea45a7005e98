//! How a worker process runs: where its coordinator is, how many render
//! threads it uses and how many tiles it holds at once.

use std::net::SocketAddr;

/// A worker's settings (built from the command line by the binary).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WorkerConfig {
    /// The coordinator's gRPC address, e.g. `http://127.0.0.1:7878`.
    pub coordinator: String,
    /// Render threads; 0 = one per core.
    pub threads: usize,
    /// A human-readable name shown by `farm status`.
    pub name: String,
    /// Tiles held at once (queued plus rendering); 0 = 4 × threads + 2.
    pub max_in_flight: u32,
    /// Where to serve `grpc.health.v1`, if anywhere.
    pub health_listen: Option<SocketAddr>,
    /// Where to serve Prometheus `/metrics`, if anywhere.
    pub metrics_listen: Option<SocketAddr>,
    /// Whether to keep re-registering after the coordinator goes away.
    pub reconnect: bool,
    /// The worker token (required with an https:// coordinator).
    pub token: Option<farm_proto::auth::Token>,
}

impl Default for WorkerConfig {
    fn default() -> Self {
        WorkerConfig {
            coordinator: "http://127.0.0.1:7878".to_string(),
            threads: 0,
            name: "worker".to_string(),
            max_in_flight: 0,
            health_listen: None,
            metrics_listen: None,
            reconnect: true,
            token: None,
        }
    }
}

impl WorkerConfig {
    /// Render threads to start: `threads`, or one per core when it is 0.
    pub fn render_threads(&self) -> usize {
        if self.threads > 0 {
            self.threads
        } else {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        }
    }

    /// Tiles to ask for at once given the pool's thread count.
    pub fn in_flight(&self, threads: usize) -> u32 {
        if self.max_in_flight > 0 {
            self.max_in_flight
        } else {
            default_in_flight(threads)
        }
    }
}

pub use farm_proto::default_in_flight;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_means_automatic() {
        let c = WorkerConfig { threads: 3, ..Default::default() };
        assert_eq!(c.render_threads(), 3);
        assert_eq!(c.in_flight(3), 14);
        let c = WorkerConfig { max_in_flight: 5, ..c };
        assert_eq!(c.in_flight(3), 5);
        assert!(WorkerConfig::default().render_threads() >= 1);
    }
}
