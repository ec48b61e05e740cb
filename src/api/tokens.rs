//! Bearer tokens with a role and a scope (`/v1/tokens`, an admin operation; `/v1/whoami`).
//! What each role may do is `app::access`'s.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// What a token may do, each role all that the one before it may: `operator` (read; teach,
/// undo, finish, predictions and feedback), `engineer` (also create and edit cells, programs,
/// routines and waypoints, import, export, re-target, settings, replays), `admin` (also delete
/// cells and programs, manage tokens, back up).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, ToSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    Operator,
    Engineer,
    Admin,
}

impl Role {
    /// Every role, from the least to the most allowed.
    pub const ALL: [Role; 3] = [Role::Operator, Role::Engineer, Role::Admin];

    /// The role's name, as stored and on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Operator => "operator",
            Role::Engineer => "engineer",
            Role::Admin => "admin",
        }
    }

    /// The role of this name.
    pub fn parse(name: &str) -> Option<Role> {
        Role::ALL.into_iter().find(|r| r.as_str() == name)
    }
}

/// A token to create.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewToken {
    /// Who or what holds it (unique among unrevoked tokens; 1 to 200 characters).
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$"
    )]
    pub name: String,
    pub role: Role,
    /// The cells it is limited to (at least one); absent or null: every cell.
    #[serde(default)]
    #[schema(min_items = 1)]
    pub cells: Option<Vec<i64>>,
}

/// A token, without its secret.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct Token {
    pub name: String,
    pub role: Role,
    /// The cells it is limited to; null: every cell.
    pub cells: Option<Vec<i64>>,
    pub created_at: String,
}

/// A token just created, with its secret: shown this once, only its SHA-256 is kept.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct CreatedToken {
    pub token: Token,
    /// Send it as `Authorization: Bearer <secret>`.
    pub secret: String,
}

/// Who a request's token says the caller is.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct WhoAmI {
    /// The token's name; `bootstrap` for the `NEXTPOSE_TOKEN`, `anonymous` when the service
    /// does not authenticate.
    pub name: String,
    pub role: Role,
    /// The cells it is limited to; null: every cell.
    pub cells: Option<Vec<i64>>,
    /// Whether the service asks for a token at all.
    pub authenticated: bool,
}
