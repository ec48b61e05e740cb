//! Pattern programs: pallets, machine-tending trays and grids taught by hand, the benchmark of
//! issue 30 (`nextpose patterns OUT_DIR --set tuning|held-out`). A palletising program visits
//! the slots of a lattice (a row, a grid, layers) one after another, each with the same moves
//! around it; what a pallet wizard asks its user to type (counts, pitches, order, layer height)
//! is what a prediction engine must find from the taught waypoints alone.
//!
//! **The jobs** ([`Job`]), each a routine (or one per layer) from the arm's home back to it:
//!
//! - [`Job::Palletise`]: per item, pick approach, pick, retract (the approach again) at a fixed
//!   pick station; place approach [`CLEARANCE_MM`] above the slot, place, retract. 6 waypoints.
//! - [`Job::Tending`]: per part, from a slot of the raw tray (approach, pick, approach) to the
//!   machine's chuck (approach, load, approach, unload after machining, approach) and into the
//!   same slot of the finished tray (approach, place, approach). 11 waypoints.
//! - [`Job::Grid`]: per point, approach, touch, retract (dispensing, screwing, inspection).
//!   3 waypoints.
//!
//! **The lattice** ([`PatternSpec`]): `counts` along the pattern's two axes and in layers, the
//! pitches, the layer height, the pattern turned by `skew` about the vertical (so its pitch
//! vectors need not lie along the work frame's axes), the visiting order ([`Order`]), every
//! other layer turned by 90° (counts and pitches swapped, the gripper turned with it), one
//! routine or one per layer, and a pattern that stops before it is full (`items`). The tool
//! points down; the place pose turns with the layer.
//!
//! **Two sets** ([`PatternSet`]): [`PatternSet::Tuning`], what an expert for patterns may be
//! chosen on, and [`PatternSet::HeldOut`], other counts, pitches, orders, skews and an early
//! stop, never looked at while tuning. Each program is placed on the table by a rigid move
//! drawn from the seed (±50 mm, ±10°). Written exact, as meant (the simulated operator adds its
//! error when it teaches them, `simulate --operator online`). The programs name an ABB IRB 4600
//! (2.05 m reach), a palletiser-sized arm, which reaches every waypoint as the simulation places
//! it.

use std::f64::consts::{FRAC_PI_2, PI};
use std::path::PathBuf;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::lab::{draw_placement, pose, tool_down};
use crate::engine::Pose;
use crate::program::{Language, NamedArm, Program, Routine};

/// The arm the pattern programs name.
pub const PATTERN_ARM: &str = "IRB 4600";
/// Their language (an ABB arm).
pub const PATTERN_LANGUAGE: Language = Language::Rapid;
/// Height of every approach above its pick, place or touch point, mm.
pub const CLEARANCE_MM: f64 = 150.0;
/// The arm's home, in the cell's frame, mm (tool down).
pub const HOME_MM: [f64; 3] = [900.0, 0.0, 900.0];
/// The palletiser's pick station (the end of a conveyor), mm.
pub const PICK_MM: [f64; 3] = [700.0, -700.0, 400.0];
/// The machine's chuck (machine tending), mm; approached horizontally from −x.
pub const CHUCK_MM: [f64; 3] = [700.0, 750.0, 700.0];
/// Where the lattice's first slot is, mm (its layer-0 place point is this plus the item's height).
pub const PATTERN_ORIGIN_MM: [f64; 3] = [1100.0, -300.0, 200.0];
/// The finished tray of machine tending stands this far from the raw one in y, mm.
pub const OUT_TRAY_OFFSET_MM: f64 = 450.0;
/// Each program is moved by up to ± this in x and y, mm …
pub const PLACEMENT_OFFSET_MM: f64 = 50.0;
/// … and turned by up to ± this about the vertical, rad (10°).
pub const PLACEMENT_YAW_RAD: f64 = 10.0 * PI / 180.0;

/// First ChaCha8 stream of the pattern programs (program `i` uses this + `i`).
const PATTERN_STREAM: u64 = 0x9A77_E500_0000_0000;

/// What the arm does at each lattice point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Job {
    Palletise,
    Tending,
    Grid,
}

