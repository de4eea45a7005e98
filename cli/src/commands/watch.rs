//! `farm watch`: attach to a job on a coordinator, from anywhere, and
//! write its image when it is done (at once, if it is done already).

use super::RemoteArgs;
use crate::embedded::{self, RenderSummary};
use farm_render::features::Features;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `farm watch`.
#[derive(Debug, clap::Args)]
pub struct WatchArgs {
    /// The job id (printed by `farm submit`, listed by `farm status`).
    pub job: u64,
    /// Output image (.exr, .pfm or .png); default job-<ID>.exr.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
    /// Stream the image to this display server (tev) as it renders.
    #[arg(long, value_name = "HOST:PORT")]
    pub display_server: Option<String>,
    /// Seconds to keep reconnecting to a coordinator that went away.
    #[arg(long, value_name = "SECONDS", default_value_t = 600.0)]
    pub reconnect_for: f64,
    /// The coordinator.
    #[command(flatten)]
    pub remote: RemoteArgs,
}

/// Follows the job to its image and writes it.
pub async fn run(args: WatchArgs) -> ExitCode {
    let remote = match args.remote.remote() {
        Ok(r) => r,
        Err(e) => return super::submit::fail(&e),
    };
    let bar = crate::progress::progress_bar(args.quiet);
    let job = args.job;
    let reconnect = super::submit::reconnect_for(args.reconnect_for);
    // With a display server, the connection that asks for the job's name
    // goes on to follow it; a coordinator out of reach is left to
    // `follow_live`'s reconnecting.
    let mut client = None;
    let mut display = match args.display_server.as_deref() {
        Some(a) => {
            client = crate::client::connect(&remote).await.ok();
            let name = match client.as_mut() {
                Some(c) => submitted_name(c, job).await,
                None => String::new(),
            };
            Some(crate::display::LiveDisplay::new(a, &scene_name(&name, job), args.quiet))
        }
        None => None,
    };
    let result = crate::client::follow_live(
        &remote,
        job,
        client,
        reconnect,
        |p| super::submit::show_progress(&bar, job, p),
        display.as_mut(),
    )
    .await;
    bar.finish_and_clear();
    let done = match result {
        Ok(d) => d,
        Err(e) => return super::submit::fail(&e),
    };
    let summary = RenderSummary {
        image: done.image,
        error: done.error,
        output: args.output.clone().unwrap_or_else(|| PathBuf::from(format!("job-{job}.exr"))),
        stats: done.stats,
        spp: done.spp,
        startup_seconds: 0.0,
        render_seconds: done.render_seconds,
        features: Features::default(),
        scene_name: scene_name(&done.name, job),
        warnings: Vec::new(),
        passes: done.passes,
        stopped: done.stopped,
        sampler: None,
    };
    if let Err(e) = embedded::write(&summary) {
        return super::submit::fail(&e);
    }
    if !args.quiet {
        say!(
            "{}: {}×{}, {} spp, job {job}",
            summary.output.display(),
            summary.image.width,
            summary.image.height,
            summary.spp
        );
    }
    ExitCode::SUCCESS
}

/// The job's name as submitted, from the coordinator's status, for the
/// display server's title before the image (which carries it too)
/// arrives; empty if the status does not list it, or cannot be had
/// (following the job reports why).
async fn submitted_name(client: &mut farm_proto::connect::Client, job: u64) -> String {
    let Ok(status) = client.get_status(farm_proto::v1::GetStatusRequest {}).await else {
        return String::new();
    };
    let jobs = status.into_inner().jobs;
    jobs.into_iter().find(|j| j.job_id == job).map(|j| j.name).unwrap_or_default()
}

/// The scene name the written image carries: the job's as submitted, or
/// "job N" from a coordinator that sends none.
fn scene_name(name: &str, job: u64) -> String {
    if name.is_empty() {
        format!("job {job}")
    } else {
        name.to_string()
    }
}
