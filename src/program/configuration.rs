//! An arm configuration as a program states it: the controller's notation for which of the
//! inverse-kinematics branches a target is reached with. The importer reads it from a file,
//! the exporter writes it, and kinematics computes it from a joint vector
//! ([`crate::kinematics::ArmConfiguration`], brand-neutral, gives each notation). One integer
//! width (`i32`) for every number of every notation.
//!
//! - **RAPID `confdata`** `[cf1, cf4, cf6, cfx]`: the quadrants of axes 1, 4 and 6 and the
//!   branch number `cfx`.
//! - **KRL Status and Turn** (`S`, `T` of an `E6POS`/`POS`): bits; a position may give either,
//!   both or none.
//! - **FANUC `CONFIG`** (`'N U T, 0, 0, 0'`): kept as written, without the quotes.

use serde::{Deserialize, Serialize};

use super::language::Language;

/// ABB RAPID `confdata`: `[cf1, cf4, cf6, cfx]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct RapidConfdata {
    pub cf1: i32,
    pub cf4: i32,
    pub cf6: i32,
    pub cfx: i32,
}

/// KUKA KRL Status (`S`) and Turn (`T`), each when given.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct KrlStatusTurn {
    pub status: Option<i32>,
    pub turn: Option<i32>,
}

/// The configuration a target is to be reached with, in the notation of one language.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Configuration {
    Rapid(RapidConfdata),
    Krl(KrlStatusTurn),
    /// FANUC `CONFIG : 'F U T, 0, 1, 0'`, as written between the quotes.
    Fanuc(String),
}

impl Configuration {
    /// The language whose notation this is.
    pub fn language(&self) -> Language {
        match self {
            Configuration::Rapid(_) => Language::Rapid,
            Configuration::Krl(_) => Language::Krl,
            Configuration::Fanuc(_) => Language::Fanuc,
        }
    }
}
