//! A method's figures at another's precision. The dissertation's cost model lets a method that
//! offers more at a lower precision save more, so "saves more than the engine" may only mean "is
//! less choosy". Here a method offers only its guesses whose own confidence figure reaches a cut,
//! and the cut that saves most while its offers are at least as precise as a floor (the engine's
//! precision on the same programs) is taken: the scoreboard's row *best baseline at the engine's
//! precision*. Over the headline population (waypoints with ≥ 2 predecessors), pooled over the
//! programs. A guess without a confidence figure is offered only when every guess is.

use serde::Serialize;

use super::metrics::saved_pct;
use crate::replay::playback::{ProgramRecord, WaypointRecord};

/// A method restricted to its most confident guesses, at a precision floor.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AtPrecision {
    pub method: String,
    /// The least confidence offered (`null`: every guess, the method as it is).
    pub min_confidence: Option<f64>,
    pub predictable: usize,
    pub offered: usize,
    pub useful: usize,
    pub precision_pct: f64,
    pub saved_pct: f64,
}

/// `method`'s best figures over `records` with its offers' precision ≥ `floor_pct`; `None` when
/// no cut reaches the floor.
pub fn at_precision(
    method: &str,
    records: &[ProgramRecord],
    floor_pct: f64,
) -> Option<AtPrecision> {
    let population: Vec<&WaypointRecord> = records
        .iter()
        .flat_map(|p| &p.waypoints)
        .filter(|r| r.predecessors >= 2)
        .collect();
    let predictable = population.len();
    if predictable == 0 {
        return None;
    }
    // Offered guesses, most confident first; those without a figure last.
    let mut offered: Vec<(Option<f64>, bool)> = population
        .iter()
        .filter(|r| r.offered)
        .map(|r| (r.confidence.filter(|c| c.is_finite()), r.useful()))
        .collect();
    offered.sort_by(|a, b| match (a.0, b.0) {
        (Some(x), Some(y)) => y.total_cmp(&x),
        (Some(_), None) => std::cmp::Ordering::Less,
        (None, Some(_)) => std::cmp::Ordering::Greater,
        (None, None) => std::cmp::Ordering::Equal,
    });
    let pct = |k: usize| 100.0 * k as f64 / predictable as f64;
    let mut best: Option<AtPrecision> = None;
    let mut useful = 0;
    for (i, (confidence, right)) in offered.iter().enumerate() {
        useful += usize::from(*right);
        // A cut falls only between two different figures (equal ones are offered together),
        // and below a guess without a figure only at the end.
        let next = offered.get(i + 1).map(|n| n.0);
        let cut_here = match (confidence, next) {
            (_, None) => true,
            (Some(c), Some(Some(n))) => n < *c,
            (Some(_), Some(None)) => true,
            (None, Some(_)) => false,
        };
        if !cut_here {
            continue;
        }
        let n = i + 1;
        let precision = 100.0 * useful as f64 / n as f64;
        if precision < floor_pct {
            continue;
        }
        let saved = saved_pct(pct(n), pct(useful));
        if best.as_ref().is_none_or(|b| saved > b.saved_pct) {
            best = Some(AtPrecision {
                method: method.to_string(),
                min_confidence: if n == offered.len() {
                    None
                } else {
                    *confidence
                },
                predictable,
                offered: n,
                useful,
                precision_pct: precision,
                saved_pct: saved,
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(confidence: Option<f64>, right: bool) -> WaypointRecord {
        let err = if right { 0.5 } else { 5.0 };
        WaypointRecord {
            routine: 0,
            predecessors: 2,
            offered: true,
            cart_mm: Some(err),
            angle_rad: Some(0.0),
            travel_mm: 10.0,
            travel_rad: 0.0,
            confidence,
            phi: None,
            psi: None,
            assimilated: None,
            micros: 0.0,
            candidate: None,
        }
    }

    fn program(waypoints: Vec<WaypointRecord>) -> ProgramRecord {
        ProgramRecord {
            program: "p".into(),
            language: "rapid".into(),
            method: "m".into(),
            waypoints,
            summary: None,
        }
    }

    #[test]
    fn the_cut_that_saves_most_above_the_floor_is_taken() {
        let mut w = vec![
            record(Some(3.0), true),
            record(Some(3.0), true),
            record(Some(2.0), true),
            record(Some(2.0), false),
            record(Some(1.0), false),
            record(Some(1.0), true),
            record(None, false),
        ];
        let mut silent = record(None, false);
        silent.offered = false;
        w.extend([silent.clone(), silent.clone(), silent]);
        let p = [program(w)];
        // ≥ 75 %: offering confidence ≥ 2 (3 of 4 right) saves more than ≥ 3 (2 of 2).
        let at = at_precision("m", &p, 75.0).unwrap();
        assert_eq!(
            (at.offered, at.useful, at.min_confidence),
            (4, 3, Some(2.0))
        );
        assert_eq!(at.predictable, 10);
        assert!((at.saved_pct - (0.9 * 30.0 - 0.1 * 10.0)).abs() < 1e-9);
        // ≥ 100 %: only the two most confident; no floor reached above it.
        let at = at_precision("m", &p, 100.0).unwrap();
        assert_eq!((at.offered, at.useful), (2, 2));
        // A low floor: down to confidence 1 (4 of 6 right); the guess without a figure, wrong,
        // would cost more than it brings.
        let at = at_precision("m", &p, 50.0).unwrap();
        assert_eq!(
            (at.offered, at.useful, at.min_confidence),
            (6, 4, Some(1.0))
        );
        // A method without confidence figures is taken as it is.
        let plain = [program(vec![record(None, true), record(None, false)])];
        let at = at_precision("m", &plain, 50.0).unwrap();
        assert_eq!((at.offered, at.min_confidence), (2, None));
        assert_eq!(at_precision("m", &plain, 60.0), None);
        // Nothing right: no cut.
        let wrong = [program(vec![record(Some(1.0), false)])];
        assert_eq!(at_precision("m", &wrong, 50.0), None);
    }
}
