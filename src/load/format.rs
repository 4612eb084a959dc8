//! The TOML scene format, version 1: serde structures with their defaults.
//! Every table rejects unknown keys; docs/scene-format.md documents each
//! key (tests/docs.rs checks it against these structures).

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Deserialize;

use super::exact;
use super::spectrum_spec::{IorSpec, SpectrumSpec};
use crate::film::{ColourSpace, Display, Gamut, Sampling, Tonemap};
use crate::integrator::IntegratorSpec;
use crate::spectrum::cie::Observer;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub camera: CameraSpec,
    #[serde(default)]
    pub film: FilmSpec,
    #[serde(default)]
    pub integrator: IntegratorSpec,
    /// Named spectra that materials and shapes can refer to by name.
    #[serde(default)]
    pub spectra: BTreeMap<String, SpectrumSpec>,
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSpec>,
    /// Measured sets: every sample of a spectrum file of named columns (a
    /// CGATS measurement) as a diffuse material `SET.SAMPLE`.
    #[serde(default)]
    pub measured: BTreeMap<String, MeasuredSet>,
    #[serde(default, rename = "shape")]
    pub shapes: Vec<ShapeSpec>,
    /// Lights that are not shapes: point, spot and directional.
    #[serde(default, rename = "light")]
    pub lights: Vec<LightSpec>,
    /// Light from every direction at infinity.
    pub environment: Option<EnvironmentSpec>,
    /// A medium filling the world (fog around everything).
    pub medium: Option<MediumSpec>,
    /// Metres per scene unit (default 1), for media coefficients given per metre.
    pub units: Option<f32>,
}

/// A `[measured.NAME]` table.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredSet {
    /// The file: CGATS.17, or a CSV with a header naming its columns.
    pub file: PathBuf,
}

/// The `[environment]` table: a constant radiance, or an equirectangular
/// image.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSpec {
    /// Radiance from every direction, a spectrum.
    pub radiance: Option<SpectrumSpec>,
    /// An equirectangular map: .exr or .hdr (linear), or PNG/JPEG (sRGB).
    pub file: Option<String>,
    /// The Hosek–Wilkie sky and sun.
    pub sky: Option<SkySpec>,
    /// Multiplies the radiance.
    pub scale: Option<f32>,
    /// Degrees about the up axis (+y), maps only.
    pub rotate: Option<f32>,
}

/// `environment.sky`: the spectral Hosek–Wilkie sky with its sun.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkySpec {
    /// Degrees above the horizon, 0 to 90.
    pub sun_elevation: f32,
    /// Degrees about +y, from +z towards +x (default 0).
    pub sun_azimuth: Option<f32>,
    /// Atmospheric turbidity, 1 (very clear) to 10 (hazy); default 3.
    pub turbidity: Option<f32>,
    /// Reflectance of the ground under the atmosphere, 0 to 1; default 0.3.
    pub ground_albedo: Option<SpectrumSpec>,
    /// Multiplies the sun's disc (default 1; 0 leaves the sky alone).
    pub sun_scale: Option<f32>,
    /// Multiplies the sky dome (default 1).
    pub sky_scale: Option<f32>,
    /// The sun's angular diameter in degrees (default 0.5358, the real
    /// sun's); larger softens shadows and keeps the irradiance.
    pub sun_aperture: Option<f32>,
}

/// A `[[light]]`: a point, spot or directional light (area lights are
/// shapes with `emission`). The keys of its `type`, beside `scale`.
#[derive(Debug, Deserialize)]
pub struct LightSpec {
    #[serde(flatten)]
    pub common: LightCommon,
    #[serde(flatten)]
    pub kind: LightKind,
}

/// The keys every light takes.
#[derive(Debug, Deserialize)]
pub struct LightCommon {
    /// Multiplies the spectrum.
    pub scale: Option<f32>,
}

/// The keys every type of a typed table takes (beside those of its type),
/// by the table's name: what an error for a key of the table lists.
pub fn keys_every_type_takes(table: &str) -> &'static [&'static str] {
    match table {
        "shape" => crate::schema::keys_of::<ShapeCommon>(),
        "light" => crate::schema::keys_of::<LightCommon>(),
        _ => &[],
    }
}

