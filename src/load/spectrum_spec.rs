//! How a spectrum is written in a scene file:
//!
//! - `0.5`: constant
//! - `"D65"`: a built-in illuminant or a name from the scene's [spectra]
//! - `[[400, 0.1], [700, 0.9]]`: a table of (nm, value), piecewise linear
//! - `{ file = "red.csv" }`: a CSV table next to the scene (`column` picks
//!   a value column of a file with several, by header name or from 1)
//! - `{ blackbody = 2856 }`: Planck's law at that temperature in kelvin
//! - `{ daylight = 5500 }`: the CIE D-series illuminant of that correlated
//!   colour temperature
//! - `{ rgb = [0.8, 0.2, 0.1] }`: linear sRGB, upsampled to a smooth spectrum
//! - `{ constant = 0.5 }`
//!
//! Each map form also takes `scale = x`.

use std::fmt;
use std::path::PathBuf;

use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;

#[derive(Clone, Debug, PartialEq)]
pub enum SpectrumSpec {
    Constant(f32),
    Named(String),
    Table(Vec<[f32; 2]>),
    File {
        path: PathBuf,
        scale: f32,
        column: Option<Column>,
    },
    Blackbody {
        kelvin: f32,
        scale: f32,
    },
    Daylight {
        kelvin: f32,
        scale: f32,
    },
    Rgb {
        rgb: [f32; 3],
        scale: f32,
    },
}

pub use crate::spectrum::csv::Column;

const FORMS: &str = "a number, a name such as \"D65\", a table [[nm, value], ...], \
or a table with one of `file`, `blackbody`, `daylight`, `rgb`, `constant` (and optionally `scale`)";

impl<'de> Deserialize<'de> for SpectrumSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(SpectrumVisitor)
    }
}

struct SpectrumVisitor;

