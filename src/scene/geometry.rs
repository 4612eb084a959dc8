//! A scene's geometry: triangles in BVH order with their shading data,
//! exact spheres in a hierarchy of their own, and the lights their emission
//! makes. Scenes that differ only in camera, materials or other lights
//! share one (`Scene::assemble`).

use rayon::prelude::*;
use std::sync::Arc;

use glam::{Vec2, Vec3, Vec4};

use super::{Emission, Mesh, ShapeInstance, SphereInstance};
use crate::geometry::sphere::SphereSet;
use crate::geometry::{triangle, Aabb, Bvh};
use crate::light::{AreaLight, Emitter, Light, SceneSphere, SphereLight};

/// What shading needs of a sphere.
#[derive(Clone, Copy, Debug)]
pub(super) struct SphereShading {
    pub(super) material: u32,
    /// Index into the light set, or `NO_LIGHT`.
    pub(super) light: u32,
    pub(super) inward: bool,
}

/// Per-triangle data that shading needs: where its vertices' attributes
/// are in the scene's attribute arrays, and which of them it has.
#[derive(Clone, Copy, Debug)]
pub(super) struct TriangleShading {
    pub(super) vertices: [u32; 3],
    pub(super) attributes: u8,
    pub(super) material: u32,
    /// Index into the light set, or `NO_LIGHT`.
    pub(super) light: u32,
}

pub(super) const NO_LIGHT: u32 = u32::MAX;
pub(super) const HAS_NORMALS: u8 = 1;
pub(super) const HAS_UVS: u8 = 2;
pub(super) const HAS_TANGENTS: u8 = 4;

/// Vertex attributes of every mesh, concatenated; a triangle's entries are
/// only meaningful where its attribute flags say so.
#[derive(Default)]
pub(super) struct VertexAttributes {
    pub(super) normals: Vec<Vec3>,
    pub(super) uvs: Vec<Vec2>,
    pub(super) tangents: Vec<Vec4>,
}

/// A scene's shapes as the renderer intersects them: triangles in BVH
/// order with their shading data, exact spheres, and the lights their
/// emission makes. Building it (the BVH) is the costly part of a scene.
pub struct SceneGeometry {
    pub(super) bvh: Bvh,
    /// Exact spheres, in a hierarchy of their own.
    pub(super) spheres: SphereSet,
    pub(super) sphere_shading: Vec<SphereShading>,
    pub(super) triangles: Vec<[Vec3; 3]>,
    pub(super) shading: Vec<TriangleShading>,
    pub(super) attributes: VertexAttributes,
    /// The area and sphere lights, in the order the shading data index.
    pub(super) surface_lights: Vec<Light>,
    /// For each surface light, the scene shape whose `emission` it is
    /// (`ShapeInstance::emission_of`).
    light_sources: Vec<Option<u32>>,
    pub(super) sphere: SceneSphere,
    pub(super) degenerate_triangles: usize,
}

/// A mesh's triangles as the scene numbers them (before the BVH orders
/// them): from `first` on, those of its triangles that are not degenerate.
struct MeshTriangles {
    first: usize,
    /// The triangles kept, where some are degenerate (None: all of them).
    kept: Option<Vec<u32>>,
    /// Where the mesh's vertices start in the attribute arrays.
    base: u32,
    /// Which attributes the mesh has (HAS_NORMALS …).
    flags: u8,
    material: u32,
    /// The mesh's emitter, an index into the scene's list of them.
    emitter: Option<u32>,
}

