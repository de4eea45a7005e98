//! Who may talk to the coordinator: TLS with the coordinator's own CA (or
//! a given certificate), tokens with roles, and the check every call
//! passes before its handler runs.
//!
//! ```text
//! farm coordinator --state-dir DIR      first start writes, in DIR:
//!   ca.pem ca.key                       the CA (tokens carry its fingerprint)
//!   farm.db                             tokens (hashed), later jobs
//!   admin.token worker.token client.token   one token of each role (0600)
//! ```
//!
//! With `--insecure` (loopback addresses only) there is no TLS and no
//! token: every caller is the local admin.

mod pki;
mod tokens;

pub use pki::{ca_fingerprint, given_identity, own_identity, write_private, ServerIdentity};
pub use tokens::{Principal, TokenRow, TokenStore};

use farm_proto::auth::{Role, Token};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tonic::{Request, Status};

/// What can go wrong setting up or checking security.
#[derive(Debug, thiserror::Error)]
pub enum SecurityError {
    /// A file in the state directory.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What failed.
        source: std::io::Error,
    },
    /// Certificates or keys.
    #[error("certificate: {0}")]
    Cert(String),
    /// The database.
    #[error("{path}: {source}")]
    Db {
        /// The database file.
        path: PathBuf,
        /// What failed.
        source: rusqlite::Error,
    },
    /// A query.
    #[error("token database: {0}")]
    Sql(#[from] rusqlite::Error),
    /// The system's random source.
    #[error("no random numbers: {0}")]
    Random(String),
}

impl SecurityError {
    fn io(path: &Path, source: std::io::Error) -> Self {
        SecurityError::Io { path: path.to_path_buf(), source }
    }
    fn db(path: &Path, source: rusqlite::Error) -> Self {
        SecurityError::Db { path: path.to_path_buf(), source }
    }
    fn cert(e: rcgen::Error) -> Self {
        SecurityError::Cert(e.to_string())
    }
}

/// How a coordinator secures its port.
#[derive(Clone)]
pub enum Security {
    /// Plaintext, no tokens (loopback only; checked by the CLI).
    Insecure,
    /// TLS with this identity, and calls checked against these tokens.
    Tls {
        /// What the server presents.
        identity: Arc<ServerIdentity>,
        /// The tokens.
        tokens: Arc<TokenStore>,
    },
}

impl std::fmt::Debug for Security {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Security::Insecure => "Insecure",
            Security::Tls { .. } => "Tls",
        })
    }
}

/// Sets up TLS and tokens in `dir`: the CA and a server certificate for
/// `hosts` (or the given certificate and key), the token database, and on
/// first start one token of each role written to `DIR/<role>.token`.
pub fn bootstrap(
    dir: &Path,
    hosts: &[String],
    given: Option<(&Path, &Path)>,
) -> Result<Security, SecurityError> {
    std::fs::create_dir_all(dir).map_err(|e| SecurityError::io(dir, e))?;
    let identity = match given {
        Some((cert, key)) => given_identity(cert, key)?,
        None => own_identity(dir, hosts)?,
    };
    let tokens = TokenStore::open(dir)?;
    if tokens.list()?.is_empty() {
        for role in [Role::Admin, Role::Worker, Role::Client] {
            let t = tokens.create(role, &format!("first {role}"), identity.ca)?;
            let path = dir.join(format!("{role}.token"));
            write_private(&path, format!("{}\n", t.expose()).as_bytes())?;
        }
    }
    Ok(Security::Tls { identity: Arc::new(identity), tokens: Arc::new(tokens) })
}

/// The gRPC interceptor: finds who is calling and attaches it to the
/// request, or refuses the call as unauthenticated. Nothing of a presented
/// token is logged.
#[derive(Clone)]
pub struct Authenticate(pub Security);

