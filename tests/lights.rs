//! Every kind of light of the list (`LightKind::ALL`), so a new one is
//! tested without editing this file: what it samples is finite and
//! positive, and it reports the densities it sampled with — `pdf_li` for
//! next-event samples, `pdf_le` for emitted rays (except the Dirac parts
//! of delta lights, which no direction finds). Lights tabulated over a
//! latitude-longitude grid may report a neighbouring cell's density for a
//! direction sampled within rounding of a cell's edge: at most 1 in 100
//! samples may differ, by at most 10%.

use glam::Vec3;
use prism::light::{LightKind, LightSource};
use prism::sampler::Sampler;
use prism::spectrum::SampledWavelengths;

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-3 * a.abs().max(b.abs()) + 1e-6
}

#[test]
fn every_light_samples_with_the_densities_it_reports() {
    let p = Vec3::new(0.1, 0.0, -0.2);
    let wl = SampledWavelengths::sample_visible(0.4);
    for &kind in LightKind::ALL {
        let light = kind.example();
        assert_eq!(light.kind(), kind);
        let power = light.power();
        assert!(power.is_finite() && power > 0.0, "{kind:?}: power {power}");
        let mut s = Sampler::new(7, 1);
        let (mut arrived, mut left, mut off) = (0, 0, 0);
        for _ in 0..4000 {
            if let Some(ls) = light.sample_li(p, s.next_2d(), &wl) {
                arrived += 1;
                assert!(
                    ls.li.is_finite() && ls.li.min_element() >= 0.0,
                    "{kind:?}: li {:?}",
                    ls.li
                );
                assert!(
                    ls.pdf > 0.0 && ls.pdf.is_finite(),
                    "{kind:?}: pdf {}",
                    ls.pdf
                );
                if !light.is_delta() {
                    let pdf = light.pdf_li(p, ls.wi, ls.point.map(|q| q.p));
                    if !close(pdf, ls.pdf) {
                        off += 1;
                        assert!(
                            (pdf - ls.pdf).abs() <= 0.1 * ls.pdf,
                            "{kind:?}: sampled at {} reports {pdf}",
                            ls.pdf
                        );
                    }
                }
            }
            if let Some(le) = light.sample_le(s.next_2d(), s.next_2d(), &wl) {
                left += 1;
                assert!(
                    le.le.is_finite() && le.le.min_element() >= 0.0,
                    "{kind:?}: le {:?}",
                    le.le
                );
                assert!(le.pdf_pos > 0.0 && le.pdf_dir >= 0.0, "{kind:?}");
                if !light.is_delta() {
                    let (pos, dir) = light.pdf_le(le.point.uv, le.dir);
                    assert!(close(pos, le.pdf_pos), "{kind:?}: {pos} vs {}", le.pdf_pos);
                    if !close(dir, le.pdf_dir) {
                        off += 1;
                        assert!(
                            (dir - le.pdf_dir).abs() <= 0.1 * le.pdf_dir,
                            "{kind:?}: sampled at {} reports {dir}",
                            le.pdf_dir
                        );
                    }
                }
            }
        }
        assert!(
            arrived > 100 && left > 100,
            "{kind:?}: {arrived} and {left} of 4000"
        );
        assert!(
            off * 100 <= arrived + left,
            "{kind:?}: {off} of {} densities differ",
            arrived + left
        );
        eprintln!(
            "{kind:?}: {off} of {} densities at a cell's edge",
            arrived + left
        );
    }
}
