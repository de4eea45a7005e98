//! Tokens in the state directory's database (`DIR/farm.db`, SQLite). Only
//! a hash of each secret is stored; a presented token is looked up by its
//! id and its secret's hash compared in constant time.

use super::SecurityError;
use farm_proto::auth::{Fingerprint, Role, Token};
use rusqlite::{params, Connection, OptionalExtension};
use std::path::Path;
use std::sync::Mutex;

/// Who made a call: the token's id, name and role.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Principal {
    /// The token's id ("local" on an insecure coordinator).
    pub id: String,
    /// The token's name.
    pub name: String,
    /// What it may do.
    pub role: Role,
}

impl Principal {
    /// Everyone on a coordinator started with `--insecure`.
    pub fn local() -> Principal {
        Principal { id: "local".into(), name: "local".into(), role: Role::Admin }
    }
}

/// A row of `farm token list`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TokenRow {
    /// Id.
    pub id: String,
    /// Name.
    pub name: String,
    /// Role.
    pub role: Role,
    /// Seconds since 1970 when made.
    pub created: i64,
    /// Whether it was revoked.
    pub revoked: bool,
}

/// The token table.
pub struct TokenStore {
    db: Mutex<Connection>,
}

fn random_hex(bytes: usize) -> Result<String, SecurityError> {
    let mut b = vec![0u8; bytes];
    getrandom::fill(&mut b).map_err(|e| SecurityError::Random(e.to_string()))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

fn hash(secret: &str) -> [u8; 32] {
    blake3::derive_key("farm 2026 token secret", secret.as_bytes())
}

fn now() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64)
}

impl TokenStore {
    /// Opens (or creates) the database in `dir`.
    pub fn open(dir: &Path) -> Result<TokenStore, SecurityError> {
        let path = dir.join("farm.db");
        let db = Connection::open(&path).map_err(|e| SecurityError::db(&path, e))?;
        db.busy_timeout(std::time::Duration::from_secs(5))
            .map_err(|e| SecurityError::db(&path, e))?;
        db.execute_batch(
            "PRAGMA journal_mode = WAL;
             CREATE TABLE IF NOT EXISTS tokens (
                 id TEXT PRIMARY KEY,
                 name TEXT NOT NULL,
                 role TEXT NOT NULL,
                 hash BLOB NOT NULL,
                 created INTEGER NOT NULL,
                 revoked INTEGER NOT NULL DEFAULT 0
             );",
        )
        .map_err(|e| SecurityError::db(&path, e))?;
        Ok(TokenStore { db: Mutex::new(db) })
    }

    fn db(&self) -> std::sync::MutexGuard<'_, Connection> {
        self.db.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Makes a token of `role` named `name`, trusting the CA `ca`.
    pub fn create(&self, role: Role, name: &str, ca: Fingerprint) -> Result<Token, SecurityError> {
        let token = Token { ca, id: random_hex(6)?, secret: random_hex(20)? };
        self.db()
            .execute(
                "INSERT INTO tokens (id, name, role, hash, created) VALUES (?1, ?2, ?3, ?4, ?5)",
                params![token.id, name, role.name(), hash(&token.secret).as_slice(), now()],
            )
            .map_err(SecurityError::Sql)?;
        tracing::info!(id = %token.id, %name, %role, "token created");
        Ok(token)
    }

    /// Every token, oldest first.
    pub fn list(&self) -> Result<Vec<TokenRow>, SecurityError> {
        let db = self.db();
        let mut q = db
            .prepare("SELECT id, name, role, created, revoked FROM tokens ORDER BY created, id")
            .map_err(SecurityError::Sql)?;
        let rows = q
            .query_map([], |r| {
                let role: String = r.get(2)?;
                Ok(TokenRow {
                    id: r.get(0)?,
                    name: r.get(1)?,
                    role: role.parse().unwrap_or(Role::Worker),
                    created: r.get(3)?,
                    revoked: r.get::<_, i64>(4)? != 0,
                })
            })
            .map_err(SecurityError::Sql)?;
        rows.collect::<Result<Vec<_>, _>>().map_err(SecurityError::Sql)
    }

    /// Revokes the token with id `id`; false when there is none.
    pub fn revoke(&self, id: &str) -> Result<bool, SecurityError> {
        let n = self
            .db()
            .execute("UPDATE tokens SET revoked = 1 WHERE id = ?1", params![id])
            .map_err(SecurityError::Sql)?;
        Ok(n > 0)
    }

    /// Who holds `token`, if it is known, unrevoked and its secret matches.
    pub fn verify(&self, token: &Token) -> Option<Principal> {
        let row: Option<(String, String, Vec<u8>, i64)> = self
            .db()
            .query_row(
                "SELECT name, role, hash, revoked FROM tokens WHERE id = ?1",
                params![token.id],
                |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
            )
            .optional()
            .ok()
            .flatten();
        let (name, role, stored, revoked) = row?;
        let ok = constant_time_eq::constant_time_eq(&stored, &hash(&token.secret));
        let role = role.parse().ok()?;
        (ok && revoked == 0).then(|| Principal { id: token.id.clone(), name, role })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_verify_until_revoked_and_only_with_their_secret() {
        let dir = std::env::temp_dir().join(format!("farm-tokens-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let store = TokenStore::open(&dir).unwrap();
        let t = store.create(Role::Client, "alice", [1; 32]).unwrap();
        let p = store.verify(&t).expect("valid");
        assert_eq!((p.name.as_str(), p.role), ("alice", Role::Client));
        let forged = Token { secret: "0".repeat(40), ..t.clone() };
        assert!(store.verify(&forged).is_none());
        let unknown = Token { id: "ffffffffffff".into(), ..t.clone() };
        assert!(store.verify(&unknown).is_none());
        // A second handle on the same database (`farm token revoke` while
        // the coordinator runs) revokes at once.
        assert!(TokenStore::open(&dir).unwrap().revoke(&t.id).unwrap());
        assert!(store.verify(&t).is_none());
        let rows = store.list().unwrap();
        assert_eq!(rows.len(), 1);
        assert!(rows[0].revoked && rows[0].name == "alice");
        // The secret is not in the database.
        let bytes = std::fs::read(dir.join("farm.db")).unwrap_or_default();
        let wal = std::fs::read(dir.join("farm.db-wal")).unwrap_or_default();
        for b in [bytes, wal] {
            assert!(!b.windows(t.secret.len()).any(|w| w == t.secret.as_bytes()));
        }
        std::fs::remove_dir_all(dir).ok();
    }
}
