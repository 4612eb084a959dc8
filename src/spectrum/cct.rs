//! Chromaticity coordinates of a colour and its correlated colour
//! temperature: CIE 1960 (u, v), CIE 1976 (u′, v′), and CCT with Duv by
//! Ohno's method (Ohno 2014, "Practical use and calculation of CCT and
//! Duv", LEUKOS 10(1)), against the Planckian locus computed with the CIE
//! 1931 observer as CIE 15 defines CCT.

use glam::{DVec2, DVec3};

use super::cie::{cmfs, CMF_START};

/// CIE 1960 UCS (u, v) of XYZ.
pub fn uv_1960(xyz: DVec3) -> DVec2 {
    let d = xyz.x + 15.0 * xyz.y + 3.0 * xyz.z;
    DVec2::new(4.0 * xyz.x / d, 6.0 * xyz.y / d)
}

/// CIE 1976 UCS (u′, v′) of XYZ.
pub fn uv_1976(xyz: DVec3) -> DVec2 {
    let uv = uv_1960(xyz);
    DVec2::new(uv.x, 1.5 * uv.y)
}

/// CIE (x, y) of XYZ.
pub fn xy(xyz: DVec3) -> DVec2 {
    DVec2::new(xyz.x, xyz.y) / (xyz.x + xyz.y + xyz.z)
}

/// (u, v) of a blackbody at `kelvin`, in f64 over the CIE 1931 1 nm table.
fn planck_uv(kelvin: f64) -> DVec2 {
    const C2: f64 = 1.438_776_877e-2; // m·K
    let xyz: DVec3 = cmfs()
        .xyz
        .iter()
        .enumerate()
        .map(|(i, bar)| {
            let l = (CMF_START + i) as f64 * 1e-9;
            // Planck's law up to a constant factor (it cancels in u, v).
            bar.as_dvec3() / (l.powi(5) * ((C2 / (l * kelvin)).exp() - 1.0))
        })
        .sum();
    uv_1960(xyz)
}

/// The correlated colour temperature (K) and Duv (signed distance from the
/// Planckian locus in (u, v), positive above it) of the chromaticity `uv`,
/// by Ohno's combined method: the nearest point of a table of the locus
/// from 1000 to 100 000 K in 1% steps, refined by re-tabulating around it
/// (as colour-science does), then the triangular solution close to the
/// locus (|Duv| < 0.002) and the parabolic one further away. None outside
/// the table's range.
pub fn cct_duv(uv: DVec2) -> Option<(f64, f64)> {
    let mut temperatures: Vec<f64> = (0..=463).map(|i| 1000.0 * 1.01f64.powi(i)).collect();
    let (mut ts, mut ds) = (temperatures.clone(), Vec::new());
    for refinement in 0..6 {
        ds = temperatures
            .iter()
            .map(|&t| (planck_uv(t) - uv).length())
            .collect();
        let m = (0..ds.len()).min_by(|&a, &b| ds[a].total_cmp(&ds[b]))?;
        if refinement == 0 && (m == 0 || m == ds.len() - 1) {
            return None;
        }
        let m = m.clamp(1, ds.len() - 2);
        ts = vec![temperatures[m - 1], temperatures[m], temperatures[m + 1]];
        ds = vec![ds[m - 1], ds[m], ds[m + 1]];
        temperatures = (0..=10)
            .map(|k| ts[0] + (ts[2] - ts[0]) * k as f64 / 10.0)
            .collect();
    }
    let ([t0, t1, t2], [d0, d1, d2]) = ([ts[0], ts[1], ts[2]], [ds[0], ds[1], ds[2]]);
    // Triangular solution between the neighbours of the nearest point.
    let (p0, p2) = (planck_uv(t0), planck_uv(t2));
    let l = (p2 - p0).length();
    let x = (d0 * d0 - d2 * d2 + l * l) / (2.0 * l);
    let t = t0 + (t2 - t0) * x / l;
    let on_locus = planck_uv(t);
    let sign = if uv.y >= on_locus.y { 1.0 } else { -1.0 };
    let duv = sign * (d0 * d0 - x * x).max(0.0).sqrt();
    if duv.abs() < 0.002 {
        return Some((t, duv));
    }
    // Parabolic solution through the three distances.
    let big_x = (t2 - t1) * (t0 - t2) * (t1 - t0);
    let a = (t0 * (d2 - d1) + t1 * (d0 - d2) + t2 * (d1 - d0)) / big_x;
    let b = -(t0 * t0 * (d2 - d1) + t1 * t1 * (d0 - d2) + t2 * t2 * (d1 - d0)) / big_x;
    let c =
        -(d0 * (t2 - t1) * t1 * t2 + d1 * (t0 - t2) * t0 * t2 + d2 * (t1 - t0) * t0 * t1) / big_x;
    let t = -b / (2.0 * a);
    Some((t, sign * (a * t * t + b * t + c)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blackbody_is_its_own_cct_on_the_locus() {
        for kelvin in [1500.0, 2856.0, 4000.0, 6504.0, 10_000.0, 25_000.0] {
            let (t, duv) = cct_duv(planck_uv(kelvin)).unwrap();
            assert!((t - kelvin).abs() < 1e-3 * kelvin, "{kelvin}: {t}");
            assert!(duv.abs() < 1e-5, "{kelvin}: {duv}");
        }
    }

    #[test]
    fn points_off_the_locus_have_their_distance_as_duv() {
        // Move 0.01 perpendicular to the locus at 5000 K, above and below.
        let (a, b) = (planck_uv(4990.0), planck_uv(5010.0));
        let tangent = (b - a).normalize();
        let normal = DVec2::new(-tangent.y, tangent.x);
        let normal = if normal.y > 0.0 { normal } else { -normal };
        for offset in [0.01, -0.01, 0.001] {
            let (t, duv) = cct_duv(planck_uv(5000.0) + normal * offset).unwrap();
            assert!((duv - offset).abs() < 1e-4, "{offset}: {duv}");
            assert!((t - 5000.0).abs() < 20.0, "{offset}: {t}");
        }
        assert!(cct_duv(DVec2::new(0.6, 0.3)).is_none());
    }
}
