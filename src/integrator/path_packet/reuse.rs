//! Paths reused between neighbouring pixels at their first bounce
//! (Bekaert, Sbert and Halton 2002, "Accelerating path tracing by
//! re-using paths"). The samples of one rank in a 2 × 2 block of pixels
//! form a group and share their wavelengths. Where a path's first surface
//! x₁ is diffuse, its bounce drew a point x₂ by the cosine; where x₂ is
//! diffuse too, the light the rest of the path found leaving x₂ is the
//! same towards any point on its side, so every pixel of the group can use
//! it: a shadow ray from its own x₁ to that x₂, and the bounce's value
//! there. Each pixel's light from its first bounce on is then estimated
//! from up to four second vertices instead of one, weighed by the balance
//! heuristic over the group's first bounces (their densities of reaching
//! the point, visibility included, which the same shadow rays tell).
//!
//! Unbiased: for each pixel the weights of the techniques that can reach
//! a point sum to one. A point on a surface that is not diffuse, or reached
//! from the other side, counts only for the pixel whose path found it, with
//! weight one. Light found at x₂ itself (a lamp) and the light sample at x₁
//! stay each pixel's own.
//!
//! A block's pixels keep their partners from sample to sample, so the
//! second vertices a pixel takes from a partner are that partner's
//! stratified sequence (blocks that shifted each sample took them from
//! different partners, and their error fell less: Cornell Box, 4–64
//! samples, relMSE 7–18% higher). The wavelengths are the block's first
//! pixel's, also a stratified sequence. (Each pixel keeping its own, with
//! what it took from others added at theirs, cost about 15% more CPU for
//! 2–7% more error.) The price is noise correlated over each block:
//! coarser grain, in blocks of 2 × 2, at low sample counts.

use glam::{Vec3, Vec4};

use crate::drive::PathCounters;
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::material::{facing_frame, ShadingGeometry};
use crate::scene::SurfaceHit;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// Where a path left its first surface, a diffuse one, by the cosine.
#[derive(Clone, Copy)]
pub(super) struct FirstBounce {
    p: Vec3,
    p_err: Vec3,
    /// The geometric normal as the hit gave it, and on `wo`'s side.
    ng: Vec3,
    ng_facing: Vec3,
    /// The shading normal on `wo`'s side: the cosine's axis.
    n: Vec3,
    wo: Vec3,
    /// R/π at the group's wavelengths.
    f: SampledSpectrum,
}

impl FirstBounce {
    pub(super) fn new(hit: &SurfaceHit, wo: Vec3, f: SampledSpectrum) -> Self {
        let (frame, ng_facing) = facing_frame(&ShadingGeometry {
            ng: hit.ng,
            ns: hit.ns,
            wo,
        });
        FirstBounce {
            p: hit.p,
            p_err: hit.p_err,
            ng: hit.ng,
            ng_facing,
            n: frame.n,
            wo,
            f,
        }
    }

    /// The geometry term from here to `x2`: |cos θ| at both ends over the
    /// squared distance, 0 where the bounce does not reflect that way (or
    /// the points coincide). A first bounce's density of reaching `x2`
    /// (area measure, visible) is this over π.
    fn geometry_to(&self, x2: &SecondVertex) -> f32 {
        let to = x2.p - self.p;
        let d2 = to.length_squared();
        if !(d2 > 0.0) {
            return 0.0;
        }
        let dir = to / d2.sqrt();
        self.cos_towards(dir) * x2.ng.dot(dir).abs() / d2
    }

    /// |cos θ| towards `dir` (unit) where the diffuse bounce reflects to
    /// it, as `Diffuse::eval` decides; 0 elsewhere.
    fn cos_towards(&self, dir: Vec3) -> f32 {
        let reflects = self.n.dot(self.wo) * self.n.dot(dir) > 0.0
            && self.wo.dot(self.ng_facing) * dir.dot(self.ng_facing) > 0.0;
        if reflects {
            self.n.dot(dir).abs()
        } else {
            0.0
        }
    }
}

/// The point a path's first bounce reached, and the path there.
#[derive(Clone, Copy)]
pub(super) struct SecondVertex {
    p: Vec3,
    p_err: Vec3,
    ng: Vec3,
    ns: Vec3,
    /// The surface is diffuse: what leaves it is the same every way.
    diffuse: bool,
    /// The light gathered before the path scattered from here, and the
    /// throughput it arrived with.
    l_before: SampledSpectrum,
    beta: SampledSpectrum,
}