/// A light's `type`, with the keys that type takes.
#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum LightKind {
    Point(PointLightSpec),
    Spot(SpotLightSpec),
    Directional(DirectionalLightSpec),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightSpec {
    /// Where the light is.
    #[serde(deserialize_with = "exact::array")]
    pub position: [f32; 3],
    /// Radiant intensity per nm, a spectrum.
    pub intensity: Option<SpectrumSpec>,
    /// Total emitted power per nm instead of `intensity`.
    pub power: Option<SpectrumSpec>,
    /// The luminous flux in lumens: scales `intensity` or `power`.
    pub lumens: Option<f32>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotLightSpec {
    /// Where the light is.
    #[serde(deserialize_with = "exact::array")]
    pub position: [f32; 3],
    /// The point the cone's axis goes through.
    #[serde(deserialize_with = "exact::array")]
    pub look_at: [f32; 3],
    /// Radiant intensity per nm on the axis, a spectrum.
    pub intensity: Option<SpectrumSpec>,
    /// Total emitted power per nm instead of `intensity`.
    pub power: Option<SpectrumSpec>,
    /// The luminous flux into the cone in lumens: scales `intensity` or
    /// `power`.
    pub lumens: Option<f32>,
    /// Half-angle in degrees where the light ends (default 30).
    pub cone_angle: Option<f32>,
    /// Half-angle in degrees where it starts to fall off (default:
    /// `cone_angle` − 5, at least 0).
    pub falloff_start: Option<f32>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalLightSpec {
    /// The direction the light travels in.
    #[serde(deserialize_with = "exact::array")]
    pub direction: [f32; 3],
    /// Irradiance on a surface facing the light, a spectrum.
    pub irradiance: SpectrumSpec,
    /// The illuminance in lux on a surface facing the light: scales
    /// `irradiance`.
    pub lux: Option<f32>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    #[serde(default, deserialize_with = "exact::option")]
    pub position: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "exact::option")]
    pub look_at: Option<[f32; 3]>,
    /// Take the camera from a glTF file (its first perspective camera, or
    /// the one called `name`) instead of position/look_at/up/fov.
    pub from_file: Option<PathBuf>,
    pub name: Option<String>,
    #[serde(default = "default_up", deserialize_with = "exact::array")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees (default 40 unless focal_length is given).
    pub fov: Option<f32>,
    /// Lens focal length in mm; with `film_height` it sets the field of view.
    pub focal_length: Option<f32>,
    /// Height of the film (sensor) in mm, for `focal_length`.
    #[serde(default = "default_film_height")]
    pub film_height: f32,
    /// "perspective" (default) or "orthographic".
    #[serde(default, rename = "type")]
    pub kind: CameraKind,
    /// Orthographic: the width of the view in scene units.
    pub width: Option<f32>,
    /// Thin lens: its radius in scene units.
    pub aperture_radius: Option<f32>,
    /// Thin lens: the f-number, with `focal_length` (scene units taken as metres).
    pub f_number: Option<f32>,
    /// Thin lens: the distance in focus, along the view (default: to `look_at`).
    pub focus_distance: Option<f32>,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum CameraKind {
    #[default]
    Perspective,
    Orthographic,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

fn default_film_height() -> f32 {
    24.0
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FilmSpec {
    /// [width, height] in pixels.
    #[serde(deserialize_with = "exact::array")]
    pub resolution: [u32; 2],
    /// Samples per pixel.
    pub spp: u32,
    /// Former place of `integrator.max_depth`, still read (with a warning).
    pub max_depth: Option<u32>,
    /// Seed of every random decision; the same seed gives the same image.
    pub seed: u64,
    /// "adaptive" or "uniform" (unset: uniform).
    pub sampling: Option<Sampling>,
    /// Exposure in stops applied to the PNG (the EXR stays radiometric).
    pub exposure: f32,
    /// The EXRs' XYZ and RGB in absolute units: Y is luminance in cd/m²
    /// (683 lm/W × ∫ L ȳ dλ) for emission in W·m⁻²·sr⁻¹·nm⁻¹.
    pub photometric: bool,
    /// Tone map for the PNG.
    pub tonemap: Tonemap,
    /// Wavelength range [min, max] in nm of the spectral buckets.
    #[serde(deserialize_with = "exact::array")]
    pub spectral_range: [f32; 2],
    /// Number of equal-width spectral buckets over `spectral_range`.
    pub spectral_buckets: u32,
    /// Write the spectral OpenEXR (NAME.spectral.exr) next to the RGB files.
    pub spectral: bool,
    /// RGB space of the EXRs.
    pub colour_space: ColourSpace,
    /// Colour-matching functions the film integrates with.
    pub observer: Observer,
    /// The illuminant that renders neutral: a name, or { temperature = K }.
    pub white_balance: Option<toml::Value>,
    /// The display the PNG is for.
    pub display: Display,
    /// Bits per PNG sample, 8 or 16.
    pub png_bits: u8,
    /// Out-of-gamut display colours: "clip" or "map".
    pub gamut: Gamut,
    /// Extra outputs of NAME.exr: "albedo", "normal", "depth", "sample_count".
    pub aovs: Vec<String>,
}

impl Default for FilmSpec {
    fn default() -> Self {
        Self {
            resolution: [512, 512],
            spp: 64,
            max_depth: None,
            seed: 0,
            sampling: None,
            exposure: 0.0,
            photometric: false,
            tonemap: Tonemap::Clamp,
            spectral_range: [380.0, 780.0],
            spectral_buckets: 40,
            spectral: true,
            colour_space: ColourSpace::SrgbLinear,
            observer: Observer::Cie1931,
            white_balance: None,
            display: Display::Srgb,
            png_bits: 8,
            gamut: Gamut::Clip,
            aovs: Vec::new(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum MaterialSpec {
    Diffuse {
        #[serde(default = "default_reflectance")]
        reflectance: SpectrumSpec,
        /// An image (sRGB colour) that multiplies `reflectance`.
        texture: Option<PathBuf>,
    },
    /// A metal: `metal = "Au" | "Ag" | "Cu" | "Al"`, or `eta` and `k` spectra.
    Conductor {
        metal: Option<String>,
        eta: Option<SpectrumSpec>,
        k: Option<SpectrumSpec>,
        /// 0 (mirror) to 1; α = roughness².
        #[serde(default)]
        roughness: f32,
    },
    /// A transparent dielectric (glass, water, gems).
    Dielectric {
        #[serde(default = "default_ior")]
        ior: IorSpec,
        /// 0 (smooth) to 1; α = roughness².
        #[serde(default)]
        roughness: f32,
        /// Where volumes overlap, the higher priority fills the overlap.
        #[serde(default)]
        priority: i32,
        /// What fills it: absorbing (coloured glass, water) or scattering.
        medium: Option<MediumSpec>,
    },
    /// A diffuse surface that fluoresces (optical brighteners, inks,
    /// highlighters): `reflectance` is its ordinary reflectance; the light
    /// it re-emits is a Donaldson matrix file (`donaldson`), or an
    /// `excitation` spectrum (the share absorbed, 0 to 1), an `emission`
    /// spectrum (its shape) and a `quantum_yield`.
    Fluorescent {
        #[serde(default = "default_reflectance")]
        reflectance: SpectrumSpec,
        /// A CSV: a header of emission wavelengths (nm) after a first
        /// cell that is not a number, then one row per excitation
        /// wavelength: D(λx, λm), per nm of excitation.
        donaldson: Option<PathBuf>,
        excitation: Option<SpectrumSpec>,
        emission: Option<SpectrumSpec>,
        /// Photons emitted per photon absorbed, 0 to 1.
        quantum_yield: Option<f32>,
    },
    /// An index-matched boundary around a medium (fog, smoke): rays cross it
    /// without refracting.
    Interface {
        #[serde(default)]
        priority: i32,
        medium: MediumSpec,
    },
}

/// A homogeneous participating medium. Coefficients are per metre (the
/// scene's `units` gives metres per scene unit). Absorption is given as a
/// spectrum (`absorption`), or in glTF's form: the colour white light takes
/// after `attenuation_distance` metres.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumSpec {
    /// σa(λ) in 1/m; "water" is pure water's (Segelstein 1981).
    pub absorption: Option<SpectrumSpec>,
    /// σs(λ) in 1/m (default 0: the medium only absorbs).
    pub scattering: Option<SpectrumSpec>,
    /// glTF KHR_materials_volume: linear sRGB colour in (0, 1] ...
    #[serde(default, deserialize_with = "exact::option")]
    pub attenuation_color: Option<[f32; 3]>,
    /// ... reached after this distance in metres.
    pub attenuation_distance: Option<f32>,
    /// The phase function (default isotropic).
    pub phase: Option<PhaseSpec>,
}

/// `phase = { hg = g }`: Henyey–Greenstein with mean cosine g in (−1, 1).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhaseSpec {
    pub hg: f32,
}

fn default_ior() -> IorSpec {
    IorSpec::Constant(1.5)
}

fn default_reflectance() -> SpectrumSpec {
    SpectrumSpec::Constant(0.5)
}

/// The list of shape types, one line each: the `type` a `[[shape]]`
/// names and the struct of the keys that type takes. `ShapeKind::ALL`
/// enumerates them, so tests that must cover every shape iterate it (and
/// match each kind exhaustively for an example).
macro_rules! shape_kinds {
    ($($kind:ident($spec:ty) => $name:literal,)*) => {
        /// A shape's `type`, with the keys that type takes.
        #[derive(Debug, Deserialize)]
        #[serde(tag = "type")]
        pub enum ShapeGeometry {
            $(#[serde(rename = $name)] $kind($spec),)*
        }

        /// A shape's `type`.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum ShapeKind {
            $($kind,)*
        }

        impl ShapeKind {
            /// Every shape type.
            pub const ALL: &'static [ShapeKind] = &[$(ShapeKind::$kind,)*];

            /// The `type` the scene file gives.
            pub fn name(self) -> &'static str {
                match self {
                    $(ShapeKind::$kind => $name,)*
                }
            }

            /// The keys of this type (beside [`ShapeCommon`]'s), from its schema.
            pub fn keys(self) -> &'static [&'static str] {
                match self {
                    $(ShapeKind::$kind => crate::schema::keys_of::<$spec>(),)*
                }
            }
        }

        impl ShapeGeometry {
            pub fn kind(&self) -> ShapeKind {
                match self {
                    $(ShapeGeometry::$kind(_) => ShapeKind::$kind,)*
                }
            }
        }
    };
}

shape_kinds! {
    Obj(FileShape) => "obj",
    Gltf(GltfShape) => "gltf",
    Quad(QuadShape) => "quad",
    Sphere(SphereShape) => "sphere",
}

/// A `[[shape]]`: the keys every shape takes, and those of its `type`.
#[derive(Debug, Deserialize)]
pub struct ShapeSpec {
    #[serde(flatten)]
    pub common: ShapeCommon,
    #[serde(flatten)]
    pub geometry: ShapeGeometry,
}

/// The keys every shape takes.
#[derive(Debug, Deserialize)]
pub struct ShapeCommon {
    /// Name of a material in [materials]; default: diffuse with reflectance 0.5.
    pub material: Option<String>,
    /// Emitted spectral radiance: makes the shape an area light.
    pub emission: Option<SpectrumSpec>,
    /// Multiplies `emission`.
    pub emission_scale: Option<f32>,
    /// Instead of `emission_scale`: the emission's luminance in cd/m²
    /// (683 lm/W × ∫ L ȳ dλ, with `emission` in W·m⁻²·sr⁻¹·nm⁻¹).
    pub luminance: Option<f32>,
    /// Emit from both faces (default: only the front, by winding order).
    pub two_sided: Option<bool>,
    /// Reverse the winding (and so the front face and normals).
    #[serde(default)]
    pub flip_normals: bool,
    pub transform: Option<TransformSpec>,
}

/// `type = "obj"`: a Wavefront OBJ file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileShape {
    /// Path of the file, relative to the scene file.
    pub file: PathBuf,
    /// Only the objects or groups of this name.
    pub mesh: Option<String>,
    /// The file's materials to replace, by name → scene material.
    pub materials: Option<BTreeMap<String, String>>,
    /// Interpolate vertex normals (default true).
    pub smooth: Option<bool>,
}

/// `type = "gltf"`: a glTF 2.0 file (.gltf or .glb).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GltfShape {
    /// Path of the file, relative to the scene file.
    pub file: PathBuf,
    /// Only the meshes of this name.
    pub mesh: Option<String>,
    /// The file's materials to replace, by name → scene material.
    pub materials: Option<BTreeMap<String, String>>,
}

/// `type = "quad"`: four corners in order; the front face is
/// counter-clockwise.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadShape {
    #[serde(deserialize_with = "exact::quad")]
    pub vertices: [[f32; 3]; 4],
}

/// `type = "sphere"`: exact, or a triangle mesh with `tessellate = true`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereShape {
    /// The centre (default the origin).
    #[serde(default, deserialize_with = "exact::option")]
    pub center: Option<[f32; 3]>,
    pub radius: f32,
    /// A triangle mesh instead of the exact sphere (default false).
    #[serde(default)]
    pub tessellate: bool,
    /// Tessellated: segments around the equator (default 64).
    pub segments: Option<u32>,
    /// Tessellated: interpolate vertex normals (default true).
    pub smooth: Option<bool>,
}

/// Scale, then rotate, then translate; or a full row-major 4×4 matrix.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformSpec {
    pub scale: Option<ScaleSpec>,
    pub rotate: Option<RotateSpec>,
    #[serde(default, deserialize_with = "exact::option")]
    pub translate: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "exact::option")]
    pub matrix: Option<[f32; 16]>,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub enum ScaleSpec {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotateSpec {
    #[serde(deserialize_with = "exact::array")]
    pub axis: [f32; 3],
    pub degrees: f32,
}
