//! A program's revisions as the changes that make them: each [`Change`] holds what it takes to
//! take it back (the values a waypoint had before an edit, a deleted routine with its
//! waypoints) and nothing more (a taught or imported waypoint is where the program now has
//! it). The program as of a revision is its present state ([`ProgramState`]) with the later
//! changes taken back in reverse order ([`ProgramState::take_back`]). Pure: storage writes and
//! reads the revisions, the application lists, compares and restores them.

use serde::{Deserialize, Serialize};

use crate::engine::PoseValues;

/// A change that does not fit the state it is taken back from (a fault of the service's,
/// never a client's).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct RevisionError(pub String);

/// A waypoint's values as an edit sets them (its routine and place stay).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WaypointValues {
    pub pose: PoseValues,
    pub joints: Option<String>,
    pub motion: Option<String>,
    pub name: Option<String>,
    pub reachable: Option<bool>,
}

/// One change to a program, as its revision stores it. Places (`seq`, `position`) are
/// 1-based and as they were at the moment of the change.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "change", rename_all = "snake_case")]
pub enum Change {
    /// A waypoint was put in at place `seq` (taught, inserted, brought back by a restore).
    WaypointAdded { routine: i64, seq: i64 },
    /// A waypoint was taken out of place `seq` (undone or deleted).
    WaypointRemoved {
        routine: i64,
        seq: i64,
        waypoint: WaypointState,
    },
    /// A waypoint's values were changed; `before` is what they were.
    WaypointModified {
        routine: i64,
        waypoint: i64,
        before: WaypointValues,
    },
    /// A routine was put in at place `position` with `waypoints` waypoints (a new routine to
    /// teach, an import, a re-targeted copy, a routine brought back by a restore).
    RoutineAdded {
        routine: i64,
        position: i64,
        waypoints: i64,
    },
    /// A routine was deleted from place `position`, with everything it held.
    RoutineRemoved {
        position: i64,
        routine: RoutineState,
    },
    /// A routine was renamed; `before` is its name then.
    RoutineRenamed {
        routine: i64,
        before: Option<String>,
    },
    /// A routine was moved from place `from` to place `to`.
    RoutineMoved { routine: i64, from: i64, to: i64 },
    /// A routine being taught was finished (the cell's model learned it).
    RoutineFinished { routine: i64 },
    /// The routines were put in another order (a restore); `before` is the order then.
    RoutinesReordered { before: Vec<i64> },
}

/// A program's routines and waypoints, now or as of a revision.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ProgramState {
    /// In program order.
    pub routines: Vec<RoutineState>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RoutineState {
    pub id: i64,
    pub name: Option<String>,
    /// Imported from an offline program.
    pub imported: bool,
    /// Learned by the cell's model (finished, or imported to be learned).
    pub learned: bool,
    /// In order.
    pub waypoints: Vec<WaypointState>,
}

