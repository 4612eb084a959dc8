//! Triangulating a polygon of a mesh file (an OBJ face of any size) in its
//! own plane by ear clipping, so concave faces (an L, a star, a ring joined
//! to its hole by a bridge) keep their shape where a fan would fill them.

use glam::{Vec2, Vec3};

/// The triangles of faces given as their corners (indices into
/// `positions`), face after face, `arities[f]` corners each: triangles as
/// they are, larger polygons by `triangulate`. A list of triangles only
/// (what big files hold) is taken as it is, not copied.
pub fn triangles_of_faces(corners: Vec<u32>, arities: &[u32], positions: &[Vec3]) -> Vec<[u32; 3]> {
    if arities.iter().all(|&a| a == 3) {
        // `try_cast_vec` refuses a list whose length or capacity is not a
        // multiple of three; it is then copied.
        return bytemuck::allocation::try_cast_vec::<u32, [u32; 3]>(corners).unwrap_or_else(
            |(_, corners)| {
                corners
                    .chunks_exact(3)
                    .map(|c| [c[0], c[1], c[2]])
                    .collect()
            },
        );
    }
    let mut triangles = Vec::with_capacity(arities.len());
    let mut start = 0;
    for &arity in arities {
        let face = &corners[start..start + arity as usize];
        start += arity as usize;
        if arity == 3 {
            triangles.push([face[0], face[1], face[2]]);
            continue;
        }
        let points: Vec<Vec3> = face.iter().map(|&i| positions[i as usize]).collect();
        triangles.extend(triangulate(&points).into_iter().map(|t| t.map(|k| face[k])));
    }
    triangles
}

/// Polygons above this size fall back to a fan: ear clipping here is
/// quadratic to cubic in the vertex count.
const MAX_EAR_CLIPPED: usize = 4096;

/// Triangles (indices into `points`, in the polygon's winding order) that
/// cover the simple polygon `points`. Degenerate polygons (no area) and
/// ones too large to clip come back as a fan.
pub fn triangulate(points: &[Vec3]) -> Vec<[usize; 3]> {
    let n = points.len();
    if n < 3 {
        return Vec::new();
    }
    let fan = || (1..n - 1).map(|i| [0, i, i + 1]).collect();
    if n == 3 || n > MAX_EAR_CLIPPED {
        return fan();
    }
    let Some(flat) = project(points) else {
        return fan();
    };
    ear_clip(&flat).unwrap_or_else(fan)
}

/// The polygon in 2D, counter-clockwise: its Newell normal's dominant axis
/// dropped, mirrored when the normal points down that axis.
fn project(points: &[Vec3]) -> Option<Vec<Vec2>> {
    let mut normal = Vec3::ZERO;
    for (i, p) in points.iter().enumerate() {
        let q = points[(i + 1) % points.len()];
        normal += Vec3::new(
            (p.y - q.y) * (p.z + q.z),
            (p.z - q.z) * (p.x + q.x),
            (p.x - q.x) * (p.y + q.y),
        );
    }
    let a = normal.abs();
    if !(a.max_element() > 0.0) {
        return None;
    }
    // Keep the two other axes in cyclic order, so the projection of a
    // polygon whose normal is +axis runs counter-clockwise.
    let (axis, sign) = if a.x >= a.y && a.x >= a.z {
        (0, normal.x)
    } else if a.y >= a.z {
        (1, normal.y)
    } else {
        (2, normal.z)
    };
    let flip = if sign < 0.0 { -1.0 } else { 1.0 };
    Some(
        points
            .iter()
            .map(|p| match axis {
                0 => Vec2::new(p.y, p.z * flip),
                1 => Vec2::new(p.z, p.x * flip),
                _ => Vec2::new(p.x, p.y * flip),
            })
            .collect(),
    )
}

fn cross(a: Vec2, b: Vec2, c: Vec2) -> f32 {
    (b - a).perp_dot(c - a)
}

/// Ear clipping of a counter-clockwise polygon. None when it gets stuck
/// (a self-intersecting polygon): the caller fans it.
fn ear_clip(p: &[Vec2]) -> Option<Vec<[usize; 3]>> {
    let n = p.len();
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut out = Vec::with_capacity(n - 2);
    let mut remaining = n;
    let mut i = 0;
    // Vertices visited since the last ear: a full round without one means
    // no ear is left.
    let mut since_ear = 0;
    while remaining > 3 {
        let (a, c) = (prev[i], next[i]);
        if is_ear(p, &next, a, i, c) {
            out.push([a, i, c]);
            next[a] = c;
            prev[c] = a;
            remaining -= 1;
            since_ear = 0;
            i = c;
        } else {
            since_ear += 1;
            if since_ear > remaining {
                return None;
            }
            i = next[i];
        }
    }
    out.push([prev[i], i, next[i]]);
    Some(out)
}