impl SecondVertex {
    pub(super) fn new(
        hit: &SurfaceHit,
        diffuse: bool,
        l_before: SampledSpectrum,
        beta: SampledSpectrum,
    ) -> Self {
        SecondVertex {
            p: hit.p,
            p_err: hit.p_err,
            ng: hit.ng,
            ns: hit.ns,
            diffuse,
            l_before,
            beta,
        }
    }

    /// Whether `a` and `b` see the same side of the surface here, by both
    /// normals.
    fn same_side(&self, a: Vec3, b: Vec3) -> bool {
        let (va, vb) = (a - self.p, b - self.p);
        self.ng.dot(va) * self.ng.dot(vb) > 0.0 && self.ns.dot(va) * self.ns.dot(vb) > 0.0
    }
}

/// A group member's sample once its path has ended.
#[derive(Clone, Copy)]
pub(super) struct Member {
    pub order: u64,
    pub sample: (u32, u32, u32),
    /// The group's number in the tile (None: the path is its own).
    pub group: Option<u64>,
    pub l: SampledSpectrum,
    /// The wavelengths the film gets.
    pub wl: SampledWavelengths,
    pub counters: PathCounters,
    pub first: Option<FirstBounce>,
    pub second: Option<SecondVertex>,
}

impl Default for Member {
    fn default() -> Self {
        Member {
            order: 0,
            sample: (0, 0, 0),
            group: None,
            l: SampledSpectrum::ZERO,
            wl: SampledWavelengths {
                lambda: Vec4::ZERO,
                pdf: Vec4::ZERO,
            },
            counters: PathCounters::default(),
            first: None,
            second: None,
        }
    }
}

/// At most this many members to a group: a 2 × 2 block.
pub(super) const GROUP: usize = 4;

