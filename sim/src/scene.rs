//! A scene: stimuli placed in the world, held in a rapier3d collider set with a BVH query
//! pipeline, answering the geometric questions the contact solver and the ground truth ask.
//!
//! # World frame (W)
//! Millimetres, `z` up; the table is the plane `z = 0` and stimuli stand on it. An object's
//! pose is a translation plus a yaw about `+z` (planar stimuli lie flat). Rapier works in f32
//! (about 1e-5 mm at these sizes); results are returned in f64.

use std::sync::Arc;

use rapier3d::parry::query::DefaultQueryDispatcher;
use rapier3d::prelude::{
    BroadPhaseBvh, Collider, ColliderBuilder, ColliderHandle, ColliderSet, IntegrationParameters, QueryFilter,
    QueryPipeline, Ray, RigidBodySet,
};

use crate::columns::{Ahead, ColumnIndex, Nearest, Prefetch};
use crate::error::{Result, SimError};
use crate::stimulus::{EdgePoint, NearContour, Stimulus};

/// Placement of an object in the world (mm, deg).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectPose {
    /// Translation of the object frame's origin (mm).
    pub position_mm: [f64; 3],
    /// Rotation about `+z` (deg, counter-clockwise seen from above).
    pub yaw_deg: f64,
}

impl Default for ObjectPose {
    fn default() -> Self {
        Self { position_mm: [0.0; 3], yaw_deg: 0.0 }
    }
}

impl ObjectPose {
    /// World point of an object-frame point.
    pub fn to_world(&self, p: [f64; 3]) -> [f64; 3] {
        let (s, c) = self.yaw_deg.to_radians().sin_cos();
        [
            self.position_mm[0] + c * p[0] - s * p[1],
            self.position_mm[1] + s * p[0] + c * p[1],
            self.position_mm[2] + p[2],
        ]
    }

    /// Object-frame point of a world point.
    pub fn to_object(&self, p: [f64; 3]) -> [f64; 3] {
        let (s, c) = self.yaw_deg.to_radians().sin_cos();
        let d = [p[0] - self.position_mm[0], p[1] - self.position_mm[1], p[2] - self.position_mm[2]];
        [c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]]
    }

    /// Rotates an in-plane vector from the object to the world frame.
    pub fn rotate_to_world(&self, v: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.yaw_deg.to_radians().sin_cos();
        [c * v[0] - s * v[1], s * v[0] + c * v[1]]
    }
}

/// Index of an object in its scene.
pub type ObjectId = usize;

/// One placed stimulus.
#[derive(Clone, Debug)]
pub struct SceneObject {
    /// The stimulus.
    pub stimulus: Arc<Stimulus>,
    /// Its placement.
    pub pose: ObjectPose,
    handle: ColliderHandle,
    /// Its triangles binned for rays straight down ([`Scene::cast_rays`]).
    columns: Arc<ColumnIndex>,
}

/// Hits of two objects nearer than this (mm) are left to the query pipeline (its order
/// decides between them).
const COLUMN_TIE_MM: f64 = 1e-3;

/// The stimulus surface found under a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceHit {
    /// Height of the surface (mm, world `z`).
    pub height_mm: f64,
    /// The object hit.
    pub object: ObjectId,
    /// Unit surface normal (world).
    pub normal: [f64; 3],
}

/// Stimuli placed in the world.
pub struct Scene {
    bodies: RigidBodySet,
    colliders: ColliderSet,
    broad_phase: BroadPhaseBvh,
    objects: Vec<SceneObject>,
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene").field("objects", &self.objects).finish()
    }
}

impl Default for Scene {
    fn default() -> Self {
        Self::new()
    }
}

impl Scene {
    /// An empty scene.
    pub fn new() -> Self {
        Self {
            bodies: RigidBodySet::new(),
            colliders: ColliderSet::new(),
            broad_phase: BroadPhaseBvh::new(),
            objects: Vec::new(),
        }
    }

