//! `farm worker`: renders tiles for a coordinator until stopped.

use std::process::ExitCode;

/// Arguments of `farm worker`.
#[derive(Debug, clap::Args)]
pub struct WorkerArgs {
    /// The coordinator, e.g. https://render-host:7878 (http:// only for one
    /// started with --insecure).
    #[arg(long, env = "FARM_COORDINATOR")]
    pub coordinator: String,
    /// The worker token.
    #[command(flatten)]
    pub token: super::TokenArgs,
    /// Render threads (default: one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Name shown in `farm status` (default: the host name).
    #[arg(long)]
    pub name: Option<String>,
    /// Serve the gRPC health service here, for probes.
    #[arg(long)]
    pub health_listen: Option<std::net::SocketAddr>,
    /// Serve Prometheus metrics at http://ADDR/metrics (counts only, no
    /// token: bind it where only your Prometheus reaches).
    #[arg(long, value_name = "ADDR")]
    pub metrics_listen: Option<std::net::SocketAddr>,
}

/// Registers and renders until SIGINT or SIGTERM.
pub async fn run(args: WorkerArgs) -> ExitCode {
    let name = args.name.clone().unwrap_or_else(|| {
        std::fs::read_to_string("/etc/hostname")
            .ok()
            .map(|h| h.trim().to_string())
            .filter(|h| !h.is_empty())
            .or_else(|| std::env::var("HOSTNAME").ok())
            .unwrap_or_else(|| "worker".into())
    });
    let token = match args.token.token() {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return e.exit_code();
        }
    };
    let config = farm_worker::WorkerConfig {
        coordinator: args.coordinator.clone(),
        threads: args.threads,
        name,
        max_in_flight: 0,
        health_listen: args.health_listen,
        metrics_listen: args.metrics_listen,
        reconnect: true,
        token,
    };
    eprintln!("worker {} rendering for {}", config.name, config.coordinator);
    match farm_worker::run(config, crate::runtime::shutdown_signal()).await {
        Ok(s) => {
            eprintln!("worker stopped after {} tiles", s.tiles_rendered);
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
