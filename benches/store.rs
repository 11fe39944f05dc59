//! The SQLite job store at scale: `CAUSTICA_BENCH_ROWS` job records (100,000 by default; all
//! finished but the last 100, as the queue caps keep it), each held by one of 100 keys, then
//! the queries a request makes: a page of a key's list (a key with 1% of the jobs, and one with
//! none), a page of everything (an admin's list), a submission's quota check and hold, the
//! bytes a key holds (its storage quota: walks the key's holds), an insert (its sequence
//! number), and a key's page while another thread lists without pause (the read-only
//! connections). The lists, the hold and the insert should cost about the same at 1,000 rows
//! and at 1,000,000: they read the rows they need through an index.
//!
//! `cargo bench --profile dev --bench store` (add `CAUSTICA_BENCH_ROWS=1000000` for the large
//! table; filling it takes a while).

use caustica::jobs::store::{Held, JobFilter, JobRecord, Store};
use caustica::jobs::{JobKind, JobSpec, JobState, Priority};
use caustica::methods::{Lane, Method};
use criterion::{Criterion, criterion_group, criterion_main};

const OWNERS: usize = 100;

fn record(i: usize) -> JobRecord {
    let spec = JobSpec {
        kind: JobKind::Render,
        method: Method::Reference,
        scene_id: "sc".into(),
        object: None,
        params: serde_json::json!({ "seed": i }),
    };
    JobRecord::new(&format!("rn_{i:032x}"), &spec, Lane::Cpu, Priority::Render)
}

fn filter(owner: Option<&str>) -> JobFilter {
    JobFilter {
        kind: JobKind::Render,
        owner: owner.map(str::to_string),
        state: None,
        method: None,
        created_since: None,
        before_seq: None,
        limit: 20,
    }
}

fn bench(c: &mut Criterion) {
    let rows: usize = std::env::var("CAUSTICA_BENCH_ROWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000);
    let dir = std::env::temp_dir().join(format!("caustica-bench-store-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let store = Store::open(&dir).unwrap();
    let t = std::time::Instant::now();
    for i in 0..rows {
        let mut r = record(i);
        if i + 100 < rows {
            r.state = JobState::Succeeded;
        }
        store.insert_job(&r).unwrap();
        store
            .hold(Held::Job, &r.id, &format!("key{}", i % OWNERS))
            .unwrap();
    }
    eprintln!("{rows} jobs stored in {:.1} s", t.elapsed().as_secs_f64());
    let mut g = c.benchmark_group(format!("sqlite store, {rows} jobs"));
    g.bench_function("list a page, key with no jobs", |b| {
        b.iter(|| store.list_jobs(&filter(Some("nobody"))).unwrap())
    });
    g.bench_function("list a page, key with its share", |b| {
        b.iter(|| store.list_jobs(&filter(Some("key7"))).unwrap())
    });
    g.bench_function("list a page, everything", |b| {
        b.iter(|| store.list_jobs(&filter(None)).unwrap())
    });
    g.bench_function("quota check and hold, then release", |b| {
        b.iter(|| {
            let held = store.hold_job_within("rn_new", "key7", usize::MAX).unwrap();
            store.release(Held::Job, "rn_new", "key7").unwrap();
            held
        })
    });
    g.bench_function("bytes a key with its share holds", |b| {
        b.iter(|| store.held_bytes("key7").unwrap())
    });
    let stop = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        s.spawn(|| {
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                store.list_jobs(&filter(Some("key3"))).unwrap();
            }
        });
        g.bench_function(
            "list a page, key with its share, another key listing",
            |b| b.iter(|| store.list_jobs(&filter(Some("key7"))).unwrap()),
        );
        stop.store(true, std::sync::atomic::Ordering::Relaxed);
    });
    let mut n = rows;
    g.bench_function("insert a job", |b| {
        b.iter(|| {
            n += 1;
            store.insert_job(&record(n)).unwrap()
        })
    });
    g.finish();
    drop(store);
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
