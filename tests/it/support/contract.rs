//! Every answer of the test servers checked against the OpenAPI document the server serves:
//! its status is one the operation lists, its media type one that status lists, and a JSON
//! body validates against that media type's schema. In-process servers
//! ([`super::server::Server`]) show each answer to a [`Contract`] as they give it; a
//! `caustica serve` child writes them to its `CAUSTICA_ANSWER_LOG`, which an [`AnswerLog`]
//! checks once the child is gone. Violations fail the test.

use caustica::http::{Observed, Observer};
use serde_json::{Value, json};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

#[derive(Default)]
pub struct Contract {
    violations: Mutex<Vec<String>>,
    /// How many answers were checked.
    checked: Mutex<usize>,
    validators: Mutex<HashMap<String, Arc<jsonschema::Validator>>>,
}

impl Contract {
    pub fn observer(self: &Arc<Contract>) -> Observer {
        let c = self.clone();
        Observer(Arc::new(move |o| c.check(o)))
    }

    /// Panics with every answer that disagreed with the spec.
    pub fn assert_clean(&self) {
        let v = self.violations.lock().unwrap();
        assert!(
            v.is_empty(),
            "{} of {} answers disagree with the OpenAPI document:\n{}",
            v.len(),
            self.checked.lock().unwrap(),
            v.join("\n")
        );
    }

    pub fn checked(&self) -> usize {
        *self.checked.lock().unwrap()
    }

    fn violation(&self, s: String) {
        self.violations.lock().unwrap().push(s);
    }

    /// The disagreements so far.
    pub fn violations(&self) -> Vec<String> {
        self.violations.lock().unwrap().clone()
    }

    /// Checks one answer; a disagreement is kept for [`Contract::assert_clean`].
    pub fn check(&self, o: Observed) {
        *self.checked.lock().unwrap() += 1;
        if let Err(e) = self.verdict(&o) {
            let body = o
                .body
                .as_ref()
                .map(|b| String::from_utf8_lossy(&b[..b.len().min(300)]).into_owned())
                .unwrap_or_default();
            self.violation(format!(
                "{} {} -> {} {}: {e} (body: {body})",
                o.method,
                o.route.as_deref().unwrap_or("(no route)"),
                o.status,
                o.content_type.as_deref().unwrap_or("(no type)"),
            ));
        }
    }

    fn verdict(&self, o: &Observed) -> Result<(), String> {
        let doc = caustica::http::openapi();
        let mt = o.content_type.as_deref().map(|t| {
            t.split(';')
                .next()
                .unwrap_or("")
                .trim()
                .to_ascii_lowercase()
        });
        let problem = Some("application/problem+json".to_string());
        // Preflights and HEAD are answered by layers the spec does not describe.
        if o.method == "OPTIONS" || o.method == "HEAD" {
            return Ok(());
        }
        let Some(route) = &o.route else {
            // No route: a 404 or 405 problem (the spec's Problem schema).
            if ![404, 405].contains(&o.status) || mt != problem {
                return Err("an unrouted request must get a 404/405 problem".into());
            }
            return self.validate("#/components/schemas/Problem", o);
        };
        let op = &doc["paths"][route.as_str()][o.method.as_str().to_ascii_lowercase()];
        if op.is_null() {
            if o.status == 405 && mt == problem {
                return self.validate("#/components/schemas/Problem", o);
            }
            return Err("the spec has no such operation".into());
        }
        let status = o.status.to_string();
        let resp = op["responses"]
            .get(&status)
            .or_else(|| op["responses"].get("default"))
            .ok_or_else(|| format!("status {status} is not among the operation's responses"))?;
        let resp = match resp.get("$ref").and_then(Value::as_str) {
            Some(r) => doc
                .pointer(r.trim_start_matches('#'))
                .ok_or_else(|| format!("{r} does not resolve"))?,
            None => resp,
        };
        let content = resp.get("content").and_then(Value::as_object);
        let empty = o.body.as_ref().is_some_and(|b| b.is_empty());
        match (content, &mt) {
            (None, None) => Ok(()),
            (None, Some(_)) if empty => Ok(()),
            (None, Some(m)) => Err(format!("the spec gives status {status} no body, not {m}")),
            (Some(_), None) => Err(format!("status {status} should have a body")),
            (Some(c), Some(m)) => {
                let Some(media) = c.get(m.as_str()) else {
                    return Err(format!(
                        "{m} is not among the media types of status {status}: {:?}",
                        c.keys().collect::<Vec<_>>()
                    ));
                };
                if m.ends_with("json") && o.body.is_some() {
                    let schema = media.get("schema").cloned().unwrap_or(json!(true));
                    let key = format!("{route} {} {status} {m}", o.method);
                    return self.validate_with(&key, schema, o);
                }
                Ok(())
            }
        }
    }

    fn validate(&self, reference: &str, o: &Observed) -> Result<(), String> {
        self.validate_with(reference, json!({ "$ref": reference }), o)
    }

    fn validate_with(&self, key: &str, schema: Value, o: &Observed) -> Result<(), String> {
        let v = {
            let mut cache = self.validators.lock().unwrap();
            match cache.get(key) {
                Some(v) => v.clone(),
                None => {
                    let doc = caustica::http::openapi();
                    let root = json!({
                        "$schema": "https://json-schema.org/draft/2020-12/schema",
                        "components": doc["components"],
                        "allOf": [schema],
                    });
                    let v = Arc::new(
                        jsonschema::draft202012::new(&root)
                            .map_err(|e| format!("the spec's schema does not compile: {e}"))?,
                    );
                    cache.insert(key.to_string(), v.clone());
                    v
                }
            }
        };
        let body = o.body.as_ref().expect("a JSON answer's body");
        let value: Value =
            serde_json::from_slice(body).map_err(|e| format!("the body is not JSON: {e}"))?;
        let errors: Vec<String> = v
            .iter_errors(&value)
            .take(5)
            .map(|e| format!("{} at {}", e, e.instance_path()))
            .collect();
        if errors.is_empty() {
            Ok(())
        } else {
            Err(errors.join("; "))
        }
    }
}

/// The answer log of `caustica serve` children (`CAUSTICA_ANSWER_LOG`), checked against the
/// spec when dropped (after the children it served are gone), then removed.
pub struct AnswerLog(PathBuf);

impl AnswerLog {
    pub fn new(name: &str) -> AnswerLog {
        let p = super::temp_dir(name).join("answers.jsonl");
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        AnswerLog(p)
    }

    pub fn path(&self) -> &Path {
        &self.0
    }

    /// Checks every line; how many answers there were.
    pub fn check(&self) -> usize {
        let c = Contract::default();
        let text = std::fs::read_to_string(&self.0).unwrap_or_default();
        for line in text.lines() {
            let v: Value = serde_json::from_str(line).expect("an answer log line is JSON");
            c.check(Observed {
                method: v["method"].as_str().unwrap().parse().unwrap(),
                route: v["route"].as_str().map(str::to_string),
                status: v["status"].as_u64().unwrap() as u16,
                content_type: v["content_type"].as_str().map(str::to_string),
                body: v["body"]
                    .as_str()
                    .map(|b| axum::body::Bytes::from(b.as_bytes().to_vec())),
            });
        }
        c.assert_clean();
        c.checked()
    }
}

impl Drop for AnswerLog {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let n = self.check();
            assert!(n > 0, "{}: no answers logged", self.0.display());
        }
        if let Some(dir) = self.0.parent() {
            let _ = std::fs::remove_dir_all(dir);
        }
    }
}
