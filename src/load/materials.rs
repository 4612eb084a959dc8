//! Materials: diffuse, conductor and dielectric tables, with their
//! spectra, textures and indices of refraction.

use super::fluorescence::FluorescenceSpec;
use super::spectra::Role;
use super::Loader;
use crate::load::format::{MaterialSpec, SceneFile};
use crate::load::spectrum_spec::{Column, IorSpec, SpectrumSpec};
use crate::load::SceneError;
use crate::material::microfacet::alpha_from_roughness;
use crate::material::{ior, metals, Ior, Material};
use crate::spectrum::{LAMBDA_MAX, LAMBDA_MIN};
use crate::texture::{Encoding, TextureRef};

impl Loader {
    /// Adds the materials of the `[measured]` sets: a diffuse material
    /// `SET.SAMPLE` for every named column of each set's file.
    pub(super) fn add_measured_materials(&self, file: &mut SceneFile) -> Result<(), SceneError> {
        for (set, spec) in std::mem::take(&mut file.measured) {
            let key = format!("measured.{set}.file");
            let full = self.input_file(&spec.file, &key)?;
            let text = crate::input::read_to_string(&full)
                .map_err(|e| self.error(format!("`{key}`: {}: {e}", full.display())))?;
            let table = crate::spectrum::formats::parse_any(&text)
                .map_err(|e| self.error(format!("`{key}`: {}: {e}", full.display())))?;
            let Some(header) = table
                .header
                .as_ref()
                .filter(|h| h.len() == table.columns.len() + 1)
            else {
                return Err(self.error(format!(
                    "`{key}`: {} names no samples: a CGATS file, or a CSV whose header names its columns",
                    full.display()
                )));
            };
            for (k, sample) in header[1..].iter().enumerate() {
                let name = format!("{set}.{sample}");
                if header[1..k + 1].contains(sample) {
                    return Err(self.error(format!(
                        "`{key}`: {} names the sample `{sample}` twice",
                        full.display()
                    )));
                }
                if file.materials.contains_key(&name) {
                    return Err(self.error(format!(
                        "`measured.{set}`: the material `{name}` is also defined under [materials]"
                    )));
                }
                let reflectance = SpectrumSpec::File {
                    path: spec.file.clone(),
                    scale: 1.0,
                    column: Some(Column::Name(sample.clone())),
                };
                let texture = None;
                file.materials.insert(
                    name,
                    MaterialSpec::Diffuse {
                        reflectance,
                        texture,
                    },
                );
            }
        }
        Ok(())
    }

