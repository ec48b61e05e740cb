//! Programs of a cell: creating and renaming them, re-targeting one to a moved fixture, and
//! exporting one for a controller (`/v1/programs`).

use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use super::PoseValues;
use super::routines::RoutineDetail;

#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CreateProgram {
    /// Name, unique within the cell (not blank; at most 200 characters).
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$"
    )]
    pub name: String,
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct Program {
    pub id: i64,
    pub cell_id: i64,
    pub name: String,
    pub created_at: String,
}

/// A new name for a program or a cell.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Rename {
    /// Not blank; at most 200 characters; unique among its siblings.
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$"
    )]
    pub name: String,
}

/// Three points measured on a fixture (mm, work frame): the origin, a point on its x axis
/// and a point in its xy plane (the pendant's three-point frame), in its old and its new place.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct FixturePoints {
    #[schema(schema_with = three_points)]
    pub old: Vec<[f64; 3]>,
    #[schema(schema_with = three_points)]
    pub new: Vec<[f64; 3]>,
}

/// Three points `[x, y, z]`, each coordinate within ±100,000 mm (as a pose's position).
fn three_points() -> utoipa::openapi::schema::Array {
    use utoipa::openapi::schema::{ArrayBuilder, ObjectBuilder, Type};
    use utoipa::openapi::{KnownFormat, SchemaFormat};
    let coordinate = ObjectBuilder::new()
        .schema_type(Type::Number)
        .format(Some(SchemaFormat::KnownFormat(KnownFormat::Double)))
        .minimum(Some(-crate::engine::POSITION_LIMIT_MM))
        .maximum(Some(crate::engine::POSITION_LIMIT_MM));
    let point = ArrayBuilder::new()
        .items(coordinate)
        .min_items(Some(3))
        .max_items(Some(3));
    ArrayBuilder::new()
        .items(point)
        .min_items(Some(3))
        .max_items(Some(3))
        .description(Some(
            "The origin, a point on the x axis (at least 1 mm from the origin) and a point in \
             the xy plane (at least 1 mm off the axis); mm, each coordinate within ±100,000 mm.",
        ))
        .build()
}

/// Where a routine's or program's fixture went: either `frame`, the moved work object's frame in
/// the current one, or `points` measured on it before and after. The copy is stored under `name`
/// (default: the original's with " (moved)").
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Retarget {
    pub frame: Option<PoseValues>,
    pub points: Option<FixturePoints>,
    /// Not blank; at most 200 characters.
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = r"^[^\x00-\x1f\x7f-\x9f]*[^\s\x00-\x1f\x7f-\x9f][^\x00-\x1f\x7f-\x9f]*$"
    )]
    pub name: Option<String>,
}

/// The re-targeted copy: a new program (or a new routine at the end of the program), finished and
/// not learned (it was not taught), every waypoint checked for reach (`reachable`), and how many
/// the arm does not reach.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Retargeted {
    pub program: Program,
    pub routines: Vec<RoutineDetail>,
    pub unreachable: usize,
}

/// Query of a program export.
#[derive(Debug, Clone, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ExportQuery {
    /// `rapid` (one `.mod`), `krl` (a `.src` and its `.dat`) or `fanuc` (one `.ls` per
    /// routine).
    #[param(pattern = "^(rapid|krl|fanuc)$")]
    pub format: String,
    /// The program as of this revision (default: as it is now).
    #[param(minimum = 0)]
    pub revision: Option<i64>,
}

/// One file of an exported program.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
#[schema(as = ExportedFileDto)]
pub struct ExportedFile {
    pub file_name: String,
    pub text: String,
}

/// A program written for a controller: the files, what the export had to change or could not
/// say (renamed targets, unpaired circles, unknown configurations, unreachable targets), and
/// the waypoints out of the arm's reach (their moves carry a comment in the file).
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ProgramExport {
    pub format: String,
    pub files: Vec<ExportedFile>,
    pub warnings: Vec<String>,
    pub unreachable: Vec<i64>,
}
