//! Merging partial renders: spectral EXRs of the same scene, seed and
//! layout, each holding some sample indices of some pixels, combine into the
//! image of all their samples. Every pixel's value is the sample-count
//! weighted mean of the parts (in f64): equal to a single render of the
//! union of the samples up to float32 rounding (the parts store means).

use std::ops::Range;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use crate::film::spectral_exr::{SpectralImage, SAMPLE_COUNT};

/// Header attributes that describe a partial render.
pub const ATTR_SCENE_HASH: &str = "prismSceneHash";
pub const ATTR_SEED: &str = "prismSeed";
pub const ATTR_SAMPLES: &str = "prismSampleRange";
pub const ATTR_REGION: &str = "prismRegion";
/// Marks an adaptive render: its pixels took different sample indices.
pub const ATTR_ADAPTIVE: &str = "prismAdaptive";

/// FNV-1a 64 of some bytes as hex: what identifies the scene a part belongs
/// to (`Scene::content_hash` gives it the hashes of the scene's files).
pub fn scene_hash(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// Parses "START..END" (END exclusive).
pub fn parse_sample_range(s: &str) -> Option<Range<u32>> {
    let (a, b) = s.split_once("..")?;
    let (a, b) = (a.trim().parse().ok()?, b.trim().parse().ok()?);
    (a < b).then_some(a..b)
}

/// Parses "X0,Y0,X1,Y1".
pub fn parse_region(s: &str) -> Option<[u32; 4]> {
    let v: Vec<u32> = s
        .split(',')
        .map(|p| p.trim().parse().ok())
        .collect::<Option<_>>()?;
    let r: [u32; 4] = v.try_into().ok()?;
    (r[0] < r[2] && r[1] < r[3]).then_some(r)
}

struct Part<'a> {
    path: &'a Path,
    image: &'a SpectralImage,
    samples: Range<u32>,
    region: [u32; 4],
}

fn describe(path: &Path, image: &SpectralImage) -> Result<(Range<u32>, [u32; 4])> {
    let attr = |k: &str| {
        image.attributes.get(k).with_context(|| {
            format!(
                "{}: no `{k}` attribute: not a partial render of prism's",
                path.display()
            )
        })
    };
    if image.attributes.contains_key(ATTR_ADAPTIVE) {
        bail!(
            "{}: an adaptive render (--adaptive): its pixels hold different sample indices, \
             which another part would count again; render parts without --adaptive",
            path.display()
        );
    }
    let samples = parse_sample_range(attr(ATTR_SAMPLES)?)
        .with_context(|| format!("{}: bad `{ATTR_SAMPLES}`", path.display()))?;
    let region = parse_region(attr(ATTR_REGION)?)
        .with_context(|| format!("{}: bad `{ATTR_REGION}`", path.display()))?;
    attr(ATTR_SCENE_HASH)?;
    attr(ATTR_SEED)?;
    for channel in [SAMPLE_COUNT, "R", "G", "B"] {
        if !image.other.contains_key(channel) {
            bail!(
                "{}: no `{channel}` channel: not a partial render of prism's",
                path.display()
            );
        }
    }
    Ok((samples, region))
}

fn overlap(a: &Range<u32>, b: &Range<u32>) -> bool {
    a.start < b.end && b.start < a.end
}

/// Merges parts; refuses parts of different scenes, seeds, resolutions or
/// spectral layouts, and parts whose samples overlap.
pub fn merge(parts: &[(PathBuf, SpectralImage)]) -> Result<SpectralImage> {
    let Some((first_path, first)) = parts.first() else {
        bail!("nothing to merge");
    };
    let mut described = Vec::new();
    for (path, image) in parts {
        let (samples, region) = check_part(first_path, first, path, image)?;
        described.push(Part {
            path,
            image,
            samples,
            region,
        });
    }
    check_no_overlap(&described)?;
    let (mut merged, total) = merged_planes(first, &described);
    describe_merged(&mut merged, &described, &total);
    Ok(merged)
}

/// A part's sample range and region, once it is checked to be of the same
/// render as the first part and to hold samples only where it says.
fn check_part(
    first_path: &Path,
    first: &SpectralImage,
    path: &Path,
    image: &SpectralImage,
) -> Result<(Range<u32>, [u32; 4])> {
    let (samples, region) = describe(path, image)?;
    let same = |k: &str| image.attributes.get(k) == first.attributes.get(k);
    let mismatch = |what: &str| {
        anyhow::anyhow!(
            "{} and {} are of different {what}",
            first_path.display(),
            path.display()
        )
    };
    if !same(ATTR_SCENE_HASH) {
        return Err(mismatch("scenes (scene hash)"));
    }
    if !same(ATTR_SEED) {
        return Err(mismatch("seeds"));
    }
    if (image.width, image.height) != (first.width, first.height) {
        return Err(mismatch("resolutions"));
    }
    if image.wavelengths != first.wavelengths || image.other.keys().ne(first.other.keys()) {
        return Err(mismatch("spectral layouts"));
    }
    // The region the attributes claim must hold every sample the part
    // has: a part with samples outside it (forged, or edited) could
    // overlap another one unseen.
    let counts = &image.other[SAMPLE_COUNT];
    let [x0, y0, x1, y1] = region;
    if x1 > image.width as u32 || y1 > image.height as u32 {
        bail!(
            "{}: region {region:?} lies outside the {}×{} image",
            path.display(),
            image.width,
            image.height
        );
    }
    for (i, &c) in counts.iter().enumerate() {
        let (x, y) = ((i % image.width) as u32, (i / image.width) as u32);
        let inside = (x0..x1).contains(&x) && (y0..y1).contains(&y);
        if c != 0.0 && !inside {
            bail!(
                    "{}: pixel ({x}, {y}) has {c} samples outside the part's region {region:?}: the part is not what its attributes say",
                    path.display()
                );
        }
        if !(c >= 0.0 && c.is_finite()) {
            bail!("{}: pixel ({x}, {y}) has {c} samples", path.display());
        }
    }
    Ok((samples, region))
}