/// Replaces each member's light from its first bounce on by the group's
/// estimate of it (see the module's comment), with the shadow rays
/// between the members' first surfaces and second vertices answered by
/// `occluded` (whether each is blocked).
pub(super) fn share(members: &mut [Member], occluded: impl FnOnce(&[Ray], &mut [bool])) {
    debug_assert!(members.len() <= GROUP);
    // The second vertices others may use, and the light leaving each at
    // the wavelengths its path still carried there. A first surface that
    // reflects none of one wavelength (a measured reflectance outside its
    // table) ends only that one: the others are still shared (dropping
    // the whole vertex left a quarter of the Cornell Box's groups, those
    // with a wavelength outside its tables' 400–700 nm, unshared).
    let mut shared: [Option<(SecondVertex, SampledSpectrum)>; GROUP] = [None; GROUP];
    for (k, m) in members.iter().enumerate() {
        if let (Some(_), Some(x2)) = (m.first, m.second) {
            let carried = x2.beta.cmpgt(Vec4::ZERO);
            if x2.diffuse && carried.any() {
                let leaving = (m.l - x2.l_before) / x2.beta;
                shared[k] = Some((x2, Vec4::select(carried, leaving, Vec4::ZERO)));
            }
        }
    }
    if shared.iter().all(Option::is_none) {
        return;
    }
    // Which pairs (i from its first surface, k's second vertex) a shadow
    // ray must answer, and its ray.
    let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); GROUP * GROUP];
    let mut pair = [(0usize, 0usize); GROUP * GROUP];
    let mut n = 0;
    for (i, m) in members.iter().enumerate() {
        let Some(x1) = m.first else { continue };
        for (k, s) in shared.iter().enumerate() {
            let Some((x2, _)) = s else { continue };
            if i == k || !x2.same_side(x1.p, members[k].first.expect("shared").p) {
                continue;
            }
            let dir = x2.p - x1.p;
            if x1.cos_towards(dir.normalize_or_zero()) == 0.0 {
                continue;
            }
            let origin = offset_ray_origin(x1.p, x1.p_err, x1.ng, dir);
            let target = offset_ray_origin(x2.p, x2.p_err, x2.ng, -dir);
            rays[n] = Ray::towards(origin, target);
            pair[n] = (i, k);
            n += 1;
        }
    }
    let mut blocked = [false; GROUP * GROUP];
    occluded(&rays[..n], &mut blocked[..n]);
    let mut visible = [[false; GROUP]; GROUP];
    for (&(i, k), &b) in pair[..n].iter().zip(&blocked[..n]) {
        visible[i][k] = !b;
    }
    for (i, m) in members.iter_mut().enumerate() {
        m.counters.rays += pair[..n].iter().filter(|(a, _)| *a == i).count() as u64;
        if shared[i].is_some() {
            visible[i][i] = true;
        }
    }
    // Each shared vertex's density over the group's first bounces (area
    // measure, visibility included), wavelength by wavelength: a first
    // bounce that reflects none of a wavelength is no technique for it.
    let density = |m: &Member, x2: &SecondVertex, seen: bool| -> SampledSpectrum {
        match m.first {
            Some(x1) if seen => {
                let p = Vec4::splat(x1.geometry_to(x2) * std::f32::consts::FRAC_1_PI);
                Vec4::select(x1.f.cmpgt(Vec4::ZERO), p, Vec4::ZERO)
            }
            _ => Vec4::ZERO,
        }
    };
    let mut sums = [Vec4::ZERO; GROUP];
    for (k, s) in shared.iter().enumerate() {
        let Some((x2, _)) = s else { continue };
        sums[k] = members
            .iter()
            .enumerate()
            .map(|(m, member)| density(member, x2, visible[m][k]))
            .sum();
    }
    for i in 0..members.len() {
        let Some(x1) = members[i].first else { continue };
        let own = match shared[i] {
            // The path's own light from x₂ on is replaced below.
            Some((x2, _)) => x2.l_before,
            None => members[i].l,
        };
        let mut l = own;
        for (k, s) in shared.iter().enumerate() {
            let Some((x2, leaving)) = s else { continue };
            if !visible[i][k] {
                continue;
            }
            let weight = Vec4::splat(x1.geometry_to(x2)) / sums[k];
            l += x1.f * *leaving * Vec4::select(sums[k].cmpgt(Vec4::ZERO), weight, Vec4::ZERO);
        }
        members[i].l = l;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Shadow rays answered: nothing blocks them.
    fn open(_: &[Ray], blocked: &mut [bool]) {
        blocked.fill(false);
    }

    fn wl() -> SampledWavelengths {
        SampledWavelengths {
            lambda: Vec4::new(450.0, 520.0, 590.0, 660.0),
            pdf: Vec4::splat(0.01),
        }
    }

    /// A path from a floor at `x1` (y = 0, seen from above) whose bounce
    /// reached a wall at `x2` (z = 2, facing −z), having gathered `before`
    /// by then and `after` since.
    fn member(x1: Vec3, x2: Vec3, before: f32, after: f32) -> Member {
        let f = SampledSpectrum::splat(0.5 * std::f32::consts::FRAC_1_PI);
        let first = FirstBounce {
            p: x1,
            p_err: Vec3::splat(1e-6),
            ng: Vec3::Y,
            ng_facing: Vec3::Y,
            n: Vec3::Y,
            wo: Vec3::new(0.0, 1.0, -1.0).normalize(),
            f,
        };
        let beta = SampledSpectrum::splat(0.5);
        let second = SecondVertex {
            p: x2,
            p_err: Vec3::splat(1e-6),
            ng: -Vec3::Z,
            ns: -Vec3::Z,
            diffuse: true,
            l_before: SampledSpectrum::splat(before),
            beta,
        };
        Member {
            l: SampledSpectrum::splat(before + after),
            wl: wl(),
            first: Some(first),
            second: Some(second),
            ..Member::default()
        }
    }

    /// The member's light is `want`, to rounding.
    fn assert_light(m: &Member, want: SampledSpectrum) {
        assert!(
            (m.l - want).abs().max_element() < 1e-5,
            "{} against {want}",
            m.l
        );
    }

    #[test]
    fn a_path_alone_keeps_its_light() {
        let mut members = [member(Vec3::ZERO, Vec3::new(0.3, 1.0, 2.0), 0.2, 0.7)];
        share(&mut members, open);
        assert_light(&members[0], SampledSpectrum::splat(0.9));
    }

    /// Paths from one point share their second vertices evenly: each
    /// keeps what it found before them and takes the mean of what all of
    /// them found past them.
    #[test]
    fn paths_from_one_point_take_the_mean_past_it() {
        let x1 = Vec3::new(0.1, 0.0, 0.2);
        let mut members = [
            member(x1, Vec3::new(-1.0, 0.5, 2.0), 0.1, 0.4),
            member(x1, Vec3::new(0.5, 2.0, 2.0), 0.3, 1.6),
            member(x1, Vec3::new(1.5, 1.0, 2.0), 0.0, 0.1),
        ];
        let unshared = members;
        share(&mut members, open);
        let mean_after = (0.4 + 1.6 + 0.1) / 3.0;
        for (m, before) in members.iter().zip([0.1, 0.3, 0.0]) {
            assert_light(m, SampledSpectrum::splat(before + mean_after));
            // Two shadow rays each, to the others' second vertices.
            assert_eq!(m.counters.rays, 2);
        }
        // Where every shadow ray is blocked, each keeps its own.
        let mut members = unshared;
        share(&mut members, |_, blocked| blocked.fill(true));
        for (m, own) in members.iter().zip([0.5, 1.9, 0.1]) {
            assert_light(m, SampledSpectrum::splat(own));
        }
    }

    /// A second vertex that is not diffuse, or that another pixel sees
    /// from the other side of its surface, is its own path's alone.
    #[test]
    fn vertices_that_cannot_be_shared_stay_their_own() {
        let x1 = Vec3::new(0.1, 0.0, 0.2);
        let mut metal = member(x1, Vec3::new(-1.0, 0.5, 2.0), 0.1, 0.4);
        metal.second.as_mut().unwrap().diffuse = false;
        let mut members = [metal, member(x1, Vec3::new(0.5, 2.0, 2.0), 0.3, 1.6)];
        share(&mut members, open);
        // The metal's path keeps its own light and takes half the other's
        // (two techniques could have found that vertex).
        let want = [0.1 + 0.4 + 0.5 * 1.6, 0.3 + 0.5 * 1.6];
        for (m, w) in members.iter().zip(want) {
            assert_light(m, SampledSpectrum::splat(w));
        }
        // From behind the wall (z > 2) the wall's point is not shared.
        let behind = Vec3::new(0.0, 0.0, 2.5);
        let mut members = [
            member(x1, Vec3::new(-1.0, 0.5, 2.0), 0.1, 0.4),
            member(behind, Vec3::new(0.5, 2.0, 2.0), 0.3, 1.6),
        ];
        share(&mut members, open);
        assert_light(&members[0], SampledSpectrum::splat(0.5));
        assert_light(&members[1], SampledSpectrum::splat(1.9));
    }

    /// A first surface that reflects none of one wavelength ends only that
    /// one: the path's vertex is shared at the others, and at that one the
    /// paths that carried it share theirs among themselves.
    #[test]
    fn a_wavelength_one_path_lost_is_shared_by_the_others() {
        let x1 = Vec3::new(0.1, 0.0, 0.2);
        let mut members = [
            member(x1, Vec3::new(-1.0, 0.5, 2.0), 0.1, 0.4),
            member(x1, Vec3::new(0.5, 2.0, 2.0), 0.3, 1.6),
            member(x1, Vec3::new(1.5, 1.0, 2.0), 0.0, 0.1),
        ];
        // The first path's surface reflects nothing at the last wavelength:
        // it carried nothing there past its first bounce.
        let lost = Vec4::new(1.0, 1.0, 1.0, 0.0);
        let m0 = &mut members[0];
        m0.l = Vec4::splat(0.1) + Vec4::splat(0.4) * lost;
        m0.first.as_mut().unwrap().f *= lost;
        m0.second.as_mut().unwrap().beta *= lost;
        share(&mut members, open);
        let all = (0.4 + 1.6 + 0.1) / 3.0;
        let carried = (1.6 + 0.1) / 2.0;
        let want = [
            Vec4::new(0.1 + all, 0.1 + all, 0.1 + all, 0.1),
            Vec4::new(0.3 + all, 0.3 + all, 0.3 + all, 0.3 + carried),
            Vec4::new(all, all, all, carried),
        ];
        for (m, w) in members.iter().zip(want) {
            assert_light(m, w);
        }
    }
}