impl Job {
    pub fn name(self) -> &'static str {
        match self {
            Job::Palletise => "pallet",
            Job::Tending => "tending",
            Job::Grid => "grid",
        }
    }

    /// Waypoints taught per lattice point.
    pub fn waypoints_per_item(self) -> usize {
        match self {
            Job::Palletise => 6,
            Job::Tending => 11,
            Job::Grid => 3,
        }
    }
}

/// The order in which a layer's points are visited.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Order {
    /// Along the first axis, row after row, each row in the same direction.
    Raster,
    /// Along the first axis, every other row back the other way.
    Serpentine,
    /// Along the second axis first, column after column.
    ColumnFirst,
}

impl Order {
    pub fn name(self) -> &'static str {
        match self {
            Order::Raster => "raster",
            Order::Serpentine => "serpentine",
            Order::ColumnFirst => "columns",
        }
    }
}

/// One pattern program.
#[derive(Debug, Clone, PartialEq)]
pub struct PatternSpec {
    pub job: Job,
    /// Points along the first axis, the second axis, and layers.
    pub counts: [usize; 3],
    /// Pitch along the first and the second axis, mm.
    pub pitch_mm: [f64; 2],
    /// Height of an item (layer pitch), mm; the place point of layer `k` is `(k + 1)` items up.
    pub layer_mm: f64,
    /// The lattice turned about the vertical, rad (0: axes along the work frame's).
    pub skew_rad: f64,
    pub order: Order,
    /// Every other layer turned by 90°: counts and pitches swapped, the gripper turned.
    pub turn_layers: bool,
    /// One routine per layer instead of one for the whole pattern.
    pub routine_per_layer: bool,
    /// Stop after this many items (`None`: the full pattern).
    pub items: Option<usize>,
}

impl PatternSpec {
    /// A name that says what the program is (`pallet_3x4x2_serpentine_turned_layers`).
    pub fn name(&self) -> String {
        let [a, b, c] = self.counts;
        let mut name = format!("{}_{a}x{b}", self.job.name());
        if c > 1 {
            name.push_str(&format!("x{c}"));
        }
        name.push('_');
        name.push_str(self.order.name());
        if self.skew_rad != 0.0 {
            name.push_str(&format!("_skew{:.0}", self.skew_rad.to_degrees()));
        }
        if self.turn_layers {
            name.push_str("_turned");
        }
        if self.routine_per_layer {
            name.push_str("_layers");
        }
        if let Some(n) = self.items {
            name.push_str(&format!("_stop{n}"));
        }
        name
    }

    /// The lattice points in the order they are visited, per layer: (place pose in the
    /// pattern's frame before placement, its `(i, j, layer)` index).
    pub fn points(&self) -> Vec<Vec<(Pose, [usize; 3])>> {
        let mut layers = Vec::new();
        let mut left = self.items.unwrap_or(usize::MAX);
        for k in 0..self.counts[2] {
            let turned = self.turn_layers && k % 2 == 1;
            let (n0, n1, p0, p1) = if turned {
                (
                    self.counts[1],
                    self.counts[0],
                    self.pitch_mm[1],
                    self.pitch_mm[0],
                )
            } else {
                (
                    self.counts[0],
                    self.counts[1],
                    self.pitch_mm[0],
                    self.pitch_mm[1],
                )
            };
            let gripper = UnitQuaternion::from_axis_angle(
                &Vector3::z_axis(),
                self.skew_rad + if turned { FRAC_PI_2 } else { 0.0 },
            ) * tool_down();
            let skew = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), self.skew_rad);
            let z = (k + 1) as f64 * self.layer_mm;
            let mut layer = Vec::new();
            for (a, b) in visit(self.order, n0, n1) {
                if left == 0 {
                    break;
                }
                left -= 1;
                let local = Vector3::new(a as f64 * p0, b as f64 * p1, 0.0);
                let at = skew * local + Vector3::new(0.0, 0.0, z);
                let index = if turned { [b, a, k] } else { [a, b, k] };
                layer.push((pose(at, gripper), index));
            }
            if !layer.is_empty() {
                layers.push(layer);
            }
        }
        layers
    }

    /// The program's routines in the cell's frame (before the program's placement): one, or one
    /// per layer, each from home back to home.
    pub fn routines(&self) -> Vec<Vec<Pose>> {
        let origin = Vector3::from(PATTERN_ORIGIN_MM);
        let home = pose(Vector3::from(HOME_MM), tool_down());
        let mut routines = Vec::new();
        let mut current = vec![home];
        let layers = self.points();
        let last = layers.len().saturating_sub(1);
        for (k, layer) in layers.into_iter().enumerate() {
            for (p, _) in layer {
                let slot = pose(origin + p.position(), p.rotation());
                current.extend(self.job_at(&slot));
            }
            if self.routine_per_layer || k == last {
                current.push(home);
                routines.push(std::mem::replace(&mut current, vec![home]));
            }
        }
        routines
    }

    /// The waypoints of one item at `slot` (its place or touch pose).
    fn job_at(&self, slot: &Pose) -> Vec<Pose> {
        let up = |p: &Pose| pose(p.position() + Vector3::z() * CLEARANCE_MM, p.rotation());
        match self.job {
            Job::Palletise => {
                let pick = pose(Vector3::from(PICK_MM), tool_down());
                vec![up(&pick), pick, up(&pick), up(slot), *slot, up(slot)]
            }
            Job::Grid => vec![up(slot), *slot, up(slot)],
            Job::Tending => {
                // The gripper points along +x into the machine; the approach stands back in −x.
                let into = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), FRAC_PI_2);
                let chuck = pose(Vector3::from(CHUCK_MM), into);
                let door = pose(
                    chuck.position() - Vector3::x() * CLEARANCE_MM,
                    chuck.rotation(),
                );
                let out = pose(
                    slot.position() + Vector3::y() * OUT_TRAY_OFFSET_MM,
                    slot.rotation(),
                );
                vec![
                    up(slot),
                    *slot,
                    up(slot),
                    door,
                    chuck,
                    door,
                    chuck,
                    door,
                    up(&out),
                    out,
                    up(&out),
                ]
            }
        }
    }
}

