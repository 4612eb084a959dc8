//! The scene: the immutable runtime scene (triangles in BVH order,
//! materials, lights, media, camera) that rendering reads. How it is
//! rendered (integrator, film) is not part of it: `crate::load` returns
//! those apart, so one scene renders under any settings.

mod batches;
mod geometry;
pub mod mesh;

use std::sync::Arc;

use glam::{Vec2, Vec3, Vec4};

pub use geometry::SceneGeometry;
use geometry::{TriangleShading, HAS_NORMALS, HAS_TANGENTS, HAS_UVS, NO_LIGHT};
pub use mesh::Mesh;

use crate::camera::Camera;
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::sphere::{Sphere, SphereHit};
use crate::geometry::{gamma, triangle, Aabb, Bvh, Ray};
use crate::light::LightSource;
use crate::light::{Light, LightSet, SceneSphere};
use crate::material::{Cutout, Material};
use crate::medium::Medium;
use crate::spectrum::{cie, Spectrum, WavelengthDistribution};
use crate::texture::TextureRef;

/// Light emitted by a shape.
#[derive(Clone, Debug)]
pub struct Emission {
    pub spectrum: Spectrum,
    /// Multiplies `spectrum` over the surface (glTF emissiveTexture).
    pub texture: Option<TextureRef>,
    pub two_sided: bool,
}

/// A resolved shape: world-space mesh, material, and emission if any.
pub struct ShapeInstance {
    pub mesh: Mesh,
    pub material: u32,
    pub emission: Option<Emission>,
    /// The scene's shape whose `emission` this is (None: an asset's own
    /// emission, or none), so that an edit of it can replace the lights.
    pub emission_of: Option<u32>,
}

/// A resolved exact sphere: world-space, with its material, emission, and
/// which face is the front.
pub struct SphereInstance {
    pub sphere: Sphere,
    pub material: u32,
    pub emission: Option<Emission>,
    /// As `ShapeInstance::emission_of`.
    pub emission_of: Option<u32>,
    /// The front face (normal, emission) is the inside.
    pub inward: bool,
}

/// A ray's closest surface hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub t: f32,
    pub p: Vec3,
    /// Bound on the absolute error of `p`, for robust ray offsets.
    pub p_err: Vec3,
    /// Unit geometric normal, front face by counter-clockwise winding.
    pub ng: Vec3,
    /// Unit shading normal (interpolated vertex normals, or `ng`).
    pub ns: Vec3,
    /// Texture coordinates (zero without them).
    pub uv: Vec2,
    /// Interpolated tangent with the bitangent sign in w (zero without).
    pub tangent: Vec4,
    pub material: u32,
    pub light: Option<usize>,
}

pub struct Scene {
    /// Tells scenes apart (unique in the process): what an integrator
    /// caches about a scene is keyed by it.
    id: u64,
    pub camera: Camera,
    pub materials: Vec<Material>,
    pub lights: LightSet,
    /// The density paths draw their wavelengths from.
    pub wavelengths: WavelengthDistribution,
    /// The bounding sphere of the geometry, as lights at infinity see it.
    pub sphere: SceneSphere,
    /// Triangles, spheres and their hierarchies: shared by scenes that
    /// differ only in camera, materials or lights (`Scene::assemble`).
    geometry: Arc<SceneGeometry>,
    /// Some material bounds a volume (paths then track the IOR stack).
    has_dielectrics: bool,
    /// The medium around everything (the stack empty), if any.
    pub world_medium: Option<Medium>,
    /// Some volume, or the world, holds a participating medium.
    has_media: bool,
    /// Some medium scatters (paths then sample free flights).
    has_scattering: bool,
    /// Per material, where its surfaces are absent; empty when no
    /// material has cut-outs (intersection then skips the test).
    cutouts: Vec<Option<Arc<Cutout>>>,
    /// Per material, whether its surfaces are single-sided (glTF's
    /// `doubleSided = false`): the camera does not see their back faces.
    /// Empty when every material is two-sided.
    single_sided: Vec<bool>,
    /// Triangles dropped at build because they had no area.
    pub degenerate_triangles: usize,
    /// Bytes held by decoded images (textures, environment maps).
    pub image_bytes: u64,
}

