//! `farm status`: a coordinator's jobs and workers, once, redrawn in place
//! (`--watch`), or as JSON for scripts (`--json`).

use super::RemoteArgs;
use farm_proto::v1::GetStatusResponse;
use std::fmt::Write as _;
use std::process::ExitCode;
use std::time::Duration;

/// Arguments of `farm status`.
#[derive(Debug, clap::Args)]
pub struct StatusArgs {
    /// Redraw every SECONDS (2 by default) until interrupted, like `watch`.
    #[arg(long, value_name = "SECONDS", num_args = 0..=1, default_missing_value = "2")]
    pub watch: Option<f64>,
    /// Print JSON: one object with "jobs" and "workers" (one per line with --watch).
    #[arg(long)]
    pub json: bool,
    /// The coordinator.
    #[command(flatten)]
    pub remote: RemoteArgs,
}

/// The two tables.
pub fn tables(s: &GetStatusResponse) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:>6}  {:<28} {:<16} {:<10} {:>13} {:>8} {:>8} {:>7}",
        "job", "name", "owner", "state", "tiles", "priority", "attempts", "retries"
    );
    for j in &s.jobs {
        let tiles = format!("{}/{}", j.tiles_done, j.tiles_total);
        let _ = writeln!(
            out,
            "{:>6}  {:<28} {:<16} {:<10} {:>13} {:>8} {:>8} {:>7}",
            j.job_id, j.name, j.owner, j.state, tiles, j.priority, j.attempts, j.retries
        );
    }
    let shots = crate::shot::shots(&s.jobs);
    if !shots.is_empty() {
        let _ = writeln!(out);
        let _ = writeln!(
            out,
            "{:>6}  {:<28} {:<16} {:>6} {:>6} {:>9} {:>6}",
            "shot", "first frame", "owner", "frames", "done", "rendering", "failed"
        );
        for v in &shots {
            let _ = writeln!(
                out,
                "{:>6}  {:<28} {:<16} {:>6} {:>6} {:>9} {:>6}",
                v.shot,
                v.name,
                v.owner,
                v.frames,
                v.done.len(),
                v.rendering.len(),
                v.failed.len()
            );
        }
    }
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "{:>6}  {:<28} {:>7} {:>9} {:>10}",
        "worker", "name", "threads", "in flight", "tiles done"
    );
    for w in &s.workers {
        let _ = writeln!(
            out,
            "{:>6}  {:<28} {:>7} {:>9} {:>10}",
            w.worker_id, w.name, w.threads, w.in_flight, w.tiles_done
        );
    }
    out
}

/// The status as one JSON object (on one line).
pub fn json(s: &GetStatusResponse) -> String {
    let jobs: Vec<serde_json::Value> = s
        .jobs
        .iter()
        .map(|j| {
            serde_json::json!({
                "id": j.job_id, "name": j.name, "owner": j.owner, "state": j.state,
                "tiles_done": j.tiles_done, "tiles_total": j.tiles_total,
                "priority": j.priority, "attempts": j.attempts, "retries": j.retries,
                "speculated": j.speculated,
                "shot": j.shot.as_ref().map(|f| serde_json::json!({
                    "shot": f.shot, "frame": f.frame, "frames": f.frames,
                })),
            })
        })
        .collect();
    let workers: Vec<serde_json::Value> = s
        .workers
        .iter()
        .map(|w| {
            serde_json::json!({
                "id": w.worker_id, "name": w.name, "threads": w.threads,
                "in_flight": w.in_flight, "tiles_done": w.tiles_done,
            })
        })
        .collect();
    let shots: Vec<serde_json::Value> = crate::shot::shots(&s.jobs)
        .iter()
        .map(|v| {
            serde_json::json!({
                "id": v.shot, "name": v.name, "owner": v.owner, "frames": v.frames,
                "done": v.done, "rendering": v.rendering, "failed": v.failed,
            })
        })
        .collect();
    serde_json::json!({ "jobs": jobs, "shots": shots, "workers": workers }).to_string()
}

/// Prints the status once, or every `--watch` seconds until interrupted.
pub async fn run(args: StatusArgs) -> ExitCode {
    let remote = match args.remote.remote() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return e.exit_code();
        }
    };
    let every = match args.watch {
        None => None,
        Some(s) if s.is_finite() && s >= 0.1 => Some(Duration::from_secs_f64(s.min(86_400.0))),
        Some(s) => {
            eprintln!("error: --watch {s}: the interval must be at least 0.1 seconds");
            return ExitCode::from(2);
        }
    };
    let interrupted = crate::runtime::shutdown_signal();
    tokio::pin!(interrupted);
    loop {
        let answer = crate::client::status(&remote).await;
        let s = match answer {
            Ok(s) => s,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        };
        let text = if args.json { json(&s) } else { tables(&s) };
        let Some(every) = every else {
            say!("{}", text.trim_end());
            return ExitCode::SUCCESS;
        };
        if args.json {
            say!("{text}");
        } else {
            // Home, clear the screen, then the tables: redrawn in place.
            say!("\x1b[H\x1b[2JEvery {:.1} s: farm status   {}\n", every.as_secs_f64(), remote.url);
            say!("{}", text.trim_end());
        }
        tokio::select! {
            () = tokio::time::sleep(every) => {}
            () = &mut interrupted => return ExitCode::SUCCESS,
        }
    }
}
