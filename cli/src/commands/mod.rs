//! One module per `farm` subcommand: its arguments and what it runs.

pub mod bench;
pub mod cancel;
pub mod converge;
pub mod coordinator;
pub mod diff;
pub mod health;
pub mod status;
pub mod submit;
pub mod worker;

/// Arguments naming a coordinator.
#[derive(Debug, clap::Args)]
pub struct RemoteArgs {
    /// The coordinator, e.g. http://render-host:7878.
    #[arg(long, env = "FARM_COORDINATOR")]
    pub coordinator: String,
}