/// The wavelengths paths draw: a mixture of the visible density (so every
/// visible wavelength stays likely) and one that follows the lights'
/// emission times the colour response (the length of the vector of linear
/// sRGB colour-matching functions), where most of the image's signal is.
/// Emission enters as its square root: what reaches the film is the
/// emission filtered by unknown reflectances, so a density that follows it
/// all the way would starve wavelengths the scene's surfaces favour. The
/// film's settings (observer, colour space, white balance) are left out on
/// purpose: renders that differ only in them draw the same wavelengths, so
/// one is exactly the other's colour transform. Fluorescent materials add
/// what they re-emit under the lights (a violet lamp's light reaches the
/// film as the green a highlighter makes of it).
/// `emission` is the lights' relative emission at the 1 nm cells' centres.
fn wavelength_distribution(
    mut emission: Vec<f64>,
    materials: &[Material],
) -> WavelengthDistribution {
    // Measured on the Cornell Box (the variance of two 64-spp renders, in
    // relMSE): half visible with the emission's square root, 11% below the
    // visible density alone; 20% or 30% visible the same within noise, the
    // emission itself (not its root) worse in blue.
    const VISIBLE: f64 = 0.5;
    let centres: Vec<f32> = WavelengthDistribution::centres().collect();
    for material in materials {
        if let Material::Fluorescent { fluorescence, .. } = material {
            let emitted = fluorescence.emitted_under(&emission);
            emission.iter_mut().zip(emitted).for_each(|(e, f)| *e += f);
        }
    }
    let response: Vec<f64> = centres
        .iter()
        .zip(&emission)
        .map(|(&l, &e)| e.sqrt() * cie::xyz_to_linear_srgb(cie::cmf(l)).length() as f64)
        .collect();
    let visible: Vec<f64> = centres
        .iter()
        .map(|&l| crate::spectrum::visible_wavelength_pdf(l) as f64)
        .collect();
    let (r_sum, v_sum): (f64, f64) = (response.iter().sum(), visible.iter().sum());
    if !(r_sum > 0.0) {
        return WavelengthDistribution::visible();
    }
    WavelengthDistribution::from_weights(
        visible
            .iter()
            .zip(&response)
            .map(|(v, r)| VISIBLE * v / v_sum + (1.0 - VISIBLE) * r / r_sum)
            .collect(),
    )
}

/// Fluorescent materials draw half their exciting wavelengths where the
/// scene's lights emit (`emission`, as `wavelength_distribution` takes it;
/// see `Fluorescence::guided_by`).
fn guide_fluorescence(materials: &mut [Material], emission: &[f64]) {
    for material in materials {
        if let Material::Fluorescent { fluorescence, .. } = material {
            *fluorescence = Arc::new(fluorescence.guided_by(emission));
        }
    }
}

static NEXT_SCENE_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Peak bytes a triangle costs while the scene is built: the build's boxes
/// and index lists, then the triangles, shading indices and BVH nodes that
/// stay, beside the imported mesh (measured, all told: 186 MB peak for a
/// 1M-triangle glTF, whose estimate is then 244 MiB; 1.73 GB for 10M).
pub const BUILD_BYTES_PER_TRIANGLE: u64 = 200;

impl Scene {
    /// Assembles the runtime scene: builds its geometry
    /// ([`SceneGeometry::build`]) and adds the other lights.
    pub fn build(
        camera: Camera,
        materials: Vec<Material>,
        shapes: Vec<ShapeInstance>,
        spheres: Vec<SphereInstance>,
        other_lights: Vec<Light>,
    ) -> Scene {
        let geometry = Arc::new(SceneGeometry::build(shapes, spheres));
        let surface_lights = geometry.surface_lights.clone();
        Scene::assemble(camera, materials, geometry, surface_lights, other_lights)
    }

