//! Parameters named as they are bound. A statement built for a batch has a place for each
//! value of each append; rather than compute `$n` from how many values came before (and so tie
//! the SQL to the order in [`super::binds`]), the SQL asks for a value's slot when it binds it:
//! [`Params::push`] binds one and answers its `$n`, [`Params::run`] binds several and answers
//! the list of theirs. Written into the SQL, those names cannot drift from the values.

use std::fmt;

use sqlx::any::{Any, AnyArguments, AnyRow};
use sqlx::error::BoxDynError;
use sqlx::query::{Query, QueryAs};
use sqlx::{Arguments, Encode, FromRow, Type};

use super::binds::Binds;
use super::error::{Result, StorageError};

/// A value's place in a statement: `$n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Slot(usize);

impl fmt::Display for Slot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "${}", self.0)
    }
}

/// Consecutive slots, written as a list: `$4, $5, $6`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Run {
    first: usize,
    end: usize,
}

impl Run {
    /// How many slots.
    pub(super) fn count(&self) -> usize {
        self.end - self.first
    }
}

impl fmt::Display for Run {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for n in self.first..self.end {
            if n > self.first {
                f.write_str(", ")?;
            }
            write!(f, "{}", Slot(n))?;
        }
        Ok(())
    }
}

/// The values of a statement being built, each bound when its slot is asked for.
#[derive(Default)]
pub(super) struct Params {
    args: AnyArguments,
    /// The first value that could not be encoded: the statement fails with it when run.
    error: Option<BoxDynError>,
}

impl Params {
    /// Binds `v` and answers its slot.
    pub(super) fn push<'t, T: Encode<'t, Any> + Type<Any>>(&mut self, v: T) -> Slot {
        if let Err(e) = self.args.add(v)
            && self.error.is_none()
        {
            self.error = Some(e);
        }
        Slot(self.args.len())
    }

    /// Binds what `bind` binds and answers their slots.
    pub(super) fn run(&mut self, bind: impl FnOnce(&mut Params)) -> Run {
        let first = self.args.len() + 1;
        bind(self);
        Run {
            first,
            end: self.args.len() + 1,
        }
    }

    /// The statement `sql`, written with the slots handed out, and its values.
    pub(super) fn query<'q>(self, sql: String) -> Result<Query<'q, Any, AnyArguments>> {
        Ok(sqlx::query_with(
            sqlx::AssertSqlSafe(sql),
            self.arguments()?,
        ))
    }

    /// The statement `sql`, answering rows of `R`.
    pub(super) fn query_as<'q, R>(self, sql: String) -> Result<QueryAs<'q, Any, R, AnyArguments>>
    where
        R: for<'r> FromRow<'r, AnyRow>,
    {
        Ok(sqlx::query_as_with(
            sqlx::AssertSqlSafe(sql),
            self.arguments()?,
        ))
    }

    fn arguments(self) -> Result<AnyArguments> {
        match self.error {
            Some(e) => Err(StorageError::Database(sqlx::Error::Encode(e))),
            None => Ok(self.args),
        }
    }
}

impl<'q> Binds<'q> for &mut Params {
    fn value<T: 'q + Encode<'q, Any> + Type<Any>>(self, v: T) -> Self {
        self.push(v);
        self
    }
}
