//! The bounded priority queues, one per [`Lane`]: small renders, then other renders, then
//! bakes; oldest first within each. Renders and bakes are bounded separately, so a flood of
//! bakes never makes renders wait for room.
//! The [`super::JobSystem`] holds them behind a mutex and wakes workers with a condvar.

use super::JobHandle;
use super::job::{Job, JobKind, Priority};
use crate::methods::Lane;
use std::collections::BinaryHeap;
use std::sync::Arc;

/// A queued job waiting for a worker.
pub(crate) struct Queued {
    pub priority: Priority,
    /// Submission order.
    pub seq: u64,
    pub job: Box<dyn Job>,
    pub handle: Arc<JobHandle>,
    /// Its share of the job memory budget, given back when the job is dropped (run or not).
    pub memory: super::MemoryHold,
}

impl PartialEq for Queued {
    fn eq(&self, o: &Self) -> bool {
        (self.priority, self.seq) == (o.priority, o.seq)
    }
}
impl Eq for Queued {}
impl PartialOrd for Queued {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Queued {
    /// BinaryHeap pops the greatest: invert so the lowest (priority, seq) comes first.
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        (o.priority, o.seq).cmp(&(self.priority, self.seq))
    }
}

#[derive(Default)]
pub(crate) struct Queues {
    cpu: BinaryHeap<Queued>,
    gpu: BinaryHeap<Queued>,
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

    pub fn push(&mut self, q: Queued) {
        self.lane(q.job.lane()).push(q);
    }

    /// The next job of `lane` (highest priority, then oldest) whose priority is at most
    /// `up_to` (`Priority::Bake`: any job).
    pub fn pop(&mut self, lane: Lane, up_to: Priority) -> Option<Queued> {
        let heap = self.lane(lane);
        let take = heap.peek().is_some_and(|q| q.priority <= up_to);
        if take { heap.pop() } else { None }
    }

    /// Drops the job `id`; whether it was queued.
    pub fn remove(&mut self, id: &str) -> bool {
        let before = self.len();
        self.cpu.retain(|q| q.handle.id != id);
        self.gpu.retain(|q| q.handle.id != id);
        before != self.len()
    }
}