    /// Places `stimulus` at `pose`.
    pub fn add(&mut self, stimulus: Arc<Stimulus>, pose: ObjectPose) -> Result<ObjectId> {
        if !(pose.position_mm.iter().all(|v| v.is_finite()) && pose.yaw_deg.is_finite()) {
            return Err(SimError::invalid(stimulus.name(), "pose", format!("must be finite, got {pose:?}")));
        }
        // Vertices go in world coordinates relative to the collider's own translation, so f32
        // keeps full precision near the object.
        let vertices = stimulus.mesh.vertices.iter().map(|v| {
            let w = pose.to_world(*v);
            rapier3d::math::Vector::new(
                (w[0] - pose.position_mm[0]) as f32,
                (w[1] - pose.position_mm[1]) as f32,
                (w[2] - pose.position_mm[2]) as f32,
            )
        });
        let collider = ColliderBuilder::trimesh(vertices.collect(), stimulus.mesh.triangles.clone())
            .map_err(|e| SimError::mesh(stimulus.name(), format!("rapier rejected the mesh: {e:?}")))?
            .translation(rapier3d::math::Vector::new(
                pose.position_mm[0] as f32,
                pose.position_mm[1] as f32,
                pose.position_mm[2] as f32,
            ))
            .friction(stimulus.entry.friction as f32)
            .build();
        let aabb = collider.compute_aabb();
        let columns = Arc::new(ColumnIndex::new(collider.shape().as_trimesh().expect("a trimesh collider")));
        let handle = self.colliders.insert(collider);
        self.broad_phase.set_aabb(&IntegrationParameters::default(), handle, aabb);
        self.objects.push(SceneObject { stimulus, pose, handle, columns });
        Ok(self.objects.len() - 1)
    }

    /// The placed objects.
    pub fn objects(&self) -> &[SceneObject] {
        &self.objects
    }

    fn object_of(&self, handle: ColliderHandle) -> Option<ObjectId> {
        self.objects.iter().position(|o| o.handle == handle)
    }

    /// The highest stimulus surface under world point `(x, y)` (a ray cast straight down), or
    /// `None` where no stimulus is.
    pub fn surface_height(&self, x_mm: f64, y_mm: f64) -> Option<SurfaceHit> {
        const ABOVE_MM: f64 = 1.0e4;
        let pipeline = self.query_pipeline();
        let ray = Ray::new(
            rapier3d::math::Vector::new(x_mm as f32, y_mm as f32, ABOVE_MM as f32),
            rapier3d::math::Vector::new(0.0, 0.0, -1.0),
        );
        let (handle, hit) = pipeline.cast_ray_and_get_normal(&ray, 2.0 * ABOVE_MM as f32, true)?;
        Some(SurfaceHit {
            height_mm: ABOVE_MM - hit.time_of_impact as f64,
            object: self.object_of(handle)?,
            normal: [hit.normal.x as f64, hit.normal.y as f64, hit.normal.z as f64],
        })
    }

    /// Casts rays from `origins` along the common unit direction `dir` (world, mm) and returns,
    /// per ray, the distance to the first stimulus surface within `max_mm` and the object hit.
    /// Rays straight down (an untilted sensor's) test only the triangles over their column
    /// (`ColumnIndex`); others go through the query pipeline's bounding-volume hierarchy,
    /// which only tests stimuli whose bounds the ray reaches. Both give the same hits.
    pub fn cast_rays(&self, origins: &[[f64; 3]], dir: [f64; 3], max_mm: f64) -> Vec<Option<(f64, ObjectId)>> {
        self.cast_rays_down(origins, dir, max_mm).unwrap_or_else(|| self.cast_rays_bvh(origins, dir, max_mm))
    }

