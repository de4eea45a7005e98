//! `farm coordinator`: the long-running scheduler and gRPC server.

use crate::EXIT_BAD_INPUT;
use std::process::ExitCode;

/// Arguments of `farm coordinator`.
#[derive(Debug, clap::Args)]
pub struct CoordinatorArgs {
    /// Address to listen on.
    #[arg(long, default_value = "0.0.0.0:7878")]
    pub listen: std::net::SocketAddr,
    /// Seconds between worker heartbeats; a worker silent for three is lost.
    #[arg(long, default_value_t = 2.0)]
    pub heartbeat: f64,
    /// The largest job to accept.
    #[command(flatten)]
    pub limits: super::LimitArgs,
}

/// Listens, then serves until SIGINT or SIGTERM.
pub async fn run(args: CoordinatorArgs) -> ExitCode {
    let listener = match tokio::net::TcpListener::bind(args.listen).await {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: cannot listen on {}: {e}", args.listen);
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let heartbeat = std::time::Duration::from_secs_f64(args.heartbeat.clamp(0.05, 3600.0));
    let addr =
        listener.local_addr().map(|a| a.to_string()).unwrap_or_else(|_| args.listen.to_string());
    eprintln!("coordinator listening on {addr}");
    match farm_coordinator::server::serve(
        listener,
        farm_coordinator::server::ServerConfig {
            limits: (&args.limits).into(),
            ..farm_coordinator::server::ServerConfig::with_heartbeat(heartbeat)
        },
        crate::runtime::shutdown_signal(),
    )
    .await
    {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