impl<'de> Visitor<'de> for SpectrumVisitor {
    type Value = SpectrumSpec;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(FORMS)
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Self::Value, E> {
        Ok(SpectrumSpec::Constant(v as f32))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Self::Value, E> {
        Ok(SpectrumSpec::Constant(v as f32))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Self::Value, E> {
        Ok(SpectrumSpec::Constant(v as f32))
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
        Ok(SpectrumSpec::Named(v.to_string()))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut rows = Vec::new();
        while let Some(row) = seq.next_element::<Vec<f32>>()? {
            match row[..] {
                [lambda, value] => rows.push([lambda, value]),
                _ => {
                    return Err(de::Error::custom(format!(
                        "each row of a spectrum table is [nm, value], found {} numbers",
                        row.len()
                    )))
                }
            }
        }
        Ok(SpectrumSpec::Table(rows))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut file: Option<PathBuf> = None;
        let mut column: Option<Column> = None;
        let mut blackbody: Option<f32> = None;
        let mut daylight: Option<f32> = None;
        let mut rgb: Option<[f32; 3]> = None;
        let mut constant: Option<f32> = None;
        let mut scale: Option<f32> = None;
        while let Some(key) = map.next_key::<String>()? {
            match key.as_str() {
                "file" => file = Some(map.next_value()?),
                "column" => column = Some(map.next_value()?),
                "blackbody" => blackbody = Some(map.next_value()?),
                "daylight" => daylight = Some(map.next_value()?),
                "rgb" => rgb = Some(map.next_value()?),
                "constant" => constant = Some(map.next_value()?),
                "scale" => scale = Some(map.next_value()?),
                other => {
                    return Err(de::Error::unknown_field(
                        other,
                        &[
                            "file",
                            "column",
                            "blackbody",
                            "daylight",
                            "rgb",
                            "constant",
                            "scale",
                        ],
                    ))
                }
            }
        }
        let scale_or_one = scale.unwrap_or(1.0);
        let forms = file.is_some() as u8
            + blackbody.is_some() as u8
            + daylight.is_some() as u8
            + rgb.is_some() as u8
            + constant.is_some() as u8;
        if forms != 1 {
            return Err(de::Error::custom(format!(
                "a spectrum table needs exactly one of `file`, `blackbody`, `daylight`, `rgb`, `constant` (found {forms})"
            )));
        }
        if column.is_some() && file.is_none() {
            return Err(de::Error::custom("`column` picks a column of a `file`"));
        }
        Ok(if let Some(path) = file {
            SpectrumSpec::File {
                path,
                scale: scale_or_one,
                column,
            }
        } else if let Some(kelvin) = daylight {
            SpectrumSpec::Daylight {
                kelvin,
                scale: scale_or_one,
            }
        } else if let Some(kelvin) = blackbody {
            SpectrumSpec::Blackbody {
                kelvin,
                scale: scale_or_one,
            }
        } else if let Some(rgb) = rgb {
            SpectrumSpec::Rgb {
                rgb,
                scale: scale_or_one,
            }
        } else {
            SpectrumSpec::Constant(constant.unwrap() * scale_or_one)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize)]
    struct Holder {
        s: SpectrumSpec,
    }

    fn parse(text: &str) -> Result<SpectrumSpec, String> {
        toml::from_str::<Holder>(text)
            .map(|h| h.s)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn every_form_parses() {
        assert_eq!(parse("s = 0.25").unwrap(), SpectrumSpec::Constant(0.25));
        assert_eq!(parse("s = 2").unwrap(), SpectrumSpec::Constant(2.0));
        assert_eq!(
            parse("s = \"D65\"").unwrap(),
            SpectrumSpec::Named("D65".into())
        );
        assert_eq!(
            parse("s = [[400, 0.1], [700.5, 1]]").unwrap(),
            SpectrumSpec::Table(vec![[400.0, 0.1], [700.5, 1.0]])
        );
        assert_eq!(
            parse("s = { file = \"a.csv\", scale = 2 }").unwrap(),
            SpectrumSpec::File {
                path: "a.csv".into(),
                scale: 2.0,
                column: None,
            }
        );
        assert_eq!(
            parse("s = { file = \"a.csv\", column = \"n\" }").unwrap(),
            SpectrumSpec::File {
                path: "a.csv".into(),
                scale: 1.0,
                column: Some(Column::Name("n".into())),
            }
        );
        assert_eq!(
            parse("s = { file = \"a.csv\", column = 2 }").unwrap(),
            SpectrumSpec::File {
                path: "a.csv".into(),
                scale: 1.0,
                column: Some(Column::Index(2)),
            }
        );
        assert_eq!(
            parse("s = { daylight = 5500, scale = 2 }").unwrap(),
            SpectrumSpec::Daylight {
                kelvin: 5500.0,
                scale: 2.0
            }
        );
        assert!(parse("s = { rgb = [1, 1, 1], column = 2 }")
            .unwrap_err()
            .contains("`column` picks a column of a `file`"));
        assert_eq!(
            parse("s = { blackbody = 2856 }").unwrap(),
            SpectrumSpec::Blackbody {
                kelvin: 2856.0,
                scale: 1.0
            }
        );
        assert_eq!(
            parse("s = { rgb = [1, 0.5, 0] }").unwrap(),
            SpectrumSpec::Rgb {
                rgb: [1.0, 0.5, 0.0],
                scale: 1.0
            }
        );
    }

    #[test]
    fn bad_forms_say_what_is_wrong_and_where() {
        let e = parse("s = { rgb = [1, 0.5, 0], file = \"x\" }").unwrap_err();
        assert!(e.contains("exactly one"), "{e}");
        let e = parse("s = { colour = 1 }").unwrap_err();
        assert!(
            e.contains("unknown field `colour`") && e.contains("line 1"),
            "{e}"
        );
        let e = parse("s = true").unwrap_err();
        assert!(e.contains("a number, a name"), "{e}");
        let e = parse("s = [[400, 1, 2]]").unwrap_err();
        assert!(e.contains("line 1") && e.contains("[nm, value]"), "{e}");
    }
}

/// How an index of refraction is written in a scene file:
///
/// - `1.5`: constant
/// - `"N-BK7"`: a named glass (N-BK7, N-SF11, N-F2, fused silica, diamond, water)
/// - `{ cauchy = [A, B] }`: n = A + B/λ², λ in µm
/// - `{ sellmeier = [[B1, B2, B3], [C1, C2, C3]] }`: λ in µm, C in µm²
/// - `{ abbe = [n_d, V_d] }`: Cauchy through n_d with Abbe number V_d
/// - a spectrum table or `{ file = "n.csv" }`: n per wavelength
#[derive(Clone, Debug, PartialEq)]
pub enum IorSpec {
    Constant(f32),
    Named(String),
    Cauchy([f32; 2]),
    Sellmeier { b: Vec<f32>, c: Vec<f32> },
    Abbe([f32; 2]),
    Spectrum(SpectrumSpec),
}

impl<'de> Deserialize<'de> for IorSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(IorVisitor)
    }
}

struct IorVisitor;

impl<'de> Visitor<'de> for IorVisitor {
    type Value = IorSpec;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(
            "a number, a glass name such as \"N-BK7\", a table [[nm, n], ...], or a table with one of \
             `cauchy`, `sellmeier`, `abbe`, `file`",
        )
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Self::Value, E> {
        Ok(IorSpec::Constant(v as f32))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Self::Value, E> {
        Ok(IorSpec::Constant(v as f32))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Self::Value, E> {
        Ok(IorSpec::Constant(v as f32))
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
        Ok(IorSpec::Named(v.to_string()))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Self::Value, A::Error> {
        SpectrumVisitor.visit_seq(seq).map(IorSpec::Spectrum)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let Some(key) = map.next_key::<String>()? else {
            return Err(de::Error::custom(
                "an empty table is not an index of refraction",
            ));
        };
        let spec = match key.as_str() {
            "cauchy" => IorSpec::Cauchy(map.next_value()?),
            "abbe" => IorSpec::Abbe(map.next_value()?),
            "sellmeier" => {
                let [b, c]: [Vec<f32>; 2] = map.next_value()?;
                if b.len() != c.len() || b.is_empty() || b.len() > 4 {
                    return Err(de::Error::custom(
                        "`sellmeier` needs [[B1, ...], [C1, ...]] of equal length, 1 to 4 terms",
                    ));
                }
                IorSpec::Sellmeier { b, c }
            }
            "file" => IorSpec::Spectrum(SpectrumSpec::File {
                path: map.next_value()?,
                scale: 1.0,
                column: None,
            }),
            other => {
                return Err(de::Error::unknown_field(
                    other,
                    &["cauchy", "sellmeier", "abbe", "file"],
                ))
            }
        };
        if let Some(extra) = map.next_key::<String>()? {
            return Err(de::Error::custom(format!(
                "unexpected `{extra}`: give one IOR form"
            )));
        }
        Ok(spec)
    }
}
