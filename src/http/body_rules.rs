//! The rules between a body's fields that the server checks and a field's own schema cannot
//! say: fields of which exactly one is given, and a field a value of another one requires.
//! Each is added to the body's schema in the spec as an `allOf` with a `oneOf` whose branches
//! are the allowed combinations, so a client (and a schema fuzzer) knows which bodies are
//! refused before it sends one. The server's own check (in `app/`) stays where the rule is
//! applied, with its message naming the fields; the schema fuzzer in the tests
//! (`tests/api/schemathesis.rs`, positive data acceptance) fails when the two disagree.
//!
//! A "given" field is present and not `null`: the wire types read a `null` as absent.

use serde_json::{Value, json};
use utoipa::Modify;
use utoipa::openapi::schema::{AllOfBuilder, Schema};
use utoipa::openapi::{OpenApi as OpenApiDoc, RefOr};

/// Adds each body's rules to its schema in the components.
pub(super) struct BodyRules;

/// A branch in which `field` is given, as `schema` says.
fn given(field: &str, schema: Value) -> Value {
    json!({ "type": "object", "required": [field], "properties": { field: schema } })
}

/// A field left out (or `null`).
fn absent() -> Value {
    json!({ "type": "null" })
}

/// Exactly one of `fields` given; each with its schema (what it is when given).
fn exactly_one(fields: &[(&str, Value)]) -> Value {
    let branches: Vec<Value> = fields
        .iter()
        .map(|(field, schema)| {
            let mut branch = given(field, schema.clone());
            for (other, _) in fields.iter().filter(|(other, _)| other != field) {
                branch["properties"][*other] = absent();
            }
            branch
        })
        .collect();
    json!({ "oneOf": branches })
}

fn reference(name: &str) -> Value {
    json!({ "$ref": format!("#/components/schemas/{name}") })
}

/// Each body schema with its rule, and the description the rule adds.
fn rules() -> Vec<(&'static str, Value, &'static str)> {
    let id = || json!({ "type": "integer" });
    vec![
        (
            "ReplayRequest",
            exactly_one(&[
                ("files", json!({ "type": "array", "minItems": 1 })),
                ("cell_id", id()),
            ]),
            "Give exactly one of `files` and `cell_id`.",
        ),
        (
            "PlacementSearch",
            exactly_one(&[
                ("program_id", id()),
                ("cell_id", id()),
                ("targets", json!({ "type": "array" })),
            ]),
            "Give exactly one of `program_id`, `cell_id` and `targets`.",
        ),
        (
            "Retarget",
            exactly_one(&[
                ("frame", reference("PoseValues")),
                ("points", reference("FixturePoints")),
            ]),
            "Give exactly one of `frame` (the moved work object) and `points` (old and new).",
        ),
        (
            "FeedbackDto",
            json!({ "oneOf": [
                {
                    "type": "object",
                    "required": ["verdict", "pose"],
                    "properties": {
                        "verdict": { "type": "string", "enum": ["adjusted"] },
                        "pose": reference("PoseValues"),
                    },
                },
                {
                    "type": "object",
                    "properties": {
                        "verdict": { "type": "string", "enum": ["accepted", "rejected"] },
                        "pose": absent(),
                    },
                },
            ]}),
            "The verdict `adjusted` comes with the `pose` finally taught; the others without one.",
        ),
        (
            "CellSettingsInput",
            json!({ "oneOf": [
                { "type": "object", "properties": { "profile": absent() } },
                {
                    "type": "object",
                    "required": ["profile"],
                    "properties": { "profile": { "type": "string", "enum": ["default"] } },
                },
                {
                    "type": "object",
                    "required": ["profile"],
                    "properties": {
                        "profile": { "type": "string", "enum": ["seed"] },
                        "offer_threshold": absent(),
                        "target_precision": absent(),
                    },
                },
            ]}),
            "The profile `seed` has no offer rule: no `offer_threshold` nor `target_precision` \
             with it.",
        ),
    ]
}

impl Modify for BodyRules {
    fn modify(&self, openapi: &mut OpenApiDoc) {
        let Some(components) = openapi.components.as_mut() else {
            return;
        };
        for (name, rule, description) in rules() {
            let Some(body) = components.schemas.remove(name) else {
                panic!("the body rules name a schema the spec lacks: {name}");
            };
            let rule: Schema = serde_json::from_value(rule)
                .unwrap_or_else(|e| panic!("the body rule of {name} is not a schema: {e}"));
            let schema = AllOfBuilder::new()
                .item(body)
                .item(rule)
                .description(Some(description))
                .build();
            components
                .schemas
                .insert(name.to_string(), RefOr::T(Schema::AllOf(schema)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_rule_is_a_schema_of_a_body_the_spec_has() {
        let doc = super::super::openapi();
        let schemas = &doc.components.as_ref().expect("components").schemas;
        for (name, _, _) in rules() {
            let Some(RefOr::T(Schema::AllOf(all))) = schemas.get(name) else {
                panic!("{name} is not wrapped with its rule");
            };
            assert_eq!(all.items.len(), 2, "{name}");
        }
    }

    #[test]
    fn exactly_one_leaves_the_others_out_of_each_branch() {
        let rule = exactly_one(&[("a", json!({"type": "integer"})), ("b", json!({}))]);
        assert_eq!(rule["oneOf"][0]["required"], json!(["a"]));
        assert_eq!(rule["oneOf"][0]["properties"]["b"], absent());
        assert_eq!(rule["oneOf"][1]["required"], json!(["b"]));
        assert_eq!(rule["oneOf"][1]["properties"]["a"], absent());
    }
}
