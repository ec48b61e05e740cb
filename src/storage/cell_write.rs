//! What a write does to its cell's row. Several instances may hold a model of one cell in
//! memory; each write to the cell advances the cell's revision, so that a model can tell
//! whether it still follows the database, and holds the row until it commits, so that writes to
//! one cell are serialised across instances without a lock of the engine's own.

/// What a write does to its cell's row (see [`super::CellState`]): every write to a cell
/// advances its revision, and holds the row until it commits, so writes to one cell are
/// serialised across instances; the engine needs no lock of its own (a conditional update of a
/// version row holds on PostgreSQL and on the distributed engines that speak its protocol).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellWrite {
    /// The write follows the model in memory, which was at this revision: refused
    /// ([`super::StorageError::Stale`]) when the cell's revision is another.
    pub expected: Option<i64>,
    /// Advance the model version by this much (a learned routine changed).
    pub advance: i64,
    /// Another instance's model of the cell cannot follow this write incrementally.
    pub reload: bool,
}

impl CellWrite {
    /// A write the model in memory made at revision `expected` and follows itself.
    pub fn following(expected: i64) -> CellWrite {
        CellWrite {
            expected: Some(expected),
            advance: 0,
            reload: false,
        }
    }

    /// A write the model in memory made at revision `expected` and follows itself, which a
    /// model of the cell in another instance cannot follow (it learns the cell again).
    pub fn following_alone(expected: i64) -> CellWrite {
        CellWrite {
            reload: true,
            ..CellWrite::following(expected)
        }
    }

    /// An edit: models elsewhere learn the cell again (and this one is rebuilt) when `reload`.
    pub fn edit(advance: bool, reload: bool) -> CellWrite {
        CellWrite {
            expected: None,
            advance: i64::from(advance),
            reload,
        }
    }
}
