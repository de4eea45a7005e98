//! A coordinator and workers in one process on 127.0.0.1, port 0: insecure
//! (plaintext, no tokens) or, with [`TestCluster::start_secure`], TLS with
//! the coordinator's own CA and tokens, as `farm coordinator` runs it.

use farm_cli::client::Remote;
use farm_coordinator::security::{bootstrap, Security};
use farm_coordinator::server::{serve, ServerConfig};
use farm_proto::auth::Token;
use farm_worker::{run, WorkerConfig};
use std::path::{Path, PathBuf};
use std::time::Duration;
use tokio::sync::oneshot;
use tokio::task::JoinHandle;

/// A running test farm.
pub struct TestCluster {
    /// The coordinator's URL.
    pub url: String,
    /// With TLS: the state directory, holding `<role>.token`.
    pub state_dir: Option<PathBuf>,
    stop: Option<oneshot::Sender<()>>,
    server: JoinHandle<()>,
    /// Worker tasks; abort one to kill that worker.
    pub workers: Vec<JoinHandle<()>>,
}

/// The token of `role` the first start wrote to `dir`.
pub fn token_in(dir: &Path, role: &str) -> Token {
    let text = std::fs::read_to_string(dir.join(format!("{role}.token"))).expect("token file");
    text.parse().expect("token")
}

impl TestCluster {
    /// Starts an insecure coordinator with the given heartbeat and
    /// `workers` workers of one thread each.
    pub async fn start(workers: usize, heartbeat: Duration) -> TestCluster {
        Self::start_with(workers, ServerConfig::with_heartbeat(heartbeat), None).await
    }

    /// Starts a coordinator with TLS and tokens whose state is in `dir`
    /// (made on first start, kept otherwise); its workers use the worker token.
    pub async fn start_secure(workers: usize, heartbeat: Duration, dir: &Path) -> TestCluster {
        let hosts = ["localhost".to_string(), "127.0.0.1".to_string()];
        let mut config = ServerConfig::with_heartbeat(heartbeat);
        config.security = bootstrap(dir, &hosts, None).expect("security");
        Self::start_with(workers, config, Some(dir.to_path_buf())).await
    }

    /// Starts an insecure coordinator with `config` and `workers` workers.
    pub async fn start_config(workers: usize, config: ServerConfig) -> TestCluster {
        Self::start_with(workers, config, None).await
    }

    async fn start_with(workers: usize, config: ServerConfig, dir: Option<PathBuf>) -> TestCluster {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
        let addr = listener.local_addr().expect("addr");
        let scheme = if matches!(config.security, Security::Tls { .. }) { "https" } else { "http" };
        let url = format!("{scheme}://{addr}");
        let (stop, stopped) = oneshot::channel::<()>();
        let server = tokio::spawn(async move {
            serve(listener, config, async {
                let _ = stopped.await;
            })
            .await
            .expect("coordinator");
        });
        let mut c =
            TestCluster { url, state_dir: dir, stop: Some(stop), server, workers: Vec::new() };
        for _ in 0..workers {
            c.add_worker();
        }
        c
    }

    /// The token of `role`, with TLS.
    pub fn token(&self, role: &str) -> Option<Token> {
        self.state_dir.as_deref().map(|d| token_in(d, role))
    }

    /// The coordinator as a client reaches it (with the client token, with TLS).
    pub fn remote(&self) -> Remote {
        Remote { url: self.url.clone(), token: self.token("client") }
    }

    /// Starts one more worker (one render thread).
    pub fn add_worker(&mut self) {
        self.add_worker_with(|_| {});
    }

    /// Starts one more worker (one render thread), its settings changed by `change`.
    pub fn add_worker_with(&mut self, change: impl FnOnce(&mut WorkerConfig)) {
        let mut config = WorkerConfig {
            coordinator: self.url.clone(),
            threads: 1,
            name: format!("test-worker-{}", self.workers.len()),
            max_in_flight: 0,
            health_listen: None,
            metrics_listen: None,
            reconnect: false,
            token: self.token("worker"),
        };
        change(&mut config);
        self.workers.push(tokio::spawn(async move {
            let _ = run(config, std::future::pending::<()>()).await;
        }));
    }

    /// Stops the coordinator and every worker.
    pub async fn stop(mut self) {
        for w in &self.workers {
            w.abort();
        }
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        let _ = tokio::time::timeout(Duration::from_secs(10), &mut self.server).await;
    }
}