    /// [`Self::cast_rays`] by the objects' [`ColumnIndex`]es, where every object sees `dir` as
    /// straight down its mesh (`None` otherwise), over the objects whose boxes span the rays.
    /// A ray whose answer could differ from the pipeline's is cast through it instead: where
    /// an index is unsure, or where two objects' hits are within rounding of each other (the
    /// pipeline's colliders sit in boxes fattened by a skin, which every hit of theirs passes).
    fn cast_rays_down(&self, origins: &[[f64; 3]], dir: [f64; 3], max_mm: f64) -> Option<Vec<Option<(f64, ObjectId)>>> {
        let d = rapier3d::math::Vector::new(dir[0] as f32, dir[1] as f32, dir[2] as f32);
        let down = rapier3d::math::Vector::new(0.0, 0.0, -1.0);
        // Only objects whose box spans some ray's (x, y) can be hit (by a ray straight down).
        let (lo, hi) = origins.iter().fold(([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]), |(lo, hi), o| {
            ([lo[0].min(o[0]), lo[1].min(o[1])], [hi[0].max(o[0]), hi[1].max(o[1])])
        });
        let mut near: Vec<(ObjectId, &Collider)> = Vec::new();
        for (id, o) in self.objects.iter().enumerate() {
            let collider = self.colliders.get(o.handle)?;
            let b = collider.compute_aabb();
            let (mins, maxs) = ([b.mins.x as f64, b.mins.y as f64], [b.maxs.x as f64, b.maxs.y as f64]);
            // With a margin far above f32 rounding.
            if (0..2).all(|k| mins[k] <= hi[k] + COLUMN_TIE_MM && maxs[k] >= lo[k] - COLUMN_TIE_MM) {
                near.push((id, collider));
            }
        }
        // The local ray of each object is the pipeline's: `inverse_transform_by` its pose.
        let probe = Ray::new(rapier3d::math::Vector::ZERO, d);
        if near.iter().any(|(_, c)| probe.inverse_transform_by(c.position()).dir != down) {
            return None;
        }
        let pipeline = self.query_pipeline();
        let max = max_mm as f32;
        let rays: Vec<Ray> = origins
            .iter()
            .map(|o| Ray::new(rapier3d::math::Vector::new(o[0] as f32, o[1] as f32, o[2] as f32), d))
            .collect();
        // Cast in the order of the first object's bins (each ray's answer is its own): the
        // bins' lists and triangles are then read forwards, row after row, where a grid's
        // rows at a slant to the mesh's would jump about them (issue 31: with the bins fetched
        // ahead below, the rays' share of a `paper` shard's samples 9.2-10.0% -> 6.1-7.4%,
        // `docs/experiments/contact.md`, "Rays down the column index").
        // The rays in the first object's frame give the keys and serve its cast.
        // Each ray's key: its bin (`u32::MAX` off the index) above its place, one `u64` to sort
        // in the order of the pairs `(bin, place)`.
        let key = |bin: Option<usize>, k: usize| (bin.map_or(u64::from(u32::MAX), |b| b as u64) << 32) | k as u64;
        let (first, mut order): (Vec<Ray>, Vec<u64>) = match near.first() {
            Some((id, collider)) => {
                let columns = &self.objects[*id].columns;
                let first: Vec<Ray> = rays.iter().map(|ray| ray.inverse_transform_by(collider.position())).collect();
                let order = first
                    .iter()
                    .enumerate()
                    .map(|(k, local)| key(columns.bin_of(local.origin.x as f64, local.origin.y as f64), k))
                    .collect();
                (first, order)
            }
            None => (Vec::new(), (0..rays.len()).map(|k| key(Some(0), k)).collect()),
        };
        order.sort_unstable();
        // The bins a few rays ahead are asked of the cache in stages, each a ray nearer than
        // the last, so that each stage reads what the one before fetched.
        let ahead = near.first().map(|(id, _)| (&self.objects[*id].columns, Prefetch::new()));
        let mut hits = vec![None; rays.len()];
        for (i, &entry) in order.iter().enumerate() {
            if let Some((columns, cache)) = ahead {
                for (stage, distance) in [(Ahead::List, 3), (Ahead::Items, 2), (Ahead::Facets, 1)] {
                    // A bin off the index (`u32::MAX`) is past every index's bins: nothing fetched.
                    if let Some(&next) = order.get(i + distance) {
                        columns.fetch_ahead(cache, stage, (next >> 32) as usize);
                    }
                }
            }
            let k = (entry & u64::from(u32::MAX)) as usize;
            let ray = &rays[k];
            hits[k] =
                self.cast_down(ray, first.get(k), &near, max).unwrap_or_else(|| self.cast_ray_bvh(&pipeline, ray, max));
        }
        Some(hits)
    }

    /// One ray straight down through the objects' [`ColumnIndex`]es; `None` where the
    /// pipeline must answer ([`Self::cast_rays_down`]). `first` is the ray in the first
    /// object's frame where the caller has it.
    fn cast_down(
        &self,
        ray: &Ray,
        first: Option<&Ray>,
        objects: &[(ObjectId, &Collider)],
        max: f32,
    ) -> Option<Option<(f64, ObjectId)>> {
        let mut nearest = Nearest::default();
        for (j, &(id, collider)) in objects.iter().enumerate() {
            let columns = &self.objects[id].columns;
            let local = match first {
                Some(local) if j == 0 => *local,
                _ => ray.inverse_transform_by(collider.position()),
            };
            let Some(toi) = columns.cast_down(&local, max)? else {
                continue;
            };
            nearest.offer(toi, id);
        }
        nearest.unless_tied(COLUMN_TIE_MM).map(|hit| hit.map(|(toi, id)| (toi as f64, id)))
    }

    /// [`Self::cast_rays`] through the query pipeline.
    fn cast_rays_bvh(&self, origins: &[[f64; 3]], dir: [f64; 3], max_mm: f64) -> Vec<Option<(f64, ObjectId)>> {
        let pipeline = self.query_pipeline();
        let d = rapier3d::math::Vector::new(dir[0] as f32, dir[1] as f32, dir[2] as f32);
        origins
            .iter()
            .map(|o| {
                let ray = Ray::new(rapier3d::math::Vector::new(o[0] as f32, o[1] as f32, o[2] as f32), d);
                self.cast_ray_bvh(&pipeline, &ray, max_mm as f32)
            })
            .collect()
    }

