//! Method `direct`: direct lighting on the GPU from every light type with shadow maps, glass
//! and mirrors drawn from the environment light. No caustics: the `caustics` component is
//! black. The baseline every caustics method adds to, and the fastest frame.

use super::{
    Env, Frames, Lane, Method, MethodArgs, MethodError, MethodImpl, MethodInfo, ParamError,
    RenderPlan,
};
use crate::render::RenderOptions;
use crate::scene::World;

pub static INFO: MethodInfo = MethodInfo {
    method: Method::Direct,
    name: "direct",
    lane: Lane::Gpu,
    gpu: true,
    bake: false,
    args: &[],
    check: false,
};

pub struct Direct;

impl MethodImpl for Direct {
    fn info(&self) -> &'static MethodInfo {
        &INFO
    }

    fn plan(&self, _: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError> {
        args.check(&INFO)?;
        Ok(Box::new(Plan))
    }
}

struct Plan;

impl RenderPlan for Plan {
    fn method(&self) -> Method {
        Method::Direct
    }

    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        let out = env.with_renderer(|r| Ok(r.render(world, &RenderOptions::default())?))?;
        let timings = out.timings.clone();
        Ok(Frames::from_output(out, timings))
    }
}
