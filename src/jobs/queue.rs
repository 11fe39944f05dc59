//! The bounded priority queues, one per [`Lane`]: small renders, then other renders, then
//! bakes. Renders and bakes are bounded separately, so a flood of bakes never makes renders
//! wait for room.
//!
//! Within a priority, keys share the workers fairly (start-time fair queueing, every job
//! weighing the same; Goyal, Vin, Cheng 1996): a job is tagged when queued with one more than
//! the later of its class's virtual time (the tag of the job last started) and its key's last
//! tag in that class, and the lowest tag runs first (oldest first among equal tags). So a key
//! that queues a hundred renders gets every other start, not the next hundred, once a second
//! key queues one; a key alone is served oldest first as before.
//!
//! A worker takes by a [`Take`]: a range of priorities (the small workers only small renders,
//! the bake worker only bakes), a cap on the jobs one key runs at once in the lane (the GPU
//! lane: one, so that one key's long render leaves the other GPU workers to the other keys),
//! and an age past which a waiting bake goes ahead of renders (so bakes are not starved by a
//! steady flow of renders).
//! The [`super::JobSystem`] holds them behind a mutex and wakes workers with a condvar.

use super::JobHandle;
use super::job::{Job, JobKind, Priority};
use crate::methods::Lane;
use std::collections::{BinaryHeap, HashMap};
use std::sync::Arc;
use std::time::Duration;

/// What a worker takes from the queues.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Take {
    pub lane: Lane,
    /// Jobs of priority at least this (`Priority::Small`: any) …
    pub from: Priority,
    /// … and at most this (`Priority::Bake`: any).
    pub up_to: Priority,
    /// A key runs at most this many jobs of the lane at once, small renders aside; its next
    /// one waits, even with a worker free, while they run.
    pub per_key: Option<usize>,
    /// A bake that has waited this long goes ahead of renders.
    pub bake_after: Option<Duration>,
}

impl Take {
    /// Any job of `lane` up to `up_to`, by priority alone.
    pub fn by_priority(lane: Lane, up_to: Priority) -> Take {
        Take {
            lane,
            from: Priority::Small,
            up_to,
            per_key: None,
            bake_after: None,
        }
    }
}

/// A queued job waiting for a worker.
pub(crate) struct Queued {
    pub priority: Priority,
    /// The key it runs for (the first to ask for it; '' anonymous).
    pub owner: String,
    /// Its fair-queueing tag, set by [`Queues::push`].
    pub tag: u64,
    /// Submission order.
    pub seq: u64,
    pub job: Box<dyn Job>,
    pub handle: Arc<JobHandle>,
    /// Its share of the job memory budget, given back when the job is dropped (run or not).
    pub memory: super::MemoryHold,
    /// Claimed from a shared store (already running under this process's lease): how long
    /// it waited there, from its record (submission to claim, by the two processes' clocks).
    pub claimed: Option<std::time::Duration>,
    /// Taken under a per-key cap: counted among its key's running jobs until
    /// [`Queues::finished`].
    pub counted: bool,
}

impl PartialEq for Queued {
    fn eq(&self, o: &Self) -> bool {
        (self.priority, self.tag, self.seq) == (o.priority, o.tag, o.seq)
    }
}
impl Eq for Queued {}
impl PartialOrd for Queued {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Queued {
    /// BinaryHeap pops the greatest: invert so the lowest (priority, tag, seq) comes first.
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        (o.priority, o.tag, o.seq).cmp(&(self.priority, self.tag, self.seq))
    }
}

#[derive(Default)]
pub(crate) struct Queues {
    cpu: BinaryHeap<Queued>,
    gpu: BinaryHeap<Queued>,
    /// Per (lane, priority): the tag of the job last started there.
    vtime: HashMap<(Lane, Priority), u64>,
    /// Per (key, lane, priority): the tag of the key's last job queued there.
    last: HashMap<(String, Lane, Priority), u64>,
    /// Per (key, lane): its running jobs taken under a per-key cap.
    running: HashMap<(String, Lane), usize>,
    /// No more jobs are taken; workers exit when they see it.
    pub closed: bool,
}

