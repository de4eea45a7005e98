//! Primitives (a shape with its material and area light) and aggregates of
//! them behind a BVH; object instances place a shared aggregate with a
//! transform (pbrt-v3 `GeometricPrimitive`, `TransformedPrimitive`, `BVHAccel`).

use crate::accel::{any_in_leaf, closest_in_leaf, Bvh};
use crate::interaction::SurfaceInteraction;
use crate::shapes::{triangle4, Shape, TriRay, Triangle};
use farm_common::geometry::{AnimatedTransform, Bounds3f, Ray, Transform};
use glam::Vec3A;
use std::sync::Arc;

/// A shape with what shades it.
#[derive(Clone, Debug)]
pub struct Primitive {
    /// The geometry, in the aggregate's space.
    pub shape: Shape,
    /// Index into the scene's materials; none for `Material "none"`
    /// (surfaces that only bound media, skipped by the Whitted integrator).
    pub material: MaybeIndex,
    /// If the shape emits: an index into the scene's lights, or, with
    /// [`crate::world::GLOW`] set, into [`crate::world::World::glows`]
    /// (an area light inside an object instance). [`crate::world::World::emitted`]
    /// reads either.
    pub area_light: MaybeIndex,
}

// A mesh has one primitive a triangle: its size is most of a mesh's memory.
const _: () = assert!(std::mem::size_of::<Primitive>() == 32);

impl Primitive {
    /// Whether testing a ray against it costs about what a box test does
    /// (a triangle): such primitives may share a BVH leaf, where spheres,
    /// quadrics and curves keep a box each.
    pub fn cheap(&self) -> bool {
        matches!(self.shape, Shape::Triangle { .. })
    }
}

/// An index that may be absent, in four bytes (an `Option<u32>` takes
/// eight): `u32::MAX` stands for none.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaybeIndex(u32);

impl MaybeIndex {
    /// No index.
    pub const NONE: MaybeIndex = MaybeIndex(u32::MAX);

    /// The index, if there is one.
    #[inline(always)]
    pub fn get(self) -> Option<u32> {
        (self.0 != u32::MAX).then_some(self.0)
    }
}

impl From<Option<u32>> for MaybeIndex {
    /// `Some(u32::MAX)` cannot be told from none; no scene has that many
    /// materials or lights (each light takes far more than four bytes).
    fn from(i: Option<u32>) -> Self {
        debug_assert_ne!(i, Some(u32::MAX));
        i.map_or(MaybeIndex::NONE, MaybeIndex)
    }
}

/// Primitives ordered for a BVH over them.
#[derive(Debug)]
pub struct Aggregate {
    prims: Vec<Primitive>,
    bvh: Bvh,
}

/// From this many primitives up, an aggregate's triangles share BVH leaves
/// of up to `maxnodeprims` (see [`Bvh::build_over`]): about a quarter of
/// the nodes. Below it the tree is pbrt-v3's as built, whose box per
/// triangle spares tests of large triangles (13% fewer instructions on
/// cornell-box, 18% on veach-mis). The trade turns where the tree of a box
/// per triangle outgrows the caches. On the kernel bench's torus
/// (`FARM_DUMP_DIR`, its segments varied; ns a ray, a box a triangle →
/// shared leaves, two alternating pairs, bare walk):
/// - 16k and 33k triangles were level (camera rays 149/144 → 147/145 and
///   159/160 → 159/164);
/// - 51k mostly gained (shadow rays 340/336 → 290/311; camera rays
///   163/161 → 149/168);
/// - 66k gained 10–20% and 100k 13–17% (shadow rays 404/407 → 357/370).
///
/// So the turn lies between 33k and 51k here; 2¹⁵ shares from just below
/// it, where sharing cost nothing. The shared scenes render the same bits
/// either way.
pub const SHARED_LEAVES_FROM: usize = 1 << 15;

impl Aggregate {
    /// Builds the BVH, with at most `max_prims` primitives in a leaf, and
    /// stores the primitives in its order.
    pub fn new(prims: Vec<Primitive>, max_prims: usize) -> Self {
        let share = Aggregate::shares_leaf(prims.len());
        let (bvh, prims) = Bvh::build_over(prims, |p| p.shape.bounds(), share, max_prims);
        Aggregate { prims, bvh }
    }

    /// Which of `count` primitives built into one BVH may share its leaves
    /// (the `cheap` test [`Bvh::build_over`] takes): triangles, in
    /// aggregates of at least [`SHARED_LEAVES_FROM`].
    pub fn shares_leaf(count: usize) -> impl Fn(&Primitive) -> bool + Copy {
        let large = count >= SHARED_LEAVES_FROM;
        move |p| large && p.cheap()
    }

    /// Bounds of everything inside.
    pub fn bounds(&self) -> Bounds3f {
        self.bvh.bounds()
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.prims.len()
    }

    /// Whether there are no primitives.
    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// The primitives, in BVH order.
    pub fn primitives(&self) -> &[Primitive] {
        &self.prims
    }