impl SceneGeometry {
    /// Drops degenerate triangles, builds the BVH, stores triangles in its
    /// order and collects the area and sphere lights. The triangles and
    /// their shading data are written once, in the BVH's order, straight
    /// from the meshes: on big meshes writing to fresh pages is much of the
    /// work (a 10M-triangle mesh's are 600 MB).
    pub fn build(mut shapes: Vec<ShapeInstance>, spheres: Vec<SphereInstance>) -> SceneGeometry {
        let (attributes, starts) =
            VertexAttributes::gather(shapes.iter_mut().map(|s| &mut s.mesh).collect());
        let mut light_emitters = Vec::new();
        let mut light_sources = Vec::new();
        let mut meshes: Vec<Mesh> = Vec::with_capacity(shapes.len());
        let mut numbering = Vec::with_capacity(shapes.len());
        let (mut count, mut degenerate) = (0, 0);
        for (shape, (base, flags)) in shapes.into_iter().zip(starts) {
            let emitter = shape.emission.map(|e| {
                let emitter = Emitter {
                    spectrum: e.spectrum,
                    texture: e.texture,
                };
                light_emitters.push((Arc::new(emitter), e.two_sided, shape.emission_of));
                light_emitters.len() as u32 - 1
            });
            let kept = kept_triangles(&shape.mesh);
            let kept_count = kept.as_ref().map_or(shape.mesh.indices.len(), Vec::len);
            degenerate += shape.mesh.indices.len() - kept_count;
            numbering.push(MeshTriangles {
                first: count,
                kept,
                base,
                flags,
                material: shape.material,
                emitter,
            });
            count += kept_count;
            meshes.push(shape.mesh);
        }
        // The mesh and vertex indices of the scene's triangle g.
        let locate = |g: usize| -> (usize, [u32; 3]) {
            let k = numbering.partition_point(|m| m.first <= g) - 1;
            let local = g - numbering[k].first;
            let t = numbering[k]
                .kept
                .as_ref()
                .map_or(local, |kept| kept[local] as usize);
            (k, meshes[k].indices[t])
        };
        let triangle = |g: usize| {
            let (k, idx) = locate(g);
            idx.map(|i| meshes[k].positions[i as usize])
        };
        let (bvh, order) = Bvh::build_from(count, triangle);
        let triangles: Vec<[Vec3; 3]> = order.par_iter().map(|&g| triangle(g as usize)).collect();
        let mut shading: Vec<TriangleShading> = order
            .par_iter()
            .map(|&g| {
                let (k, idx) = locate(g as usize);
                let m = &numbering[k];
                TriangleShading {
                    vertices: idx.map(|i| m.base + i),
                    attributes: m.flags,
                    material: m.material,
                    light: NO_LIGHT,
                }
            })
            .collect();
        let mut lights = Vec::new();
        // Each emitting triangle's light, in the BVH's order.
        let emitting = numbering.iter().any(|m| m.emitter.is_some());
        for (prim, &g) in order.iter().enumerate().take_while(|_| emitting) {
            if let Some(e) = numbering[locate(g as usize).0].emitter {
                shading[prim].light = lights.len() as u32;
                let info = &shading[prim];
                let uvs = (info.attributes & HAS_UVS != 0)
                    .then(|| info.vertices.map(|v| attributes.uvs[v as usize]));
                let (emitter, two_sided, source) = &light_emitters[e as usize];
                light_sources.push(*source);
                lights.push(Light::Area(AreaLight::new(
                    triangles[prim],
                    uvs,
                    emitter.clone(),
                    *two_sided,
                )));
            }
        }
        drop(meshes);
        let (sphere_set, sphere_shading) = sphere_lights(&spheres, &mut lights);
        light_sources.extend(
            spheres
                .iter()
                .filter(|s| s.emission.is_some())
                .map(|s| s.emission_of),
        );
        let empty = triangles.is_empty() && sphere_set.is_empty();
        let sphere = bounding_sphere(bvh.bounds().union(sphere_set.bounds()), empty);
        SceneGeometry {
            bvh,
            spheres: sphere_set,
            sphere_shading,
            triangles,
            shading,
            attributes,
            surface_lights: lights,
            light_sources,
            sphere,
            degenerate_triangles: degenerate,
        }
    }
}
impl VertexAttributes {
    /// The meshes' vertex attributes, concatenated, and where each mesh's
    /// start and which it has. An attribute that no mesh has stays empty;
    /// meshes without one that others have get zeros (one base index
    /// serves all three arrays). A mesh that holds every vertex gives its
    /// arrays up instead of being copied.
    fn gather(mut meshes: Vec<&mut Mesh>) -> (Self, Vec<(u32, u8)>) {
        let total: usize = meshes.iter().map(|m| m.positions.len()).sum();
        let any = |has: fn(&Mesh) -> bool| meshes.iter().any(|m| has(m));
        let wanted = [
            any(|m| m.normals.is_some()),
            any(|m| m.uvs.is_some()),
            any(|m| m.tangents.is_some()),
        ];
        // Reserved exactly: vectors that grow by doubling reserve address
        // space they never use, which `ulimit -v` counts.
        let reserve = |wanted: bool| if wanted { total } else { 0 };
        let mut all = VertexAttributes {
            normals: Vec::with_capacity(reserve(wanted[0])),
            uvs: Vec::with_capacity(reserve(wanted[1])),
            tangents: Vec::with_capacity(reserve(wanted[2])),
        };
        let mut starts = Vec::with_capacity(meshes.len());
        let mut base = 0;
        for mesh in meshes.iter_mut() {
            let n = mesh.positions.len();
            let sole = n == total;
            let (end, mut flags) = (base + n, 0);
            if append(&mut all.normals, mesh.normals.take(), wanted[0], sole, end) {
                flags |= HAS_NORMALS;
            }
            if append(&mut all.uvs, mesh.uvs.take(), wanted[1], sole, end) {
                flags |= HAS_UVS;
            }
            if append(
                &mut all.tangents,
                mesh.tangents.take(),
                wanted[2],
                sole,
                end,
            ) {
                flags |= HAS_TANGENTS;
            }
            starts.push((base as u32, flags));
            base += n;
        }
        (all, starts)
    }
}

/// Appends one mesh's attribute (`own`) to `all`, or zeros up to `end`
/// where it has none but others do; returns whether it has it.
fn append<T: Copy + Default>(
    all: &mut Vec<T>,
    own: Option<Vec<T>>,
    wanted: bool,
    sole: bool,
    end: usize,
) -> bool {
    let has = own.is_some();
    match own {
        Some(own) if sole => *all = own,
        Some(own) => all.extend_from_slice(&own),
        None if wanted => all.resize(end, T::default()),
        None => {}
    }
    has
}