impl Queues {
    pub fn len(&self) -> usize {
        self.cpu.len() + self.gpu.len()
    }

    /// Jobs of `kind` waiting, in both lanes.
    pub fn count(&self, kind: JobKind) -> usize {
        let bake = |q: &&Queued| q.priority == Priority::Bake;
        let bakes = self.cpu.iter().filter(bake).count() + self.gpu.iter().filter(bake).count();
        match kind {
            JobKind::Bake => bakes,
            JobKind::Render => self.len() - bakes,
        }
    }

    /// Jobs waiting, per lane (cpu, gpu).
    pub fn depth(&self) -> (usize, usize) {
        (self.cpu.len(), self.gpu.len())
    }

    fn lane(&mut self, lane: Lane) -> &mut BinaryHeap<Queued> {
        match lane {
            Lane::Cpu => &mut self.cpu,
            Lane::Gpu => &mut self.gpu,
        }
    }

    /// Queues `q`, tagged after its key's jobs already queued in its class.
    pub fn push(&mut self, mut q: Queued) {
        let lane = q.job.lane();
        let v = self.vtime.get(&(lane, q.priority)).copied().unwrap_or(0);
        let last = self
            .last
            .entry((q.owner.clone(), lane, q.priority))
            .or_insert(0);
        q.tag = (*last).max(v) + 1;
        *last = q.tag;
        self.lane(lane).push(q);
    }

    /// The next job of `lane` (highest priority, then lowest tag, then oldest) whose priority
    /// is at most `up_to` (`Priority::Bake`: any job).
    #[cfg(test)]
    pub fn pop(&mut self, lane: Lane, up_to: Priority) -> Option<Queued> {
        self.take(&Take::by_priority(lane, up_to))
    }

    /// The next job by `t`: of its lane and priorities, its key under the cap, a bake waiting
    /// past `bake_after` first, then highest priority, lowest tag, oldest. Scans the lane
    /// (bounded by the queue caps, a few hundred jobs).
    pub fn take(&mut self, t: &Take) -> Option<Queued> {
        let heap = match t.lane {
            Lane::Cpu => &mut self.cpu,
            Lane::Gpu => &mut self.gpu,
        };
        if heap.is_empty() {
            return None;
        }
        let running = &self.running;
        let capped = |q: &Queued| {
            t.per_key.is_some_and(|cap| {
                q.priority != Priority::Small
                    && running
                        .get(&(q.owner.clone(), t.lane))
                        .is_some_and(|n| *n >= cap)
            })
        };
        let aged = |q: &Queued| {
            q.priority == Priority::Bake
                && t.bake_after
                    .is_some_and(|d| q.handle.enqueued.elapsed() >= d)
        };
        let mut items = std::mem::take(heap).into_vec();
        let best = items
            .iter()
            .enumerate()
            .filter(|(_, q)| (t.from..=t.up_to).contains(&q.priority) && !capped(q))
            .min_by_key(|(_, q)| (!aged(q), q.priority, q.tag, q.seq))
            .map(|(i, _)| i);
        let q = best.map(|i| items.swap_remove(i));
        *heap = BinaryHeap::from(items);
        let mut q = q?;
        if t.per_key.is_some() && q.priority != Priority::Small {
            *self.running.entry((q.owner.clone(), t.lane)).or_insert(0) += 1;
            q.counted = true;
        }
        let v = self.vtime.entry((t.lane, q.priority)).or_insert(0);
        *v = (*v).max(q.tag);
        // Keys whose last tag the class has passed start afresh there: forget them, so that
        // the map holds only keys with jobs at or ahead of the class's time.
        let (vt, p, lane) = (*v, q.priority, t.lane);
        if self.last.len() > 64 {
            self.last
                .retain(|(_, l, pr), t| (*l, *pr) != (lane, p) || *t > vt);
        }
        Some(q)
    }

