//! Reading spectral tables: a wavelength column followed by one or more
//! value columns, separated by commas or by whitespace (the `.spd` form of
//! LuxPop and Mitsuba: `300.194000 0.980000`). Lines starting with `#` are
//! comments; a first row that does not parse as numbers is a header.
//!
//! Wavelengths are nanometres unless the header (or a comment before the
//! data) names another unit (µm, Å). The values are checked against the
//! unit named and the visible range: a file whose header says "Lambda (A)"
//! over values of 300–800 is read in nanometres, and the table's `note`
//! says what was assumed.

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub struct SpectralTable {
    pub header: Option<Vec<String>>,
    pub wavelengths: Vec<f32>,
    /// One vector per value column.
    pub columns: Vec<Vec<f32>>,
    /// What was assumed about the wavelengths' unit, when the file left
    /// room for doubt (for a warning).
    pub note: Option<String>,
}

/// Which value column of a multi-column file: a header's name, or its
/// position counting from 1 (the wavelength column not counted).
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(untagged)]
pub enum Column {
    Index(usize),
    Name(String),
}

impl SpectralTable {
    /// The value column `which` names (a header name, or a position from
    /// 1), or the only one; a file of several needs `which`.
    pub fn column(&self, which: Option<&Column>) -> Result<usize, String> {
        let names: Vec<&str> = match &self.header {
            Some(h) => h[1..].iter().map(String::as_str).collect(),
            None => Vec::new(),
        };
        let listed = || {
            if names.is_empty() {
                format!(
                    "{} value columns, unnamed: pick one by position from 1",
                    self.columns.len()
                )
            } else {
                format!("columns: {}", names.join(", "))
            }
        };
        match which {
            None if self.columns.len() == 1 => Ok(0),
            None => Err(format!(
                "the file has {} value columns: say which with `column` (a name or a position from 1; {})",
                self.columns.len(),
                listed()
            )),
            Some(Column::Index(i)) if (1..=self.columns.len()).contains(i) => Ok(i - 1),
            Some(Column::Index(i)) => Err(format!(
                "`column = {i}`: the file has {} value columns, numbered from 1",
                self.columns.len()
            )),
            Some(Column::Name(n)) => names
                .iter()
                .position(|h| h.trim() == n)
                .ok_or_else(|| format!("no column named `{n}` ({})", listed())),
        }
    }
}

/// A wavelength unit a file may name.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Unit {
    Nanometre,
    Micrometre,
    Angstrom,
}

impl Unit {
    fn in_nm(self) -> f32 {
        match self {
            Unit::Nanometre => 1.0,
            Unit::Micrometre => 1000.0,
            Unit::Angstrom => 0.1,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Unit::Nanometre => "nm",
            Unit::Micrometre => "µm",
            Unit::Angstrom => "Å",
        }
    }

    /// The unit a header or comment names, if any.
    fn named_in(text: &str) -> Option<Unit> {
        let lower = text.to_lowercase();
        if lower.contains('å') || lower.contains("(a)") || lower.contains("[a]") {
            return Some(Unit::Angstrom);
        }
        lower
            .split(|c: char| !c.is_alphanumeric() && c != 'µ')
            .find_map(|word| match word {
                "nm" | "nanometer" | "nanometers" | "nanometre" | "nanometres" => {
                    Some(Unit::Nanometre)
                }
                "um" | "µm" | "micron" | "microns" | "micrometer" | "micrometers"
                | "micrometre" | "micrometres" => Some(Unit::Micrometre),
                "angstrom" | "angstroms" => Some(Unit::Angstrom),
                _ => None,
            })
    }
}

/// Whether wavelengths from `min` to `max` nm reach into the visible range.
fn visible(min: f32, max: f32) -> bool {
    max >= 360.0 && min <= 830.0
}

#[derive(Debug, Clone, PartialEq)]
pub struct CsvError {
    pub line: usize,
    pub message: String,
}

impl fmt::Display for CsvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for CsvError {}

