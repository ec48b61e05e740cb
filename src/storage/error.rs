//! What can go wrong with a write or a read, as the application sees it: the few failures it
//! answers differently (a name taken, a row gone, a cell another instance moved on) apart from
//! the database's own errors, which it only reports.

/// Storage failures, as the application sees them.
#[derive(Debug, thiserror::Error)]
pub enum StorageError {
    /// A uniqueness constraint was violated (e.g. a name already taken).
    #[error("already exists: {0}")]
    Conflict(String),
    /// A referenced row does not exist.
    #[error("not found")]
    NotFound,
    /// The cell was written by another instance since this one's model of it was read: the
    /// write was not made; catch up and try again.
    #[error("cell {cell} changed since revision {expected}")]
    Stale { cell: i64, expected: i64 },
    /// The store cannot take writes (it is shutting down).
    #[error("storage unavailable: {0}")]
    Unavailable(String),
    /// A program's history does not fit its present state (a fault of the service's, never a
    /// client's).
    #[error("program history: {0}")]
    History(String),
    #[error("database error: {0}")]
    Database(#[from] sqlx::Error),
    #[error("migration failed: {0}")]
    Migration(#[from] sqlx::migrate::MigrateError),
    /// A pending migration failed at start-up: nothing of the upgrade was kept, the database
    /// is at migration `at` as before ([`super::migrate`]).
    #[error(
        "migration {version:04} ({description}) failed, so none of this upgrade was kept: the \
         database is at migration {at:04} as it was; {error}"
    )]
    MigrationFailed {
        version: i64,
        description: String,
        at: i64,
        error: sqlx::Error,
    },
}

pub(super) type Result<T> = std::result::Result<T, StorageError>;

/// A failed statement that may have broken a constraint: a taken name is a
/// [`StorageError::Conflict`], a missing row [`StorageError::NotFound`].
pub(super) fn classify(e: sqlx::Error) -> StorageError {
    if let sqlx::Error::Database(db) = &e
        && db.is_unique_violation()
    {
        return StorageError::Conflict(db.message().to_string());
    }
    if let sqlx::Error::RowNotFound = e {
        return StorageError::NotFound;
    }
    StorageError::Database(e)
}