/// The triangles of `mesh` with an area, where some have none (None: all
/// have one).
fn kept_triangles(mesh: &Mesh) -> Option<Vec<u32>> {
    let has_area = |t: &[u32; 3]| triangle::area(&t.map(|i| mesh.positions[i as usize])) > 0.0;
    if mesh.indices.par_iter().all(has_area) {
        return None;
    }
    Some(
        (0..mesh.indices.len() as u32)
            .into_par_iter()
            .filter(|&t| has_area(&mesh.indices[t as usize]))
            .collect(),
    )
}

/// The sphere around `bounds` (none for an empty scene).
fn bounding_sphere(bounds: Aabb, empty: bool) -> SceneSphere {
    if empty {
        return SceneSphere::default();
    }
    let centre = (bounds.min + bounds.max) * 0.5;
    SceneSphere {
        centre,
        radius: (bounds.max - centre).length(),
    }
}

/// The spheres' hierarchy and shading, with a light added to `lights` for
/// each emitting sphere.
impl SceneGeometry {
    /// The surface lights with the emission of scene shapes replaced:
    /// `emission[i]` for the lights of shape `i` (which must emit, as when
    /// the geometry was built); assets' own emission stays.
    pub fn surface_lights_with(&self, emission: &[Option<Emission>]) -> Vec<Light> {
        let emitters: Vec<Option<(Arc<Emitter>, bool)>> = emission
            .iter()
            .map(|e| {
                e.as_ref().map(|e| {
                    let emitter = Emitter {
                        spectrum: e.spectrum.clone(),
                        texture: e.texture.clone(),
                    };
                    (Arc::new(emitter), e.two_sided)
                })
            })
            .collect();
        self.surface_lights
            .iter()
            .zip(&self.light_sources)
            .map(
                |(light, source)| match source.and_then(|s| emitters.get(s as usize)?.as_ref()) {
                    Some((emitter, two_sided)) => light.with_emitter(emitter.clone(), *two_sided),
                    None => light.clone(),
                },
            )
            .collect()
    }

    /// The lights of the geometry's surfaces as built.
    pub fn surface_lights(&self) -> &[Light] {
        &self.surface_lights
    }
}

fn sphere_lights(
    spheres: &[SphereInstance],
    lights: &mut Vec<Light>,
) -> (SphereSet, Vec<SphereShading>) {
    let set = SphereSet::new(&spheres.iter().map(|s| s.sphere).collect::<Vec<_>>());
    let shading = spheres
        .iter()
        .map(|s| {
            let light = match &s.emission {
                Some(e) => {
                    let emitter = Arc::new(Emitter {
                        spectrum: e.spectrum.clone(),
                        texture: e.texture.clone(),
                    });
                    lights.push(Light::Sphere(SphereLight::new(
                        s.sphere,
                        emitter,
                        e.two_sided,
                        s.inward,
                    )));
                    lights.len() as u32 - 1
                }
                None => NO_LIGHT,
            };
            SphereShading {
                material: s.material,
                light,
                inward: s.inward,
            }
        })
        .collect();
    (set, shading)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(x: f32) -> Mesh {
        Mesh::quad([0.0, 1.0, 2.0, 3.0].map(|y| Vec3::new(x, y, 0.0)))
    }

    #[test]
    fn attributes_line_up_with_one_base_and_none_are_stored_for_nothing() {
        let mut with_normals = quad(0.0);
        with_normals.normals = Some(vec![Vec3::Z; 4]);
        let mut with_uvs = quad(2.0);
        with_uvs.uvs = Some((0..4).map(|i| Vec2::splat(i as f32)).collect());
        let mut meshes = [with_normals, quad(1.0), with_uvs];
        let (all, starts) = VertexAttributes::gather(meshes.iter_mut().collect());
        assert_eq!(starts, [(0, HAS_NORMALS), (4, 0), (8, HAS_UVS)]);
        assert_eq!(all.normals[..4], [Vec3::Z; 4]);
        assert_eq!(all.normals[4..], [Vec3::ZERO; 8]);
        assert_eq!(all.uvs[..8], [Vec2::ZERO; 8]);
        assert_eq!(all.uvs[8 + 3], Vec2::splat(3.0));
        // No mesh has tangents: none are stored.
        assert!(all.tangents.is_empty());

        // A mesh with every vertex gives its arrays up.
        let mut sole = quad(0.0);
        sole.uvs = Some(vec![Vec2::ONE; 4]);
        let held = sole.uvs.as_ref().unwrap().as_ptr();
        let (all, starts) = VertexAttributes::gather(vec![&mut sole]);
        assert_eq!(starts, [(0, HAS_UVS)]);
        assert_eq!(all.uvs.as_ptr(), held);
        assert!(all.normals.is_empty() && all.tangents.is_empty());
    }
}