    /// The query pipeline over every object.
    fn query_pipeline(&self) -> QueryPipeline<'_> {
        self.broad_phase.as_query_pipeline(
            &DefaultQueryDispatcher,
            &self.bodies,
            &self.colliders,
            QueryFilter::default(),
        )
    }

    /// One ray through the query pipeline: distance (mm) and object of the first hit within
    /// `max` (mm).
    fn cast_ray_bvh(&self, pipeline: &QueryPipeline<'_>, ray: &Ray, max: f32) -> Option<(f64, ObjectId)> {
        let (handle, toi) = pipeline.cast_ray(ray, max, true)?;
        Some((toi as f64, self.object_of(handle)?))
    }

    /// Height of the highest stimulus top in the scene (mm, world `z`), `None` when empty.
    /// Sensor depths are measured from it.
    pub fn top_height_mm(&self) -> Option<f64> {
        self.objects
            .iter()
            .filter_map(|o| self.colliders.get(o.handle).map(|c| c.compute_aabb().maxs.z as f64))
            .reduce(f64::max)
    }

    /// The edges of planar object `object` within `margin_mm` of the world box `[lo, hi]`
    /// (in-plane, mm): [`Scene::edge`] for its points near an edge, in time for the edges near
    /// the box only.
    pub fn edges_near(&self, object: ObjectId, lo_mm: [f64; 2], hi_mm: [f64; 2], margin_mm: f64) -> NearEdges {
        let o = &self.objects[object];
        let corners = [[lo_mm[0], lo_mm[1]], [hi_mm[0], lo_mm[1]], [lo_mm[0], hi_mm[1]], [hi_mm[0], hi_mm[1]]]
            .map(|c| o.pose.to_object([c[0], c[1], 0.0]));
        let lo = [0, 1].map(|k| corners.iter().map(|c| c[k]).fold(f64::INFINITY, f64::min));
        let hi = [0, 1].map(|k| corners.iter().map(|c| c[k]).fold(f64::NEG_INFINITY, f64::max));
        NearEdges { pose: o.pose, near: o.stimulus.contour.near(lo, hi, margin_mm) }
    }

    /// Height of object `id`'s top face (mm, world `z`): the top of its bounding box, where a
    /// planar stimulus's flat top lies.
    pub fn object_top_mm(&self, id: ObjectId) -> Option<f64> {
        self.colliders.get(self.objects.get(id)?.handle).map(|c| c.compute_aabb().maxs.z as f64)
    }

    /// Objects whose bounding boxes reach the axis-aligned box `[min, max]` (world, mm).
    pub fn objects_in_box(&self, min_mm: [f64; 3], max_mm: [f64; 3]) -> Vec<ObjectId> {
        let mut ids: Vec<ObjectId> = self
            .objects
            .iter()
            .enumerate()
            .filter(|(_, o)| {
                let Some(c) = self.colliders.get(o.handle) else { return false };
                let aabb = c.compute_aabb();
                (0..3).all(|k| (aabb.mins[k] as f64) <= max_mm[k] && (aabb.maxs[k] as f64) >= min_mm[k])
            })
            .map(|(i, _)| i)
            .collect();
        ids.sort_unstable();
        ids
    }

    /// Contour loops of a planar object in world coordinates (mm).
    pub fn contour_world(&self, object: ObjectId) -> Vec<Vec<[f64; 2]>> {
        let o = &self.objects[object];
        o.stimulus
            .contour
            .loops
            .iter()
            .map(|l| {
                l.iter()
                    .map(|p| {
                        let w = o.pose.to_world([p[0], p[1], 0.0]);
                        [w[0], w[1]]
                    })
                    .collect()
            })
            .collect()
    }

    /// Nearest edge point of a planar object to world point `(x, y)`: signed distance (mm,
    /// negative over the material), closest point and edge tangent, in world coordinates.
    pub fn edge(&self, object: ObjectId, x_mm: f64, y_mm: f64) -> EdgePoint {
        let o = &self.objects[object];
        let p = o.pose.to_object([x_mm, y_mm, 0.0]);
        edge_to_world(&o.pose, o.stimulus.contour.nearest([p[0], p[1]]))
    }
}