/// Refuses parts that hold the same samples of the same pixels.
fn check_no_overlap(described: &[Part]) -> Result<()> {
    for (i, a) in described.iter().enumerate() {
        for b in &described[i + 1..] {
            let regions_meet = a.region[0] < b.region[2]
                && b.region[0] < a.region[2]
                && a.region[1] < b.region[3]
                && b.region[1] < a.region[3];
            if regions_meet && overlap(&a.samples, &b.samples) {
                bail!(
                    "{} (samples {:?}) and {} (samples {:?}) overlap: the same samples of the same pixels would count twice",
                    a.path.display(),
                    a.samples,
                    b.path.display(),
                    b.samples
                );
            }
        }
    }
    Ok(())
}

/// The parts' planes, each pixel the sample-weighted mean of the parts'
/// (the sample counts summed), and each pixel's total sample count.
fn merged_planes(first: &SpectralImage, described: &[Part]) -> (SpectralImage, Vec<f64>) {
    let n = first.width * first.height;
    let counts: Vec<&Vec<f32>> = described
        .iter()
        .map(|p| &p.image.other[SAMPLE_COUNT])
        .collect();
    let total: Vec<f64> = (0..n)
        .map(|i| counts.iter().map(|c| c[i] as f64).sum())
        .collect();
    let weighted_mean = |plane_of: &dyn Fn(&SpectralImage) -> &Vec<f32>| -> Vec<f32> {
        (0..n)
            .map(|i| {
                if total[i] == 0.0 {
                    return 0.0;
                }
                let sum: f64 = described
                    .iter()
                    .zip(&counts)
                    .map(|(p, c)| plane_of(p.image)[i] as f64 * c[i] as f64)
                    .sum();
                (sum / total[i]) as f32
            })
            .collect()
    };
    let mut merged = first.clone();
    for b in 0..first.spectral.len() {
        merged.spectral[b] = weighted_mean(&|img| &img.spectral[b]);
    }
    for name in first.other.keys() {
        if name != SAMPLE_COUNT {
            merged
                .other
                .insert(name.clone(), weighted_mean(&|img| &img.other[name]));
        }
    }
    merged.other.insert(
        SAMPLE_COUNT.into(),
        total.iter().map(|&t| t as f32).collect(),
    );
    (merged, total)
}

/// The merged image's attributes: its sample range(s), region, fewest
/// samples a pixel and number of parts.
fn describe_merged(merged: &mut SpectralImage, described: &[Part], total: &[f64]) {
    // The merged sample range, where the parts form one.
    let mut ranges: Vec<Range<u32>> = described.iter().map(|p| p.samples.clone()).collect();
    ranges.sort_by_key(|r| (r.start, r.end));
    ranges.dedup();
    let contiguous = ranges.windows(2).all(|w| w[0].end == w[1].start);
    let description = if contiguous {
        format!("{}..{}", ranges[0].start, ranges[ranges.len() - 1].end)
    } else {
        ranges
            .iter()
            .map(|r| format!("{}..{}", r.start, r.end))
            .collect::<Vec<_>>()
            .join(",")
    };
    merged.attributes.insert(ATTR_SAMPLES.into(), description);
    let bounds = described.iter().fold([u32::MAX, u32::MAX, 0, 0], |b, p| {
        [
            b[0].min(p.region[0]),
            b[1].min(p.region[1]),
            b[2].max(p.region[2]),
            b[3].max(p.region[3]),
        ]
    });
    merged
        .attributes
        .insert(ATTR_REGION.into(), bounds.map(|v| v.to_string()).join(","));
    let min = total.iter().copied().fold(f64::INFINITY, f64::min);
    merged
        .attributes
        .insert("prismMinSamplesPerPixel".into(), (min as u64).to_string());
    merged
        .attributes
        .insert("prismMergedParts".into(), described.len().to_string());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_and_regions_parse() {
        assert_eq!(parse_sample_range("0..16"), Some(0..16));
        assert_eq!(parse_sample_range("16..16"), None);
        assert_eq!(parse_sample_range("a..3"), None);
        assert_eq!(parse_region("0,0,64,32"), Some([0, 0, 64, 32]));
        assert_eq!(parse_region("0,0,64"), None);
        assert_eq!(parse_region("5,0,5,10"), None);
        // FNV-1a 64's published test vectors.
        assert_eq!(scene_hash(b""), "cbf29ce484222325");
        assert_eq!(scene_hash(b"a"), "af63dc4c8601ec8c");
        assert_eq!(scene_hash(b"foobar"), "85944171f73967e8");
    }
}
