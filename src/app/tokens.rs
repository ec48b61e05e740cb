//! Bearer tokens stored in the database: created with a random secret that is shown once,
//! kept as the SHA-256 of that secret, found by it, revoked by name. Who may do what with a
//! token is [`super::access`]'s.
//!
//! A secret is 32 bytes from the operating system's random source, written `npt_` + 64 hex
//! digits. With that much entropy a fast hash is enough (no password-hashing KDF is needed:
//! no one can guess a secret to test against a stolen hash), and storing only the hash means a
//! copy of the database (a backup) grants no access. A token is looked up by its hash, and the
//! stored hash is then compared with the computed one in constant time.

use rand::TryRngCore;
use rand::rngs::OsRng;
use sha2::{Digest, Sha256};
use subtle::ConstantTimeEq;

use crate::api::{CreatedToken, NewToken, Role, Token, WhoAmI};
use crate::storage::{StorageError, TokenRow};

use super::access::Caller;
use super::{App, AppError, Result, check_name};

/// What every secret starts with, so a leaked one is recognisable (secret scanners).
pub const SECRET_PREFIX: &str = "npt_";

/// A new secret: [`SECRET_PREFIX`] and 32 random bytes in hex.
fn new_secret() -> Result<String> {
    let mut bytes = [0u8; 32];
    OsRng
        .try_fill_bytes(&mut bytes)
        .map_err(|e| AppError::Internal(format!("the OS random source failed: {e}")))?;
    Ok(format!("{SECRET_PREFIX}{}", hex(&bytes)))
}

/// The SHA-256 of a secret, in hex, as stored.
pub fn secret_hash(secret: &[u8]) -> String {
    hex(&Sha256::digest(secret))
}

fn hex(bytes: &[u8]) -> String {
    use std::fmt::Write;
    bytes.iter().fold(String::new(), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

impl App {
    /// Creates a token and answers with its secret, shown this once.
    pub async fn create_token(&self, new: NewToken) -> Result<CreatedToken> {
        check_name("token name", &new.name)?;
        if new.cells.as_ref().is_some_and(Vec::is_empty) {
            return Err(AppError::Invalid(
                "a token limited to no cells could touch none; leave `cells` out for every cell"
                    .into(),
            ));
        }
        if let Some(cells) = &new.cells {
            for &cell in cells {
                if self.store.cell(cell).await?.is_none() {
                    return Err(AppError::not_found("cell", cell));
                }
            }
        }
        let secret = new_secret()?;
        let row = self
            .store
            .insert_token(
                &new.name,
                new.role.as_str(),
                &secret_hash(secret.as_bytes()),
                new.cells.as_deref(),
            )
            .await
            .map_err(|e| match e {
                StorageError::Conflict(_) => {
                    AppError::Exists(format!("a token named {:?} exists", new.name))
                }
                StorageError::NotFound => {
                    AppError::Invalid("a cell the token is limited to does not exist".into())
                }
                other => other.into(),
            })?;
        self.credentials.tokens_changed();
        Ok(CreatedToken {
            token: self.token(row).await?,
            secret,
        })
    }

    /// The unrevoked tokens, by name.
    pub async fn tokens(&self) -> Result<Vec<Token>> {
        let mut out = Vec::new();
        for row in self.store.tokens().await? {
            out.push(self.token(row).await?);
        }
        Ok(out)
    }

    /// Revokes the token of this name: from now on it is unknown (401) here, and within
    /// [`super::credentials::STALE_AFTER`] on every other instance sharing the database.
    pub async fn revoke_token(&self, name: &str) -> Result<()> {
        let revoked = self.store.revoke_token(name).await.map_err(|e| match e {
            StorageError::NotFound => AppError::NotFoundName {
                what: "token",
                name: name.to_string(),
            },
            other => other.into(),
        });
        // Whatever the store answered (a failure may still have committed), read again.
        self.credentials.tokens_changed();
        revoked
    }

    /// The caller a request's bearer secret names (already taken out of `Authorization:
    /// Bearer …`; None when the request had none). `bootstrap` is whether the service has a
    /// bootstrap token (which the adapters check first, as it needs no database). Without one
    /// and without any stored token, the service does not authenticate: everyone is
    /// [`Caller::anonymous`]. Otherwise an unknown, revoked or missing secret is
    /// [`AppError::Unauthenticated`].
    pub async fn caller(&self, secret: Option<&[u8]>, bootstrap: bool) -> Result<Caller> {
        if let Some(secret) = secret {
            let hash = secret_hash(secret);
            let token = match self.credentials.token(&hash) {
                Some(token) => Some(token),
                None => match self.store.token_by_hash(&hash).await? {
                    Some(row)
                        if bool::from(row.secret_sha256.as_bytes().ct_eq(hash.as_bytes())) =>
                    {
                        let token = self.token(row).await?;
                        self.credentials.keep_token(&hash, &token);
                        Some(token)
                    }
                    _ => None,
                },
            };
            if let Some(token) = token {
                return Ok(Caller {
                    name: token.name,
                    role: token.role,
                    cells: token.cells,
                    authenticated: true,
                });
            }
        }
        if !self.asks_for_token(bootstrap).await? {
            return Ok(Caller::anonymous());
        }
        Err(AppError::Unauthenticated)
    }

    /// Whether a request must carry a token: with a bootstrap token (`bootstrap`), or while
    /// any stored token is not revoked.
    pub async fn asks_for_token(&self, bootstrap: bool) -> Result<bool> {
        if bootstrap {
            return Ok(true);
        }
        if self.credentials.any_token() {
            return Ok(true);
        }
        let any = self.store.any_token().await?;
        if any {
            self.credentials.keep_any_token();
        }
        Ok(any)
    }

    /// Who the caller is, on the wire.
    pub fn whoami(&self, caller: &Caller) -> WhoAmI {
        WhoAmI {
            name: caller.name.clone(),
            role: caller.role,
            cells: caller.cells.clone(),
            authenticated: caller.authenticated,
        }
    }

    async fn token(&self, row: TokenRow) -> Result<Token> {
        let role = Role::parse(&row.role).ok_or_else(|| {
            AppError::Internal(format!(
                "token {:?} has the unknown role {:?}",
                row.name, row.role
            ))
        })?;
        let cells = if row.all_cells == 1 {
            None
        } else {
            Some(self.store.token_cells(row.id).await?)
        };
        Ok(Token {
            name: row.name,
            role,
            cells,
            created_at: row.created_at,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secrets_are_random_prefixed_and_hashed() {
        let a = new_secret().unwrap();
        let b = new_secret().unwrap();
        assert_ne!(a, b);
        assert!(
            a.starts_with(SECRET_PREFIX) && a.len() == SECRET_PREFIX.len() + 64,
            "{a}"
        );
        // SHA-256("abc"), FIPS 180-2.
        assert_eq!(
            secret_hash(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
