//! What authenticating and authorising a request reads, kept in memory (issue 49), so a request
//! costs no query for it in the common case:
//!
//! - **tokens by secret hash**, and that some token exists (so the server asks for one).
//!   Creating or revoking a token on this instance clears both at once; another instance's
//!   change (`nextpose token` on the database, another server on the same PostgreSQL) is seen
//!   within [`STALE_AFTER`], the bound on how long a token revoked elsewhere may still be taken
//!   here. That no token exists is never remembered: an open server reads it again on every
//!   request, so the first token made on the host turns authentication on at once;
//! - **the cell of a program, routine, waypoint or prediction**: a resource never changes cell
//!   and ids are never reused, so an entry never goes wrong while its resource lives. A
//!   resource deleted since may still have its entry: [`super::access`] reads the store again
//!   before it denies on a cached cell, so what a caller is told is what the store says.
//!
//! Unknown secrets are not remembered (each costs its query, as before), and the scope map is
//! emptied when it holds [`MAX_SCOPES`] entries, so neither grows without bound.

use std::collections::HashMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use crate::api::Token;

use super::access::Scope;
use super::registry::lock_map;

/// How long a token, or the answer to "is there any token", is taken from memory before it is
/// read again: the most a change made by another instance of the service waits to be seen.
pub const STALE_AFTER: Duration = Duration::from_secs(1);

/// Entries of the scope map before it is emptied.
pub const MAX_SCOPES: usize = 1 << 16;

#[derive(Debug, Default)]
pub(super) struct Credentials {
    tokens: Mutex<HashMap<String, (Token, Instant)>>,
    /// When a token was last seen to exist.
    any_token: Mutex<Option<Instant>>,
    scopes: Mutex<HashMap<Scope, i64>>,
}

fn fresh(at: Instant) -> bool {
    at.elapsed() < STALE_AFTER
}

impl Credentials {
    /// The token of a secret hash, if read within [`STALE_AFTER`].
    pub(super) fn token(&self, hash: &str) -> Option<Token> {
        let mut tokens = lock_map(&self.tokens);
        match tokens.get(hash) {
            Some((token, at)) if fresh(*at) => Some(token.clone()),
            Some(_) => {
                tokens.remove(hash);
                None
            }
            None => None,
        }
    }

    pub(super) fn keep_token(&self, hash: &str, token: &Token) {
        let mut tokens = lock_map(&self.tokens);
        // Stale entries of secrets no longer used go when the map is written.
        if tokens.len() >= MAX_SCOPES {
            tokens.retain(|_, (_, at)| fresh(*at));
        }
        tokens.insert(hash.to_string(), (token.clone(), Instant::now()));
    }

    /// Whether some token was seen to exist within [`STALE_AFTER`].
    pub(super) fn any_token(&self) -> bool {
        let seen = self.any_token.lock().unwrap_or_else(|e| e.into_inner());
        seen.is_some_and(fresh)
    }

    /// Some token exists (read from the store just now).
    pub(super) fn keep_any_token(&self) {
        *self.any_token.lock().unwrap_or_else(|e| e.into_inner()) = Some(Instant::now());
    }

    /// A token was created or revoked here: read them all again.
    pub(super) fn tokens_changed(&self) {
        lock_map(&self.tokens).clear();
        *self.any_token.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }

    /// The cell of a resource, as read before.
    pub(super) fn cell_of(&self, scope: Scope) -> Option<i64> {
        lock_map(&self.scopes).get(&scope).copied()
    }

    pub(super) fn keep_cell_of(&self, scope: Scope, cell: i64) {
        let mut scopes = lock_map(&self.scopes);
        if scopes.len() >= MAX_SCOPES {
            scopes.clear();
        }
        scopes.insert(scope, cell);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::api::Role;

    fn token(name: &str) -> Token {
        Token {
            name: name.into(),
            role: Role::Operator,
            cells: Some(vec![3]),
            created_at: "2026-12-07T00:00:00Z".into(),
        }
    }

    #[test]
    fn a_change_here_forgets_every_token_and_whether_there_is_one() {
        let c = Credentials::default();
        assert_eq!(c.token("h"), None);
        assert!(!c.any_token());
        c.keep_token("h", &token("op"));
        c.keep_any_token();
        assert_eq!(c.token("h"), Some(token("op")));
        assert!(c.any_token());
        c.tokens_changed();
        assert_eq!(c.token("h"), None);
        assert!(!c.any_token());
    }

    #[test]
    fn the_scope_map_is_bounded() {
        let c = Credentials::default();
        for id in 0..MAX_SCOPES as i64 {
            c.keep_cell_of(Scope::Routine(id), 1);
        }
        assert_eq!(c.cell_of(Scope::Routine(5)), Some(1));
        c.keep_cell_of(Scope::Program(1), 2);
        assert_eq!(c.cell_of(Scope::Routine(5)), None, "emptied when full");
        assert_eq!(c.cell_of(Scope::Program(1)), Some(2));
    }
}
