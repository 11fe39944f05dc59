//! One test suite for both job-store back-ends: SQLite (the embedded default) and PostgreSQL
//! (a throwaway cluster, `support::pg`). Each check runs against each; the suite asserts the
//! behaviour the job system relies on: records, holds, idempotency, claims that never hand one
//! job to two workers, leases that run out (a negative lease is one that already has, so no
//! test waits on a clock), attempts and their limit, state changes conditional on the worker.

use crate::support::pg::PgCluster;
use caustica::jobs::store::{
    Held, JobFilter, JobRecord, MAX_ATTEMPTS, Store, StoreEvent, StoredArtifact,
};
use caustica::jobs::{JobKind, JobSpec, JobState, Lane, Priority};
use caustica::methods::Method;
use std::collections::HashSet;
use std::sync::Arc;

fn spec(kind: JobKind, scene: &str, n: u32) -> JobSpec {
    JobSpec {
        kind,
        method: if kind == JobKind::Bake {
            Method::Csl
        } else {
            Method::Reference
        },
        scene_id: scene.into(),
        object: (kind == JobKind::Bake).then(|| "sphere".to_string()),
        params: serde_json::json!({ "n": n }),
    }
}

fn insert(s: &Store, id: &str, kind: JobKind, lane: Lane, prio: Priority) -> JobRecord {
    let r = JobRecord::new(id, &spec(kind, "sc_1", 0), lane, prio);
    s.insert_job(&r).unwrap();
    r
}

fn filter(kind: JobKind) -> JobFilter {
    JobFilter {
        kind,
        owner: None,
        state: None,
        method: None,
        created_since: None,
        before_seq: None,
        limit: 100,
    }
}

fn artifact(name: &str) -> StoredArtifact {
    StoredArtifact {
        name: name.into(),
        len: 3,
        sha256: "ab".repeat(32),
    }
}

