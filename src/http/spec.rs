//! The OpenAPI document the server serves at `/openapi.json` and `api/openapi.yaml` commits
//! for readers.
//!
//! The operations (paths, parameters, statuses, media types and their prose) are written once
//! in `operations.yaml` beside this file; every body schema in `components/schemas` is
//! generated here from the Rust types the server parses and serialises (schemars): the scene,
//! the requests, the job, the pages, the problem. So a field added to a type is in the spec at
//! the next build, the `http_openapi` tests fail while the committed `api/openapi.yaml` is
//! stale, and the integration tests check every answer their servers give against this
//! document (`tests/it/support/contract.rs`). The request types below describe bodies the
//! handlers parse field by field (for errors that name the field); tests check that the two
//! agree.

use crate::http::error::ProblemBody;
use crate::http::routes::events::Progress;
use crate::http::routes::jobs::JobView;
use crate::http::routes::lists::{Page, SceneSummary};
use crate::jobs::render::RenderParams;
use crate::jobs::scenes::SceneInfo;
use crate::methods::Method;
use crate::scene::types::SceneDesc;
use schemars::generate::SchemaSettings;
use schemars::{JsonSchema, SchemaGenerator};
use serde_json::{Map, Value};

/// The scene of a request: a scene object, or the id of a stored scene.
#[derive(JsonSchema)]
#[serde(untagged)]
#[allow(dead_code)]
enum SceneRef {
    Scene(SceneDesc),
    /// The id of a stored scene (`POST /v1/scenes`).
    Id(#[schemars(regex(pattern = "^[0-9a-f]{64}$"))] String),
}

/// The body of `POST /v1/renders`: the scene, the method, and the render's parameters (each
/// method's own options in the field named after it: `csl`, `pinhole`, `water`, `beams`,
/// `progressive`; a method's options given to another method are refused with 422).
#[derive(JsonSchema)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
struct RenderRequest {
    scene: SceneRef,
    /// The method (default `auto`: the fastest method measured within 0.10 of the reference
    /// on scenes of this kind, checked where the rule is unsure; see docs/accuracy.md).
    #[serde(default = "auto")]
    method: Method,
    /// false: answer 202 with the job at once; true: wait for the image up to the server's
    /// wait (then 202).
    #[serde(default = "yes")]
    wait: bool,
    #[serde(flatten)]
    params: RenderParams,
}

fn auto() -> Method {
    Method::Auto
}

fn yes() -> bool {
    true
}

/// The body of `POST /v1/bakes`: exactly one of `scene` and `scene_id`, the object baked, and
/// the method with its parameters.
#[derive(JsonSchema)]
#[allow(dead_code)]
struct BakeRequest {
    #[serde(default)]
    scene: Option<SceneRef>,
    /// The id of a stored scene (the same as giving the id as `scene`).
    #[serde(default)]
    #[schemars(regex(pattern = "^[0-9a-f]{64}$"))]
    scene_id: Option<String>,
    /// The name of the object the bake is for.
    object: String,
    #[serde(flatten)]
    method: BakeMethod,
}

/// What is baked: a method and its parameters (defaults filled in before the bake's id is
/// computed). `direct` and the methods without a bake are refused with 422 naming `method`.
#[derive(JsonSchema)]
#[serde(tag = "method", rename_all = "snake_case")]
#[allow(dead_code)]
enum BakeMethod {
    /// Caustic spot lights (Liu et al. 2008) of the object for the scene's first directional
    /// light, or with `dynamic` for every direction; the artifact is the checksummed CSL set
    /// of `caustica bake csl`.
    Csl {
        #[serde(default)]
        params: Option<crate::methods::csl::BakeParams>,
    },
    /// The light transport table of a glass object (Iwasaki et al. 2005), the checksummed
    /// artifact of `caustica bake transport`.
    Transport {
        #[serde(default)]
        params: Option<crate::methods::transport::BakeParams>,
    },
    /// A CPU ground-truth render of the scene; the artifact is a multi-layer EXR of every
    /// component.
    Reference {
        #[serde(default)]
        params: Option<crate::methods::reference::BakeParams>,
    },
}

/// The methods a bake may name, as [`BakeMethod`] lists them.
pub const BAKE_METHODS: [Method; 3] = [Method::Csl, Method::Transport, Method::Reference];

/// The hand-written part: `operations.yaml`.
const OPERATIONS: &str = include_str!("operations.yaml");

/// The schemas of `components/schemas`, generated from the types. Requests are described as
/// the server reads them, answers as it writes them.
fn schemas() -> Map<String, Value> {
    let settings = |s: SchemaSettings| {
        let mut s = s.with(|s| s.definitions_path = "/components/schemas".into());
        s.meta_schema = None;
        s
    };
    let mut requests =
        SchemaGenerator::new(settings(SchemaSettings::draft2020_12().for_deserialize()));
    named::<SceneDesc>(&mut requests, "Scene");
    named::<RenderRequest>(&mut requests, "RenderRequest");
    named::<BakeRequest>(&mut requests, "BakeRequest");
    let mut answers =
        SchemaGenerator::new(settings(SchemaSettings::draft2020_12().for_serialize()));
    named::<JobView>(&mut answers, "Job");
    named::<Page<JobView>>(&mut answers, "JobPage");
    named::<Page<SceneSummary>>(&mut answers, "SceneSummaryPage");
    named::<SceneInfo>(&mut answers, "SceneInfo");
    named::<ProblemBody>(&mut answers, "Problem");
    named::<Progress>(&mut answers, "ProgressEvent");
    let mut out = requests.take_definitions(true);
    for (k, v) in answers.take_definitions(true) {
        match out.get(&k) {
            Some(w) if *w != v => panic!(
                "schema {k} differs between requests and answers: give one of the types \
                 another name"
            ),
            _ => {
                out.insert(k, v);
            }
        }
    }
    let mut out = Value::Object(out);
    tidy(&mut out);
    let Value::Object(mut out) = out else {
        unreachable!()
    };
    out.sort_keys();
    out
}

/// Generates `T`'s schema into `g`, under `name` (the name the operations refer to).
fn named<T: JsonSchema>(g: &mut SchemaGenerator, name: &str) {
    let s = g.subschema_for::<T>();
    let want = format!("#/components/schemas/{name}");
    assert_eq!(
        s.get("$ref").and_then(Value::as_str),
        Some(want.as_str()),
        "{} must be generated as {name}",
        T::schema_name()
    );
}

/// Makes the generated schemas plainer for client generators: an enum of documented unit
/// variants (schemars writes `oneOf` of `const`s) becomes one `enum` whose description lists
/// the variants; integer `format`s that OpenAPI does not define (`uint32`...) and `default:
/// null` are dropped.
fn tidy(v: &mut Value) {
    match v {
        Value::Object(o) => {
            if let Some(Value::Array(alts)) = o.get("oneOf")
                && !alts.is_empty()
                && alts.iter().all(|a| {
                    a.get("const").is_some_and(Value::is_string)
                        && a.as_object().is_some_and(|a| {
                            a.keys()
                                .all(|k| ["const", "description", "type"].contains(&k.as_str()))
                        })
                })
            {
                let values: Vec<Value> = alts.iter().map(|a| a["const"].clone()).collect();
                let notes: Vec<String> = alts
                    .iter()
                    .filter_map(|a| {
                        let d = a.get("description")?.as_str()?.replace('\n', " ");
                        Some(format!("- `{}`: {d}", a["const"].as_str()?))
                    })
                    .collect();
                o.remove("oneOf");
                o.insert("type".into(), "string".into());
                o.insert("enum".into(), Value::Array(values));
                if !notes.is_empty() {
                    let head = o
                        .get("description")
                        .and_then(Value::as_str)
                        .map(|d| format!("{d}\n\n"))
                        .unwrap_or_default();
                    o.insert(
                        "description".into(),
                        format!("{head}{}", notes.join("\n")).into(),
                    );
                }
            }
            if let Some(Value::String(f)) = o.get("format")
                && [
                    "uint", "uint8", "uint16", "uint32", "uint64", "int8", "int16",
                ]
                .contains(&f.as_str())
            {
                o.remove("format");
            }
            // `default: null` on every optional field says nothing a client needs, and some
            // generators take a field with a default for one that is always present.
            if o.get("default") == Some(&Value::Null) {
                o.remove("default");
            }
            for x in o.values_mut() {
                tidy(x);
            }
        }
        Value::Array(a) => a.iter_mut().for_each(tidy),
        _ => {}
    }
}

/// Moves the properties a union's alternatives share into each alternative, titled by its
/// method (`CslBakeRequest`...): client generators read a `oneOf` beside `properties` as the
/// alternatives alone, and would lose the shared fields.
fn distribute(union: &mut Value) {
    let o = union.as_object_mut().expect("a union schema");
    let props = o
        .remove("properties")
        .unwrap_or_else(|| serde_json::json!({}));
    let required = o
        .remove("required")
        .unwrap_or_else(|| serde_json::json!([]));
    o.remove("type");
    for alt in o["oneOf"].as_array_mut().expect("oneOf").iter_mut() {
        let method = alt["properties"]["method"]["const"]
            .as_str()
            .expect("an alternative per method")
            .to_string();
        for (k, v) in props.as_object().expect("properties") {
            alt["properties"][k] = v.clone();
        }
        let mut req: Vec<Value> = required.as_array().cloned().unwrap_or_default();
        req.extend(alt["required"].as_array().cloned().unwrap_or_default());
        alt["required"] = Value::Array(req);
        let mut title = method;
        title[..1].make_ascii_uppercase();
        alt["title"] = format!("{title}BakeRequest").into();
        alt["additionalProperties"] = false.into();
    }
}

/// The whole document: `operations.yaml` with the generated schemas.
pub fn document() -> Value {
    let mut doc: Value = serde_yaml_ng::from_str(OPERATIONS).expect("operations.yaml parses");
    let comps = doc["components"]
        .as_object_mut()
        .expect("operations.yaml has components");
    assert!(
        !comps.contains_key("schemas"),
        "operations.yaml must not write schemas: they are generated"
    );
    let mut schemas = schemas();
    distribute(&mut schemas["BakeRequest"]);
    // The problem types, from the pages the server serves.
    let slugs: Vec<&str> = crate::http::problems::PROBLEMS
        .iter()
        .map(|d| d.slug)
        .collect();
    let ty = &mut schemas["Problem"]["properties"]["type"];
    let d = ty["description"].as_str().unwrap_or_default().to_string();
    ty["description"] = format!("{d} The slugs: {}.", slugs.join(", ")).into();
    comps.insert("schemas".into(), Value::Object(schemas));
    // What any request may get, whatever its route: a malformed request line or header (400),
    // a URI or head past the limits (414, 431), an internal error (500), a server holding as
    // many connections as it accepts (503); and but for the operations' endpoints, a client
    // past its pace (429).
    for (path, item) in doc["paths"].as_object_mut().expect("paths").iter_mut() {
        let paced = !matches!(path.as_str(), "/healthz" | "/readyz" | "/metrics");
        for op in item.as_object_mut().expect("a path item").values_mut() {
            let Some(responses) = op.get_mut("responses").and_then(Value::as_object_mut) else {
                continue;
            };
            let codes = [
                ("400", "Problem"),
                ("414", "Problem"),
                ("431", "Problem"),
                ("500", "Problem"),
                ("503", "Busy"),
            ];
            let pace = paced.then_some(("429", "Busy"));
            for (code, r) in codes.into_iter().chain(pace) {
                responses.entry(code).or_insert_with(
                    || serde_json::json!({ "$ref": format!("#/components/responses/{r}") }),
                );
            }
        }
    }
    doc
}

/// The document as committed in `api/openapi.yaml`.
pub fn yaml() -> String {
    format!(
        "# Generated by `caustica openapi` from src/http/operations.yaml and the Rust types: do not\n\
         # edit; change those and regenerate (the http_openapi tests say when this is stale).\n{}",
        serde_yaml_ng::to_string(&document()).expect("the document serialises")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_schema_reference_resolves() {
        let doc = document();
        let mut refs = vec![];
        fn walk(v: &Value, out: &mut Vec<String>) {
            match v {
                Value::Object(o) => {
                    if let Some(Value::String(r)) = o.get("$ref") {
                        out.push(r.clone());
                    }
                    o.values().for_each(|x| walk(x, out));
                }
                Value::Array(a) => a.iter().for_each(|x| walk(x, out)),
                _ => {}
            }
        }
        walk(&doc, &mut refs);
        assert!(refs.len() > 20);
        for r in refs {
            let ptr = r.strip_prefix('#').expect("local reference");
            assert!(doc.pointer(ptr).is_some(), "{r} does not resolve");
        }
    }

    #[test]
    fn the_bake_union_names_the_methods_that_bake() {
        let doc = document();
        let alts = doc["components"]["schemas"]["BakeRequest"]["oneOf"]
            .as_array()
            .expect("a union by method");
        let named: Vec<&str> = alts
            .iter()
            .map(|a| a["properties"]["method"]["const"].as_str().unwrap())
            .collect();
        let want: Vec<String> = BAKE_METHODS
            .iter()
            .map(|m| {
                serde_json::to_value(m)
                    .unwrap()
                    .as_str()
                    .unwrap()
                    .to_string()
            })
            .collect();
        assert_eq!(named, want);
        // And those are exactly the methods whose bake parameters parse.
        for m in [
            Method::Auto,
            Method::Direct,
            Method::Reference,
            Method::Csl,
            Method::Transport,
            Method::Pinhole,
            Method::Water,
            Method::Beams,
            Method::Photons,
        ] {
            let bakes = m
                .imp()
                .bake_params(&serde_json::json!({}), "params")
                .is_ok();
            assert_eq!(bakes, BAKE_METHODS.contains(&m), "{m:?}");
        }
    }

    #[test]
    fn every_bake_request_field_is_one_the_handler_reads() {
        // The handler's parser refuses unknown fields: a body with every property the schema
        // names (of any alternative) parses.
        let doc = document();
        for alt in doc["components"]["schemas"]["BakeRequest"]["oneOf"]
            .as_array()
            .unwrap()
        {
            let mut body = serde_json::Map::new();
            for (k, p) in alt["properties"].as_object().unwrap() {
                let v = match k.as_str() {
                    "method" => p["const"].clone(),
                    "params" => serde_json::json!({}),
                    _ => "x".into(),
                };
                body.insert(k.clone(), v);
            }
            serde_json::from_value::<crate::http::routes::bakes::BakeRequest>(Value::Object(body))
                .unwrap_or_else(|e| panic!("{}: {e}", alt["title"]));
        }
    }

    #[test]
    fn the_render_request_is_the_handlers_fields_and_its_parameters() {
        // The handler takes scene, method and wait, and parses the rest as RenderParams.
        let doc = document();
        let props = doc["components"]["schemas"]["RenderRequest"]["properties"]
            .as_object()
            .unwrap();
        let defaults: RenderParams = serde_json::from_value(serde_json::json!({})).unwrap();
        let fields = serde_json::to_value(defaults).unwrap();
        let mut want: Vec<&str> = fields
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .chain(["scene", "method", "wait"])
            .collect();
        want.sort();
        let got: Vec<&str> = props.keys().map(String::as_str).collect();
        assert_eq!(got, want);
    }

    #[test]
    fn documented_enums_become_plain_enums() {
        let doc = document();
        let m = &doc["components"]["schemas"]["Method"];
        assert_eq!(m["type"], "string");
        assert!(m["enum"].as_array().unwrap().contains(&"photons".into()));
        assert!(m["description"].as_str().unwrap().contains("- `csl`: "));
    }
}
