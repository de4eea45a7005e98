//! `farm coordinator`: the long-running scheduler and gRPC server.

use crate::EXIT_BAD_INPUT;
use farm_coordinator::security::{self, Security};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

/// "90", "90s", "30m", "24h", "7d" as a duration.
pub fn parse_duration(s: &str) -> Result<Duration, String> {
    let s = s.trim();
    let (num, unit) = s.split_at(s.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(s.len()));
    let n: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a time such as 90s, 30m, 24h or 7d"))?;
    let scale = match unit {
        "" | "s" => 1.0,
        "m" => 60.0,
        "h" => 3600.0,
        "d" => 86400.0,
        _ => return Err(format!("unknown unit {unit:?} in {s:?}: use s, m, h or d")),
    };
    let secs = n * scale;
    if !(0.0..=1e10).contains(&secs) {
        return Err(format!("{s:?} is out of range"));
    }
    Ok(Duration::from_secs_f64(secs))
}

/// "1048576", "500M", "16G", "1T" (powers of 1024; a trailing "B" or "iB" is allowed) as bytes.
pub fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let t = t.strip_suffix("iB").or_else(|| t.strip_suffix('B')).unwrap_or(t);
    let (num, unit) = t.split_at(t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len()));
    let n: f64 =
        num.trim().parse().map_err(|_| format!("{s:?} is not a size such as 500M or 16G"))?;
    let shift = match unit {
        "" => 0,
        "K" | "k" => 10,
        "M" => 20,
        "G" => 30,
        "T" => 40,
        _ => return Err(format!("unknown unit {unit:?} in {s:?}: use K, M, G or T")),
    };
    let v = n * (1u64 << shift) as f64;
    if !(0.0..1.8e19).contains(&v) {
        return Err(format!("{s:?} is out of range"));
    }
    Ok(v as u64)
}

/// Arguments of `farm coordinator`.
#[derive(Debug, clap::Args)]
pub struct CoordinatorArgs {
    /// Address to listen on.
    #[arg(long, default_value = "0.0.0.0:7878")]
    pub listen: SocketAddr,
    /// Where the coordinator keeps its CA, tokens and state (default
    /// $XDG_STATE_HOME/farm, else ~/.local/state/farm). The first start
    /// writes admin.token, worker.token and client.token there.
    #[arg(long, value_name = "DIR", env = "FARM_STATE_DIR")]
    pub state_dir: Option<PathBuf>,
    /// Host names and IP addresses clients and workers reach this
    /// coordinator by, for its certificate (default: this host's name,
    /// localhost, 127.0.0.1, ::1 and the listen address).
    #[arg(long, value_name = "HOST", num_args = 1..)]
    pub advertise: Vec<String>,
    /// Serve this certificate chain (PEM) instead of one signed by the
    /// coordinator's own CA; tokens then pin the chain's last certificate.
    #[arg(long, value_name = "FILE", requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// The private key (PEM) of --tls-cert.
    #[arg(long, value_name = "FILE", requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
    /// No TLS and no tokens: anyone who reaches the port may do anything.
    /// Only allowed on a loopback address.
    #[arg(long, conflicts_with_all = ["tls_cert", "tls_key"])]
    pub insecure: bool,
    /// Seconds between worker heartbeats; a worker silent for three is lost.
    #[arg(long, default_value_t = 2.0)]
    pub heartbeat: f64,
    /// Also serve grpc.health.v1 in plaintext here, for probes that speak
    /// no TLS (Kubernetes' gRPC probes); it tells nothing but "serving".
    #[arg(long, value_name = "ADDR")]
    pub health_listen: Option<SocketAddr>,
    /// The most tiles one worker may hold at once, whatever it asks for.
    #[arg(long, value_name = "N", default_value_t = 256)]
    pub max_in_flight: u32,
    /// How long a finished, failed or cancelled job (and its image) is
    /// kept for `farm watch` before it is purged with the blobs no other
    /// job needs: 90s, 30m, 24h, 7d.
    #[arg(long, value_name = "TIME", default_value = "24h", value_parser = parse_duration)]
    pub keep_finished: Duration,
    /// A job not submitted with --detach is cancelled when no client has
    /// watched it for this long.
    #[arg(long, value_name = "TIME", default_value = "2m", value_parser = parse_duration)]
    pub client_grace: Duration,
    /// The most bytes of scenes and assets one client (token) may have
    /// stored: 500M, 16G.
    #[arg(long, value_name = "BYTES", default_value = "16G", value_parser = parse_bytes)]
    pub client_quota: u64,
    /// The most bytes of scenes and assets stored in all.
    #[arg(long, value_name = "BYTES", default_value = "64G", value_parser = parse_bytes)]
    pub store_limit: u64,
    /// The largest job to accept.
    #[command(flatten)]
    pub limits: super::LimitArgs,
}

