//! Error messages of the scene file that serde and the toml crate leave
//! vague: errors inside typed tables, which they report at the table's
//! header without the key, and "did you mean" for near misses.

use crate::load::format;

/// Errors inside tables parsed through their `type` (shapes, lights,
/// materials, the integrator) come from serde without their key, and the
/// toml crate places them at the table's header. Names the table
/// (`shape[2]`) and its type, points the caret at the key the message
/// names, and adds the keys every type of the table takes to those
/// expected (what "did you mean" chooses from).
pub(super) fn in_typed_table(text: &str, message: String) -> String {
    let Some(line) = message
        .strip_prefix("TOML parse error at line ")
        .and_then(|rest| rest.split_once(','))
        .and_then(|(n, _)| n.trim().parse::<usize>().ok())
    else {
        return message;
    };
    let lines: Vec<&str> = text.lines().collect();
    let Some((table, name)) = table_at(&lines, line.wrapping_sub(1)) else {
        return message;
    };
    // The toml crate's message is four lines of place, then serde's.
    let Some(detail) = message.splitn(5, '\n').nth(4).map(str::trim_end) else {
        return message;
    };
    let body: Vec<(usize, &str)> = lines
        .iter()
        .copied()
        .enumerate()
        .skip(line)
        .take_while(|(_, l)| !l.trim_start().starts_with('['))
        .collect();
    let key_of = |l: &str| {
        l.split_once('=')
            .map(|(k, _)| k.trim().trim_matches('"').to_string())
    };
    let kind = body
        .iter()
        .find(|(_, l)| key_of(l).as_deref() == Some("type"))
        .and_then(|(_, l)| l.split_once('=').map(|(_, v)| v.trim().to_string()))
        .map(|v| format!("`type = {v}`"));
    let named = |prefix: &str| {
        detail
            .strip_prefix(prefix)
            .and_then(|rest| rest.split_once('`'))
            .map(|(k, _)| k.to_string())
    };
    let key_line = |key: &str| {
        body.iter()
            .find(|(_, l)| key_of(l).as_deref() == Some(key))
            .map(|&(i, l)| (i, l, key.len()))
    };
    let (at, detail) = if let Some(key) = named("unknown field `") {
        let mut expected = expected_keys(detail);
        expected.extend(
            format::keys_every_type_takes(&name)
                .iter()
                .map(|k| k.to_string()),
        );
        let expected: Vec<String> = expected.iter().map(|k| format!("`{k}`")).collect();
        let detail = format!(
            "unknown field `{key}`, expected one of {}",
            expected.join(", ")
        );
        let full = format!("`{table}.{key}`");
        let detail = match &kind {
            Some(kind) => format!("{full} does not apply to {kind}: {detail}"),
            None => format!("{full} is not a key of `[{table}]`: {detail}"),
        };
        (key_line(&key), detail)
    } else if let Some((_, rest)) = detail.split_once(&format!("`{table}.")) {
        // The table's own message, naming the key in full.
        let key = rest.split('`').next().unwrap_or_default();
        (key_line(key), detail.to_string())
    } else if let Some(key) = named("missing field `") {
        (
            None,
            format!("`{table}`{} needs `{key}`", in_brackets(&kind)),
        )
    } else {
        (None, format!("`{table}`{}: {detail}", in_brackets(&kind)))
    };
    let (i, l, width) = at.unwrap_or((line - 1, lines[line - 1], lines[line - 1].trim().len()));
    let column = l.len() - l.trim_start().len();
    let number = (i + 1).to_string();
    let pad = " ".repeat(number.len());
    format!(
        "TOML parse error at line {}, column {}\n{pad} |\n{number} | {l}\n{pad} | {}{}\n{detail}",
        i + 1,
        column + 1,
        " ".repeat(column),
        "^".repeat(width),
    )
}

/// " (`type = \"sphere\"`)", or nothing for a table without a type.
fn in_brackets(kind: &Option<String>) -> String {
    kind.as_ref().map_or(String::new(), |k| format!(" ({k})"))
}

/// The table whose header is line `index`: its dotted name with the index
/// of an array of tables (`shape[2]`), and its name alone (`shape`).
fn table_at(lines: &[&str], index: usize) -> Option<(String, String)> {
    let header = lines.get(index)?.trim();
    let name = |h: &str| -> Option<(bool, String)> {
        let h = h.trim();
        if let Some(rest) = h.strip_prefix("[[") {
            return Some((true, rest.split_once("]]")?.0.trim().to_string()));
        }
        let rest = h.strip_prefix('[')?;
        Some((false, rest.split_once(']')?.0.trim().to_string()))
    };
    let (array, table) = name(header)?;
    if !array {
        return Some((table.clone(), table));
    }
    let before = lines[..index]
        .iter()
        .filter(|l| name(l) == Some((true, table.clone())))
        .count();
    Some((format!("{table}[{before}]"), table))
}

/// The names serde's "expected one of `a`, `b`" (or "expected `a`") lists,
/// on the line it starts.
fn expected_keys(detail: &str) -> Vec<String> {
    let Some((_, expected)) = detail.split_once("expected") else {
        return Vec::new();
    };
    expected
        .split('`')
        .skip(1)
        .step_by(2)
        .take_while(|c| !c.contains('\n'))
        .map(str::to_string)
        .collect()
}

/// Adds "did you mean `spp`?" to serde's "unknown field `samples`, expected
/// one of ..." (and "unknown variant") when one of the expected names is close.
pub(super) fn with_suggestion(message: String) -> String {
    let Some(start) = message
        .find("unknown field `")
        .or_else(|| message.find("unknown variant `"))
    else {
        return message;
    };
    let rest = &message[start..];
    let Some(open) = rest.find('`') else {
        return message;
    };
    let Some(close) = rest[open + 1..].find('`') else {
        return message;
    };
    let unknown = &rest[open + 1..open + 1 + close];
    let best = expected_keys(rest)
        .into_iter()
        .map(|c| (edit_distance(&unknown.to_lowercase(), &c.to_lowercase()), c))
        .min();
    match best {
        Some((d, c)) if d > 0 && d <= 2.max(unknown.len() / 3) => {
            format!("{message}\ndid you mean `{c}`?")
        }
        _ => message,
    }
}

/// Levenshtein distance.
pub(super) fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for j in 0..b.len() {
            let cur = row[j + 1];
            row[j + 1] = (prev + (ca != b[j]) as usize).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggestions_for_near_misses_only() {
        let m = "TOML parse error at line 5, column 1\n  |\n5 | spq = 4\n  | ^^^\nunknown field `spq`, expected one of `resolution`, `spp`, `max_depth`\n".to_string();
        assert!(with_suggestion(m).ends_with("did you mean `spp`?"));
        let m = "unknown field `zzzzzz`, expected one of `resolution`, `spp`".to_string();
        assert!(!with_suggestion(m).contains("did you mean"));
        let m =
            "unknown variant `dielectirc`, expected one of `diffuse`, `conductor`, `dielectric`"
                .to_string();
        assert!(with_suggestion(m).ends_with("did you mean `dielectric`?"));
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }
}
