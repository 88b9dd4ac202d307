//! A material whose closure inputs vary over the surface: at a hit the program runs once
//! from the hit's [`ShadingPoint`], the closure template is instantiated with the
//! registers, and that hit's BSDF is built exactly as a fixed material of those values
//! would be (pbrt-v4's material → BSDF at the hit). The BSDF is kept per thread for the
//! hit, so next-event estimation, sampling and MIS at one vertex build it once.

use super::closure::{Orient, Template};
use super::program::{Program, ShadingPoint};
use crate::material::{Black, Bsdf, BsdfFlags, BsdfSample, ShadingContext};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3, Vec3A};
use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};

/// Builds the BSDF of a fixed description (the scene's builder, shared with fixed materials).
pub type BuildFn = dyn Fn(&crate::scene::BsdfDesc) -> crate::Result<Box<dyn Bsdf>> + Send + Sync;

pub struct GraphBsdf {
    pub program: Program,
    pub template: Template,
    build: Box<BuildFn>,
    flags: BsdfFlags,
    /// Its closures carry their own normals (a linked Normal somewhere): each lobe is
    /// oriented at the hit in the vertex's frame (`closure::Orient`).
    orient: bool,
    /// Distinguishes materials in the per-thread cache.
    id: u64,
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

struct Cached {
    material: u64,
    key: [u32; 7],
    regs: Vec<Vec3>,
    bsdf: Option<Box<dyn Bsdf>>,
}

thread_local! {
    static CACHE: RefCell<Cached> = const { RefCell::new(Cached { material: 0, key: [0; 7], regs: Vec::new(), bsdf: None }) };
}

/// The identity of a hit: where it is and where it is seen from.
fn hit_key(sp: &ShadingPoint) -> [u32; 7] {
    let p = sp.position;
    let i = sp.incoming;
    [
        p.x.to_bits(),
        p.y.to_bits(),
        p.z.to_bits(),
        i.x.to_bits(),
        i.y.to_bits(),
        i.z.to_bits(),
        sp.object_index.to_bits(),
    ]
}

impl GraphBsdf {
    /// `build` turns an instantiated description into a BSDF; the flags are those of
    /// the material at a default hit, plus a delta lobe where a roughness may reach 0.
    pub fn new(program: Program, template: Template, build: Box<BuildFn>, orient: bool) -> crate::Result<Self> {
        let mut regs = Vec::new();
        program.run(&ShadingPoint::default(), &mut regs);
        let mut flags = build(&template.instantiate(&|r| regs[r as usize], None))?.flags();
        flags.smooth = true;
        flags.specular |= template.may_be_specular();
        Ok(Self { program, template, build, flags, orient, id: NEXT_ID.fetch_add(1, Ordering::Relaxed) })
    }

    /// The BSDF at the context's hit.
    fn with<R>(&self, ctx: &ShadingContext, f: impl FnOnce(&dyn Bsdf) -> R) -> R {
        CACHE.with(|c| {
            let mut c = c.borrow_mut();
            let key = hit_key(&ctx.hit);
            if c.material != self.id || c.key != key || c.bsdf.is_none() {
                let Cached { regs, .. } = &mut *c;
                self.program.run(&ctx.hit, regs);
                let orient = self.orient.then(|| Orient::at(&ctx.hit, ctx.frame));
                let desc = self.template.instantiate(&|r| regs[r as usize], orient.as_ref());
                let bsdf = (self.build)(&desc).unwrap_or_else(|_| Box::new(Black));
                c.bsdf = Some(bsdf);
                c.material = self.id;
                c.key = key;
            }
            f(c.bsdf.as_deref().expect("just built"))
        })
    }
}

impl Bsdf for GraphBsdf {
    fn flags(&self) -> BsdfFlags {
        self.flags
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        self.with(ctx, |b| b.eval(ctx, wo, wi, out))
    }
    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        self.with(ctx, |b| b.pdf(ctx, wo, wi))
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        self.with(ctx, |b| b.sample(ctx, wo, u, uc, throughput))
    }
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        self.with(ctx, |b| b.albedo(ctx, out))
    }
    fn specular_weights(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        wi: Vec3A,
        throughput: &SampledSpectrum,
        out: &mut SampledSpectrum,
    ) -> bool {
        self.with(ctx, |b| b.specular_weights(ctx, wo, wi, throughput, out))
    }
}
