//! `api/scene.schema.json` is generated from the scene types and must stay in step with them:
//! regenerate it with `CAUSTICA_BLESS=1 cargo test --test it schema::`.

use crate::support::repo_path;
use caustica::scene::types::scene_schema;

#[test]
fn committed_schema_matches_the_types() {
    let generated = serde_json::to_string_pretty(&scene_schema()).unwrap() + "\n";
    let path = repo_path("api/scene.schema.json");
    if std::env::var_os("CAUSTICA_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let committed = std::fs::read_to_string(&path).expect("api/scene.schema.json exists");
    assert!(
        committed == generated,
        "api/scene.schema.json is stale: run CAUSTICA_BLESS=1 cargo test --test it schema::"
    );
}

#[test]
fn every_example_scene_parses() {
    let mut n = 0;
    for e in std::fs::read_dir(repo_path("scenes")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "json") {
            let bytes = std::fs::read(&p).unwrap();
            caustica::scene::parse_scene(&bytes).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            caustica::scene::load_scene_file(&p, &Default::default())
                .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            n += 1;
        }
    }
    assert!(n >= 3);
}