/// The (first-axis, second-axis) indices of an `n0 × n1` layer in `order`.
fn visit(order: Order, n0: usize, n1: usize) -> Vec<(usize, usize)> {
    match order {
        Order::Raster => (0..n1).flat_map(|b| (0..n0).map(move |a| (a, b))).collect(),
        Order::Serpentine => (0..n1)
            .flat_map(|b| (0..n0).map(move |a| if b % 2 == 0 { (a, b) } else { (n0 - 1 - a, b) }))
            .collect(),
        Order::ColumnFirst => (0..n0).flat_map(|a| (0..n1).map(move |b| (a, b))).collect(),
    }
}

/// Which programs to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PatternSet {
    /// What an expert for patterns may be chosen on.
    Tuning,
    /// Other counts, pitches, orders, skews and an early stop: never looked at while tuning.
    HeldOut,
}

impl PatternSet {
    pub fn name(self) -> &'static str {
        match self {
            PatternSet::Tuning => "tuning",
            PatternSet::HeldOut => "held-out",
        }
    }

    /// The set's programs.
    pub fn specs(self) -> Vec<PatternSpec> {
        let spec = |job, counts, pitch_mm, layer_mm, order| PatternSpec {
            job,
            counts,
            pitch_mm,
            layer_mm,
            skew_rad: 0.0,
            order,
            turn_layers: false,
            routine_per_layer: false,
            items: None,
        };
        let deg = |d: f64| d * PI / 180.0;
        match self {
            PatternSet::Tuning => vec![
                spec(
                    Job::Palletise,
                    [3, 4, 2],
                    [200.0, 250.0],
                    150.0,
                    Order::Raster,
                ),
                PatternSpec {
                    turn_layers: true,
                    routine_per_layer: true,
                    ..spec(
                        Job::Palletise,
                        [3, 4, 2],
                        [200.0, 250.0],
                        150.0,
                        Order::Serpentine,
                    )
                },
                PatternSpec {
                    turn_layers: true,
                    ..spec(
                        Job::Palletise,
                        [4, 3, 2],
                        [180.0, 240.0],
                        120.0,
                        Order::Raster,
                    )
                },
                spec(Job::Grid, [4, 5, 1], [60.0, 40.0], 20.0, Order::Raster),
                spec(Job::Grid, [3, 6, 1], [50.0, 50.0], 20.0, Order::Serpentine),
                spec(
                    Job::Tending,
                    [3, 4, 1],
                    [80.0, 80.0],
                    60.0,
                    Order::Serpentine,
                ),
            ],
            PatternSet::HeldOut => vec![
                PatternSpec {
                    skew_rad: deg(20.0),
                    turn_layers: true,
                    ..spec(
                        Job::Palletise,
                        [2, 5, 3],
                        [260.0, 160.0],
                        130.0,
                        Order::ColumnFirst,
                    )
                },
                PatternSpec {
                    routine_per_layer: true,
                    items: Some(22),
                    ..spec(
                        Job::Palletise,
                        [3, 3, 3],
                        [220.0, 220.0],
                        140.0,
                        Order::Serpentine,
                    )
                },
                PatternSpec {
                    skew_rad: deg(45.0),
                    ..spec(
                        Job::Palletise,
                        [4, 4, 1],
                        [150.0, 150.0],
                        100.0,
                        Order::Raster,
                    )
                },
                PatternSpec {
                    skew_rad: deg(30.0),
                    ..spec(Job::Grid, [5, 4, 1], [45.0, 55.0], 20.0, Order::ColumnFirst)
                },
                spec(Job::Grid, [2, 8, 1], [70.0, 35.0], 20.0, Order::Raster),
                PatternSpec {
                    skew_rad: deg(-15.0),
                    ..spec(
                        Job::Tending,
                        [2, 6, 1],
                        [90.0, 70.0],
                        60.0,
                        Order::ColumnFirst,
                    )
                },
            ],
        }
    }
}