/// Scenes, holds, the sweep's queries, idempotency keys.
fn scenes_holds_and_keys(s: &Store) {
    let files = vec![("a.bin".to_string(), vec![1u8, 2, 3])];
    s.put_scene("sc_1", br#"{"name":"one"}"#, &files, "alice")
        .unwrap();
    // The same id again: the first stays; the second owner holds it too.
    s.put_scene("sc_1", br#"{"name":"other"}"#, &[], "bob")
        .unwrap();
    s.put_scene("sc_2", br#"{"name":"two"}"#, &[], "bob")
        .unwrap();
    // Each holder counts a scene whole: its JSON (14 bytes) and files (3).
    assert_eq!(s.held_bytes("alice").unwrap(), 17);
    assert_eq!(s.held_bytes("bob").unwrap(), 17 + 14);
    assert_eq!(s.held_bytes("carol").unwrap(), 0);
    assert!(s.scene_exists("sc_1").unwrap());
    assert!(!s.scene_exists("sc_9").unwrap());
    let got = s.get_scene("sc_1").unwrap().unwrap();
    assert_eq!(got.scene_json, br#"{"name":"one"}"#);
    assert_eq!(got.files, files);
    assert!(s.get_scene("sc_9").unwrap().is_none());
    let all = s.list_scenes(None, None, None, 10).unwrap();
    let names: Vec<_> = all.iter().map(|r| (r.1.as_str(), r.2.as_str())).collect();
    assert_eq!(names, [("sc_2", "two"), ("sc_1", "one")], "newest first");
    let alice = s.list_scenes(Some("alice"), None, None, 10).unwrap();
    assert_eq!(alice.len(), 1);
    let page2 = s.list_scenes(None, None, Some(all[0].0), 10).unwrap();
    assert_eq!(page2.len(), 1, "the cursor skips the first page");
    assert_eq!(page2[0].1, "sc_1");
    assert_eq!(
        s.first_holder(Held::Scene, "sc_1").unwrap().unwrap(),
        "alice"
    );
    assert_eq!(s.holders(Held::Scene, "sc_1").unwrap(), 2);
    assert!(s.holds(Held::Scene, "sc_1", "bob").unwrap());
    assert_eq!(s.release(Held::Scene, "sc_1", "alice").unwrap(), 1);
    assert_eq!(s.first_holder(Held::Scene, "sc_1").unwrap().unwrap(), "bob");
    // A scene a queued job uses is not deleted, held or not.
    insert(s, "rn_scene", JobKind::Render, Lane::Cpu, Priority::Render);
    s.release_all(Held::Scene, "sc_1").unwrap();
    assert!(s.scene_in_use("sc_1").unwrap());
    assert!(!s.delete_scene("sc_1").unwrap());
    let unheld = s.unheld_scenes(i64::MAX).unwrap();
    assert_eq!(unheld, ["sc_1"]);
    assert!(
        s.unheld_scenes(0).unwrap().is_empty(),
        "younger than the cut"
    );
    assert!(
        s.finish(
            "rn_scene",
            "",
            JobState::Canceled,
            0.0,
            &[],
            &serde_json::json!({}),
            Some("canceled"),
            None
        )
        .unwrap()
    );
    assert!(!s.scene_in_use("sc_1").unwrap());
    assert!(s.delete_scene("sc_1").unwrap());
    assert!(s.get_scene("sc_1").unwrap().is_none());
    assert!(!s.delete_scene("sc_2").unwrap(), "bob holds it");

    assert!(s.idempotency("k1").unwrap().is_none());
    s.put_idempotency("k1", "h1", "rn_a").unwrap();
    s.put_idempotency("k1", "h2", "rn_b").unwrap();
    assert_eq!(
        s.idempotency("k1").unwrap().unwrap(),
        ("h1".to_string(), "rn_a".to_string()),
        "the first use stands"
    );
    s.replace_idempotency("k1", "h3", "rn_c").unwrap();
    assert_eq!(s.idempotency("k1").unwrap().unwrap().1, "rn_c");
}

/// Records: insert, read back, list with filters and cursors, finish, delete, requeue.
fn records(s: &Store) {
    let r = insert(s, "rn_1", JobKind::Render, Lane::Gpu, Priority::Small);
    insert(s, "rn_2", JobKind::Render, Lane::Cpu, Priority::Render);
    insert(s, "bk_1", JobKind::Bake, Lane::Cpu, Priority::Bake);
    s.hold(Held::Job, "rn_1", "alice").unwrap();
    s.hold(Held::Job, "rn_2", "bob").unwrap();
    let got = s.get_job("rn_1").unwrap().unwrap();
    assert_eq!(got.spec(), r.spec());
    assert_eq!(
        (got.state, got.lane, got.priority, got.attempts),
        (JobState::Queued, Lane::Gpu, Priority::Small, 0)
    );
    assert!(s.get_job("rn_9").unwrap().is_none());
    let renders = s.list_jobs(&filter(JobKind::Render)).unwrap();
    let ids: Vec<_> = renders.iter().map(|(_, r)| r.id.as_str()).collect();
    assert_eq!(ids, ["rn_2", "rn_1"], "newest first, renders only");
    let mut f = filter(JobKind::Render);
    f.owner = Some("alice".into());
    assert_eq!(s.list_jobs(&f).unwrap().len(), 1);
    f.owner = None;
    f.before_seq = Some(renders[0].0);
    assert_eq!(s.list_jobs(&f).unwrap()[0].1.id, "rn_1");
    f.before_seq = None;
    f.method = Some(Method::Csl);
    assert!(s.list_jobs(&f).unwrap().is_empty());
    assert_eq!(s.count_queued(JobKind::Render).unwrap(), 2);
    assert_eq!(s.active_jobs_of("alice").unwrap(), 1);

    // A worker runs rn_1 to the end with an artifact.
    assert!(s.set_running("rn_1", "w1", 60_000).unwrap());
    assert!(!s.set_running("rn_1", "w2", 60_000).unwrap(), "not queued");
    s.set_progress("rn_1", 0.5, "tracing").unwrap();
    let got = s.get_job("rn_1").unwrap().unwrap();
    assert_eq!((got.progress, got.stage.as_str()), (0.5, "tracing"));
    assert_eq!(got.worker.as_deref(), Some("w1"));
    let a = artifact("rn_1.png");
    let timings = [("queue".to_string(), 1.5), ("run".to_string(), 20.0)];
    let info = serde_json::json!({ "adapter": "x" });
    assert!(
        !s.finish(
            "rn_1",
            "w2",
            JobState::Succeeded,
            1.0,
            &timings,
            &info,
            None,
            Some(("image/png", &a))
        )
        .unwrap(),
        "another worker's end is refused"
    );
    assert!(
        s.finish(
            "rn_1",
            "w1",
            JobState::Succeeded,
            1.0,
            &timings,
            &info,
            None,
            Some(("image/png", &a))
        )
        .unwrap()
    );
    // Its artifact's bytes count for its holders.
    let before = s.held_bytes("dora").unwrap();
    s.hold(Held::Job, "rn_1", "dora").unwrap();
    assert_eq!(s.held_bytes("dora").unwrap(), before + a.len);
    s.release(Held::Job, "rn_1", "dora").unwrap();
    let got = s.get_job("rn_1").unwrap().unwrap();
    assert_eq!(got.state, JobState::Succeeded);
    assert_eq!(got.timings, timings);
    assert_eq!(got.info, info);
    assert_eq!(got.artifact_path.as_deref(), Some("rn_1.png"));
    assert_eq!(got.artifact_type.as_deref(), Some("image/png"));
    assert_eq!(got.artifact_len, Some(3));
    assert_eq!(got.stage, "done");
    assert!(got.finished_at.is_some() && got.worker.is_none());
    // The same worker, late: the job has ended, nothing changes.
    assert!(
        !s.finish(
            "rn_1",
            "w1",
            JobState::Failed,
            0.0,
            &[],
            &info,
            Some("late"),
            None
        )
        .unwrap()
    );
    assert_eq!(s.renders_by_last_use().unwrap(), [("rn_1".to_string(), 3)]);
    assert_eq!(
        s.finished_before(JobKind::Render, i64::MAX).unwrap(),
        ["rn_1"]
    );
    assert!(s.finished_before(JobKind::Render, 0).unwrap().is_empty());
    s.touch(&[("rn_1".to_string(), caustica::jobs::store::now_ms())])
        .unwrap();

    // A lost artifact fails the job once, for the reader that saw that artifact.
    assert!(!s.fail_lost("rn_1", Some("00"), "lost").unwrap());
    assert!(s.fail_lost("rn_1", Some(&"ab".repeat(32)), "lost").unwrap());
    assert!(!s.fail_lost("rn_1", Some(&"ab".repeat(32)), "lost").unwrap());
    let got = s.get_job("rn_1").unwrap().unwrap();
    assert_eq!(got.state, JobState::Failed);
    assert_eq!(got.error_code(), Some(caustica::jobs::ErrorCode::Store));
    // Failed jobs run again; queued ones are not "requeued".
    s.requeue("rn_1").unwrap();
    let got = s.get_job("rn_1").unwrap().unwrap();
    assert_eq!((got.state, got.error.as_deref()), (JobState::Queued, None));
    s.requeue("rn_2").unwrap();
    assert_eq!(s.get_job("rn_2").unwrap().unwrap().state, JobState::Queued);

    // Deleting: only finished jobs; their holds and keys go with them.
    s.put_idempotency("k2", "h", "bk_1").unwrap();
    s.hold(Held::Job, "bk_1", "carol").unwrap();
    assert!(s.delete_job_record("bk_1").unwrap().is_none(), "queued");
    assert_eq!(
        s.request_cancel("bk_1").unwrap(),
        Some(JobState::Canceled),
        "a queued job is canceled at once"
    );
    assert_eq!(s.delete_job_record("bk_1").unwrap(), Some(None));
    assert!(s.get_job("bk_1").unwrap().is_none());
    assert!(s.idempotency("k2").unwrap().is_none());
    assert_eq!(s.holders(Held::Job, "bk_1").unwrap(), 0);
    assert_eq!(s.request_cancel("bk_1").unwrap(), None);
}

/// Claims: priority then age, per lane; leases, heartbeats, expiry, attempts, cancellation.
fn claims_and_leases(s: &Store) {
    insert(s, "bk_a", JobKind::Bake, Lane::Cpu, Priority::Bake);
    insert(s, "rn_a", JobKind::Render, Lane::Cpu, Priority::Render);
    insert(s, "rn_b", JobKind::Render, Lane::Cpu, Priority::Small);
    insert(s, "rn_g", JobKind::Render, Lane::Gpu, Priority::Render);
    let id = |r: Option<JobRecord>| r.map(|r| r.id);
    // The small-render worker takes only small renders.
    assert_eq!(
        id(s.claim(Lane::Cpu, Priority::Small, "w1", 60_000).unwrap()).as_deref(),
        Some("rn_b")
    );
    assert!(
        s.claim(Lane::Cpu, Priority::Small, "w1", 60_000)
            .unwrap()
            .is_none()
    );
    assert_eq!(
        id(s.claim(Lane::Cpu, Priority::Bake, "w2", 60_000).unwrap()).as_deref(),
        Some("rn_a"),
        "renders before bakes"
    );
    let bake = s
        .claim(Lane::Cpu, Priority::Bake, "w3", -1)
        .unwrap()
        .unwrap();
    assert_eq!(
        (bake.id.as_str(), bake.state, bake.attempts),
        ("bk_a", JobState::Running, 1)
    );
    assert_eq!(bake.worker.as_deref(), Some("w3"));
    assert!(
        s.claim(Lane::Cpu, Priority::Bake, "w1", 60_000)
            .unwrap()
            .is_none()
    );
    assert_eq!(
        id(s.claim(Lane::Gpu, Priority::Bake, "w1", 60_000).unwrap()).as_deref(),
        Some("rn_g")
    );

    // w3's lease ran out (a negative lease): the job goes back to the queue and another worker
    // takes it; w3's late end is refused.
    let r = s.reap_expired().unwrap();
    assert_eq!(
        (r.requeued.as_slice(), r.failed.len()),
        (["bk_a".to_string()].as_slice(), 0)
    );
    let again = s
        .claim(Lane::Cpu, Priority::Bake, "w4", 60_000)
        .unwrap()
        .unwrap();
    assert_eq!((again.id.as_str(), again.attempts), ("bk_a", 2));
    assert!(
        !s.finish(
            "bk_a",
            "w3",
            JobState::Succeeded,
            1.0,
            &[],
            &serde_json::json!({}),
            None,
            Some(("application/octet-stream", &artifact("bk_a.bin")))
        )
        .unwrap()
    );
    // A live worker's heartbeat keeps its jobs: nothing expires.
    let ids = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert!(
        s.heartbeat("w4", &ids(&["bk_a"]), 60_000)
            .unwrap()
            .is_empty()
    );
    assert_eq!(s.reap_expired().unwrap(), Default::default());
    // A heartbeat with a lease already over lets the reaper take it; after MAX_ATTEMPTS the
    // job fails instead of going round again.
    s.heartbeat("w4", &ids(&["bk_a"]), -1).unwrap();
    assert_eq!(s.reap_expired().unwrap().requeued, ["bk_a"]);
    for n in 3..=MAX_ATTEMPTS {
        let r = s
            .claim(Lane::Cpu, Priority::Bake, "w5", -1)
            .unwrap()
            .unwrap();
        assert_eq!(r.attempts, n);
        let reaped = s.reap_expired().unwrap();
        if n < MAX_ATTEMPTS {
            assert_eq!(reaped.requeued, ["bk_a"]);
        } else {
            assert_eq!(reaped.failed, ["bk_a"]);
        }
    }
    let failed = s.get_job("bk_a").unwrap().unwrap();
    assert_eq!(failed.state, JobState::Failed);
    assert_eq!(
        failed.error_code(),
        Some(caustica::jobs::ErrorCode::WorkerLost)
    );
    assert!(failed.error.unwrap().contains("lease"));
    // Run again on request: attempts start over.
    s.requeue("bk_a").unwrap();
    let r = s
        .claim(Lane::Cpu, Priority::Bake, "w6", 60_000)
        .unwrap()
        .unwrap();
    assert_eq!(r.attempts, 1);

    // Cancellation of a running job reaches its worker through the heartbeat.
    assert_eq!(s.request_cancel("bk_a").unwrap(), Some(JobState::Running));
    assert_eq!(
        s.heartbeat("w6", &ids(&["bk_a"]), 60_000).unwrap(),
        ["bk_a"]
    );
    assert!(
        s.heartbeat("w1", &ids(&["rn_b", "rn_g"]), 60_000)
            .unwrap()
            .is_empty()
    );
    // Interrupted by a shutdown: back to the queue, the attempt not counted; only its worker
    // may do that.
    s.set_queued("bk_a", "w1").unwrap();
    assert_eq!(s.get_job("bk_a").unwrap().unwrap().state, JobState::Running);
    s.set_queued("bk_a", "w6").unwrap();
    let r = s.get_job("bk_a").unwrap().unwrap();
    assert_eq!((r.state, r.attempts, r.worker), (JobState::Queued, 0, None));
    // A job the store says w7 holds but w7 does not run (its claim's answer was lost) is not
    // kept alive by w7's heartbeat: its lease runs out and it is queued again.
    insert(s, "rn_lost", JobKind::Render, Lane::Cpu, Priority::Render);
    let r = s
        .claim(Lane::Cpu, Priority::Bake, "w7", -1)
        .unwrap()
        .unwrap();
    assert_eq!(r.id, "rn_lost");
    s.heartbeat("w7", &ids(&["another"]), 60_000).unwrap();
    assert_eq!(s.reap_expired().unwrap().requeued, ["rn_lost"]);
}

/// Within a priority, the key with the fewest jobs running goes first, then the oldest job.
fn fair_claims(s: &Store) {
    for (id, owner) in [
        ("a1", "alice"),
        ("a2", "alice"),
        ("a3", "alice"),
        ("b1", "bob"),
    ] {
        s.hold(Held::Job, id, owner).unwrap();
        insert(s, id, JobKind::Render, Lane::Cpu, Priority::Render);
    }
    let mut order = vec![];
    while let Some(r) = s.claim(Lane::Cpu, Priority::Bake, "w", 60_000).unwrap() {
        order.push(r.id);
    }
    assert_eq!(
        order,
        ["a1", "b1", "a2", "a3"],
        "bob's one job does not wait for alice's"
    );
}

/// Eight threads claim from one store at once: every job is taken exactly once.
fn concurrent_claims(s: Arc<Store>) {
    let n = 120;
    for i in 0..n {
        let kind = if i % 3 == 0 {
            JobKind::Bake
        } else {
            JobKind::Render
        };
        let prio = match i % 3 {
            0 => Priority::Bake,
            1 => Priority::Render,
            _ => Priority::Small,
        };
        insert(&s, &format!("job_{i:03}"), kind, Lane::Cpu, prio);
    }
    let claimed: Vec<Vec<String>> = std::thread::scope(|sc| {
        let hs: Vec<_> = (0..8)
            .map(|w| {
                let s = &s;
                sc.spawn(move || {
                    let me = format!("w{w}");
                    let mut got = vec![];
                    while let Some(r) = s.claim(Lane::Cpu, Priority::Bake, &me, 60_000).unwrap() {
                        assert_eq!(r.worker.as_deref(), Some(me.as_str()));
                        got.push(r.id);
                    }
                    got
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let all: Vec<&String> = claimed.iter().flatten().collect();
    let unique: HashSet<&&String> = all.iter().collect();
    assert_eq!(all.len(), n, "every job claimed");
    assert_eq!(unique.len(), n, "no job claimed twice");
    assert_eq!(s.count_queued(JobKind::Render).unwrap(), 0);
}

/// Quotas that hold: the count and the hold are one step, so sixteen submissions of one key
/// at once pass a cap of three exactly three times; a job's own hold does not count twice; a
/// hold being submitted (no record yet) counts; a key's list reads its own holds; idempotency
/// records expire.
fn quotas_lists_and_expiry(s: Arc<Store>) {
    assert_eq!(s.hold_job_within("rn_q1", "alice", 2).unwrap(), Ok(()));
    assert_eq!(
        s.hold_job_within("rn_q1", "alice", 2).unwrap(),
        Ok(()),
        "held already"
    );
    assert_eq!(s.hold_job_within("rn_q2", "alice", 2).unwrap(), Ok(()));
    assert_eq!(
        s.hold_job_within("rn_q3", "alice", 2).unwrap(),
        Err(2),
        "two being submitted count"
    );
    insert(&s, "rn_q1", JobKind::Render, Lane::Cpu, Priority::Render);
    s.finish(
        "rn_q1",
        "",
        JobState::Canceled,
        0.0,
        &[],
        &serde_json::json!({}),
        Some("canceled"),
        None,
    )
    .unwrap();
    assert_eq!(
        s.hold_job_within("rn_q3", "alice", 2).unwrap(),
        Ok(()),
        "a finished job does not count"
    );
    let won: usize = std::thread::scope(|sc| {
        let hs: Vec<_> = (0..16)
            .map(|i| {
                let s = &s;
                sc.spawn(move || {
                    s.hold_job_within(&format!("rn_race{i}"), "bob", 3)
                        .unwrap()
                        .is_ok()
                })
            })
            .collect();
        hs.into_iter().map(|h| usize::from(h.join().unwrap())).sum()
    });
    assert_eq!(won, 3, "sixteen submissions at once, a quota of three");
    insert(
        &s,
        "rn_race_job",
        JobKind::Render,
        Lane::Cpu,
        Priority::Render,
    );
    let mut f = filter(JobKind::Render);
    f.owner = Some("nobody".into());
    assert!(s.list_jobs(&f).unwrap().is_empty());
    f.owner = Some("alice".into());
    let ids: Vec<String> = s
        .list_jobs(&f)
        .unwrap()
        .into_iter()
        .map(|r| r.1.id)
        .collect();
    assert_eq!(ids, ["rn_q1"], "alice's holds with a record");
    f.owner = None;
    f.state = Some(JobState::Queued);
    let ids: Vec<String> = s
        .list_jobs(&f)
        .unwrap()
        .into_iter()
        .map(|r| r.1.id)
        .collect();
    assert_eq!(ids, ["rn_race_job"]);

    s.put_idempotency("old", "h", "rn_q1").unwrap();
    let now = caustica::jobs::store::now_ms();
    assert_eq!(s.expire_idempotency(now - 3_600_000).unwrap(), 0);
    assert_eq!(s.expire_idempotency(now + 60_000).unwrap(), 1);
    assert!(s.idempotency("old").unwrap().is_none());
}

/// What other processes hear: a queued job's lane, a job's changes, a cancellation asked of
/// a running job. SQLite has no other processes and says so.
fn notifications(s: &Store) {
    let (tx, rx) = std::sync::mpsc::channel();
    let tx = std::sync::Mutex::new(tx);
    let listening = s
        .listen(Box::new(move |e| {
            let _ = tx.lock().unwrap().send(e);
        }))
        .unwrap();
    if s.backend() == "sqlite" {
        assert!(!listening);
        return;
    }
    assert!(listening);
    let next = || {
        rx.recv_timeout(std::time::Duration::from_secs(30))
            .expect("a notification")
    };
    insert(s, "rn_n", JobKind::Render, Lane::Gpu, Priority::Render);
    let mut heard = vec![next(), next()];
    heard.sort_by_key(|e| format!("{e:?}"));
    assert_eq!(
        heard,
        [
            StoreEvent::Job("rn_n".into()),
            StoreEvent::Queued(Lane::Gpu)
        ]
    );
    s.claim(Lane::Gpu, Priority::Bake, "w1", 60_000)
        .unwrap()
        .unwrap();
    assert_eq!(next(), StoreEvent::Job("rn_n".into()));
    assert_eq!(s.request_cancel("rn_n").unwrap(), Some(JobState::Running));
    assert_eq!(next(), StoreEvent::Cancel("rn_n".into()));
    s.set_progress("rn_n", 0.25, "x").unwrap();
    assert_eq!(next(), StoreEvent::Job("rn_n".into()));
}

fn run_suite(open: &dyn Fn(&str) -> Store) {
    scenes_holds_and_keys(&open("scenes"));
    records(&open("records"));
    claims_and_leases(&open("claims"));
    fair_claims(&open("fair"));
    concurrent_claims(Arc::new(open("concurrent")));
    quotas_lists_and_expiry(Arc::new(open("quotas")));
    notifications(&open("notify"));
}

fn temp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("caustica-store-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn the_sqlite_store_passes_the_suite() {
    let root = temp("sqlite");
    run_suite(&|name| Store::open(&root.join(name)).unwrap());
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn the_postgres_store_passes_the_suite() {
    let pg = PgCluster::start("suite");
    let root = temp("pg");
    run_suite(&|name| Store::open_with(&root.join(name), Some(&pg.url(name)), None).unwrap());
    // Migrations are versioned: opening again (a second process) changes nothing.
    let url = format!("postgres://caustica@127.0.0.1:{}/records", pg.port);
    let again = Store::open_with(&root.join("again"), Some(&url), None).unwrap();
    assert_eq!(
        again.get_job("rn_1").unwrap().unwrap().state,
        JobState::Queued
    );
    let _ = std::fs::remove_dir_all(&root);
}
