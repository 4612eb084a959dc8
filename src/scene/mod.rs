//! The scene: its file format, the loaders, and the immutable runtime scene
//! (triangles in BVH order, materials, lights, camera) that rendering reads.

pub mod format;
mod load;
pub mod mesh;
pub mod spectrum_spec;

use glam::Vec3;

pub use format::{Strategy, Tonemap};
pub use load::{check_film_size, check_spectral_layout, load, load_str, SceneError};
pub use mesh::Mesh;

use crate::camera::Camera;
use crate::geometry::{gamma, triangle, Aabb, Bvh, Ray};
use crate::light::{AreaLight, LightSet};
use crate::material::Material;
use crate::spectrum::Spectrum;

/// How to render: everything in a scene file that is not geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub rr_depth: u32,
    pub seed: u64,
    pub strategy: Strategy,
    pub exposure: f32,
    pub tonemap: Tonemap,
    pub spectral_range: [f32; 2],
    pub spectral_buckets: u32,
    pub spectral_output: bool,
}

/// Light emitted by a shape.
#[derive(Clone, Debug)]
pub struct Emission {
    pub spectrum: Spectrum,
    pub two_sided: bool,
}

/// A resolved shape: world-space mesh, material, and emission if any.
pub struct ShapeInstance {
    pub mesh: Mesh,
    pub material: u32,
    pub emission: Option<Emission>,
}

/// Per-triangle data that shading needs.
#[derive(Clone, Copy, Debug)]
struct TriangleShading {
    normals: Option<[Vec3; 3]>,
    material: u32,
    /// Index into the light set, or `NO_LIGHT`.
    light: u32,
}

const NO_LIGHT: u32 = u32::MAX;

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
    pub material: u32,
    pub light: Option<usize>,
}

pub struct Scene {
    pub camera: Camera,
    pub settings: RenderSettings,
    pub materials: Vec<Material>,
    pub lights: LightSet,
    bvh: Bvh,
    triangles: Vec<[Vec3; 3]>,
    shading: Vec<TriangleShading>,
    /// Triangles dropped at build because they had no area.
    pub degenerate_triangles: usize,
}

impl Scene {
    /// Assembles the runtime scene: drops degenerate triangles, builds the
    /// BVH, stores triangles in its order and collects the area lights.
    pub fn build(
        camera: Camera,
        settings: RenderSettings,
        materials: Vec<Material>,
        shapes: Vec<ShapeInstance>,
    ) -> Scene {
        let mut triangles = Vec::new();
        let mut shading = Vec::new();
        let mut emitters: Vec<Option<u32>> = Vec::new();
        let mut spectra = Vec::new();
        let mut two_sided = Vec::new();
        let mut degenerate = 0;
        for shape in shapes {
            let emission = shape.emission.map(|e| {
                spectra.push(e.spectrum);
                two_sided.push(e.two_sided);
                spectra.len() as u32 - 1
            });
            for idx in &shape.mesh.indices {
                let p = idx.map(|i| shape.mesh.positions[i as usize]);
                if !(triangle::area(&p) > 0.0) {
                    degenerate += 1;
                    continue;
                }
                triangles.push(p);
                shading.push(TriangleShading {
                    normals: shape
                        .mesh
                        .normals
                        .as_ref()
                        .map(|n| idx.map(|i| n[i as usize])),
                    material: shape.material,
                    light: NO_LIGHT,
                });
                emitters.push(emission);
            }
        }
        let bounds: Vec<Aabb> = triangles.iter().map(|t| Aabb::of_points(t)).collect();
        let (bvh, order) = Bvh::build(&bounds);
        let triangles: Vec<[Vec3; 3]> = order.iter().map(|&i| triangles[i as usize]).collect();
        let mut shading: Vec<TriangleShading> =
            order.iter().map(|&i| shading[i as usize]).collect();
        let mut lights = Vec::new();
        for (prim, &original) in order.iter().enumerate() {
            if let Some(e) = emitters[original as usize] {
                shading[prim].light = lights.len() as u32;
                lights.push(AreaLight {
                    prim: prim as u32,
                    emission: e,
                    two_sided: two_sided[e as usize],
                    area: triangle::area(&triangles[prim]),
                });
            }
        }
        Scene {
            camera,
            settings,
            materials,
            lights: LightSet::new(lights, spectra),
            bvh,
            triangles,
            shading,
            degenerate_triangles: degenerate,
        }
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    pub fn bounds(&self) -> Aabb {
        self.bvh.bounds()
    }

    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    pub fn triangle(&self, prim: u32) -> &[Vec3; 3] {
        &self.triangles[prim as usize]
    }

    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        let (prim, hit) = self.bvh.intersect(ray, &self.triangles)?;
        let tri = &self.triangles[prim as usize];
        let info = &self.shading[prim as usize];
        let [b0, b1, b2] = hit.b;
        // The hit point from barycentrics is more accurate than o + t·d.
        let p = tri[0] * b0 + tri[1] * b1 + tri[2] * b2;
        let p_err = gamma(7) * ((tri[0] * b0).abs() + (tri[1] * b1).abs() + (tri[2] * b2).abs());
        let ng = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        let ns = match info.normals {
            Some(n) => {
                let s = n[0] * b0 + n[1] * b1 + n[2] * b2;
                if s.length_squared() > 0.0 && s.is_finite() {
                    s.normalize()
                } else {
                    ng
                }
            }
            None => ng,
        };
        Some(SurfaceHit {
            t: hit.t,
            p,
            p_err,
            ng,
            ns,
            material: info.material,
            light: (info.light != NO_LIGHT).then_some(info.light as usize),
        })
    }

    pub fn occluded(&self, ray: &Ray) -> bool {
        self.bvh.occluded(ray, &self.triangles)
    }
}
