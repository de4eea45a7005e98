//! `farm status`: a coordinator's jobs and workers.

use super::RemoteArgs;
use std::process::ExitCode;

/// Prints the jobs and the workers as two tables.
pub async fn run(args: RemoteArgs) -> ExitCode {
    let remote = match args.remote() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return e.exit_code();
        }
    };
    match crate::client::status(&remote).await {
        Ok(s) => {
            say!(
                "{:>6}  {:<28} {:<16} {:<10} {:>13} {:>8} {:>8} {:>7}",
                "job",
                "name",
                "owner",
                "state",
                "tiles",
                "priority",
                "attempts",
                "retries"
            );
            for j in &s.jobs {
                let tiles = format!("{}/{}", j.tiles_done, j.tiles_total);
                say!(
                    "{:>6}  {:<28} {:<16} {:<10} {:>13} {:>8} {:>8} {:>7}",
                    j.job_id,
                    j.name,
                    j.owner,
                    j.state,
                    tiles,
                    j.priority,
                    j.attempts,
                    j.retries
                );
            }
            say!();
            say!(
                "{:>6}  {:<28} {:>7} {:>9} {:>10}",
                "worker",
                "name",
                "threads",
                "in flight",
                "tiles done"
            );
            for w in &s.workers {
                say!(
                    "{:>6}  {:<28} {:>7} {:>9} {:>10}",
                    w.worker_id,
                    w.name,
                    w.threads,
                    w.in_flight,
                    w.tiles_done
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