    /// The runtime scene of built geometry (perhaps another scene's) with
    /// these camera, materials, lights of its surfaces (the geometry's own,
    /// or `SceneGeometry::surface_lights_with` other emission) and other
    /// lights (which learn the scene's bounds). The geometry's material
    /// indices must fit `materials`.
    pub fn assemble(
        camera: Camera,
        materials: Vec<Material>,
        geometry: Arc<SceneGeometry>,
        surface_lights: Vec<Light>,
        other_lights: Vec<Light>,
    ) -> Scene {
        let sphere = geometry.sphere;
        let mut lights = surface_lights;
        lights.extend(
            other_lights
                .into_iter()
                .map(|l| l.with_scene_bounds(sphere)),
        );
        let lights = LightSet::new(lights);
        let centres: Vec<f32> = WavelengthDistribution::centres().collect();
        let emission = lights.relative_emission(&centres);
        let mut materials = materials;
        guide_fluorescence(&mut materials, &emission);
        let wavelengths = wavelength_distribution(emission, &materials);
        Scene {
            id: NEXT_SCENE_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            wavelengths,
            camera,
            has_dielectrics: materials.iter().any(|m| m.bounds_volume()),
            has_media: materials.iter().any(|m| m.medium().is_some()),
            has_scattering: materials
                .iter()
                .any(|m| m.medium().is_some_and(|m| m.scatters())),
            world_medium: None,
            cutouts: Vec::new(),
            single_sided: Vec::new(),
            materials,
            lights,
            sphere,
            degenerate_triangles: geometry.degenerate_triangles,
            geometry,
            image_bytes: 0,
        }
    }

    /// The geometry, to share with a scene that differs in other parts.
    pub fn geometry(&self) -> &Arc<SceneGeometry> {
        &self.geometry
    }
}

impl Scene {
    /// The bytes the scene holds: geometry, BVH, lights and images.
    pub fn memory_bytes(&self) -> u64 {
        let bytes = |n: usize, each: usize| (n * each) as u64;
        bytes(
            self.geometry.triangles.len(),
            std::mem::size_of::<[Vec3; 3]>(),
        ) + bytes(
            self.geometry.shading.len(),
            std::mem::size_of::<TriangleShading>(),
        ) + bytes(self.geometry.attributes.normals.len(), 12)
            + bytes(self.geometry.attributes.uvs.len(), 8)
            + bytes(self.geometry.attributes.tangents.len(), 16)
            + self.geometry.bvh.size_bytes() as u64
            + self.geometry.spheres.size_bytes() as u64
            + bytes(self.lights.len(), std::mem::size_of::<Light>() + 16)
            + self.image_bytes
    }

    /// Whether any material bounds a volume (a dielectric).
    /// Unique to this scene in the process.
    pub fn id(&self) -> u64 {
        self.id
    }

    pub fn has_dielectrics(&self) -> bool {
        self.has_dielectrics
    }

    /// The scene with `medium` filling the world.
    pub fn with_world_medium(mut self, medium: Option<Medium>) -> Scene {
        if let Some(m) = &medium {
            self.has_media = true;
            self.has_scattering |= m.scatters();
        }
        self.world_medium = medium;
        self
    }

    /// The scene with the materials `single_sided` names seen by the camera
    /// from the front only.
    pub fn with_single_sided(mut self, single_sided: &std::collections::HashSet<u32>) -> Scene {
        if !single_sided.is_empty() {
            self.single_sided = (0..self.materials.len() as u32)
                .map(|i| single_sided.contains(&i))
                .collect();
        }
        self
    }

    /// Whether some material is single-sided.
    pub fn has_single_sided(&self) -> bool {
        !self.single_sided.is_empty()
    }

    /// Whether a camera ray along `dir` passes a surface of `material`
    /// with geometric normal `ng`: the back face of a single-sided surface.
    /// Only the camera's view culls them (as rasterisers do); every other
    /// ray meets both faces, so light transport stays reciprocal.
    #[inline]
    pub fn hides_back_face(&self, material: u32, ng: Vec3, dir: Vec3) -> bool {
        !self.single_sided.is_empty() && self.single_sided[material as usize] && dir.dot(ng) > 0.0
    }