/// The state directory: the one given, else the user's state directory.
pub fn state_dir(given: Option<&Path>) -> PathBuf {
    if let Some(d) = given {
        return d.to_path_buf();
    }
    let env = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    env("XDG_STATE_HOME")
        .or_else(|| env("HOME").map(|h| h.join(".local/state")))
        .map(|d| d.join("farm"))
        .unwrap_or_else(|| PathBuf::from("farm-state"))
}

/// This host's name, if it has one.
fn host_name() -> Option<String> {
    std::fs::read_to_string("/etc/hostname")
        .ok()
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok().filter(|h| !h.is_empty()))
}

/// The names the certificate is for.
fn advertised(args: &CoordinatorArgs) -> Vec<String> {
    if !args.advertise.is_empty() {
        return args.advertise.clone();
    }
    let mut hosts: Vec<String> = host_name().into_iter().collect();
    hosts.extend(["localhost", "127.0.0.1", "::1"].map(String::from));
    if !args.listen.ip().is_unspecified() {
        hosts.push(args.listen.ip().to_string());
    }
    hosts.dedup();
    hosts
}

fn security(args: &CoordinatorArgs, hosts: &[String], dir: &Path) -> Result<Security, String> {
    if args.insecure {
        if !args.listen.ip().is_loopback() {
            return Err(format!(
                "--insecure is only allowed on a loopback address, not {}: anyone who reaches the port would own the farm",
                args.listen
            ));
        }
        return Ok(Security::Insecure);
    }
    let given = args.tls_cert.as_deref().zip(args.tls_key.as_deref());
    security::bootstrap(dir, hosts, given).map_err(|e| e.to_string())
}

/// Listens, then serves until SIGINT or SIGTERM.
pub async fn run(args: CoordinatorArgs) -> ExitCode {
    let hosts = advertised(&args);
    let dir = state_dir(args.state_dir.as_deref());
    let security = match security(&args, &hosts, &dir) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let listener = match tokio::net::TcpListener::bind(args.listen).await {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: cannot listen on {}: {e}", args.listen);
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    if let Some(addr) = args.health_listen {
        match tokio::net::TcpListener::bind(addr).await {
            Ok(l) => {
                tokio::spawn(farm_worker::health::serve(l, std::future::pending()));
            }
            Err(e) => {
                eprintln!("error: cannot serve health checks on {addr}: {e}");
                return ExitCode::from(EXIT_BAD_INPUT);
            }
        }
    }
    let heartbeat = std::time::Duration::from_secs_f64(args.heartbeat.clamp(0.05, 3600.0));
    let addr =
        listener.local_addr().map(|a| a.to_string()).unwrap_or_else(|_| args.listen.to_string());
    match &security {
        Security::Tls { .. } => eprintln!(
            "coordinator listening on https://{addr} (state and tokens in {}; the certificate names {})",
            dir.display(),
            hosts.join(", ")
        ),
        Security::Insecure => eprintln!(
            "coordinator listening on http://{addr} (insecure: no TLS, no tokens; state in {})",
            dir.display()
        ),
    }
    let mut config = farm_coordinator::server::ServerConfig::with_heartbeat(heartbeat);
    config.limits = (&args.limits).into();
    config.security = security;
    config.scheduler.max_in_flight = args.max_in_flight.max(1);
    config.client_grace = args.client_grace;
    config.state = farm_coordinator::state::StateConfig {
        dir: Some(dir),
        keep_finished: args.keep_finished,
        blobs: farm_coordinator::state::BlobLimits {
            client_quota: args.client_quota,
            store_limit: args.store_limit,
            ..Default::default()
        },
    };
    match farm_coordinator::server::serve(listener, config, crate::runtime::shutdown_signal()).await
    {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