impl RoutineState {
    /// Being taught (neither finished nor imported).
    pub fn open(&self) -> bool {
        !self.imported && !self.learned
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WaypointState {
    pub id: i64,
    #[serde(flatten)]
    pub values: WaypointValues,
}

fn inconsistent(what: String) -> RevisionError {
    RevisionError(what)
}

impl ProgramState {
    fn routine_mut(&mut self, id: i64) -> Result<&mut RoutineState, RevisionError> {
        self.routines
            .iter_mut()
            .find(|r| r.id == id)
            .ok_or_else(|| inconsistent(format!("routine {id} is not in the program")))
    }

    fn index_of(&self, id: i64) -> Result<usize, RevisionError> {
        self.routines
            .iter()
            .position(|r| r.id == id)
            .ok_or_else(|| inconsistent(format!("routine {id} is not in the program")))
    }

    /// The state before `change`, from the state after it.
    pub fn take_back(&mut self, change: &Change) -> Result<(), RevisionError> {
        match change {
            Change::WaypointAdded { routine, seq } => {
                let r = self.routine_mut(*routine)?;
                let at = place(*seq, r.waypoints.len())?;
                r.waypoints.remove(at);
            }
            Change::WaypointRemoved {
                routine,
                seq,
                waypoint,
            } => {
                let r = self.routine_mut(*routine)?;
                let at = place(*seq, r.waypoints.len() + 1)?;
                r.waypoints.insert(at, waypoint.clone());
            }
            Change::WaypointModified {
                routine,
                waypoint,
                before,
            } => {
                let r = self.routine_mut(*routine)?;
                let w = r
                    .waypoints
                    .iter_mut()
                    .find(|w| w.id == *waypoint)
                    .ok_or_else(|| inconsistent(format!("waypoint {waypoint} is not there")))?;
                w.values = before.clone();
            }
            Change::RoutineAdded { routine, .. } => {
                let at = self.index_of(*routine)?;
                self.routines.remove(at);
            }
            Change::RoutineRemoved { position, routine } => {
                let at = place(*position, self.routines.len() + 1)?;
                self.routines.insert(at, routine.clone());
            }
            Change::RoutineRenamed { routine, before } => {
                self.routine_mut(*routine)?.name = before.clone();
            }
            Change::RoutineMoved { routine, from, to } => {
                let at = self.index_of(*routine)?;
                if at + 1 != *to as usize {
                    return Err(inconsistent(format!(
                        "routine {routine} is at place {}, not {to}",
                        at + 1
                    )));
                }
                let r = self.routines.remove(at);
                let back = place(*from, self.routines.len() + 1)?;
                self.routines.insert(back, r);
            }
            Change::RoutineFinished { routine } => {
                self.routine_mut(*routine)?.learned = false;
            }
            Change::RoutinesReordered { before } => {
                let mut by_id: Vec<Option<RoutineState>> = std::mem::take(&mut self.routines)
                    .into_iter()
                    .map(Some)
                    .collect();
                for id in before {
                    let r = by_id
                        .iter_mut()
                        .find(|r| r.as_ref().is_some_and(|r| r.id == *id))
                        .and_then(Option::take)
                        .ok_or_else(|| inconsistent(format!("routine {id} is not there")))?;
                    self.routines.push(r);
                }
                if by_id.iter().any(Option::is_some) {
                    return Err(inconsistent("a reordering lost a routine".into()));
                }
            }
        }
        Ok(())
    }
}

/// The index of 1-based place `n` in a list that has `len` places.
fn place(n: i64, len: usize) -> Result<usize, RevisionError> {
    match usize::try_from(n) {
        Ok(n) if (1..=len).contains(&n) => Ok(n - 1),
        _ => Err(inconsistent(format!("place {n} of {len}"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn waypoint(id: i64, x: f64) -> WaypointState {
        WaypointState {
            id,
            values: WaypointValues {
                pose: PoseValues {
                    x,
                    y: 0.0,
                    z: 0.0,
                    qw: 1.0,
                    qx: 0.0,
                    qy: 0.0,
                    qz: 0.0,
                },
                joints: None,
                motion: None,
                name: None,
                reachable: None,
            },
        }
    }

    fn routine(id: i64, waypoints: Vec<WaypointState>) -> RoutineState {
        RoutineState {
            id,
            name: Some(format!("r{id}")),
            imported: false,
            learned: false,
            waypoints,
        }
    }

    /// Changes made in turn, taken back in reverse order, give the program as it was.
    #[test]
    fn taking_back_the_changes_in_reverse_gives_the_state_before_them() {
        let before = ProgramState {
            routines: vec![routine(1, vec![waypoint(10, 1.0)]), routine(2, vec![])],
        };
        let mut after = before.clone();
        // Taught a waypoint to routine 1, edited its first, moved routine 2 to the front.
        after.routines[0].waypoints.push(waypoint(11, 2.0));
        let edited = std::mem::replace(&mut after.routines[0].waypoints[0], waypoint(10, 5.0));
        let moved = after.routines.remove(1);
        after.routines.insert(0, moved);
        let changes = [
            Change::WaypointAdded { routine: 1, seq: 2 },
            Change::WaypointModified {
                routine: 1,
                waypoint: 10,
                before: edited.values,
            },
            Change::RoutineMoved {
                routine: 2,
                from: 2,
                to: 1,
            },
        ];
        for c in changes.iter().rev() {
            after.take_back(c).unwrap();
        }
        assert_eq!(after, before);
    }

    /// A change that does not fit the state is an error, not a panic.
    #[test]
    fn a_change_that_does_not_fit_is_refused() {
        let mut state = ProgramState {
            routines: vec![routine(1, vec![])],
        };
        let e = state
            .take_back(&Change::WaypointAdded { routine: 1, seq: 1 })
            .unwrap_err();
        assert_eq!(e, RevisionError("place 1 of 0".into()));
        assert!(
            state
                .take_back(&Change::RoutineFinished { routine: 9 })
                .is_err()
        );
    }
}
