//! `farm health`: exit 0 if a gRPC health service reports SERVING.

use std::process::ExitCode;

/// Arguments of `farm health`.
#[derive(Debug, clap::Args)]
pub struct HealthArgs {
    /// Address of the gRPC health service.
    #[arg(long, default_value = "http://127.0.0.1:7878")]
    pub addr: String,
}

/// Asks the health service once.
pub async fn run(args: HealthArgs) -> ExitCode {
    match crate::client::healthy(&args.addr).await {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
