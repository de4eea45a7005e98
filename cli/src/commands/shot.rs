//! `farm submit` of several scenes: a shot, each scene a frame with its
//! own image (see [`crate::frames`]). Embedded, the frames render one after
//! another on every core; on a farm, a few at a time ([`crate::shot`]).
//! Each frame is written as soon as it is done, a frame that fails fails
//! alone, and the shot ends with a line saying which frames failed. The
//! next frame is parsed while one renders.

use super::submit::SubmitArgs;
use super::submit::{fail, finish, remote_options, run_embedded_to, show_progress, Parsed};
use crate::error::Error;
use crate::frames::{frame_scenes, read_ahead, FrameOutput, FrameScene, Outputs};
use crate::shot::{FrameEnd, ShotPlace};
use farm_scene::{SceneError, StreamedScene};
use std::collections::BTreeSet;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Renders the shot whose first scene is `first` and the rest `rest`.
pub fn run(
    args: &SubmitArgs,
    inputs: &[PathBuf],
    first: StreamedScene,
    rest: impl Iterator<Item = Result<StreamedScene, SceneError>> + Send,
    first_parsed: Duration,
) -> ExitCode {
    if args.detach {
        return fail(&Error::Usage(
            "--detach submits one scene: a shot's frames go to the farm a few at a time as earlier ones finish, so its client stays with it".into(),
        ));
    }
    let mut outputs = match Outputs::new(
        args.output.as_deref(),
        args.error_map.as_deref(),
        args.first_frame,
        true,
    ) {
        Ok(o) => o,
        Err(e) => return fail(&e),
    };
    std::thread::scope(|scope| {
        let scenes = std::iter::once(Ok(first)).chain(rest);
        let frames = read_ahead(scope, frame_scenes(inputs, &mut outputs, scenes, first_parsed));
        let mut tally = Tally::default();
        if args.coordinator.is_some() {
            let frame_count = inputs.len() as u32;
            crate::runtime::block_on(async move {
                let stopped = on_farm(args, frames, frame_count, &mut tally).await;
                tally.report(args, stopped)
            })
        } else {
            let stopped = embedded(args, frames, &mut tally);
            tally.report(args, stopped)
        }
    })
}

/// Renders each frame here in turn.
fn embedded(
    args: &SubmitArgs,
    frames: impl Iterator<Item = Result<FrameScene, Error>>,
    tally: &mut Tally,
) -> Option<Error> {
    if args.display_server.is_some() && !args.quiet {
        eprintln!("note: each frame is streamed to the display server as its own image");
    }
    for frame in frames {
        let f = match frame {
            Ok(f) => f,
            Err(e) => return Some(e),
        };
        let start = f.start();
        let scene = Parsed { file: f.file, desc: f.desc, warnings: f.warnings, start };
        let code = run_embedded_to(args, scene, f.out.image.clone(), f.out.error_map.as_deref());
        tally.ended(&f.out, code == ExitCode::SUCCESS);
    }
    None
}

/// Renders the frames on the farm, a few at a time.
async fn on_farm(
    args: &SubmitArgs,
    frames: impl Iterator<Item = Result<FrameScene, Error>>,
    frame_count: u32,
    tally: &mut Tally,
) -> Option<Error> {
    let remote = match super::submit::remote(args) {
        Ok(r) => r,
        Err(e) => return Some(e),
    };
    if args.display_server.is_some() && !args.quiet {
        eprintln!(
            "warning: --display-server streams single renders from a farm, not shots; ignored"
        );
    }
    let opts = remote_options(args);
    // Retrying: the frames the shot has an image of, or is rendering.
    let have = match args.retry_failed {
        None => BTreeSet::new(),
        Some(shot) => match crate::shot::existing_shot(&remote, shot).await {
            Err(e) => return Some(e),
            Ok(v) => {
                if !args.quiet {
                    eprintln!(
                        "shot {shot}: {} frames done, {} rendering; rendering the others again",
                        v.done.len(),
                        v.rendering.len()
                    );
                }
                v.done.into_iter().chain(v.rendering).collect()
            }
        },
    };
    let frames = frames.filter(|f| f.as_ref().map_or(true, |f| !have.contains(&f.out.frame)));
    let place = ShotPlace { shot: args.retry_failed, frames: frame_count };
    let bar = crate::progress::progress_bar(args.quiet);
    let result = crate::shot::submit_shot(
        &remote,
        frames,
        &opts,
        place,
        args.frames_in_flight as usize,
        |frame, p| {
            show_progress(&bar, u64::from(frame), p);
            bar.set_message(format!("frame {frame}, {} workers", p.workers));
        },
        |end| {
            bar.suspend(|| match end {
                FrameEnd::Done(summary, out) => {
                    let code = finish(args, *summary, out.error_map.as_deref());
                    tally.ended(&out, code == ExitCode::SUCCESS);
                }
                FrameEnd::Failed(out, e) => {
                    eprintln!("error: frame {}: {e}", out.frame);
                    tally.ended(&out, false);
                }
            })
        },
    )
    .await;
    bar.finish_and_clear();
    match result {
        Ok(totals) => {
            tally.uploaded = Some((totals.uploaded_bytes, totals.blobs_reused));
            tally.shot = Some(totals.shot).filter(|&s| s != 0);
            None
        }
        Err(e) => Some(e),
    }
}

/// How the shot's frames ended.
#[derive(Default)]
struct Tally {
    written: usize,
    failed: Vec<u32>,
    /// Bytes uploaded, and blobs sent once for several frames (on a farm).
    uploaded: Option<(u64, usize)>,
    /// The shot's id on the farm.
    shot: Option<u64>,
}

impl Tally {
    fn ended(&mut self, out: &FrameOutput, ok: bool) {
        if ok {
            self.written += 1;
        } else {
            self.failed.push(out.frame);
        }
    }

    /// Prints the shot's line and gives its exit code.
    fn report(mut self, args: &SubmitArgs, stopped: Option<Error>) -> ExitCode {
        self.failed.sort_unstable();
        let frames = self.written + self.failed.len();
        if !args.quiet {
            let sent = match self.uploaded {
                Some((bytes, reused)) => format!(
                    ", {} uploaded ({reused} blobs shared between frames sent once)",
                    farm_coordinator::state::bytes(bytes)
                ),
                None => String::new(),
            };
            let id = self.shot.map(|s| format!(" {s}")).unwrap_or_default();
            say!(
                "shot{id}: {frames} frames, {} written, {} failed{sent}",
                self.written,
                self.failed.len()
            );
        }
        if let Some(e) = stopped {
            return fail(&e);
        }
        if self.failed.is_empty() {
            return ExitCode::SUCCESS;
        }
        let list: Vec<String> = self.failed.iter().map(u32::to_string).collect();
        let noun = if list.len() == 1 { "frame" } else { "frames" };
        eprintln!("error: {noun} {} failed", list.join(", "));
        if let Some(shot) = self.shot {
            eprintln!(
                "`farm submit --retry-failed {shot}` with the same files and -o renders them again"
            );
        }
        ExitCode::FAILURE
    }
}
