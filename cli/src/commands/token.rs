//! `farm token`: make, list and revoke the tokens of a coordinator, on its
//! host (they live in its state directory; a running coordinator sees a
//! change at its next call).

use farm_coordinator::security::{ca_fingerprint, TokenStore};
use farm_proto::auth::Role;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `farm token`.
#[derive(Debug, clap::Args)]
pub struct TokenArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: TokenCommand,
    /// The coordinator's state directory (default as `farm coordinator`).
    #[arg(long, value_name = "DIR", env = "FARM_STATE_DIR", global = true)]
    pub state_dir: Option<PathBuf>,
}

/// `farm token` subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum TokenCommand {
    /// Make a token and print it (the only time its secret is shown).
    Create {
        /// worker, client or admin.
        #[arg(long)]
        role: Role,
        /// A name for listings and `farm status` (default: the role).
        #[arg(long)]
        name: Option<String>,
    },
    /// List the tokens (never their secrets).
    List,
    /// Revoke a token by id: calls with it are refused from now on.
    Revoke {
        /// The token's id (see `farm token list`).
        id: String,
    },
}

/// Runs the subcommand.
pub fn run(args: TokenArgs) -> ExitCode {
    let dir = super::coordinator::state_dir(args.state_dir.as_deref());
    let result = (|| -> Result<ExitCode, String> {
        let store = TokenStore::open(&dir).map_err(|e| e.to_string())?;
        match args.command {
            TokenCommand::Create { role, name } => {
                let ca = ca_fingerprint(&dir).map_err(|e| {
                    format!(
                        "{e} (start `farm coordinator --state-dir {}` once first)",
                        dir.display()
                    )
                })?;
                let name = name.unwrap_or_else(|| role.name().to_string());
                let t = store.create(role, &name, ca).map_err(|e| e.to_string())?;
                say!("{}", t.expose());
            }
            TokenCommand::List => {
                say!("{:<14} {:<8} {:<24} {:>12} {}", "id", "role", "name", "created", "revoked");
                for t in store.list().map_err(|e| e.to_string())? {
                    let revoked = if t.revoked { "yes" } else { "no" };
                    say!("{:<14} {:<8} {:<24} {:>12} {}", t.id, t.role, t.name, t.created, revoked);
                }
            }
            TokenCommand::Revoke { id } => {
                if !store.revoke(&id).map_err(|e| e.to_string())? {
                    return Err(format!("no token {id}"));
                }
                say!("token {id} revoked");
            }
        }
        Ok(ExitCode::SUCCESS)
    })();
    result.unwrap_or_else(|e| {
        eprintln!("error: {e}");
        ExitCode::FAILURE
    })
}
