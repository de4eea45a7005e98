//! A coordinator and workers in one process on 127.0.0.1, port 0.

use farm_coordinator::server::{serve, ServerConfig};
use farm_worker::{run, WorkerConfig};
use std::time::Duration;
use tokio::sync::oneshot;
use tokio::task::JoinHandle;

/// A running test farm.
pub struct TestCluster {
    /// The coordinator's URL.
    pub url: String,
    stop: Option<oneshot::Sender<()>>,
    server: JoinHandle<()>,
    /// Worker tasks; abort one to kill that worker.
    pub workers: Vec<JoinHandle<()>>,
}

impl TestCluster {
    /// Starts a coordinator with the given heartbeat and `workers` workers of one thread each.
    pub async fn start(workers: usize, heartbeat: Duration) -> TestCluster {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.expect("bind");
        let url = format!("http://{}", listener.local_addr().expect("addr"));
        let (stop, stopped) = oneshot::channel::<()>();
        let server = tokio::spawn(async move {
            serve(listener, ServerConfig::with_heartbeat(heartbeat), async {
                let _ = stopped.await;
            })
            .await
            .expect("coordinator");
        });
        let mut c = TestCluster { url, stop: Some(stop), server, workers: Vec::new() };
        for _ in 0..workers {
            c.add_worker();
        }
        c
    }

    /// Starts one more worker (one render thread).
    pub fn add_worker(&mut self) {
        let config = WorkerConfig {
            coordinator: self.url.clone(),
            threads: 1,
            name: format!("test-worker-{}", self.workers.len()),
            max_in_flight: 0,
            health_listen: None,
            reconnect: false,
        };
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
