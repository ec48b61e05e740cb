//! Who may do what: the one place where roles, scopes and operations meet.
//!
//! A request's caller ([`Caller`]) is found by the adapters from its bearer token
//! ([`App::caller`]): the bootstrap token (`NEXTPOSE_TOKEN`, an unscoped admin named
//! `bootstrap`) or a token stored in the database ([`super::tokens`]). Before running an
//! operation the adapter asks [`App::authorize`] with the operation's [`Action`] and the
//! resource it touches ([`Scope`]); a refusal changes nothing because nothing has run yet.
//!
//! - The action names the least role that may do it, once ([`Action::role`]); roles are
//!   ordered, each allowed all that the one below it is.
//! - A token limited to some cells may touch only those: the cell of the resource is found
//!   from the resource (a program's, a routine's, a waypoint's or a prediction's cell). An
//!   operation on the service as a whole (creating a cell, uploading a robot, a replay) other
//!   than reading needs an unscoped token, since it is not any one cell's.
//! - A resource that does not exist is not refused here: the operation answers 404 as it
//!   would for anyone allowed the action.
//!
//! Without a bootstrap token and without any stored token, the service does not authenticate
//! and every caller is an unscoped admin (`anonymous`), as before tokens existed, with one
//! exception: an anonymous caller may not manage tokens ([`Action::ManageTokens`]). Creating
//! the first token turns authentication on, so on an open server it would let whoever reaches
//! the port first own the service and lock every pendant out; the first token is made on the
//! host (`nextpose token create`) or given at start-up (`--token`), by whoever runs the service.

use crate::api::{Cell, Role};

use super::{App, AppError, Result};

/// Who is calling.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Caller {
    /// The token's name (`bootstrap`, `anonymous` or a stored token's).
    pub name: String,
    pub role: Role,
    /// The cells the caller may touch; None: every cell.
    pub cells: Option<Vec<i64>>,
    /// Whether the service authenticates at all (false: `anonymous`).
    pub authenticated: bool,
}

impl Caller {
    /// The bootstrap token's caller: an unscoped admin.
    pub fn bootstrap() -> Caller {
        Caller {
            name: "bootstrap".to_string(),
            role: Role::Admin,
            cells: None,
            authenticated: true,
        }
    }

    /// Everyone, when the service does not authenticate.
    pub fn anonymous() -> Caller {
        Caller {
            name: "anonymous".to_string(),
            role: Role::Admin,
            cells: None,
            authenticated: false,
        }
    }

    fn may_touch(&self, cell: i64) -> bool {
        self.cells
            .as_ref()
            .is_none_or(|cells| cells.contains(&cell))
    }
}

/// Why an anonymous caller may not manage tokens, and how the first one is made.
pub const ANONYMOUS_TOKENS: &str = "this server does not authenticate (it has no token), and an \
    anonymous request may not create or manage tokens: the first token would turn authentication \
    on and lock out every pendant without it. Create the first admin token on the server's host \
    with `nextpose token create --db <database> --name <name> --role admin`, or start the server \
    with --token (NEXTPOSE_TOKEN), then call this with that token";

/// What an operation does, by the least role that may do it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Action {
    /// Reading anything: cells, stats, programs, routines, predictions, robots, frames,
    /// reach, metrics, who am I.
    Read,
    /// Teaching: append, undo, finish, trajectories, predict again, feedback, start a routine.
    Teach,
    /// Creating and editing cells, programs, routines and waypoints; settings, calibration,
    /// rebuild; import, export, re-target; robots; replays.
    Edit,
    /// Deleting cells and programs.
    Delete,
    /// Backups.
    Administer,
    /// Creating, listing and revoking tokens: an admin's, and never an anonymous caller's (on
    /// a server that does not authenticate, the first token would turn authentication on).
    ManageTokens,
    /// Reading the audit trail.
    Inspect,
}

impl Action {
    /// The least role that may do it.
    pub fn role(self) -> Role {
        match self {
            Action::Read | Action::Teach => Role::Operator,
            Action::Edit | Action::Inspect => Role::Engineer,
            Action::Delete | Action::Administer | Action::ManageTokens => Role::Admin,
        }
    }
}

/// The resource an operation touches, by which its cell is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Scope {
    /// The service as a whole (lists, new cells, robots, replays, tokens, backups).
    Service,
    Cell(i64),
    Program(i64),
    Routine(i64),
    Waypoint(i64),
    Prediction(i64),
}

