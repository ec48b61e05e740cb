//! The bearer token both adapters require when one is configured. REST reads it from the
//! `Authorization` header, gRPC from the `authorization` metadata entry (the same HTTP/2
//! header); the check here knows neither transport.

use std::fmt;
use std::sync::Arc;

use subtle::ConstantTimeEq;
use thiserror::Error;

use crate::app::{App, AppError, Caller};

/// A configured token that cannot be used.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum TokenError {
    /// An empty token would otherwise have turned authentication off without a word.
    #[error(
        "the bearer token (NEXTPOSE_TOKEN / --token) is empty: set a non-empty token, or unset \
         it to serve without authentication"
    )]
    Empty,
    /// No client could send it: header values are visible ASCII, and surrounding spaces are
    /// not part of the credentials.
    #[error(
        "the bearer token (NEXTPOSE_TOKEN / --token) must be visible ASCII without leading or \
         trailing spaces, or no client could send it"
    )]
    Unsendable,
}

/// The token every request but health checks must carry as `Authorization: Bearer <token>`.
#[derive(Clone)]
pub struct BearerToken(Arc<str>);

impl fmt::Debug for BearerToken {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("BearerToken(..)")
    }
}

impl BearerToken {
    /// Refuses a token that is empty or that no client could send.
    pub fn new(token: &str) -> Result<BearerToken, TokenError> {
        if token.trim().is_empty() {
            return Err(TokenError::Empty);
        }
        let sendable =
            token.trim() == token && token.bytes().all(|b| b == b' ' || b.is_ascii_graphic());
        if !sendable {
            return Err(TokenError::Unsendable);
        }
        Ok(BearerToken(Arc::from(token)))
    }

    /// The token a setting asks for: none when unset (no authentication), an error when set
    /// but unusable (an empty `NEXTPOSE_TOKEN` must not mean "no authentication").
    pub fn from_setting(setting: Option<&str>) -> Result<Option<BearerToken>, TokenError> {
        setting.map(BearerToken::new).transpose()
    }

    /// Whether an `Authorization` value carries this token: the scheme `Bearer` in any case
    /// (RFC 7235 §2.1: auth-schemes are case-insensitive), one or more spaces, the token
    /// (compared in constant time).
    pub fn admits(&self, authorization: Option<&[u8]>) -> bool {
        let Some(value) = authorization else {
            return false;
        };
        bearer_secret(value).is_some_and(|given| constant_time_eq(given, self.0.as_bytes()))
    }
}

/// The credentials of an `Authorization` value of the scheme `Bearer` (in any case, RFC 7235
/// §2.1), after one or more spaces; None for another scheme or none given.
pub fn bearer_secret(value: &[u8]) -> Option<&[u8]> {
    const SCHEME: &[u8] = b"bearer";
    let (scheme, rest) = value.split_at_checked(SCHEME.len())?;
    if !scheme.eq_ignore_ascii_case(SCHEME) || rest.first() != Some(&b' ') {
        return None;
    }
    let given = rest.trim_ascii_start();
    (!given.is_empty()).then_some(given)
}

/// Compares without an early exit, so the time taken does not reveal how much matched.
fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    a.ct_eq(b).into()
}

/// The caller a request's `Authorization` value names, for both adapters: the bootstrap
/// token's ([`Caller::bootstrap`]) when it is that, else whoever the stored tokens say
/// ([`App::caller`]: anonymous when the service authenticates no one, 401 otherwise).
pub async fn identify(
    app: &App,
    bootstrap: Option<&BearerToken>,
    authorization: Option<&[u8]>,
) -> Result<Caller, AppError> {
    match bootstrap {
        Some(token) if token.admits(authorization) => Ok(Caller::bootstrap()),
        _ => {
            app.caller(authorization.and_then(bearer_secret), bootstrap.is_some())
                .await
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_and_unsendable_tokens_are_refused() {
        assert_eq!(BearerToken::new("").unwrap_err(), TokenError::Empty);
        assert_eq!(BearerToken::new("  ").unwrap_err(), TokenError::Empty);
        assert_eq!(
            BearerToken::new(" s3cret").unwrap_err(),
            TokenError::Unsendable
        );
        assert_eq!(
            BearerToken::new("s3cret\n").unwrap_err(),
            TokenError::Unsendable
        );
        assert_eq!(
            BearerToken::new("sécret").unwrap_err(),
            TokenError::Unsendable
        );
        assert!(BearerToken::from_setting(None).unwrap().is_none());
        assert!(BearerToken::from_setting(Some("")).is_err());
    }

    #[test]
    fn the_scheme_is_case_insensitive_and_the_token_exact() {
        let t = BearerToken::new("s3cret").unwrap();
        for ok in [
            "Bearer s3cret",
            "bearer s3cret",
            "BEARER s3cret",
            "bEaReR   s3cret",
        ] {
            assert!(t.admits(Some(ok.as_bytes())), "{ok}");
        }
        for bad in [
            "",
            "Bearer",
            "Bearer ",
            "Bearers3cret",
            "Bearer s3cre",
            "Bearer s3cret2",
            "Bearer S3CRET",
            "Basic s3cret",
            "s3cret",
            "Token s3cret",
        ] {
            assert!(!t.admits(Some(bad.as_bytes())), "{bad}");
        }
        assert!(!t.admits(None));
    }
}