/// One generated program and how it was made.
#[derive(Debug, Clone, PartialEq)]
pub struct PatternProgram {
    pub spec: PatternSpec,
    /// Where the cell stood (world from cell).
    pub placement: Isometry3<f64>,
    /// The program (exact), with `nextpose-patterns/<set>` as its repository.
    pub program: Program,
}

/// The repository a set's programs name.
pub fn repository(set: PatternSet) -> String {
    format!("nextpose-patterns/{}", set.name())
}

/// The set's programs, each placed by a rigid move drawn from `seed`.
pub fn generate(set: PatternSet, seed: u64) -> Vec<PatternProgram> {
    set.specs()
        .into_iter()
        .enumerate()
        .map(|(i, spec)| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(PATTERN_STREAM.wrapping_add(i as u64));
            let placement = draw_placement(
                Vector3::zeros(),
                PLACEMENT_OFFSET_MM,
                PLACEMENT_YAW_RAD,
                &mut rng,
            );
            let name = format!("{i:02}_{}", spec.name());
            let routines = spec
                .routines()
                .into_iter()
                .enumerate()
                .map(|(r, poses)| Routine {
                    name: format!("layer{}", r + 1),
                    waypoints: poses
                        .iter()
                        .map(|p| Pose::from_isometry(placement * p.isometry()))
                        .collect(),
                })
                .collect();
            PatternProgram {
                program: Program {
                    source: PathBuf::from(format!("{name}.json")),
                    name,
                    language: Some(PATTERN_LANGUAGE),
                    repo: Some(repository(set)),
                    arm: Some(NamedArm {
                        designation: PATTERN_ARM.into(),
                        found_in: "nextpose patterns".into(),
                    }),
                    routines,
                },
                spec,
                placement,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(order: Order, counts: [usize; 3]) -> PatternSpec {
        PatternSpec {
            job: Job::Grid,
            counts,
            pitch_mm: [10.0, 20.0],
            layer_mm: 5.0,
            skew_rad: 0.0,
            order,
            turn_layers: false,
            routine_per_layer: false,
            items: None,
        }
    }

    fn indices(spec: &PatternSpec) -> Vec<[usize; 3]> {
        spec.points()
            .into_iter()
            .flatten()
            .map(|(_, ix)| ix)
            .collect()
    }

    #[test]
    fn each_order_visits_every_point_once_in_its_sequence() {
        let raster = indices(&grid(Order::Raster, [3, 2, 1]));
        assert_eq!(
            raster,
            [
                [0, 0, 0],
                [1, 0, 0],
                [2, 0, 0],
                [0, 1, 0],
                [1, 1, 0],
                [2, 1, 0]
            ]
        );
        let serpentine = indices(&grid(Order::Serpentine, [3, 2, 1]));
        assert_eq!(
            serpentine,
            [
                [0, 0, 0],
                [1, 0, 0],
                [2, 0, 0],
                [2, 1, 0],
                [1, 1, 0],
                [0, 1, 0]
            ]
        );
        let columns = indices(&grid(Order::ColumnFirst, [3, 2, 1]));
        assert_eq!(
            columns,
            [
                [0, 0, 0],
                [0, 1, 0],
                [1, 0, 0],
                [1, 1, 0],
                [2, 0, 0],
                [2, 1, 0]
            ]
        );
        // The points are the lattice's: index times pitch.
        for (p, [a, b, _]) in grid(Order::Serpentine, [3, 2, 1]).points().concat() {
            let want = Vector3::new(a as f64 * 10.0, b as f64 * 20.0, 5.0);
            assert!((p.position() - want).norm() < 1e-9);
        }
    }

    /// A turned layer swaps counts and pitches and turns the gripper by 90°.
    #[test]
    fn a_turned_layer_swaps_the_axes_and_turns_the_gripper() {
        let spec = PatternSpec {
            turn_layers: true,
            pitch_mm: [10.0, 20.0],
            ..grid(Order::Raster, [2, 3, 2])
        };
        let layers = spec.points();
        assert_eq!((layers[0].len(), layers[1].len()), (6, 6));
        let (first, second) = (&layers[0][0].0, &layers[1][0].0);
        assert!((first.angle_to(second) - FRAC_PI_2).abs() < 1e-9);
        // Layer 2 runs along the second axis first with the second pitch.
        let step = layers[1][1].0.position() - layers[1][0].0.position();
        assert!((step - Vector3::new(20.0, 0.0, 0.0)).norm() < 1e-9);
        assert!((second.position().z - 10.0).abs() < 1e-9);
    }

    #[test]
    fn a_skewed_pattern_pitches_along_turned_axes_and_can_stop_early() {
        let spec = PatternSpec {
            skew_rad: PI / 4.0,
            items: Some(4),
            ..grid(Order::Raster, [3, 3, 1])
        };
        let points = spec.points().concat();
        assert_eq!(points.len(), 4);
        let step = points[1].0.position() - points[0].0.position();
        let h = 10.0 / 2f64.sqrt();
        assert!((step - Vector3::new(h, h, 0.0)).norm() < 1e-9);
    }

    /// Every program: home first and last in each routine, the job's waypoints per item, one
    /// routine per layer where asked; the named IRB 4600 reaches all of it as the simulation
    /// places it; and the two sets are different programs.
    #[test]
    fn both_sets_are_whole_programs_the_named_arm_reaches() {
        use crate::kinematics::placement::{ReachCheck, ReachSetup};
        let check = ReachCheck::new(ReachSetup::default()).unwrap();
        let home = pose(Vector3::from(HOME_MM), tool_down());
        let tuning = generate(PatternSet::Tuning, 1);
        let held_out = generate(PatternSet::HeldOut, 1);
        for p in tuning.iter().chain(&held_out) {
            let items: usize = p.spec.points().iter().map(Vec::len).sum();
            let taught: usize = p.program.waypoint_count();
            let routines = p.program.routines.len();
            assert_eq!(
                taught,
                items * p.spec.job.waypoints_per_item() + 2 * routines,
                "{}",
                p.program.name
            );
            let layers = p.spec.points().len();
            assert_eq!(routines, if p.spec.routine_per_layer { layers } else { 1 });
            for r in &p.program.routines {
                for end in [&r.waypoints[0], &r.waypoints[r.waypoints.len() - 1]] {
                    let want = Pose::from_isometry(p.placement * home.isometry());
                    assert!(end.distance_to(&want) < 1e-9);
                }
            }
            let poses: Vec<Pose> = p.program.poses().copied().collect();
            let arm = check
                .place(
                    PATTERN_LANGUAGE.as_str(),
                    p.program.arm_designation(),
                    &poses,
                )
                .unwrap()
                .unwrap();
            assert_eq!(arm.arm.robot, "abb_irb4600", "{}", p.program.name);
            assert_eq!(arm.arm.reached, poses.len(), "{}", p.program.name);
        }
        let names =
            |s: &[PatternProgram]| -> Vec<String> { s.iter().map(|p| p.spec.name()).collect() };
        assert!(names(&tuning).iter().all(|n| !names(&held_out).contains(n)));
        assert_eq!(held_out[1].spec.points().concat().len(), 22);
        assert_eq!(generate(PatternSet::Tuning, 1), tuning);
        assert_ne!(
            generate(PatternSet::Tuning, 2)[0].placement,
            tuning[0].placement
        );
    }
}
