//! Bake jobs: the method's bake of one object ([`crate::methods::MethodImpl::plan_bake`]),
//! checked at submission, run on the CPU pool. Bakes are deterministic, so re-running one after
//! a restart gives the same artifact: for `csl` and `transport` the bytes of `caustica bake`,
//! for `reference` a multi-layer EXR of every component. `csl` and `transport` artifacts are
//! also kept in the data directory's artifact store, where renders find them.

use super::job::{Artifact, Job, JobError, JobKind};
use super::worker::JobCtx;
use crate::methods::{BakePlan, BakeRequest, Lane, Method};
use crate::scene::{Limits, World};
use std::sync::Arc;

pub struct BakeJob {
    method: Method,
    plan: Box<dyn BakePlan>,
}

impl BakeJob {
    /// Checks the bake of `object` with the canonical `params` of `method`.
    pub fn new(
        world: Arc<World>,
        method: Method,
        object: Option<&str>,
        params: &serde_json::Value,
        limits: &Limits,
    ) -> Result<Self, JobError> {
        let plan = method.imp().plan_bake(BakeRequest {
            world,
            object,
            params,
            limits,
        })?;
        Ok(BakeJob { method, plan })
    }
}

impl Job for BakeJob {
    fn kind(&self) -> JobKind {
        JobKind::Bake
    }

    fn method(&self) -> Method {
        self.method
    }

    fn lane(&self) -> Lane {
        Lane::Cpu
    }

    fn memory(&self) -> u64 {
        self.plan.memory()
    }

    fn run(&self, ctx: &JobCtx<'_>) -> Result<Artifact, JobError> {
        let b = ctx
            .with_env(|env| self.plan.run(env))
            .map_err(|e| ctx.method_error(e))?;
        Ok(Artifact {
            content_type: b.content_type,
            ext: b.ext,
            bytes: b.bytes,
            timings: b.timings,
            info: b.info,
        })
    }
}