    /// The scene with cut-outs for the materials `cutouts` names.
    pub fn with_cutouts(mut self, cutouts: std::collections::HashMap<u32, Cutout>) -> Scene {
        if cutouts.is_empty() {
            return self;
        }
        let cutouts: Vec<Option<Arc<Cutout>>> = (0..self.materials.len() as u32)
            .map(|i| cutouts.get(&i).cloned().map(Arc::new))
            .collect();
        // Emissive triangles of cut-out materials emit only where present.
        let mut lights = std::mem::take(&mut self.lights).into_lights();
        for info in &self.geometry.shading {
            if let (Some(c), Some(Light::Area(light))) = (
                &cutouts[info.material as usize],
                lights.get_mut(info.light as usize),
            ) {
                *light = light.clone().with_cutout(c.clone());
            }
        }
        self.lights = LightSet::new(lights);
        self.cutouts = cutouts;
        self
    }

    /// Whether any participating medium is present (segments then
    /// attenuate and shadow rays measure transmittance).
    pub fn has_media(&self) -> bool {
        self.has_media
    }

    /// Whether some material fluoresces (paths then change wavelength).
    pub fn has_fluorescence(&self) -> bool {
        self.materials.iter().any(Material::is_fluorescent)
    }

    /// Whether any medium scatters (paths then sample free flights).
    pub fn has_scattering(&self) -> bool {
        self.has_scattering
    }

    /// The medium inside `material`'s volume, or the world's for None
    /// (a path outside every volume).
    #[inline]
    pub fn medium_inside(&self, material: Option<u32>) -> Option<&Medium> {
        match material {
            Some(m) => self.materials[m as usize].medium(),
            None => self.world_medium.as_ref(),
        }
    }

    pub fn triangle_count(&self) -> usize {
        self.geometry.triangles.len()
    }

    pub fn bounds(&self) -> Aabb {
        self.geometry
            .bvh
            .bounds()
            .union(self.geometry.spheres.bounds())
    }

    /// The bounds of the surfaces whose material `pick` chooses (empty
    /// when there are none).
    pub fn bounds_where(&self, pick: impl Fn(&Material) -> bool) -> Aabb {
        let picked: Vec<bool> = self.materials.iter().map(pick).collect();
        let g = &self.geometry;
        let triangles = g.triangles.iter().zip(&g.shading);
        let mut bounds = triangles
            .filter(|(_, s)| picked[s.material as usize])
            .fold(Aabb::EMPTY, |b, (t, _)| b.union(Aabb::of_points(t)));
        for (id, sphere) in g.spheres.iter() {
            if picked[g.sphere_shading[id as usize].material as usize] {
                bounds = bounds.union(sphere.bounds());
            }
        }
        bounds
    }

    pub fn bvh(&self) -> &Bvh {
        &self.geometry.bvh
    }

    pub fn triangle(&self, prim: u32) -> &[Vec3; 3] {
        &self.geometry.triangles[prim as usize]
    }

    /// The closest hit as a triangle index (BVH order) with distance and
    /// barycentrics, without the shading data: the query Embree's
    /// `rtcIntersect1` answers, for comparing traversal alone.
    pub fn closest_triangle(&self, ray: &Ray) -> Option<(u32, triangle::TriangleHit)> {
        self.geometry.bvh.intersect(ray)
    }

