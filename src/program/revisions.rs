//! A program's revisions as the changes that make them: each [`Change`] holds what it takes to
//! take it back (the values a waypoint had before an edit, a deleted routine with its
//! waypoints) and nothing more (a taught or imported waypoint is where the program now has
//! it). The program as of a revision is its present state ([`ProgramState`]) with the later
//! changes taken back in reverse order ([`ProgramState::take_back`]); a restore to an earlier
//! state makes the changes [`ProgramState::changes_to`] plans. Pure: storage writes, reads and
//! makes the changes in SQL, the application lists, compares and restores revisions.

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

impl ProgramState {
    /// The changes that make this state `target`, in the order a restore makes them, each as
    /// its revision stores it: the routines not in the target go, with their waypoints; the
    /// routines in both take the target's name and waypoints (one not in the target goes, one
    /// whose values differ takes the target's, one only in the target comes in at its place);
    /// the routines only in the target come back at the end, with their waypoints; then the
    /// target's order. A routine in both keeps whether it is learned. The waypoints a routine
    /// keeps are in the target's order (waypoints are never reordered).
    pub fn changes_to(&self, target: &ProgramState) -> Vec<Change> {
        let mut work = self.clone();
        let mut changes = Vec::new();
        let in_target = |id: i64| target.routines.iter().any(|t| t.id == id);
        while let Some(at) = work.routines.iter().position(|r| !in_target(r.id)) {
            let routine = work.routines.remove(at);
            changes.push(Change::RoutineRemoved {
                position: at as i64 + 1,
                routine,
            });
        }
        for t in &target.routines {
            let Some(r) = work.routines.iter_mut().find(|r| r.id == t.id) else {
                continue;
            };
            if r.name != t.name {
                changes.push(Change::RoutineRenamed {
                    routine: r.id,
                    before: std::mem::replace(&mut r.name, t.name.clone()),
                });
            }
            waypoint_changes(r, t, &mut changes);
        }
        for t in &target.routines {
            if work.routines.iter().any(|r| r.id == t.id) {
                continue;
            }
            let position = work.routines.len() as i64 + 1;
            work.routines.push(t.clone());
            changes.push(Change::RoutineAdded {
                routine: t.id,
                position,
                waypoints: t.waypoints.len() as i64,
            });
        }
        let order: Vec<i64> = target.routines.iter().map(|r| r.id).collect();
        let now: Vec<i64> = work.routines.iter().map(|r| r.id).collect();
        if now != order {
            changes.push(Change::RoutinesReordered { before: now });
        }
        changes
    }

    /// Routine `id` of this state.
    pub fn routine(&self, id: i64) -> Result<&RoutineState, RevisionError> {
        self.routines
            .iter()
            .find(|r| r.id == id)
            .ok_or_else(|| inconsistent(format!("routine {id} is not in the program")))
    }
}

/// The changes that make routine `r`'s waypoints `t`'s (see [`ProgramState::changes_to`]).
fn waypoint_changes(r: &mut RoutineState, t: &RoutineState, changes: &mut Vec<Change>) {
    let in_target = |id: i64| t.waypoints.iter().any(|x| x.id == id);
    while let Some(at) = r.waypoints.iter().position(|w| !in_target(w.id)) {
        let waypoint = r.waypoints.remove(at);
        changes.push(Change::WaypointRemoved {
            routine: r.id,
            seq: at as i64 + 1,
            waypoint,
        });
    }
    for (at, x) in t.waypoints.iter().enumerate() {
        match r.waypoints.iter_mut().find(|w| w.id == x.id) {
            Some(w) if w.values != x.values => changes.push(Change::WaypointModified {
                routine: r.id,
                waypoint: x.id,
                before: std::mem::replace(&mut w.values, x.values.clone()),
            }),
            Some(_) => {}
            None => {
                // The waypoints kept are in the target's order: this one's place is free.
                r.waypoints.insert(at.min(r.waypoints.len()), x.clone());
                changes.push(Change::WaypointAdded {
                    routine: r.id,
                    seq: at as i64 + 1,
                });
            }
        }
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

    /// The changes towards a target, made in turn, give the target (as a restore makes them);
    /// taken back in reverse order they give the state they started from.
    #[test]
    fn the_changes_to_a_target_make_it_and_take_back_to_the_start() {
        let mut kept = routine(
            2,
            vec![waypoint(20, 1.0), waypoint(21, 2.0), waypoint(22, 3.0)],
        );
        let start = ProgramState {
            routines: vec![
                routine(1, vec![waypoint(10, 1.0)]),
                kept.clone(),
                routine(3, vec![]),
            ],
        };
        // Routine 1 gone, routine 4 back (at the front), routine 2 renamed with its second
        // waypoint gone, its third edited and one back between its first and third.
        kept.name = Some("renamed".into());
        kept.waypoints = vec![waypoint(20, 1.0), waypoint(23, 9.0), waypoint(22, 4.0)];
        let target = ProgramState {
            routines: vec![
                routine(4, vec![waypoint(40, 0.0)]),
                routine(3, vec![]),
                kept,
            ],
        };
        let changes = start.changes_to(&target);
        let kinds: Vec<&str> = changes
            .iter()
            .map(|c| match c {
                Change::RoutineRemoved { .. } => "routine removed",
                Change::RoutineRenamed { .. } => "renamed",
                Change::WaypointRemoved { .. } => "waypoint removed",
                Change::WaypointModified { .. } => "modified",
                Change::WaypointAdded { .. } => "waypoint added",
                Change::RoutineAdded { .. } => "routine added",
                Change::RoutinesReordered { .. } => "reordered",
                _ => "other",
            })
            .collect();
        assert_eq!(
            kinds,
            [
                "routine removed",
                "renamed",
                "waypoint removed",
                "waypoint added",
                "modified",
                "routine added",
                "reordered"
            ]
        );
        let mut back = target.clone();
        for c in changes.iter().rev() {
            back.take_back(c).unwrap();
        }
        assert_eq!(back, start);
        // Nothing to change: no change.
        assert!(target.changes_to(&target).is_empty());
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
