//! A caustic with a closed form: a point light of intensity I at height 1
//! over a Lambertian floor of albedo ρ (y = 0), under a horizontal mirror (a
//! smooth conductor) at height 2, and optionally a vertical mirror at
//! z = 2. The floor receives the light directly and from its mirror images
//! — at height 3 over the ceiling mirror, at z = 4 behind the vertical one
//! — each attenuated by the mirror's Fresnel reflectance, and has radiance
//! ρE/π. `max_depth` leaves out every longer path the tests look at.

use glam::DVec3;
use prism::load::Loaded;
use prism::scene::Scene;

pub const RHO: f64 = 0.5;
pub const INTENSITY: f64 = 10.0;
/// The mirrors' complex index of refraction.
pub const ETA: f64 = 0.2;
pub const K: f64 = 3.0;

/// Fresnel reflectance of a conductor of complex index η + ik at incidence
/// cos θ (exact, for unpolarised light), computed here independently of
/// prism's own.
pub fn conductor_reflectance(cos: f64, eta: f64, k: f64) -> f64 {
    // n² − sin²θ = a + ib, with n = η + ik; s and p amplitudes from its root.
    let sin2 = 1.0 - cos * cos;
    let (a, b) = (eta * eta - k * k - sin2, 2.0 * eta * k);
    let modulus = (a * a + b * b).sqrt();
    let (u, v) = (((modulus + a) / 2.0).sqrt(), ((modulus - a) / 2.0).sqrt());
    let rs = ((cos - u).powi(2) + v * v) / ((cos + u).powi(2) + v * v);
    // r_p = (n² cos − w) / (n² cos + w), w = u + iv, n² = (a + sin²) + ib.
    let (n2r, n2i) = (a + sin2, b);
    let (pr, pi) = (n2r * cos - u, n2i * cos - v);
    let (qr, qi) = (n2r * cos + u, n2i * cos + v);
    let rp = (pr * pr + pi * pi) / (qr * qr + qi * qi);
    0.5 * (rs + rp)
}

/// The scene for integrator `kind` (with `extra` integrator keys).
pub fn scene(kind: &str, extra: &str, vertical_mirror: bool, max_depth: u32) -> Loaded {
    super::scene(&text(kind, extra, vertical_mirror, max_depth))
}

/// `scene`'s file, 32 × 24 pixels.
pub fn text(kind: &str, extra: &str, vertical_mirror: bool, max_depth: u32) -> String {
    let vertical = if vertical_mirror {
        "[[shape]]\ntype = \"quad\"\nvertices = [[-8, 0, 2], [-8, 1.9, 2], [8, 1.9, 2], [8, 0, 2]]\nmaterial = \"mirror\"\n"
    } else {
        ""
    };
    format!(
        "[camera]\nposition = [0, 1.8, -3]\nlook_at = [0, 0, 1]\nfov = 30\n\
         [film]\nresolution = [32, 24]\n\
         [integrator]\ntype = \"{kind}\"\nmax_depth = {max_depth}\n{extra}\n\
         [materials.floor]\ntype = \"diffuse\"\nreflectance = {RHO}\n\
         [materials.mirror]\ntype = \"conductor\"\neta = {ETA}\nk = {K}\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-20, 0, -20], [-20, 0, 20], [20, 0, 20], [20, 0, -20]]\nmaterial = \"floor\"\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-8, 2, -8], [8, 2, -8], [8, 2, 8], [-8, 2, 8]]\nmaterial = \"mirror\"\n\
         {vertical}\
         [[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = {INTENSITY}\n"
    )
}

/// Irradiance on the floor at `p` (y = 0).
pub fn irradiance(p: DVec3, vertical_mirror: bool) -> f64 {
    direct(p) + mirrored(p, vertical_mirror)
}

/// Irradiance straight from the light.
pub fn direct(p: DVec3) -> f64 {
    INTENSITY / (p - DVec3::Y).length().powi(3)
}

/// Irradiance from the mirror images: the ceiling mirror's and (when there
/// is one) the vertical mirror's.
pub fn mirrored(p: DVec3, vertical_mirror: bool) -> f64 {
    let r2 = (p - 3.0 * DVec3::Y).length();
    let mut e = conductor_reflectance(3.0 / r2, ETA, K) * 3.0 / r2.powi(3);
    if vertical_mirror && p.z < 2.0 {
        let image = DVec3::new(0.0, 1.0, 4.0);
        let r3 = (p - image).length();
        e += conductor_reflectance((image.z - p.z) / r3, ETA, K) / r3.powi(3);
    }
    INTENSITY * e
}

/// The mean of `f` over the disc of radius `r` about `p` in the floor's
/// plane (r = 0: f at p) — what photon density estimation with a fixed
/// radius measures.
pub fn disc_mean(p: DVec3, r: f64, f: impl Fn(DVec3) -> f64) -> f64 {
    if r == 0.0 {
        return f(p);
    }
    let (rings, spokes) = (8, 24);
    let mut sum = 0.0;
    for i in 0..rings {
        // Rings of equal area.
        let rho = r * ((i as f64 + 0.5) / rings as f64).sqrt();
        for j in 0..spokes {
            let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / spokes as f64;
            sum += f(p + DVec3::new(rho * phi.cos(), 0.0, rho * phi.sin()));
        }
    }
    sum / (rings * spokes) as f64
}

/// Where the camera ray through raster (x, y) meets the floor, and the
/// reflectance of the mirrors it met on the way (None: it missed the floor).
pub fn floor_seen(scene: &Scene, x: f32, y: f32, vertical_mirror: bool) -> Option<(DVec3, f64)> {
    let r = scene.camera.generate_ray(x, y);
    let (mut o, mut d) = (r.origin.as_dvec3(), r.dir.as_dvec3());
    let mut weight = 1.0;
    if vertical_mirror && d.z > 0.0 {
        let t = (2.0 - o.z) / d.z;
        let hit = o + d * t;
        if hit.y > 0.0 && hit.y < 1.9 && hit.x.abs() < 8.0 {
            weight *= conductor_reflectance(d.z, ETA, K);
            o = hit;
            d.z = -d.z;
        }
    }
    if d.y >= 0.0 {
        return None;
    }
    let t = -o.y / d.y;
    let p = o + d * t;
    (p.x.abs() < 20.0 && p.z.abs() < 20.0).then_some((p, weight))
}

/// Expected luminance of every pixel (the mean over 4 × 4 points of it: the
/// box filter), or None where a point misses the floor or (with
/// `via_mirror`) does not see it in the vertical mirror. The mirrored light
/// is averaged over discs of `radius`, as photon mapping measures it (its
/// direct light comes from light sampling, exactly).
pub fn expected_pixels(
    scene: &Scene,
    vertical_mirror: bool,
    via_mirror: bool,
    radius: f64,
) -> Vec<Option<f64>> {
    let (w, h) = scene.camera.resolution();
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let mut sum = 0.0;
            let mut ok = true;
            for (i, j) in (0..4).flat_map(|i| (0..4).map(move |j| (i, j))) {
                let (px, py) = (
                    x as f32 + (i as f32 + 0.5) / 4.0,
                    y as f32 + (j as f32 + 0.5) / 4.0,
                );
                match floor_seen(scene, px, py, vertical_mirror) {
                    Some((p, weight)) if !via_mirror || weight < 1.0 => {
                        let e = direct(p) + disc_mean(p, radius, |q| mirrored(q, vertical_mirror));
                        sum += weight * RHO / std::f64::consts::PI * e;
                    }
                    _ => ok = false,
                }
            }
            out.push(ok.then_some(sum / 16.0));
        }
    }
    out
}
