//! Spectrum files other than CSV, read into the same table: IES TM-27 XML
//! (`.spdx`, one spectrum) and CGATS.17 text (what i1Profiler, ArgyllCMS
//! and X-Rite tools write for measured sets: one column per sample, named
//! by SAMPLE_NAME, else SAMPLE_ID).

use super::csv::{self, CsvError, SpectralTable};

/// Reads a spectrum file of any format prism knows, by its content.
pub fn parse_any(text: &str) -> Result<SpectralTable, CsvError> {
    let head = text.trim_start_matches('\u{feff}').trim_start();
    if head.starts_with("CGATS") || text.contains("BEGIN_DATA_FORMAT") {
        cgats(text)
    } else if text.contains("<IESTM2714") || text.contains("<SpectralData") {
        spdx(text)
    } else {
        csv::parse(text)
    }
}

fn error(line: usize, message: impl Into<String>) -> CsvError {
    CsvError {
        line,
        message: message.into(),
    }
}

/// IES TM-27 (`.spdx`): every `<SpectralData wavelength="nm">value</…>`.
fn spdx(text: &str) -> Result<SpectralTable, CsvError> {
    let mut rows: Vec<(f32, f32)> = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("<SpectralData") {
        let line = text.len() - rest.len() + at;
        let line = text[..line].lines().count().max(1);
        rest = &rest[at + "<SpectralData".len()..];
        let close = rest
            .find('>')
            .ok_or_else(|| error(line, "unterminated <SpectralData> tag"))?;
        let attributes = &rest[..close];
        let wavelength = attribute(attributes, "wavelength")
            .ok_or_else(|| error(line, "<SpectralData> without a wavelength attribute"))?;
        let end = rest
            .find("</SpectralData>")
            .ok_or_else(|| error(line, "<SpectralData> without its closing tag"))?;
        let value = rest[close + 1..end].trim();
        let parse = |s: &str, what: &str| {
            s.parse::<f32>()
                .map_err(|_| error(line, format!("{what} `{s}` is not a number")))
        };
        rows.push((parse(&wavelength, "wavelength")?, parse(value, "value")?));
        rest = &rest[end..];
    }
    if rows.is_empty() {
        return Err(error(1, "no <SpectralData> elements: not a TM-27 spectrum"));
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let text: String = rows.iter().map(|(l, v)| format!("{l},{v}\n")).collect();
    csv::parse(&text)
}

/// The value of `name="…"` (or '…') among a tag's attributes.
fn attribute(attributes: &str, name: &str) -> Option<String> {
    let at = attributes.find(&format!("{name}="))?;
    let rest = &attributes[at + name.len() + 1..];
    let quote = rest.chars().next().filter(|c| *c == '"' || *c == '\'')?;
    let end = rest[1..].find(quote)?;
    Some(rest[1..1 + end].to_string())
}

/// The wavelength a CGATS spectral field names (`SPECTRAL_NM380`,
/// `SPECTRAL_380`, `SPEC_380`, `NM380`, `R380`), if it is one.
fn spectral_field(name: &str) -> Option<f32> {
    let upper = name.to_ascii_uppercase();
    ["SPECTRAL_NM", "SPECTRAL_", "SPEC_", "NM_", "NM", "R_", "R"]
        .iter()
        .find_map(|p| upper.strip_prefix(p).and_then(|n| n.parse::<f32>().ok()))
}

/// Whitespace-separated tokens, quoted strings kept whole.
fn tokens(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut chars = line.chars().peekable();
    while let Some(&c) = chars.peek() {
        if c.is_whitespace() {
            chars.next();
        } else if c == '"' {
            chars.next();
            out.push(chars.by_ref().take_while(|&c| c != '"').collect());
        } else {
            let mut t = String::new();
            while let Some(&c) = chars.peek() {
                if c.is_whitespace() {
                    break;
                }
                t.push(c);
                chars.next();
            }
            out.push(t);
        }
    }
    out
}

/// CGATS.17: the data format's spectral fields become the wavelengths,
/// each sample a column named by SAMPLE_NAME (else SAMPLE_ID). Values in
/// percent (any above 1.5) are divided by 100.
fn cgats(text: &str) -> Result<SpectralTable, CsvError> {
    let (mut fields, mut samples) = (Vec::<String>::new(), Vec::<(usize, Vec<String>)>::new());
    let (mut in_format, mut in_data) = (false, false);
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        match line {
            "BEGIN_DATA_FORMAT" => in_format = true,
            "END_DATA_FORMAT" => in_format = false,
            "BEGIN_DATA" => in_data = true,
            "END_DATA" => in_data = false,
            _ if line.is_empty() || line.starts_with('#') => {}
            _ if in_format => fields.extend(tokens(line)),
            _ if in_data => samples.push((i + 1, tokens(line))),
            _ => {}
        }
    }
    let spectral: Vec<(usize, f32)> = fields
        .iter()
        .enumerate()
        .filter_map(|(k, f)| spectral_field(f).map(|l| (k, l)))
        .collect();
    if spectral.len() < 2 {
        return Err(error(
            1,
            "the CGATS data format names no spectral fields (SPECTRAL_NM380, SPEC_380, ...)",
        ));
    }
    let name_field = ["SAMPLE_NAME", "SAMPLE_ID"]
        .iter()
        .find_map(|n| fields.iter().position(|f| f.eq_ignore_ascii_case(n)));
    let mut names = Vec::new();
    let mut columns = Vec::new();
    for (line, values) in &samples {
        if values.len() != fields.len() {
            return Err(error(
                *line,
                format!("{} values for {} fields", values.len(), fields.len()),
            ));
        }
        // (A comma would split the name in the table's header.)
        names.push(match name_field {
            Some(k) => values[k].replace(',', " "),
            None => (names.len() + 1).to_string(),
        });
        let column: Result<Vec<f32>, CsvError> = spectral
            .iter()
            .map(|&(k, _)| {
                values[k]
                    .parse::<f32>()
                    .map_err(|_| error(*line, format!("`{}` is not a number", values[k])))
            })
            .collect();
        columns.push(column?);
    }
    if columns.is_empty() {
        return Err(error(
            1,
            "the CGATS file has no samples between BEGIN_DATA and END_DATA",
        ));
    }
    let percent = columns.iter().flatten().any(|v| *v > 1.5);
    // The rows as a CSV with a header, so the table gets csv's checks.
    let mut csv_text = format!("nm,{}\n", names.join(","));
    for (row, &(_, lambda)) in spectral.iter().enumerate() {
        let values: Vec<String> = columns
            .iter()
            .map(|c| (if percent { c[row] / 100.0 } else { c[row] }).to_string())
            .collect();
        csv_text.push_str(&format!("{lambda},{}\n", values.join(",")));
    }
    let mut table = csv::parse(&csv_text)?;
    if percent {
        table.note = Some("values above 1.5 found: read as percent".into());
    }
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tm27_spectral_data_in_any_order() {
        let x = r#"<?xml version="1.0"?>
<IESTM2714 xmlns="iestm2714" version="1.0"><SpectralDistribution>
<SpectralQuantity>relative</SpectralQuantity>
<SpectralData wavelength="390">0.25</SpectralData>
<SpectralData wavelength='380'> 0.5 </SpectralData>
</SpectralDistribution></IESTM2714>"#;
        let t = parse_any(x).unwrap();
        assert_eq!(t.wavelengths, vec![380.0, 390.0]);
        assert_eq!(t.columns, vec![vec![0.5, 0.25]]);
        assert!(parse_any("<IESTM2714></IESTM2714>").is_err());
    }

    #[test]
    fn cgats_samples_become_named_columns() {
        let c = "CGATS.17\nORIGINATOR \"i1Profiler\"\nNUMBER_OF_FIELDS 5\nBEGIN_DATA_FORMAT\n\
                 SAMPLE_ID SAMPLE_NAME SPECTRAL_NM400 SPECTRAL_NM410 SPECTRAL_NM420\nEND_DATA_FORMAT\n\
                 NUMBER_OF_SETS 2\nBEGIN_DATA\n1 A1 5.0 6.0 7.0\n2 \"B 1\" 50 60 70\nEND_DATA\n";
        let t = parse_any(c).unwrap();
        assert_eq!(t.wavelengths, vec![400.0, 410.0, 420.0]);
        assert_eq!(t.header.as_ref().unwrap()[1..], ["A1", "B 1"]);
        assert_eq!(t.columns[1], vec![0.5, 0.6, 0.7]);
        assert!(t.note.as_ref().unwrap().contains("percent"));
        let argyll = "CGATS.17\nBEGIN_DATA_FORMAT\nSAMPLE_ID SPEC_400 SPEC_500\nEND_DATA_FORMAT\n\
                      BEGIN_DATA\nA1 0.1 0.2\nEND_DATA\n";
        let t = parse_any(argyll).unwrap();
        assert_eq!(t.header.as_ref().unwrap()[1..], ["A1"]);
        assert_eq!(t.columns[0], vec![0.1, 0.2]);
        let short = argyll.replace("A1 0.1 0.2", "A1 0.1");
        assert!(parse_any(&short)
            .unwrap_err()
            .to_string()
            .contains("line 6"));
    }
}