    /// The closest hit along `ray` before its `t_max`: its `t` and the
    /// primitive hit, with the surface point written to `si` (render
    /// space). `si` is written only by hits, each closer than the last, so
    /// a miss leaves it as it was.
    #[inline]
    pub fn intersect(&self, ray: &Ray, si: &mut SurfaceInteraction) -> Option<(f32, &Primitive)> {
        // A triangle's interaction is built for the closest hit only, from
        // its barycentrics; other shapes build theirs as they are hit.
        // The barycentrics as one 16-byte lane group: kept as three floats,
        // they were stored in pieces of 4 and 8 bytes and read back across
        // them, a load no store could forward.
        let mut best: Option<(f32, usize, Option<Vec3A>)> = None;
        let tr = TriRay::new(ray);
        self.bvh.intersect_leaves(
            ray,
            // Inlined into each compiled form of the walk (SSE, AVX).
            #[inline(always)]
            |prims, r| {
                // A leaf of three or four triangles at once, each lane
                // accepted in turn as the loop below would: the same hits.
                if prims.len() >= triangle4::FEWEST {
                    if let Some(q) = triangle4::test(&self.prims[prims.clone()], r, &tr, false) {
                        return q.accept(r, |k| {
                            best = Some((
                                q.t[k],
                                prims.start + k,
                                Some(Vec3A::from(q.barycentrics(k))),
                            ));
                        });
                    }
                }
                closest_in_leaf(
                    prims,
                    r,
                    #[inline(always)]
                    |i: usize, r: &Ray| {
                        let (t, barycentrics) = match &self.prims[i].shape {
                            Shape::Triangle { mesh, v } => {
                                let (t, b) = Triangle { mesh, v: *v }
                                    .hit_barycentrics_prepared(r, &tr, true)?;
                                (t, Some(Vec3A::from(b)))
                            }
                            shape => {
                                let t = shape.intersect_into(r, si)?;
                                (t, None)
                            }
                        };
                        best = Some((t, i, barycentrics));
                        Some(t)
                    },
                )
            },
        );
        let (t, i, barycentrics) = best?;
        let prim = &self.prims[i];
        if let Some(b) = barycentrics {
            // Barycentrics are only ever recorded for a triangle.
            prim.shape.triangle()?.interaction_into(ray, b.to_array(), si);
        }
        si.prim = i as u32;
        Some((t, prim))
    }

    /// [`Aggregate::intersect`] returning the interaction by value (with
    /// `prim` the index of the primitive hit), for callers outside the
    /// render loop.
    pub fn closest(&self, ray: &Ray) -> Option<(f32, SurfaceInteraction)> {
        let mut si = SurfaceInteraction::default();
        let (t, _) = self.intersect(ray, &mut si)?;
        Some((t, si))
    }

    /// Whether anything blocks `ray` before its `t_max`.
    #[inline(always)]
    pub fn intersect_p(&self, ray: &Ray) -> bool {
        let tr = TriRay::new(ray);
        self.bvh.intersect_any_leaves(
            ray,
            #[inline(always)]
            |prims, r| {
                if prims.len() >= triangle4::FEWEST {
                    if let Some(q) = triangle4::test(&self.prims[prims.clone()], r, &tr, true) {
                        return q.mask != 0;
                    }
                }
                any_in_leaf(
                    prims,
                    r,
                    #[inline(always)]
                    |i: usize, r: &Ray| self.prims[i].shape.intersect_p_prepared(r, &tr),
                )
            },
        )
    }
}

/// Where an instance sits: fixed, or moving over the shutter interval.
#[derive(Clone, Debug)]
pub enum Placement {
    /// A fixed transform and its inverse.
    Static(Transform),
    /// Keyframed transforms interpolated at each ray's time.
    Animated(AnimatedTransform),
}

/// A shared aggregate placed in the scene (pbrt-v3 `TransformedPrimitive`).
#[derive(Debug)]
pub struct Instance {
    /// The shared geometry, in its own space.
    pub geometry: Arc<Aggregate>,
    /// Render-from-instance.
    pub placement: Placement,
}

impl Instance {
    /// Render-space bounds over the whole shutter interval.
    pub fn bounds(&self) -> Bounds3f {
        match &self.placement {
            Placement::Static(t) => t.bounds(&self.geometry.bounds()),
            Placement::Animated(a) => a.motion_bounds(&self.geometry.bounds()),
        }
    }

    #[inline]
    fn render_from_instance(&self, time: f32) -> Transform {
        match &self.placement {
            Placement::Static(t) => *t,
            Placement::Animated(a) => a.interpolate(time),
        }
    }

    /// The closest hit, its surface point moved back to render space in
    /// `si` (see [`Aggregate::intersect`]).
    #[inline]
    pub fn intersect(&self, ray: &Ray, si: &mut SurfaceInteraction) -> Option<(f32, &Primitive)> {
        let xf = self.render_from_instance(ray.time);
        let local = xf.inverse().ray(ray);
        let hit = self.geometry.intersect(&local, si)?;
        *si = si.transform(&xf);
        Some(hit)
    }

    /// Whether anything in the instance blocks `ray`.
    #[inline]
    pub fn intersect_p(&self, ray: &Ray) -> bool {
        let xf = self.render_from_instance(ray.time);
        self.geometry.intersect_p(&xf.inverse().ray(ray))
    }
}