/// The fields of a line: separated by semicolons (with decimal commas, as
/// spreadsheets write CSV where the comma is the decimal mark), by commas,
/// or by tabs and spaces (where a comma, not being the separator, is a
/// decimal mark).
fn split_fields(line: &str) -> Vec<String> {
    let decimal_comma = |f: &str| f.trim().replace(',', ".");
    if line.contains(';') {
        line.split(';').map(decimal_comma).collect()
    } else if line.contains('\t') {
        line.split_whitespace().map(decimal_comma).collect()
    } else if line.contains(',') {
        line.split(',').map(|f| f.trim().to_string()).collect()
    } else {
        line.split_whitespace().map(str::to_string).collect()
    }
}

/// Parses a spectral table, checking that wavelengths are finite, positive
/// and strictly increasing and that every value is finite.
pub fn parse(text: &str) -> Result<SpectralTable, CsvError> {
    let mut table = SpectralTable {
        header: None,
        wavelengths: Vec::new(),
        columns: Vec::new(),
        note: None,
    };
    // The unit named before the data: the header's, else a comment's.
    let (mut header_unit, mut comment_unit) = (None, None);
    for (index, raw) in text.lines().enumerate() {
        let line_no = index + 1;
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(comment) = line.strip_prefix('#') {
            if table.wavelengths.is_empty() && comment_unit.is_none() {
                comment_unit = Unit::named_in(comment);
            }
            continue;
        }
        let fields = split_fields(line);
        let err = |message: String| CsvError {
            line: line_no,
            message,
        };
        if fields.len() < 2 {
            return Err(err(format!(
                "expected `wavelength,value[,...]` (or the same separated by spaces), found `{line}`"
            )));
        }
        let parsed: Result<Vec<f32>, _> = fields.iter().map(|f| f.parse::<f32>()).collect();
        let numbers = match parsed {
            Ok(n) => n,
            Err(_) if table.wavelengths.is_empty() && table.header.is_none() => {
                header_unit = Unit::named_in(&fields[0]).or_else(|| Unit::named_in(line));
                table.header = Some(fields.iter().map(|s| s.trim().to_string()).collect());
                continue;
            }
            Err(_) => return Err(err(format!("not a number in `{line}`"))),
        };
        if table.columns.is_empty() {
            table.columns = vec![Vec::new(); numbers.len() - 1];
        } else if numbers.len() - 1 != table.columns.len() {
            return Err(err(format!(
                "expected {} columns, found {}",
                table.columns.len() + 1,
                numbers.len()
            )));
        }
        let lambda = numbers[0];
        if !lambda.is_finite() || lambda <= 0.0 {
            return Err(err(format!(
                "wavelength {lambda} must be a positive number"
            )));
        }
        if let Some(&prev) = table.wavelengths.last() {
            if lambda <= prev {
                return Err(err(format!(
                    "wavelengths must increase: {lambda} nm follows {prev} nm"
                )));
            }
        }
        if let Some(bad) = numbers[1..].iter().find(|v| !v.is_finite()) {
            return Err(err(format!("value {bad} is not a finite number")));
        }
        table.wavelengths.push(lambda);
        for (column, v) in table.columns.iter_mut().zip(&numbers[1..]) {
            column.push(*v);
        }
    }
    if table.wavelengths.len() < 2 {
        return Err(CsvError {
            line: text.lines().count(),
            message: "a spectrum needs at least two rows".into(),
        });
    }
    let (min, max) = (table.wavelengths[0], *table.wavelengths.last().unwrap());
    let unit = match header_unit.or(comment_unit) {
        Some(u) if visible(min * u.in_nm(), max * u.in_nm()) => u,
        Some(u) if visible(min, max) => {
            table.note = Some(format!(
                "the file names {} but its wavelengths ({min}–{max}) fall in the visible range only as nanometres: read as nm",
                u.name()
            ));
            Unit::Nanometre
        }
        Some(u) => u,
        None if !visible(min, max) && visible(min * 1000.0, max * 1000.0) => {
            table.note = Some(format!(
                "no wavelength unit named; {min}–{max} read as micrometres"
            ));
            Unit::Micrometre
        }
        None => Unit::Nanometre,
    };
    if unit != Unit::Nanometre {
        for l in &mut table.wavelengths {
            *l *= unit.in_nm();
        }
    }
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_header_comments_and_columns() {
        let t = parse("# note\nwavelength_nm,n,k\n400,1.5,0.1\n500, 1.4 ,0.2\n").unwrap();
        assert_eq!(t.header.unwrap(), vec!["wavelength_nm", "n", "k"]);
        assert_eq!(t.wavelengths, vec![400.0, 500.0]);
        assert_eq!(t.columns, vec![vec![1.5, 1.4], vec![0.1, 0.2]]);
    }

    #[test]
    fn semicolons_and_tabs_take_decimal_commas() {
        let t = parse("nm;R;G\n400;0,5;0,25\n410,5;0,6;0,3\n").unwrap();
        assert_eq!(t.header.unwrap(), vec!["nm", "R", "G"]);
        assert_eq!(t.wavelengths, vec![400.0, 410.5]);
        assert_eq!(t.columns, vec![vec![0.5, 0.6], vec![0.25, 0.3]]);
        let t = parse("400\t0,5\n410\t0,75\n").unwrap();
        assert_eq!(t.columns, vec![vec![0.5, 0.75]]);
    }

    #[test]
    fn a_column_is_picked_by_name_or_position_and_several_need_one() {
        let t = parse("nm,n,k\n400,1.5,0.1\n500,1.4,0.2\n").unwrap();
        assert_eq!(t.column(Some(&Column::Name("k".into()))), Ok(1));
        assert_eq!(t.column(Some(&Column::Index(1))), Ok(0));
        let e = t.column(None).unwrap_err();
        assert!(
            e.contains("2 value columns") && e.contains("columns: n, k"),
            "{e}"
        );
        assert!(t
            .column(Some(&Column::Index(3)))
            .unwrap_err()
            .contains("numbered from 1"));
        assert!(t
            .column(Some(&Column::Name("x".into())))
            .unwrap_err()
            .contains("no column named `x`"));
        let one = parse("400,1\n500,2\n").unwrap();
        assert_eq!(one.column(None), Ok(0));
    }

    #[test]
    fn whitespace_separated_spd_files_with_comments_read_as_csv() {
        let spd =
            "# LuxPop-style .spd\n# nm  value\n300.194000 0.980000\n400.5\t0.5\n  700   0.25  \n";
        let t = parse(spd).unwrap();
        assert_eq!(t.wavelengths, vec![300.194, 400.5, 700.0]);
        assert_eq!(t.columns, vec![vec![0.98, 0.5, 0.25]]);
        assert_eq!(t.note, None);
    }

    #[test]
    fn a_named_unit_is_applied_and_checked_against_the_visible_range() {
        // The header's unit, applied.
        let t = parse("wavelength (um),n\n0.4,1.5\n0.7,1.4\n").unwrap();
        assert_eq!(t.wavelengths, vec![400.0, 700.0]);
        assert_eq!(t.note, None);
        let t = parse("# Lambda in Angstrom\n4000 1\n7000 2\n").unwrap();
        assert_eq!(t.wavelengths, vec![400.0, 700.0]);
        // A header that says Å over values that are nanometres: read as
        // nanometres, and said.
        let t = parse("Lambda (A)  value\n300.0 0.1\n800.0 0.2\n").unwrap();
        assert_eq!(t.wavelengths, vec![300.0, 800.0]);
        let note = t.note.unwrap();
        assert!(note.contains("Å") && note.contains("nm"), "{note}");
        // No unit and values only visible as micrometres.
        let t = parse("0.38,1\n0.78,2\n").unwrap();
        assert_eq!(t.wavelengths, vec![380.0, 780.0]);
        assert!(t.note.unwrap().contains("micrometres"));
        // Plain nanometres say nothing.
        assert_eq!(parse("380 1\n780 2\n").unwrap().note, None);
    }

    #[test]
    fn rejects_bad_rows_with_line_numbers() {
        let e = parse("400,1\n390,2\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.message.contains("increase"));
        assert_eq!(parse("-5,1\n400,2\n").unwrap_err().line, 1);
        assert!(parse("400,1\n500,nan\n")
            .unwrap_err()
            .message
            .contains("finite"));
        assert!(parse("400,1\n500,x\n")
            .unwrap_err()
            .message
            .contains("not a number"));
        assert!(parse("400,1\n").is_err());
        assert_eq!(parse("400,1\n500,2,3\n").unwrap_err().line, 2);
    }
}