/// The edges of one planar object near a world box ([`Scene::edges_near`]).
#[derive(Clone, Debug)]
pub struct NearEdges {
    pose: ObjectPose,
    near: NearContour,
}

impl NearEdges {
    /// [`Scene::edge`] at world point `(x, y)` of the box, `None` farther from the edge than
    /// the margin.
    pub fn edge(&self, x_mm: f64, y_mm: f64) -> Option<EdgePoint> {
        let p = self.pose.to_object([x_mm, y_mm, 0.0]);
        Some(edge_to_world(&self.pose, self.near.nearest([p[0], p[1]])?))
    }
}

/// An edge point of an object placed at `pose`, from its frame into the world's.
fn edge_to_world(pose: &ObjectPose, e: EdgePoint) -> EdgePoint {
    let w = pose.to_world([e.point[0], e.point[1], 0.0]);
    EdgePoint {
        signed_distance_mm: e.signed_distance_mm,
        point: [w[0], w[1]],
        tangent: pose.rotate_to_world(e.tangent),
    }
}

/// A flat surface (the top of `disk`, at the origin) with friction `friction`.
pub fn flat_scene(disk: &Stimulus, friction: f64) -> Result<Scene> {
    let mut stim = disk.clone();
    stim.entry.friction = friction;
    let mut scene = Scene::new();
    scene.add(Arc::new(stim), ObjectPose::default())?;
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;

    /// The column search ([`crate::columns::ColumnIndex`]) must hit what parry's BVH hits, to
    /// the bit: the gaps, footprints and so every image depend on these distances. Every
    /// built-in stimulus, two of them in one scene shifted and turned, rays straight down at
    /// random points over their bounds, on their vertices and next to them (where triangles
    /// meet and the BVH's traversal order decides between near-equal hits), and along the
    /// lines of a probe grid through the origin.
    #[test]
    fn straight_down_rays_hit_what_parrys_bvh_hits() {
        let catalogue = crate::builtin_catalogue().expect("shapes");
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut uniform = |lo: f64, hi: f64| rng.random_range(lo..hi);
        for name in catalogue.names() {
            let stimulus = catalogue.get(&name).expect("a built-in");
            let mut scene = Scene::new();
            scene.add(stimulus.clone(), ObjectPose::default()).expect("placed");
            scene.add(stimulus.clone(), ObjectPose { position_mm: [40.0, -25.0, 3.0], yaw_deg: 33.0 }).expect("placed");
            let mut origins = Vec::new();
            for object in scene.objects() {
                let (lo, hi) = object.stimulus.mesh.vertices.iter().fold(
                    ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
                    |(lo, hi), v| {
                        let w = object.pose.to_world(*v);
                        ([lo[0].min(w[0]), lo[1].min(w[1])], [hi[0].max(w[0]), hi[1].max(w[1])])
                    },
                );
                for _ in 0..4000 {
                    origins.push([uniform(lo[0] - 1.0, hi[0] + 1.0), uniform(lo[1] - 1.0, hi[1] + 1.0), 120.0]);
                }
                for v in object.stimulus.mesh.vertices.iter().step_by(3) {
                    let w = object.pose.to_world(*v);
                    for d in [0.0, 2e-6, -5e-6, 1.2e-5, -3e-5, 1e-4] {
                        origins.push([w[0] + d, w[1] - d, 120.0]);
                        origins.push([w[0] - d, w[1], 120.0]);
                    }
                }
            }
            for i in -60..=60 {
                for j in -60..=60 {
                    origins.push([i as f64 * 0.5, j as f64 * 0.5, 97.25]);
                }
            }
            let down = [0.0, 0.0, -1.0];
            let columns =
                scene.cast_rays_down(&origins, down, 200.0).expect("every object sees the rays straight down");
            let bvh = scene.cast_rays_bvh(&origins, down, 200.0);
            let hits = bvh.iter().filter(|h| h.is_some()).count();
            assert!(hits > origins.len() / 4, "{name}: the rays should mostly hit ({hits} of {})", origins.len());
            for ((o, c), b) in origins.iter().zip(&columns).zip(&bvh) {
                assert_eq!(c, b, "{name}: the ray down from {o:?}");
            }
            // A reach shorter than the hits: none.
            assert!(scene.cast_rays_down(&origins, down, 50.0).expect("down").iter().all(Option::is_none));
        }
        // Tilted rays take the pipeline.
        let scene = flat_scene(&catalogue.get("disk").expect("disk"), 0.5).expect("scene");
        assert!(scene.cast_rays_down(&[[0.0, 0.0, 50.0]], [0.0, 0.6, -0.8], 100.0).is_none());
    }
}