    pub(super) fn material(
        &self,
        name: &str,
        spec: &MaterialSpec,
        file: &SceneFile,
    ) -> Result<Material, SceneError> {
        let key = format!("materials.{name}");
        let roughness_alpha = |r: f32| {
            if !(0.0..=1.0).contains(&r) {
                return Err(self.error(format!("`{key}.roughness` must lie in [0, 1], found {r}")));
            }
            Ok(alpha_from_roughness(r))
        };
        Ok(match spec {
            MaterialSpec::Diffuse {
                reflectance,
                texture,
            } => Material::Diffuse {
                reflectance: crate::material::Reflectance {
                    factor: self.spectrum(
                        reflectance,
                        Role::Reflectance,
                        file,
                        &format!("{key}.reflectance"),
                    )?,
                    texture: match texture {
                        None => None,
                        Some(rel) => {
                            let path = self.input_file(rel, &format!("{key}.texture"))?;
                            let t = self
                                .textures
                                .borrow_mut()
                                .file(&path, Encoding::SrgbColour)
                                .map_err(|e| self.error(format!("`{key}.texture`: {e}")))?;
                            Some(TextureRef::new(t))
                        }
                    },
                },
            },
            MaterialSpec::Conductor {
                metal,
                eta,
                k,
                roughness,
            } => {
                let (eta, k) = match (metal, eta, k) {
                    (Some(m), None, None) => metals::metal(m).ok_or_else(|| {
                        self.error(format!(
                            "`{key}.metal`: unknown metal `{m}` (known: {})",
                            metals::NAMES.join(", ")
                        ))
                    })?,
                    (None, Some(eta), Some(k)) => (
                        self.spectrum(eta, Role::Unbounded, file, &format!("{key}.eta"))?,
                        self.spectrum(k, Role::Unbounded, file, &format!("{key}.k"))?,
                    ),
                    _ => {
                        return Err(self.error(format!(
                            "`{key}`: give either `metal`, or both `eta` and `k`"
                        )))
                    }
                };
                Material::Conductor {
                    eta,
                    k,
                    alpha: roughness_alpha(*roughness)?,
                }
            }
            MaterialSpec::Dielectric {
                ior,
                roughness,
                priority,
                medium,
            } => Material::Dielectric {
                ior: self.ior(ior, file, &format!("{key}.ior"))?,
                alpha: roughness_alpha(*roughness)?,
                priority: *priority,
                medium: match medium {
                    Some(m) => Some(Box::new(self.medium(m, file, &format!("{key}.medium"))?)),
                    None => None,
                },
                tint: None,
                opaque: None,
            },
            MaterialSpec::Fluorescent {
                reflectance,
                donaldson,
                excitation,
                emission,
                quantum_yield,
            } => {
                let r = self.spectrum(
                    reflectance,
                    Role::Reflectance,
                    file,
                    &format!("{key}.reflectance"),
                )?;
                let spec = FluorescenceSpec {
                    donaldson: donaldson.as_deref(),
                    excitation: excitation.as_ref(),
                    emission: emission.as_ref(),
                    quantum_yield: *quantum_yield,
                };
                Material::Fluorescent {
                    fluorescence: self.fluorescence(&spec, &r, file, &key)?,
                    reflectance: r.into(),
                }
            }
            MaterialSpec::Interface { priority, medium } => Material::Interface {
                priority: *priority,
                medium: Box::new(self.medium(medium, file, &format!("{key}.medium"))?),
            },
        })
    }

    pub(super) fn ior(
        &self,
        spec: &IorSpec,
        file: &SceneFile,
        key: &str,
    ) -> Result<Ior, SceneError> {
        let ior = match spec {
            IorSpec::Constant(n) => Ior::Constant(*n),
            IorSpec::Named(name) => Ior::preset(name).ok_or_else(|| {
                let names: Vec<&str> = ior::PRESETS.iter().map(|p| p.0).collect();
                self.error(format!(
                    "`{key}`: unknown glass `{name}` (known: {})",
                    names.join(", ")
                ))
            })?,
            IorSpec::Cauchy([a, b]) => Ior::Cauchy { a: *a, b: *b },
            IorSpec::Abbe([nd, vd]) => {
                if !(*vd > 0.0) {
                    return Err(self.error(format!("`{key}`: the Abbe number must be positive")));
                }
                Ior::abbe(*nd, *vd)
            }
            IorSpec::Sellmeier { b, c } => {
                let (mut bb, mut cc) = ([0.0; 4], [0.0; 4]);
                bb[..b.len()].copy_from_slice(b);
                cc[..c.len()].copy_from_slice(c);
                Ior::Sellmeier { b: bb, c: cc }
            }
            IorSpec::Spectrum(s) => Ior::Table(self.spectrum(s, Role::Unbounded, file, key)?),
        };
        // The index must be a sensible positive number over the whole range.
        let worst = (0..=(LAMBDA_MAX - LAMBDA_MIN) as usize)
            .map(|i| ior.eval(LAMBDA_MIN + i as f32))
            .find(|n| !(n.is_finite() && *n >= 1e-3 && *n <= 100.0));
        if let Some(n) = worst {
            return Err(self.error(format!(
                "`{key}`: the index of refraction must be finite and between 0.001 and 100 over {LAMBDA_MIN}-{LAMBDA_MAX} nm, found {n}"
            )));
        }
        Ok(ior)
    }
}
