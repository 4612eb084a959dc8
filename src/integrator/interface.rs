//! Where a path meets a surface: the dielectric bookkeeping every
//! integrator shares. A dielectric's surface is a real interface between
//! two media of the IOR stack, or a false intersection (inside a medium of
//! higher priority) that the path crosses without scattering.

use glam::Vec3;

use super::ior_stack::{Crossing, Entry, IorStack};
use super::volume::{self, Flight};
use super::PathCounters;
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::material::{Bsdf, ShadingGeometry};
use crate::medium::HenyeyGreenstein;
use crate::sampler::Sampler;
use crate::scene::{Scene, SurfaceHit};
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// A path that crosses more false intersections than this in a row is
/// ended (a pathological overlap of surfaces, never a real scene).
pub const MAX_FALSE_INTERSECTIONS: u32 = 256;

/// What a surface is to the path that meets it.
#[derive(Clone, Copy, Debug)]
pub enum Meeting {
    /// A false intersection: the path goes straight on (the stack has
    /// already entered or left the surface's medium).
    Pass,
    /// A real surface. `eta` is n_inside / n_outside per wavelength (1 for
    /// anything but a dielectric); `medium` is the dielectric that a
    /// transmission enters (`true`) or leaves (`false`).
    Real {
        eta: SampledSpectrum,
        medium: Option<(Entry, bool)>,
    },
}

/// Where a ray goes next.
#[derive(Clone, Copy, Debug)]
pub enum Next {
    /// The path scattered inside a medium, at `p`, by `phase`.
    Medium { p: Vec3, phase: HenyeyGreenstein },
    /// A real surface, and what it is to the path (see [`Meeting::Real`]).
    Surface {
        hit: SurfaceHit,
        eta: SampledSpectrum,
        medium: Option<(Entry, bool)>,
    },
    /// The ray left the scene.
    Escaped,
    /// More than [`MAX_FALSE_INTERSECTIONS`] false intersections in a row.
    Lost,
}

/// Whether the closest surface along a ray is known before `trace` is
/// called (a stream of rays traced together found it).
#[derive(Clone, Copy)]
pub enum FirstHit {
    Unknown,
    Known(Option<SurfaceHit>),
}

/// Traces `ray` to the next real surface, crossing false intersections
/// and interfaces (the stack enters and leaves their objects). On return
/// `ray` is the segment that reached the surface, escaped or scattered;
/// every ray traced counts. `first` may already hold `scene.intersect(ray)`
/// (the same answer, bit for bit, and the same rays counted). In a medium
/// the path's throughput `flight` attenuates (Beer–Lambert), and in a
/// scattering one the path may scatter: `sampler` draws the free-flight
/// distance (`volume::fly`); None never scatters (first-hit queries). A
/// `camera_ray` passes the back faces of single-sided surfaces (glTF's
/// `doubleSided = false`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn trace(
    scene: &Scene,
    ray: &mut Ray,
    mut first: FirstHit,
    camera_ray: bool,
    stack: &mut IorStack,
    wl: &SampledWavelengths,
    flight: &mut Flight,
    sampler: Option<&mut Sampler>,
    counters: &mut PathCounters,
) -> Next {
    let mut optical_depth = volume::optical_depth(scene, sampler);
    for _ in 0..=MAX_FALSE_INTERSECTIONS {
        counters.rays += 1;
        let hit = match std::mem::replace(&mut first, FirstHit::Unknown) {
            FirstHit::Known(hit) => hit,
            FirstHit::Unknown => scene.intersect(ray),
        };
        if let Some(m) = scene.has_media().then(|| stack.medium(scene)).flatten() {
            let speed = ray.dir.length();
            let d = hit.map_or(f32::INFINITY, |h| h.t * speed);
            if let Some(t) = volume::fly(m, wl, d, &mut optical_depth, flight) {
                let p = flight_end(ray, t / speed, hit.as_ref());
                ray.t_max = t / speed;
                return Next::Medium { p, phase: m.phase };
            }
        }
        let Some(hit) = hit else {
            return Next::Escaped;
        };
        let meeting = if camera_ray && scene.hides_back_face(hit.material, hit.ng, ray.dir) {
            Meeting::Pass
        } else {
            meet(scene, &hit, ray.dir, stack, wl, counters)
        };
        match meeting {
            Meeting::Pass => {
                *ray = Ray::new(
                    offset_ray_origin(hit.p, hit.p_err, hit.ng, ray.dir),
                    ray.dir,
                );
            }
            Meeting::Real { eta, medium } => return Next::Surface { hit, eta, medium },
        }
    }
    Next::Lost
}

