//! The Kubernetes manifests (`deploy/kubernetes`): every resource a kustomization lists is
//! valid against the Kubernetes schemas (`kubernetes-validate --strict`, from PyPI: the one
//! `KUBERNETES_VALIDATE` names, else one on the PATH, else one this test installs into a
//! virtual environment under `target/`), no manifest is left out of a kustomization, and what
//! they say matches the binary: the commands they run parse, GPU workers ask for a GPU, and
//! each pod's termination grace covers the job grace.

use crate::support::{caustica_command, repo_path};
use std::path::{Path, PathBuf};

use std::process::Command;

/// The validator's version when this test installs it (its schemas: Kubernetes 1.37).
const VALIDATE_VERSION: &str = "1.37.0";

fn validator() -> PathBuf {
    crate::support::python_tool(
        "KUBERNETES_VALIDATE",
        "kubernetes-validate",
        &format!("kubernetes-validate=={VALIDATE_VERSION}"),
    )
}

/// The files a kustomization lists, following `..`-style bases to theirs.
fn resources(kustomization: &Path, out: &mut Vec<PathBuf>) {
    let dir = kustomization.parent().unwrap();
    let k: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(&std::fs::read_to_string(kustomization).unwrap()).unwrap();
    for r in k["resources"].as_sequence().expect("resources") {
        let p = dir.join(r.as_str().unwrap());
        if p.is_dir() {
            resources(&p.join("kustomization.yaml"), out);
        } else {
            assert!(
                p.is_file(),
                "{} lists a missing {}",
                kustomization.display(),
                p.display()
            );
            out.push(p.canonicalize().unwrap());
        }
    }
}

/// Every YAML document of the listed files.
fn documents(files: &[PathBuf]) -> Vec<serde_yaml_ng::Value> {
    use serde::Deserialize;
    let mut docs = vec![];
    for f in files {
        let text = std::fs::read_to_string(f).unwrap();
        for d in serde_yaml_ng::Deserializer::from_str(&text) {
            docs.push(serde_yaml_ng::Value::deserialize(d).unwrap());
        }
    }
    docs
}

#[test]
fn the_kubernetes_manifests_validate_and_match_the_binary() {
    let root = repo_path("deploy/kubernetes");
    let mut base = vec![];
    resources(&root.join("kustomization.yaml"), &mut base);
    let mut all = vec![];
    resources(&root.join("with-postgres/kustomization.yaml"), &mut all);
    assert!(
        base.iter().all(|f| all.contains(f)),
        "the overlay includes the base"
    );
    // No manifest left out.
    for d in [root.clone(), root.join("with-postgres")] {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "yaml")
                && p.file_name().unwrap() != "kustomization.yaml"
            {
                assert!(
                    all.contains(&p.canonicalize().unwrap()),
                    "{} is listed nowhere",
                    p.display()
                );
            }
        }
    }
    let out = Command::new(validator())
        .args(["--strict", "--quiet"])
        .args(&all)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", validator().display()));
    assert!(
        out.status.success(),
        "manifests do not validate:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );

    let docs = documents(&all);
    let config = docs
        .iter()
        .find(|d| d["kind"] == "ConfigMap")
        .expect("a ConfigMap");
    let job_grace: f64 = config["data"]["CAUSTICA_SHUTDOWN_GRACE_S"]
        .as_str()
        .unwrap()
        .parse()
        .unwrap();
    let mut seen = (0, 0);
    for d in docs.iter().filter(|d| d["kind"] == "Deployment") {
        let name = d["metadata"]["name"].as_str().unwrap();
        let pod = &d["spec"]["template"]["spec"];
        let grace = pod["terminationGracePeriodSeconds"].as_f64().unwrap();
        assert!(
            grace >= job_grace + 5.0,
            "{name}: terminationGracePeriodSeconds {grace} does not cover the job grace \
             {job_grace} s"
        );
        let c = &pod["containers"][0];
        let args: Vec<&str> = c["args"]
            .as_sequence()
            .unwrap()
            .iter()
            .map(|a| a.as_str().unwrap())
            .collect();
        // The command parses (clap refuses unknown flags and values): `--help` after the
        // arguments prints help only if everything before it parsed.
        let out = caustica_command()
            .args(&args)
            .arg("--help")
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{name}: `caustica {}` does not parse: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
        let gpu = c["resources"]["limits"]["nvidia.com/gpu"].as_i64();
        if args.contains(&"worker") {
            let lanes = args[args.iter().position(|a| *a == "--lanes").unwrap() + 1];
            assert_eq!(
                lanes.contains("gpu"),
                gpu == Some(1),
                "{name}: GPU lane and GPU request go together"
            );
            if gpu.is_some() {
                seen.0 += 1;
                assert!(
                    !pod["tolerations"].as_sequence().unwrap().is_empty(),
                    "{name}: tolerates GPU nodes' taint"
                );
            } else {
                seen.1 += 1;
            }
        } else {
            assert!(
                args.contains(&"--no-workers"),
                "{name}: the API runs no jobs"
            );
            assert_eq!(c["readinessProbe"]["httpGet"]["path"], "/readyz");
        }
    }
    assert_eq!(seen, (1, 1), "one GPU and one CPU worker Deployment");
    let pdbs = docs
        .iter()
        .filter(|d| d["kind"] == "PodDisruptionBudget")
        .count();
    assert_eq!(
        pdbs, 3,
        "a disruption budget for the API and each worker kind"
    );
}
