//! The OpenAPI schemas of the engine's types that travel on the wire as they are (a pose's seven
//! numbers, the teaching noise, the acceptance tolerance, the profile, the segmentation
//! criterion, the operator's verdict on a suggestion, the learner's merge test, the recall gate).
//!
//! The engine is pure and knows nothing of the web: it derives `Serialize`/`Deserialize` for
//! these types, not `utoipa::ToSchema`. Their schemas are described here instead, by a mirror of
//! each type (same fields, same serde attributes, same docs, which become the schema's
//! descriptions) whose derived schema the real type answers with. The tests below keep every
//! mirror in step with its type: a value of either reads back as the other.

use std::borrow::Cow;

use utoipa::openapi::{RefOr, Schema};
use utoipa::{PartialSchema, ToSchema};

use crate::engine::Noise;
use crate::engine::Tolerance;
use crate::engine::config::{MergeRule, RecallGate};
use crate::engine::experts::acceptance::Verdict;
use crate::engine::lead_through::segment::Criterion;
use crate::engine::{PoseValues, Profile};

/// `$ty` answers with the schema of its mirror `$mirror` (which carries the name).
macro_rules! schema_of {
    ($ty:ty, $mirror:ty) => {
        impl PartialSchema for $ty {
            fn schema() -> RefOr<Schema> {
                <$mirror as PartialSchema>::schema()
            }
        }

        impl ToSchema for $ty {
            fn name() -> Cow<'static, str> {
                <$mirror as ToSchema>::name()
            }
        }
    };
}

schema_of!(PoseValues, mirror::PoseValues);
schema_of!(Noise, mirror::Noise);
schema_of!(Tolerance, mirror::Tolerance);
schema_of!(Profile, mirror::Profile);
schema_of!(Criterion, mirror::Criterion);
schema_of!(Verdict, mirror::Verdict);
schema_of!(MergeRule, mirror::MergeRule);
schema_of!(RecallGate, mirror::RecallGate);

/// Schema-only copies of the engine's wire types; never built outside the tests.
#[allow(dead_code)]
pub(crate) mod mirror {
    use serde::{Deserialize, Serialize};
    use utoipa::ToSchema;

    /// A pose as plain numbers, as clients send and see it: position in mm and a unit quaternion
    /// `w, x, y, z`. The service accepts a pose whose numbers are finite, whose coordinates are
    /// within ±100,000 mm (100 m) of the frame's origin and whose quaternion is within 1e-3 of
    /// unit norm (it is normalised); anything else is a 422 naming the field and value.
    #[derive(Debug, Serialize, Deserialize, ToSchema)]
    #[serde(deny_unknown_fields)]
    pub struct PoseValues {
        /// mm
        #[schema(minimum = -100000.0, maximum = 100000.0)]
        pub x: f64,
        /// mm
        #[schema(minimum = -100000.0, maximum = 100000.0)]
        pub y: f64,
        /// mm
        #[schema(minimum = -100000.0, maximum = 100000.0)]
        pub z: f64,
        /// Within ±1.001 (a quaternion within 1e-3 of unit norm).
        #[schema(minimum = -1.001, maximum = 1.001)]
        pub qw: f64,
        #[schema(minimum = -1.001, maximum = 1.001)]
        pub qx: f64,
        #[schema(minimum = -1.001, maximum = 1.001)]
        pub qy: f64,
        #[schema(minimum = -1.001, maximum = 1.001)]
        pub qz: f64,
    }

    /// A relative move as plain numbers (a prediction's `relative`): the translation in mm and
    /// the rotation as a unit quaternion `w, x, y, z` with `qw ≥ 0`, in the frame of the
    /// waypoint it starts from. Not a pose in the work frame, so not bounded like one: a move
    /// between two poses within ±100 m may be longer than 100 m on an axis.
    #[derive(Debug, Serialize, Deserialize, ToSchema)]
    #[serde(deny_unknown_fields)]
    pub struct RelativeMove {
        /// mm
        pub x: f64,
        /// mm
        pub y: f64,
        /// mm
        pub z: f64,
        pub qw: f64,
        pub qx: f64,
        pub qy: f64,
        pub qz: f64,
    }

    /// Teaching noise: one-sigma error per axis of a taught waypoint.
    #[derive(Debug, Serialize, Deserialize, ToSchema)]
    #[serde(deny_unknown_fields)]
    pub struct Noise {
        /// Position, mm per axis (at most 100).
        #[schema(minimum = 0.0, maximum = 100.0)]
        pub mm: f64,
        /// Rotation, rad per axis (at most 0.5).
        #[schema(minimum = 0.0, maximum = 0.5)]
        pub rad: f64,
    }

    /// How close two elements (or two guesses) must be to count as the same: translation in mm and
    /// rotation in rad, both bounds inclusive.
    #[derive(Debug, Serialize, Deserialize, ToSchema)]
    #[serde(deny_unknown_fields)]
    pub struct Tolerance {
        /// mm
        #[schema(minimum = 0.0)]
        pub mm: f64,
        /// rad
        #[schema(minimum = 0.0)]
        pub rad: f64,
    }