/// Whether (a, b, c) is convex and holds no other vertex of the remaining
/// polygon inside or on its edges (vertices at the same place as a corner,
/// as a bridge to a hole makes, do not count).
fn is_ear(p: &[Vec2], next: &[usize], a: usize, b: usize, c: usize) -> bool {
    let (pa, pb, pc) = (p[a], p[b], p[c]);
    if !(cross(pa, pb, pc) > 0.0) {
        return false;
    }
    // "The same place" within a whisker of the triangle's size.
    let eps2 = 1e-10 * (pa - pb).length_squared().max((pb - pc).length_squared());
    let at_corner = |q: Vec2| {
        [pa, pb, pc]
            .iter()
            .any(|&v| (q - v).length_squared() <= eps2)
    };
    let mut j = next[c];
    while j != a {
        let q = p[j];
        if cross(pa, pb, q) >= 0.0
            && cross(pb, pc, q) >= 0.0
            && cross(pc, pa, q) >= 0.0
            && !at_corner(q)
        {
            return false;
        }
        j = next[j];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(points: &[Vec3], tris: &[[usize; 3]]) -> f32 {
        tris.iter()
            .map(|t| {
                0.5 * (points[t[1]] - points[t[0]])
                    .cross(points[t[2]] - points[t[0]])
                    .length()
            })
            .sum()
    }

    /// Shoelace area of a polygon in the z = 0 plane (signed: CCW positive).
    fn shoelace(points: &[Vec3]) -> f32 {
        (0..points.len())
            .map(|i| {
                let (p, q) = (points[i], points[(i + 1) % points.len()]);
                0.5 * (p.x * q.y - q.x * p.y)
            })
            .sum()
    }

    #[test]
    fn an_l_and_a_star_keep_their_area_and_winding() {
        let l: Vec<Vec3> = [[0., 0.], [2., 0.], [2., 1.], [1., 1.], [1., 2.], [0., 2.]]
            .iter()
            .map(|v| Vec3::new(v[0], v[1], 0.0))
            .collect();
        let star: Vec<Vec3> = (0..10)
            .map(|i| {
                let r = if i % 2 == 0 { 1.0 } else { 0.35 };
                let t = i as f32 * std::f32::consts::PI / 5.0;
                Vec3::new(r * t.cos(), r * t.sin(), 0.0)
            })
            .collect();
        for poly in [l, star] {
            for reversed in [false, true] {
                let mut poly = poly.clone();
                if reversed {
                    poly.reverse();
                }
                let tris = triangulate(&poly);
                assert_eq!(tris.len(), poly.len() - 2);
                assert!((area(&poly, &tris) - shoelace(&poly).abs()).abs() < 1e-5);
                // Every triangle turns the way the polygon does.
                let normal = shoelace(&poly).signum();
                for t in &tris {
                    let z = (poly[t[1]] - poly[t[0]]).cross(poly[t[2]] - poly[t[0]]).z;
                    assert!(z * normal > 0.0, "{t:?}");
                }
            }
        }
    }

    #[test]
    fn a_ring_joined_to_its_hole_by_a_bridge_is_a_ring_in_any_plane() {
        // Outer circle counter-clockwise, a bridge in, the hole clockwise,
        // the bridge back out: 66 vertices.
        let mut ring = Vec::new();
        for i in 0..=32 {
            let t = i as f32 * std::f32::consts::TAU / 32.0;
            ring.push(Vec3::new(0.5 * t.cos(), 0.5 * t.sin(), 0.0));
        }
        for i in (0..=32).rev() {
            let t = i as f32 * std::f32::consts::TAU / 32.0;
            ring.push(Vec3::new(0.3 * t.cos(), 0.3 * t.sin(), 0.0));
        }
        assert_eq!(ring.len(), 66);
        let expected = 0.5 * 32.0 * (0.25 - 0.09) * (std::f32::consts::TAU / 32.0).sin();
        let rotation = glam::Quat::from_euler(glam::EulerRot::XYZ, 0.7, -1.1, 0.3);
        for poly in [ring.clone(), ring.iter().map(|&p| rotation * p).collect()] {
            let tris = triangulate(&poly);
            let a = area(&poly, &tris);
            assert!((a - expected).abs() < 1e-4, "area {a}, expected {expected}");
        }
    }
}