    /// A job taken under a per-key cap ([`Queued::counted`]) of `owner` in `lane` ended.
    pub fn finished(&mut self, owner: &str, lane: Lane) {
        let k = (owner.to_string(), lane);
        if let Some(n) = self.running.get_mut(&k) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                self.running.remove(&k);
            }
        }
    }

    /// Drops the job `id`; whether it was queued. Its key's last tag in its class goes back to
    /// that of the key's latest job still queued there, so that a key that cancels a backlog
    /// is not left waiting behind it.
    pub fn remove(&mut self, id: &str) -> bool {
        let mut gone = None;
        for heap in [&mut self.cpu, &mut self.gpu] {
            heap.retain(|q| {
                let keep = q.handle.id != id;
                if !keep {
                    gone = Some((q.owner.clone(), q.job.lane(), q.priority));
                }
                keep
            });
        }
        let Some(class) = gone else {
            return false;
        };
        let (owner, lane, priority) = &class;
        let latest = self
            .lane(*lane)
            .iter()
            .filter(|q| (&q.owner, q.priority) == (owner, *priority))
            .map(|q| q.tag)
            .max();
        match latest {
            Some(t) => {
                self.last.insert(class, t);
            }
            None => {
                self.last.remove(&class);
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::job::{Artifact, JobError};
    use crate::jobs::worker::JobCtx;
    use crate::jobs::{JobHandle, MemoryHold};
    use crate::methods::Method;
    use std::sync::Mutex;

    struct Stub(Lane, Priority);
    impl Job for Stub {
        fn kind(&self) -> JobKind {
            match self.1 {
                Priority::Bake => JobKind::Bake,
                _ => JobKind::Render,
            }
        }
        fn method(&self) -> Method {
            Method::Direct
        }
        fn lane(&self) -> Lane {
            self.0
        }
        fn priority(&self) -> Priority {
            self.1
        }
        fn run(&self, _: &JobCtx<'_>) -> Result<Artifact, JobError> {
            unreachable!("queue tests do not run jobs")
        }
    }

    fn job(owner: &str, id: &str, priority: Priority, seq: u64) -> Queued {
        Queued {
            priority,
            owner: owner.into(),
            tag: 0,
            seq,
            job: Box::new(Stub(Lane::Cpu, priority)),
            handle: JobHandle::new(id.into()),
            claimed: None,
            counted: false,
            memory: MemoryHold {
                bytes: 0,
                pool: Arc::new(Mutex::new(0)),
            },
        }
    }

    fn drain(q: &mut Queues) -> Vec<String> {
        std::iter::from_fn(|| q.pop(Lane::Cpu, Priority::Bake))
            .map(|j| j.handle.id.clone())
            .collect()
    }

    #[test]
    fn keys_take_turns_within_a_priority() {
        let mut q = Queues::default();
        let mut seq = 0..;
        for i in 0..4 {
            q.push(job(
                "a",
                &format!("a{i}"),
                Priority::Render,
                seq.next().unwrap(),
            ));
        }
        // a0 starts; then b queues two and c one, after all of a's.
        assert_eq!(q.pop(Lane::Cpu, Priority::Bake).unwrap().handle.id, "a0");
        for (o, i) in [("b", "b0"), ("b", "b1"), ("c", "c0")] {
            q.push(job(o, i, Priority::Render, seq.next().unwrap()));
        }
        // A small render still goes first, and a bake last, whoever queued it.
        q.push(job("a", "bake", Priority::Bake, seq.next().unwrap()));
        q.push(job("a", "small", Priority::Small, seq.next().unwrap()));
        assert_eq!(
            drain(&mut q),
            ["small", "a1", "b0", "c0", "a2", "b1", "a3", "bake"]
        );
        // A key alone is served oldest first, and a key that comes back after the others
        // ran gets no credit for the time it was away.
        for i in 0..3 {
            q.push(job(
                "a",
                &format!("x{i}"),
                Priority::Render,
                seq.next().unwrap(),
            ));
        }
        assert_eq!(q.pop(Lane::Cpu, Priority::Bake).unwrap().handle.id, "x0");
        q.push(job("d", "d0", Priority::Render, seq.next().unwrap()));
        q.push(job("d", "d1", Priority::Render, seq.next().unwrap()));
        assert_eq!(drain(&mut q), ["x1", "d0", "x2", "d1"]);
        // A key that cancels its backlog is not tagged after it.
        for i in 0..5 {
            q.push(job(
                "e",
                &format!("e{i}"),
                Priority::Render,
                seq.next().unwrap(),
            ));
        }
        for i in 0..5 {
            assert!(q.remove(&format!("e{i}")));
        }
        assert!(!q.remove("e0"));
        q.push(job("f", "f0", Priority::Render, seq.next().unwrap()));
        q.push(job("f", "f1", Priority::Render, seq.next().unwrap()));
        q.push(job("e", "e5", Priority::Render, seq.next().unwrap()));
        assert_eq!(drain(&mut q), ["f0", "e5", "f1"]);
    }

    #[test]
    fn a_key_runs_at_most_its_cap_and_a_bake_that_waited_goes_first() {
        let mut q = Queues::default();
        let t = Take {
            per_key: Some(1),
            ..Take::by_priority(Lane::Cpu, Priority::Bake)
        };
        let mut seq = 0..;
        for (o, i, p) in [
            ("a", "a0", Priority::Render),
            ("a", "a1", Priority::Render),
            ("a", "a-small", Priority::Small),
            ("b", "b0", Priority::Render),
        ] {
            q.push(job(o, i, p, seq.next().unwrap()));
        }
        let take = |q: &mut Queues| q.take(&t).map(|j| (j.handle.id.clone(), j.counted));
        // A small render is not counted against its key's cap.
        assert_eq!(take(&mut q), Some(("a-small".into(), false)));
        assert_eq!(take(&mut q), Some(("a0".into(), true)));
        // a runs a0: its a1 waits and b's job goes ahead of it, then nothing can start.
        assert_eq!(take(&mut q), Some(("b0".into(), true)));
        assert_eq!(take(&mut q), None);
        assert_eq!(q.len(), 1, "a1 is still queued");
        q.finished("a", Lane::Cpu);
        assert_eq!(take(&mut q), Some(("a1".into(), true)));
        // Without a cap a key's jobs are not counted.
        q.push(job("a", "a2", Priority::Render, seq.next().unwrap()));
        let a2 = q.pop(Lane::Cpu, Priority::Bake).unwrap();
        assert_eq!((a2.handle.id.as_str(), a2.counted), ("a2", false));

        // A bake goes after renders, unless it waited past `bake_after`.
        q.push(job("c", "bake", Priority::Bake, seq.next().unwrap()));
        q.push(job("c", "render", Priority::Render, seq.next().unwrap()));
        let aged = Take {
            bake_after: Some(Duration::ZERO),
            ..Take::by_priority(Lane::Cpu, Priority::Bake)
        };
        assert_eq!(q.take(&aged).unwrap().handle.id, "bake");
        q.push(job("c", "bake2", Priority::Bake, seq.next().unwrap()));
        let patient = Take {
            bake_after: Some(Duration::from_secs(3600)),
            ..aged
        };
        assert_eq!(q.take(&patient).unwrap().handle.id, "render");
        // A worker that takes renders only never takes a bake, however long it waited; one
        // that takes bakes only, no render.
        let renders = Take {
            up_to: Priority::Render,
            ..aged
        };
        assert!(q.take(&renders).is_none());
        q.push(job("c", "render2", Priority::Render, seq.next().unwrap()));
        let bakes = Take {
            from: Priority::Bake,
            ..patient
        };
        assert_eq!(q.take(&bakes).unwrap().handle.id, "bake2");
        assert!(q.take(&bakes).is_none());
        assert_eq!(q.take(&renders).unwrap().handle.id, "render2");
    }
}
