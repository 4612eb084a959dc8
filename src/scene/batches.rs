//! Rays traced together: as a stream, whose walks take turns so that
//! their waits for memory overlap (big trees), or eight at a time through
//! a small tree, one to a SIMD lane. Both answer as `intersect` and
//! `occluded` answer each ray.

use super::{Scene, SurfaceHit};
use crate::geometry::triangle;
use crate::geometry::Ray;

impl Scene {
    /// `intersect` for every ray of `rays` (`hits[i]` answers `rays[i]`,
    /// bit for bit as `intersect` would): the triangles' walks interleaved
    /// as a stream (`Bvh::intersect_stream`), so that on a mesh that
    /// outgrows the caches their waits for memory overlap.
    pub fn intersect_stream(
        &self,
        rays: &[Ray],
        triangles: &mut [Option<(u32, triangle::TriangleHit)>],
        hits: &mut [Option<SurfaceHit>],
    ) {
        if !self.cutouts.is_empty() {
            // Rays that pass cut-outs go on from there: one at a time.
            for (hit, ray) in hits.iter_mut().zip(rays) {
                *hit = self.intersect(ray);
            }
            return;
        }
        self.geometry.bvh.intersect_stream(rays, triangles);
        for ((hit, ray), triangle) in hits.iter_mut().zip(rays).zip(triangles.iter()) {
            *hit = self.surface_along(ray, *triangle);
        }
    }

    /// `intersect` for every ray of `rays` (`hits[i]` answers `rays[i]`),
    /// eight at a time through the tree together where it is small enough
    /// for that to pay (`Bvh::prefers_packets`), else one by one.
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<SurfaceHit>]) {
        if !self.cutouts.is_empty() || !self.geometry.bvh.prefers_packets() {
            for (hit, ray) in hits.iter_mut().zip(rays) {
                *hit = self.intersect(ray);
            }
            return;
        }
        let mut triangles = [None; 8];
        for (rays, hits) in rays.chunks(8).zip(hits.chunks_mut(8)) {
            let triangles = &mut triangles[..rays.len()];
            self.geometry.bvh.intersect_packet(rays, triangles);
            for ((hit, ray), triangle) in hits.iter_mut().zip(rays).zip(triangles.iter()) {
                *hit = self.surface_along(ray, *triangle);
            }
        }
    }

    /// `occluded` for every ray of `rays`, eight at a time as
    /// `intersect_packet`.
    pub fn occluded_packet(&self, rays: &[Ray], blocked: &mut [bool]) {
        if !self.cutouts.is_empty() || !self.geometry.bvh.prefers_packets() {
            for (b, ray) in blocked.iter_mut().zip(rays) {
                *b = self.occluded(ray);
            }
            return;
        }
        for (rays, blocked) in rays.chunks(8).zip(blocked.chunks_mut(8)) {
            self.geometry.bvh.occluded_packet(rays, blocked);
        }
        if !self.geometry.spheres.is_empty() {
            for (b, ray) in blocked.iter_mut().zip(rays) {
                *b = *b || self.geometry.spheres.occluded(ray);
            }
        }
    }

    /// `occluded` for every ray of `rays` (`blocked[i]` answers
    /// `rays[i]`), the triangles' walks interleaved as in `intersect_stream`.
    pub fn occluded_stream(&self, rays: &[Ray], blocked: &mut [bool]) {
        if !self.cutouts.is_empty() {
            for (b, ray) in blocked.iter_mut().zip(rays) {
                *b = self.occluded(ray);
            }
            return;
        }
        self.geometry.bvh.occluded_stream(rays, blocked);
        if !self.geometry.spheres.is_empty() {
            for (b, ray) in blocked.iter_mut().zip(rays) {
                *b = *b || self.geometry.spheres.occluded(ray);
            }
        }
    }
}
