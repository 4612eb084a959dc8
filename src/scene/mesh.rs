//! Triangle meshes: built-in shapes, OBJ files, and transforms.

use std::f32::consts::PI;

use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};

/// An indexed triangle mesh in world space.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Per-vertex normals for smooth shading, if any.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates (v down, as in glTF), if any.
    pub uvs: Option<Vec<Vec2>>,
    /// Per-vertex tangents (xyz) with the bitangent sign (w), for normal maps.
    pub tangents: Option<Vec<Vec4>>,
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    /// A planar quad through four corners, front face counter-clockwise.
    pub fn quad(corners: [Vec3; 4]) -> Mesh {
        Mesh {
            positions: corners.to_vec(),
            indices: vec![[0, 1, 2], [0, 2, 3]],
            ..Default::default()
        }
    }

    /// The bytes this mesh's arrays hold.
    pub fn heap_bytes(&self) -> u64 {
        let len = |n: usize, each: usize| (n * each) as u64;
        len(self.positions.len(), 12)
            + self.normals.as_ref().map_or(0, |n| len(n.len(), 12))
            + self.uvs.as_ref().map_or(0, |u| len(u.len(), 8))
            + self.tangents.as_ref().map_or(0, |t| len(t.len(), 16))
            + len(self.indices.len(), 12)
    }

    /// The bytes [`Mesh::sphere`] will hold, known before it is built.
    pub fn sphere_bytes(segments: u32) -> u64 {
        let segments = segments.max(3) as u64;
        let rings = (segments / 2).max(2);
        let vertices = (segments + 1) * (rings + 1);
        vertices * 24 + 2 * segments * rings * 12
    }

    /// A latitude-longitude sphere with outward normals (front face outside).
    pub fn sphere(center: Vec3, radius: f32, segments: u32, smooth: bool) -> Mesh {
        let segments = segments.max(3);
        let rings = (segments / 2).max(2);
        // Reserved exactly (see `sphere_bytes`): no address space to spare.
        let vertices = ((segments + 1) * (rings + 1)) as usize;
        let mut positions = Vec::with_capacity(vertices);
        let mut normals = Vec::with_capacity(vertices);
        for r in 0..=rings {
            // Exact poles: the first and last rings are single points.
            let (sin_t, cos_t) = match r {
                0 => (0.0, 1.0),
                _ if r == rings => (0.0, -1.0),
                _ => (PI * r as f32 / rings as f32).sin_cos(),
            };
            for s in 0..=segments {
                let phi = 2.0 * PI * s as f32 / segments as f32;
                let n = Vec3::new(sin_t * phi.cos(), cos_t, sin_t * phi.sin());
                positions.push(center + radius * n);
                normals.push(n);
            }
        }
        let row = segments + 1;
        let mut indices = Vec::with_capacity((2 * segments * (rings - 1)) as usize);
        for r in 0..rings {
            for s in 0..segments {
                let (a, b) = (r * row + s, r * row + s + 1);
                let (c, d) = (a + row, b + row);
                // At the poles one triangle of each quad has no area: a
                // fan of triangles remains.
                if r != 0 {
                    indices.push([a, b, d]);
                }
                if r != rings - 1 {
                    indices.push([a, d, c]);
                }
            }
        }
        Mesh {
            positions,
            normals: smooth.then_some(normals),
            indices,
            ..Default::default()
        }
    }

    /// Applies an affine transform (normals by the inverse transpose).
    pub fn transform(&mut self, m: &Mat4) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        let linear = Mat3::from_mat4(*m);
        if let Some(normals) = &mut self.normals {
            let nm = linear.inverse().transpose();
            for n in normals {
                *n = (nm * *n).normalize_or_zero();
            }
        }
        if let Some(tangents) = &mut self.tangents {
            // Tangents follow the surface (they are directions in it).
            for t in tangents {
                *t = (linear * t.truncate()).normalize_or_zero().extend(t.w);
            }
        }
        // A mirroring transform turns the winding, and so the front face:
        // swap it back. Vertex normals (inverse transpose) are already right;
        // the tangent frame's handedness changes.
        if linear.determinant() < 0.0 {
            for f in &mut self.indices {
                f.swap(1, 2);
            }
            if let Some(tangents) = &mut self.tangents {
                tangents.iter_mut().for_each(|t| t.w = -t.w);
            }
        }
    }

    /// Reverses the winding and normals, turning the front face around.
    pub fn flip(&mut self) {
        for f in &mut self.indices {
            f.swap(1, 2);
        }
        if let Some(normals) = &mut self.normals {
            normals.iter_mut().for_each(|n| *n = -*n);
        }
        // The bitangent n × t changes sign with n; keep the map's frame.
        if let Some(tangents) = &mut self.tangents {
            tangents.iter_mut().for_each(|t| t.w = -t.w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_faces_point_outward() {
        let m = Mesh::sphere(Vec3::new(1.0, 2.0, 3.0), 2.0, 16, true);
        let c = Vec3::new(1.0, 2.0, 3.0);
        let mut area = 0.0;
        for f in &m.indices {
            let p = f.map(|i| m.positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            // No degenerate triangles, not even at the poles.
            assert!(n.length() > 0.0, "degenerate {p:?}");
            assert!(n.dot((p[0] + p[1] + p[2]) / 3.0 - c) > 0.0, "{p:?} {n}");
            area += 0.5 * n.length();
        }
        // A 16-segment sphere's area is a little under 4πr².
        assert!(
            area < 4.0 * PI * 4.0 && area > 0.9 * 4.0 * PI * 4.0,
            "{area}"
        );
    }

    #[test]
    fn mirroring_keeps_the_outside_outside() {
        let mut m = Mesh::quad([Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]);
        m.transform(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        let p = m.indices[0].map(|i| m.positions[i as usize]);
        assert!((p[1] - p[0]).cross(p[2] - p[0]).z > 0.0);
        // Smooth normals stay on the outside too.
        let mut s = Mesh::sphere(Vec3::ZERO, 1.0, 8, true);
        s.transform(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        for (p, n) in s.positions.iter().zip(s.normals.as_ref().unwrap()) {
            assert!(p.dot(*n) > 0.9, "{p} {n}");
        }
    }
}