    /// Engine profile: a named configuration.
    #[derive(Debug, Serialize, Deserialize, ToSchema)]
    #[serde(rename_all = "snake_case")]
    pub enum Profile {
        /// The dissertation's engine as specified in ALGORITHM.md.
        #[serde(rename = "seed")]
        Dissertation,
        /// The best combination measured on the shared corpus.
        Default,
    }

    /// How the prediction error of §5.7 is measured.
    #[derive(Debug, Serialize, Deserialize, ToSchema)]
    #[serde(rename_all = "snake_case")]
    pub enum Criterion {
        /// Direction of the predicted step against the observed one (the default; see the module
        /// docs).
        Direction,
        /// Eq. 5.7 as written: error over step length.
        #[serde(rename = "seed")]
        ErrorOverStep,
    }

    /// How the learner decides that a move joins an existing state.
    #[derive(Debug, Serialize, Deserialize, ToSchema)]
    #[serde(rename_all = "snake_case")]
    pub enum MergeRule {
        /// The seed's: join the state whose total scatter with the move stays within ε.
        Total,
        /// Join the state whose scatter grows least, when the increase stays within ε.
        Incremental,
    }

    /// When a recalled continuation is offered: the window has at least `min_window` moves and
    /// fits the recalled context's states within `max_cost`.
    #[derive(Debug, Serialize, Deserialize, ToSchema)]
    pub struct RecallGate {
        /// Mean squared Mahalanobis distance of the window to the recalled context's states.
        #[schema(minimum = 0.0)]
        pub max_cost: f64,
        /// Fewest window moves (after backoff) a recall may condition on (0 to 50, the largest
        /// horizon).
        #[schema(minimum = 0, maximum = 50)]
        pub min_window: usize,
    }

    #[derive(Debug, Serialize, Deserialize, ToSchema)]
    #[serde(rename_all = "snake_case")]
    pub enum Verdict {
        /// Accepted as is.
        Accepted,
        /// Accepted, then adjusted to the given pose.
        Adjusted,
        Rejected,
    }
}

#[cfg(test)]
mod tests {
    use serde::Serialize;
    use serde::de::DeserializeOwned;

    use super::*;

    /// `value` reads back as `M` and that as `T`, unchanged: the mirror has the same fields (or
    /// variants) under the same names.
    fn same_wire<T, M>(value: T)
    where
        T: Serialize + DeserializeOwned + PartialEq + std::fmt::Debug,
        M: Serialize + DeserializeOwned,
    {
        let json = serde_json::to_value(&value).expect("serialises");
        let mirror: M = serde_json::from_value(json.clone()).expect("the mirror reads it");
        let back = serde_json::to_value(&mirror).expect("serialises");
        assert_eq!(back, json);
        let again: T = serde_json::from_value(back).expect("the type reads the mirror's");
        assert_eq!(again, value);
    }

    #[test]
    fn every_mirror_matches_its_type() {
        same_wire::<_, mirror::PoseValues>(PoseValues {
            x: 1.0,
            y: 2.0,
            z: 3.0,
            qw: 1.0,
            qx: 0.0,
            qy: 0.0,
            qz: 0.0,
        });
        same_wire::<_, mirror::RelativeMove>(PoseValues {
            x: 250_000.0,
            y: 2.0,
            z: 3.0,
            qw: 1.0,
            qx: 0.0,
            qy: 0.0,
            qz: 0.0,
        });
        same_wire::<_, mirror::Noise>(Noise { mm: 0.5, rad: 0.01 });
        same_wire::<_, mirror::Tolerance>(Tolerance { mm: 1.0, rad: 0.1 });
        for p in Profile::ALL {
            same_wire::<_, mirror::Profile>(p);
            assert_eq!(serde_json::to_value(p).expect("serialises"), p.name());
        }
        for c in Criterion::ALL {
            same_wire::<_, mirror::Criterion>(c);
            assert_eq!(serde_json::to_value(c).expect("serialises"), c.name());
        }
        for m in [MergeRule::Total, MergeRule::Incremental] {
            same_wire::<_, mirror::MergeRule>(m);
        }
        same_wire::<_, mirror::RecallGate>(RecallGate {
            max_cost: 0.1,
            min_window: 2,
        });
        for v in Verdict::ALL {
            same_wire::<_, mirror::Verdict>(v);
            assert_eq!(Verdict::named(v.as_str()), Some(v));
            assert_eq!(serde_json::to_value(v).expect("serialises"), v.as_str());
        }
    }

    #[test]
    fn the_names_are_the_published_ones() {
        assert_eq!(<PoseValues as ToSchema>::name(), "PoseValues");
        assert_eq!(<Noise as ToSchema>::name(), "Noise");
        assert_eq!(<Tolerance as ToSchema>::name(), "Tolerance");
        assert_eq!(<Profile as ToSchema>::name(), "Profile");
        assert_eq!(<Criterion as ToSchema>::name(), "Criterion");
        assert_eq!(<Verdict as ToSchema>::name(), "Verdict");
        assert_eq!(<MergeRule as ToSchema>::name(), "MergeRule");
        assert_eq!(<RecallGate as ToSchema>::name(), "RecallGate");
    }
}