    /// The closest surface along `ray`, passing where cut-outs leave a
    /// surface absent (its `t` stays measured along `ray`).
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        if self.cutouts.is_empty() {
            return self.closest_surface(ray);
        }
        let mut r = *ray;
        let mut travelled = 0.0;
        for _ in 0..MAX_CUTOUTS_CROSSED {
            let mut hit = self.closest_surface(&r)?;
            match &self.cutouts[hit.material as usize] {
                Some(c) if !c.present(hit.uv, blend_number(hit.p, r.dir)) => {
                    travelled += hit.t;
                    r = Ray {
                        origin: offset_ray_origin(hit.p, hit.p_err, hit.ng, r.dir),
                        dir: r.dir,
                        t_max: r.t_max - hit.t,
                        in_free_space: false,
                    };
                }
                _ => {
                    hit.t += travelled;
                    return Some(hit);
                }
            }
        }
        None
    }

    fn closest_surface(&self, ray: &Ray) -> Option<SurfaceHit> {
        self.surface_along(ray, self.geometry.bvh.intersect(ray))
    }

    /// The closest surface along `ray`, given its closest triangle.
    #[inline(always)]
    fn surface_along(
        &self,
        ray: &Ray,
        triangle: Option<(u32, triangle::TriangleHit)>,
    ) -> Option<SurfaceHit> {
        if !self.geometry.spheres.is_empty() {
            let t_max = triangle.as_ref().map_or(ray.t_max, |(_, h)| h.t);
            if let Some((k, hit)) = self.geometry.spheres.intersect(ray, t_max) {
                return Some(self.sphere_surface(k, &hit));
            }
        }
        let (prim, hit) = triangle?;
        let tri = &self.geometry.triangles[prim as usize];
        let info = &self.geometry.shading[prim as usize];
        let [b0, b1, b2] = hit.b;
        // The hit point from barycentrics is more accurate than o + t·d.
        let p = tri[0] * b0 + tri[1] * b1 + tri[2] * b2;
        let p_err = gamma(7) * ((tri[0] * b0).abs() + (tri[1] * b1).abs() + (tri[2] * b2).abs());
        let ng = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        let [v0, v1, v2] = info.vertices.map(|v| v as usize);
        let a = &self.geometry.attributes;
        let mut ns = ng;
        if info.attributes & HAS_NORMALS != 0 {
            let s = a.normals[v0] * b0 + a.normals[v1] * b1 + a.normals[v2] * b2;
            if s.length_squared() > 0.0 && s.is_finite() {
                ns = s.normalize();
            }
        }
        let mut tangent = Vec4::ZERO;
        if info.attributes & HAS_TANGENTS != 0 {
            let t = a.tangents[v0] * b0 + a.tangents[v1] * b1 + a.tangents[v2] * b2;
            tangent = t.truncate().extend(a.tangents[v0].w);
        }
        Some(SurfaceHit {
            t: hit.t,
            p,
            p_err,
            ng,
            ns,
            uv: self.uv_at(prim, [b1, b2]),
            tangent,
            material: info.material,
            light: (info.light != NO_LIGHT).then_some(info.light as usize),
        })
    }

    /// The surface where sphere `k` is hit: its normals face the front.
    fn sphere_surface(&self, k: u32, hit: &SphereHit) -> SurfaceHit {
        let info = &self.geometry.sphere_shading[k as usize];
        let (n, sign) = if info.inward {
            (-hit.n, -1.0)
        } else {
            (hit.n, 1.0)
        };
        let tangent = if hit.dpdu.length_squared() > 0.0 {
            hit.dpdu.normalize().extend(sign)
        } else {
            Vec4::ZERO
        };
        SurfaceHit {
            t: hit.t,
            p: hit.p,
            p_err: hit.p_err,
            ng: n,
            ns: n,
            uv: hit.uv,
            tangent,
            material: info.material,
            light: (info.light != NO_LIGHT).then_some(info.light as usize),
        }
    }

    /// Texture coordinates on triangle `prim` at barycentrics (b1, b2).
    pub fn uv_at(&self, prim: u32, b: [f32; 2]) -> Vec2 {
        let info = &self.geometry.shading[prim as usize];
        if info.attributes & HAS_UVS == 0 {
            return Vec2::ZERO;
        }
        let uv = info
            .vertices
            .map(|v| self.geometry.attributes.uvs[v as usize]);
        uv[0] * (1.0 - b[0] - b[1]) + uv[1] * b[0] + uv[2] * b[1]
    }

    pub fn occluded(&self, ray: &Ray) -> bool {
        if self.cutouts.is_empty() {
            self.geometry.bvh.occluded(ray) || self.geometry.spheres.occluded(ray)
        } else {
            self.intersect(ray).is_some()
        }
    }
}

/// Cut-out surfaces one ray may pass before it is taken as lost (a forest
/// of leaf cards is far below this).
const MAX_CUTOUTS_CROSSED: usize = 4096;

/// A uniform number in [0, 1) from where a ray meets a surface and where it
/// goes: decides stochastic transparency the same way on every run and
/// thread, independently for different rays.
fn blend_number(p: Vec3, dir: Vec3) -> f32 {
    let mut h: u64 = 0x9e37_79b9_7f4a_7c15;
    for x in [p.x, p.y, p.z, dir.x, dir.y, dir.z] {
        h = (h ^ u64::from(x.to_bits())).wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
    }
    (h >> 40) as f32 / (1u64 << 24) as f32
}
