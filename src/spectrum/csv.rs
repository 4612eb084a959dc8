//! Reading spectral CSV tables: a wavelength column in nanometres followed by
//! one or more value columns. Lines starting with `#` are comments; a first
//! row that does not parse as numbers is a header.

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub struct SpectralTable {
    pub header: Option<Vec<String>>,
    pub wavelengths: Vec<f32>,
    /// One vector per value column.
    pub columns: Vec<Vec<f32>>,
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

/// Parses a spectral table, checking that wavelengths are finite, positive
/// and strictly increasing and that every value is finite.
pub fn parse(text: &str) -> Result<SpectralTable, CsvError> {
    let mut table = SpectralTable {
        header: None,
        wavelengths: Vec::new(),
        columns: Vec::new(),
    };
    for (index, raw) in text.lines().enumerate() {
        let line_no = index + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let err = |message: String| CsvError {
            line: line_no,
            message,
        };
        if fields.len() < 2 {
            return Err(err(format!(
                "expected `wavelength,value[,...]`, found `{line}`"
            )));
        }
        let parsed: Result<Vec<f32>, _> = fields.iter().map(|f| f.parse::<f32>()).collect();
        let numbers = match parsed {
            Ok(n) => n,
            Err(_) if table.wavelengths.is_empty() && table.header.is_none() => {
                table.header = Some(fields.iter().map(|s| s.to_string()).collect());
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
