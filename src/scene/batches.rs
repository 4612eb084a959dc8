//! Rays traced together: as a stream, whose walks take turns so that
//! their waits for memory overlap (big trees), or eight or sixteen at a
//! time (`packet_width`) through a small tree, one to a SIMD lane. Both
//! answer as `intersect` and `occluded` answer each ray.

use super::{Scene, SurfaceHit};
use crate::geometry::bvh::{packet_width, MAX_PACKET_WIDTH};
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
    /// `packet_width()` at a time through the tree together where it is
    /// small enough for that to pay (`Bvh::prefers_packets`), else one by
    /// one.
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<SurfaceHit>]) {
        if !self.cutouts.is_empty() || !self.geometry.bvh.prefers_packets() {
            for (hit, ray) in hits.iter_mut().zip(rays) {
                *hit = self.intersect(ray);
            }
            return;
        }
        let mut triangles = [None; MAX_PACKET_WIDTH];
        let width = packet_width();
        for (rays, hits) in rays.chunks(width).zip(hits.chunks_mut(width)) {
            let triangles = &mut triangles[..rays.len()];
            self.geometry.bvh.intersect_packet(rays, triangles);
            for ((hit, ray), triangle) in hits.iter_mut().zip(rays).zip(triangles.iter()) {
                *hit = self.surface_along(ray, *triangle);
            }
        }
    }

    /// `occluded` for every ray of `rays`, `packet_width()` at a time as
    /// `intersect_packet`.
    pub fn occluded_packet(&self, rays: &[Ray], blocked: &mut [bool]) {
        if !self.cutouts.is_empty() || !self.geometry.bvh.prefers_packets() {
            for (b, ray) in blocked.iter_mut().zip(rays) {
                *b = self.occluded(ray);
            }
            return;
        }
        let width = packet_width();
        for (rays, blocked) in rays.chunks(width).zip(blocked.chunks_mut(width)) {
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
