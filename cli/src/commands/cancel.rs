//! `farm cancel`: stop a job on a coordinator.

use super::RemoteArgs;
use std::process::ExitCode;

/// Arguments of `farm cancel`.
#[derive(Debug, clap::Args)]
pub struct CancelArgs {
    /// The job id (see `farm status`).
    pub job: u64,
    /// The coordinator.
    #[command(flatten)]
    pub remote: RemoteArgs,
}

/// Cancels the job and says whether it was still running.
pub async fn run(args: CancelArgs) -> ExitCode {
    let remote = match args.remote.remote() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return e.exit_code();
        }
    };
    match crate::client::cancel(&remote, args.job).await {
        Ok(true) => {
            say!("job {} cancelled", args.job);
            ExitCode::SUCCESS
        }
        Ok(false) => {
            eprintln!("error: job {} is not queued or running", args.job);
            ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