impl std::fmt::Display for Scope {
    /// As the audit trail names it: `routine 12`, `service`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Scope::Service => f.write_str("service"),
            Scope::Cell(id) => write!(f, "cell {id}"),
            Scope::Program(id) => write!(f, "program {id}"),
            Scope::Routine(id) => write!(f, "routine {id}"),
            Scope::Waypoint(id) => write!(f, "waypoint {id}"),
            Scope::Prediction(id) => write!(f, "prediction {id}"),
        }
    }
}

impl App {
    /// Whether `caller` may do `action` on `scope`: [`AppError::PermissionDenied`] if not.
    pub async fn authorize(&self, caller: &Caller, action: Action, scope: Scope) -> Result<()> {
        let denied = |why: String| {
            Err(AppError::PermissionDenied(format!(
                "token {:?} ({}) {why}",
                caller.name,
                caller.role.as_str()
            )))
        };
        if action == Action::ManageTokens && !caller.authenticated {
            return Err(AppError::PermissionDenied(ANONYMOUS_TOKENS.to_string()));
        }
        if caller.role < action.role() {
            return denied(format!(
                "may not do this: it needs the {} role",
                action.role().as_str()
            ));
        }
        if caller.cells.is_none() {
            return Ok(());
        }
        // A cell remembered is checked with the store before it denies (the resource may be
        // gone, see [`super::credentials`]).
        if let Some(cell) = self.credentials.cell_of(scope)
            && caller.may_touch(cell)
        {
            return Ok(());
        }
        let Some(cell) = self.cell_of(scope).await? else {
            if scope == Scope::Service && action != Action::Read {
                return denied("is limited to some cells; this concerns the whole service".into());
            }
            return Ok(());
        };
        if caller.may_touch(cell) {
            Ok(())
        } else {
            denied(format!("may not touch cell {cell}"))
        }
    }

    /// The cells the caller may touch (all of them when it is not limited), in the order
    /// [`App::cells`] lists them: a token limited to some cells does not learn of the others.
    pub async fn visible_cells(&self, caller: &Caller) -> Result<Vec<Cell>> {
        let mut cells = self.cells().await?;
        cells.retain(|c| caller.may_touch(c.id));
        Ok(cells)
    }

    /// The cell a resource belongs to; None for the service or a resource that does not exist.
    async fn cell_of(&self, scope: Scope) -> Result<Option<i64>> {
        let cell = match scope {
            Scope::Service => None,
            Scope::Cell(id) => Some(id),
            Scope::Program(id) => self.store.program(id).await?.map(|p| p.cell_id),
            Scope::Routine(id) => self.store.routine_cell(id).await?.map(|(cell, _)| cell),
            Scope::Waypoint(id) => match self.store.waypoint(id).await? {
                Some(w) => self.store.routine_cell(w.routine_id).await?.map(|(c, _)| c),
                None => None,
            },
            Scope::Prediction(id) => self.store.prediction(id).await?.map(|p| p.cell_id),
        };
        if let Some(cell) = cell
            && !matches!(scope, Scope::Cell(_))
        {
            self.credentials.keep_cell_of(scope, cell);
        }
        Ok(cell)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_role_may_do_what_the_one_below_may() {
        let order = [
            Action::Read,
            Action::Teach,
            Action::Edit,
            Action::Delete,
            Action::Administer,
        ];
        for pair in order.windows(2) {
            assert!(pair[0].role() <= pair[1].role(), "{pair:?}");
        }
        assert_eq!(Action::Teach.role(), Role::Operator);
        assert_eq!(Action::Edit.role(), Role::Engineer);
        assert_eq!(Action::Inspect.role(), Role::Engineer);
        assert_eq!(Action::Delete.role(), Role::Admin);
        assert!(Role::Operator < Role::Engineer && Role::Engineer < Role::Admin);
    }

    #[test]
    fn a_scoped_caller_touches_only_its_cells() {
        let c = Caller {
            name: "op".into(),
            role: Role::Operator,
            cells: Some(vec![2, 5]),
            authenticated: true,
        };
        assert!(c.may_touch(2) && c.may_touch(5) && !c.may_touch(3));
        assert!(Caller::bootstrap().may_touch(3));
    }
}