/// Where a free flight along `ray` ends, at parameter `t` before the
/// surface `hit` that the ray was heading for: the point itself, or, when
/// it lies within the hit's rounding error of the surface, the point
/// offset to the ray's side of it. (Rounded to the far side, the point
/// would be outside the medium: its next ray would miss the exit, or meet
/// the surface again from outside and enter the medium a second time.)
#[inline]
pub fn flight_end(ray: &Ray, t: f32, hit: Option<&SurfaceHit>) -> Vec3 {
    let p = ray.origin + ray.dir * t;
    let Some(hit) = hit else {
        return p;
    };
    let near = offset_ray_origin(hit.p, hit.p_err, hit.ng, -ray.dir);
    let beyond = (p - near).dot(hit.ng) * ray.dir.dot(hit.ng) > 0.0;
    if beyond {
        near
    } else {
        p
    }
}

/// What reaches the end of the segment `shadow` (from a point whose media
/// are `stack`): zero if a surface blocks it, else the transmittance of
/// the media it crosses. Interfaces and false intersections let it through
/// (they do not refract); every other surface blocks it.
pub fn transmittance(
    scene: &Scene,
    shadow: &Ray,
    stack: &IorStack,
    wl: &SampledWavelengths,
    counters: &mut PathCounters,
) -> SampledSpectrum {
    transmittance_to(scene, shadow, stack, wl, counters, false)
}

/// The transmittance of a segment that ends at the camera: single-sided
/// surfaces that the camera would see from behind let it through, as the
/// camera's own rays pass them.
pub fn transmittance_to_camera(
    scene: &Scene,
    shadow: &Ray,
    stack: &IorStack,
    wl: &SampledWavelengths,
    counters: &mut PathCounters,
) -> SampledSpectrum {
    transmittance_to(scene, shadow, stack, wl, counters, true)
}

fn transmittance_to(
    scene: &Scene,
    shadow: &Ray,
    stack: &IorStack,
    wl: &SampledWavelengths,
    counters: &mut PathCounters,
    to_camera: bool,
) -> SampledSpectrum {
    counters.rays += 1;
    let culling = to_camera && scene.has_single_sided();
    if !scene.has_media() && !culling {
        return if scene.occluded(shadow) {
            SampledSpectrum::ZERO
        } else {
            SampledSpectrum::ONE
        };
    }
    let target = shadow.origin + shadow.dir;
    let mut stack = *stack;
    let mut ray = *shadow;
    let mut tr = SampledSpectrum::ONE;
    for i in 0..=MAX_FALSE_INTERSECTIONS {
        if i > 0 {
            counters.rays += 1;
        }
        let hit = scene.intersect(&ray);
        if let Some(m) = stack.medium(scene) {
            let d = hit.map_or(ray.t_max, |h| h.t) * ray.dir.length();
            tr *= crate::medium::transmittance(m.coefficients(wl).sigma_t(), d);
            if tr == SampledSpectrum::ZERO {
                return tr;
            }
        }
        let Some(hit) = hit else {
            return tr;
        };
        // What a path would pass (an interface, a false intersection, a
        // single-sided surface the camera sees from behind) the shadow ray
        // passes too; a real surface blocks it.
        let hidden = culling && scene.hides_back_face(hit.material, hit.ng, -ray.dir);
        if !hidden {
            if let Meeting::Real { .. } = meet(scene, &hit, ray.dir, &mut stack, wl, counters) {
                return SampledSpectrum::ZERO;
            }
        }
        let origin = offset_ray_origin(hit.p, hit.p_err, hit.ng, ray.dir);
        ray = if shadow.t_max.is_finite() {
            Ray::towards(origin, target)
        } else {
            Ray::new(origin, shadow.dir)
        };
    }
    SampledSpectrum::ZERO
}

/// The media on the side of a surface that `wi` leaves into: `stack` as
/// the path arrived, moved through the surface if `wi` crosses it.
#[inline]
pub fn stack_towards(
    stack: &IorStack,
    medium: Option<(Entry, bool)>,
    wo: Vec3,
    wi: Vec3,
    ng: Vec3,
) -> IorStack {
    let mut s = *stack;
    let mut ignored = PathCounters::default();
    scatter(&mut s, medium, wo, wi, ng, &mut ignored);
    s
}

/// The BSDF at a real surface `hit`, met by a path arriving from `wo`
/// (unit, pointing back along the path), at its wavelengths (which a smooth
/// dispersive surface may end); `eta` is what `trace` found there.
#[inline]
pub fn bsdf_at(
    scene: &Scene,
    hit: &SurfaceHit,
    wo: Vec3,
    wl: &mut SampledWavelengths,
    eta: SampledSpectrum,
) -> Bsdf {
    let material = &scene.materials[hit.material as usize];
    let geom = ShadingGeometry {
        ng: hit.ng,
        ns: material.shading_normal(hit.ns, hit.tangent, hit.uv),
        wo,
    };
    material.bsdf(&geom, hit.uv, wl, eta)
}

