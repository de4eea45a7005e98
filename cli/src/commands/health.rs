//! `farm health`: exit 0 if a gRPC health service reports SERVING.

use std::process::ExitCode;

/// Arguments of `farm health`.
#[derive(Debug, clap::Args)]
pub struct HealthArgs {
    /// Address of the gRPC health service (https:// needs a token, for
    /// its CA fingerprint; the health service itself answers anyone).
    #[arg(long, default_value = "http://127.0.0.1:7878")]
    pub addr: String,
    /// The token.
    #[command(flatten)]
    pub token: super::TokenArgs,
}

/// Asks the health service once.
pub async fn run(args: HealthArgs) -> ExitCode {
    let token = match args.token.token() {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return e.exit_code();
        }
    };
    let remote = crate::client::Remote { url: args.addr.clone(), token };
    match crate::client::healthy(&remote).await {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