impl tonic::service::Interceptor for Authenticate {
    fn call(&mut self, mut req: Request<()>) -> Result<Request<()>, Status> {
        let principal = match &self.0 {
            Security::Insecure => Principal::local(),
            Security::Tls { tokens, .. } => {
                let presented = req
                    .metadata()
                    .get("authorization")
                    .and_then(|v| v.to_str().ok())
                    .and_then(|v| v.strip_prefix("Bearer "))
                    .and_then(|t| t.parse::<Token>().ok());
                let Some(token) = presented else {
                    tracing::warn!("call refused: no token");
                    return Err(Status::unauthenticated(
                        "a token is required (--token-file FILE or FARM_TOKEN)",
                    ));
                };
                let Some(p) = tokens.verify(&token) else {
                    tracing::warn!(token = %token.id, "call refused: unknown or revoked token");
                    return Err(Status::unauthenticated("the token is unknown or revoked"));
                };
                p
            }
        };
        req.extensions_mut().insert(principal);
        Ok(req)
    }
}

/// What a call does, for the role check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// RegisterWorker, Work, FetchBlob.
    Work,
    /// UploadBlob, SubmitJob, and watching, listing and cancelling jobs
    /// (a client's own; an admin's any).
    Submit,
}

impl Action {
    fn allowed(self, role: Role) -> bool {
        matches!(
            (self, role),
            (_, Role::Admin) | (Action::Work, Role::Worker) | (Action::Submit, Role::Client)
        )
    }
}

/// The caller of `req` if its role may do `action`.
pub fn require<T>(req: &Request<T>, action: Action) -> Result<Principal, Status> {
    let p = req
        .extensions()
        .get::<Principal>()
        .cloned()
        .ok_or_else(|| Status::unauthenticated("a token is required"))?;
    if !action.allowed(p.role) {
        tracing::warn!(token = %p.id, role = %p.role, ?action, "call refused: wrong role");
        let what = match action {
            Action::Work => "only worker and admin tokens may work for the farm",
            Action::Submit => "only client and admin tokens may submit, watch or cancel jobs",
        };
        return Err(Status::permission_denied(format!("{what}; this is a {} token", p.role)));
    }
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_role_does_only_its_part() {
        for (action, role, ok) in [
            (Action::Work, Role::Worker, true),
            (Action::Work, Role::Client, false),
            (Action::Submit, Role::Client, true),
            (Action::Submit, Role::Worker, false),
            (Action::Work, Role::Admin, true),
            (Action::Submit, Role::Admin, true),
        ] {
            let mut req = Request::new(());
            req.extensions_mut().insert(Principal { role, ..Principal::local() });
            assert_eq!(require(&req, action).is_ok(), ok, "{action:?} as {role}");
        }
        let e = require(&Request::new(()), Action::Work).unwrap_err();
        assert_eq!(e.code(), tonic::Code::Unauthenticated);
    }

    #[test]
    fn first_start_makes_a_ca_and_one_token_per_role() {
        let dir = std::env::temp_dir().join(format!("farm-bootstrap-{}", std::process::id()));
        let Security::Tls { identity, tokens } =
            bootstrap(&dir, &["localhost".into(), "127.0.0.1".into()], None).unwrap()
        else {
            panic!("not TLS")
        };
        for role in ["admin", "worker", "client"] {
            let text = std::fs::read_to_string(dir.join(format!("{role}.token"))).unwrap();
            let t: Token = text.parse().unwrap();
            assert_eq!(t.ca, identity.ca, "tokens pin the CA");
            assert_eq!(tokens.verify(&t).unwrap().role.name(), role);
        }
        assert!(identity.chain_pem.matches("BEGIN CERTIFICATE").count() == 2);
        // A restart keeps the CA (tokens stay valid) and makes no new tokens.
        let Security::Tls { identity: again, tokens } = bootstrap(&dir, &[], None).unwrap() else {
            panic!("not TLS")
        };
        assert_eq!(again.ca, identity.ca);
        assert_eq!(tokens.list().unwrap().len(), 3);
        std::fs::remove_dir_all(dir).ok();
    }
}