/// The index of refraction of a dielectric material at the path's wavelengths.
#[inline]
pub fn ior_at(scene: &Scene, material: u32, wl: &SampledWavelengths) -> SampledSpectrum {
    match scene.materials[material as usize].ior() {
        Some(ior) => ior.eval4(wl.lambda),
        None => SampledSpectrum::ONE,
    }
}

/// Classifies the surface `hit` met by a ray of direction `dir`.
#[inline]
pub fn meet(
    scene: &Scene,
    hit: &SurfaceHit,
    dir: Vec3,
    stack: &mut IorStack,
    wl: &SampledWavelengths,
    counters: &mut PathCounters,
) -> Meeting {
    let material = &scene.materials[hit.material as usize];
    if !material.bounds_volume() {
        return Meeting::Real {
            eta: SampledSpectrum::ONE,
            medium: None,
        };
    }
    let m = Entry {
        material: hit.material,
        priority: material.priority(),
    };
    let entering = dir.dot(hit.ng) < 0.0;
    if material.is_interface() {
        // Index-matched: the path enters or leaves its medium, unbent.
        move_through(stack, m, entering, counters);
        return Meeting::Pass;
    }
    match stack.classify(m, entering) {
        Crossing::False => {
            move_through(stack, m, entering, counters);
            Meeting::Pass
        }
        Crossing::Real { outside, inside } => {
            let n_out = outside.map_or(SampledSpectrum::ONE, |o| ior_at(scene, o, wl));
            Meeting::Real {
                eta: ior_at(scene, inside, wl) / n_out,
                medium: Some((m, entering)),
            }
        }
    }
}

/// After scattering at a real surface from `wo` to `wi`: a transmission
/// through a dielectric moves the path into or out of its medium. Returns
/// whether the path crossed the surface.
#[inline]
pub fn scatter(
    stack: &mut IorStack,
    medium: Option<(Entry, bool)>,
    wo: Vec3,
    wi: Vec3,
    ng: Vec3,
    counters: &mut PathCounters,
) -> bool {
    let crossed = wi.dot(ng) * wo.dot(ng) < 0.0;
    if let (true, Some((m, entering))) = (crossed, medium) {
        move_through(stack, m, entering, counters);
    }
    crossed
}

#[inline]
fn move_through(stack: &mut IorStack, m: Entry, entering: bool, counters: &mut PathCounters) {
    if entering {
        if !stack.push(m) {
            counters.stack_overflows += 1;
        }
    } else {
        stack.remove(m.material);
    }
}

/// The dielectric media that contain the point `p` (on a surface of normal
/// `n`, or `n` zero in free space), as a path starting there must carry
/// them: a ray from `p` to infinity leaves each containing object before
/// it enters it, so an object whose surface the ray first meets from the
/// inside contains `p`. Assumes closed meshes, as the stack does. The
/// stack lists the outermost first, as a path from outside would have
/// entered them.
pub fn media_at(
    scene: &Scene,
    p: Vec3,
    p_err: Vec3,
    n: Vec3,
    counters: &mut PathCounters,
) -> IorStack {
    let mut stack = IorStack::default();
    if !scene.has_dielectrics() {
        return stack;
    }
    // Any direction does; this one is along no axis, so it does not graze
    // the axis-aligned walls that scenes are full of.
    let dir = Vec3::new(0.285_7, 0.912_4, 0.293_1).normalize();
    let mut ray = Ray::new(offset_ray_origin(p, p_err, n, dir), dir);
    let mut seen = [u32::MAX; 2 * super::ior_stack::CAPACITY];
    let mut n_seen = 0;
    let mut inside = [None; super::ior_stack::CAPACITY];
    let mut n_inside = 0;
    for _ in 0..=MAX_FALSE_INTERSECTIONS {
        counters.rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            break;
        };
        let material = &scene.materials[hit.material as usize];
        if material.bounds_volume() && !seen[..n_seen].contains(&hit.material) {
            if n_seen == seen.len() {
                break;
            }
            seen[n_seen] = hit.material;
            n_seen += 1;
            if dir.dot(hit.ng) > 0.0 && n_inside < inside.len() {
                inside[n_inside] = Some(Entry {
                    material: hit.material,
                    priority: material.priority(),
                });
                n_inside += 1;
            }
        }
        ray = Ray::new(offset_ray_origin(hit.p, hit.p_err, hit.ng, dir), dir);
    }
    // Met innermost first: enter them outermost first.
    for m in inside[..n_inside].iter().rev().flatten() {
        let _ = stack.push(*m);
    }
    stack
}
