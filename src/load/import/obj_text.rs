//! The geometry of an OBJ file, read in parallel: the text is cut at line
//! breaks into chunks that threads read on their own (vertices, faces and
//! the `o`/`g`/`usemtl`/`mtllib` statements between them); counts summed
//! over the chunks before each one then resolve its relative (negative)
//! indices and its line numbers, and the faces are gathered into pieces
//! (one per object or group and material, as OBJ readers split them), each
//! with the vertices its faces use. Material libraries are read elsewhere.
//!
//! Read: `v x y z [w]` (a colour after the position is skipped), `vt u v`,
//! `vn x y z`, `f` with `v`, `v/vt`, `v//vn`, `v/vt/vn` corners, positive
//! or negative; `o`, `g`, `usemtl`, `mtllib`. Lines, points, curves,
//! surfaces and smoothing groups carry no triangles and are skipped.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

mod pieces;
mod words;
use pieces::{Joined, Plan, Sources};
use words::{corner, number, Words};

/// The faces of one object or group with one material.
#[derive(Debug, Default)]
pub struct ObjPiece {
    /// The `o` or `g` name ("unnamed_object" before any).
    pub name: String,
    /// The `usemtl` name in force, if any.
    pub material: Option<String>,
    pub positions: Vec<Vec3>,
    /// Per vertex, where every corner of the piece names one.
    pub uvs: Option<Vec<Vec2>>,
    pub normals: Option<Vec<Vec3>>,
    /// Corners of the faces, face after face, as indices into the vertices.
    pub corners: Vec<u32>,
    /// Corners per face (3 or more).
    pub arities: Vec<u32>,
    /// Some corner names a normal that does not exist.
    pub broken_normals: bool,
}

/// What an OBJ file holds: its pieces in file order and the material
/// libraries it names.
#[derive(Debug, Default)]
pub struct ObjGeometry {
    pub pieces: Vec<ObjPiece>,
    pub material_libraries: Vec<String>,
    /// The first face corner naming a `vn` line that does not exist.
    pub broken_normal: Option<String>,
}

/// Chunks are cut no smaller than this, so that small files stay whole.
const MIN_CHUNK: usize = 1 << 20;

/// No corner attribute (texture coordinate or normal).
const NONE: u32 = u32::MAX;

/// An index no vertex list can reach (beyond what u32 holds, or before
/// the first): an error, or for normals a warning, once resolved.
const OUT_OF_RANGE: u32 = u32::MAX - 1;

/// A corner normal index beyond the file's `vn` lines (the piece's normals
/// are computed instead).
const BROKEN: u32 = u32::MAX - 2;

/// Parses OBJ text. Errors name the line.
pub fn parse(bytes: &[u8]) -> Result<ObjGeometry, String> {
    let texts = split_at_lines(bytes, rayon::current_num_threads() * 4);
    let mut read: Vec<Chunk> = texts.par_iter().map(|c| Chunk::read(c)).collect();
    // Counts before each chunk: lines, and v, vt, vn.
    let mut before = Vec::with_capacity(read.len());
    let mut totals = [0usize; 4];
    for c in &read {
        before.push(totals);
        totals[0] += c.lines;
        totals[1] += c.positions.len();
        totals[2] += c.uvs.len();
        totals[3] += c.normals.len();
    }
    if let Some((c, (line, message))) = read
        .iter()
        .enumerate()
        .find_map(|(i, c)| c.error.clone().map(|e| (i, e)))
    {
        return Err(format!("line {}: {message}", before[c][0] + line));
    }
    read.par_iter_mut()
        .zip(&before)
        .zip(&texts)
        .try_for_each(|((c, b), text)| c.resolve(text, *b, totals))?;

    let bad = read.par_iter().zip(&before).find_map_first(|(c, b)| {
        let i = c.positions.iter().position(|p| !p.is_finite())?;
        Some(b[1] + i)
    });
    if let Some(i) = bad {
        return Err(format!("vertex {} is not finite", i + 1));
    }

    let mut geometry = ObjGeometry {
        broken_normal: read.iter().find_map(|c| c.broken_normal.clone()),
        ..ObjGeometry::default()
    };
    let plans = plan_pieces(&read, &mut geometry.material_libraries);
    let sources = Sources {
        chunks: &read,
        positions: Joined::new(read.iter().map(|c| c.positions.as_slice())),
        uvs: Joined::new(read.iter().map(|c| c.uvs.as_slice())),
        normals: Joined::new(read.iter().map(|c| c.normals.as_slice())),
    };
    geometry.pieces = plans.into_par_iter().map(|p| sources.piece(p)).collect();
    // The chunks' corners are hundreds of megabytes on big files: returned
    // to the system on a thread of their own while the caller goes on.
    rayon::spawn(move || drop(read));
    Ok(geometry)
}

/// The pieces as face ranges (chunk, faces) between the statements that
/// split them; the material libraries named go to `libraries`.
fn plan_pieces(read: &[Chunk], libraries: &mut Vec<String>) -> Vec<Plan> {
    let mut plans: Vec<Plan> = Vec::new();
    let mut current = Plan {
        name: "unnamed_object".into(),
        ..Plan::default()
    };
    for (k, chunk) in read.iter().enumerate() {
        let mut start = 0;
        for (at, statement) in &chunk.statements {
            if *at > start {
                current.ranges.push((k, start, *at));
                start = *at;
            }
            match statement {
                Statement::Group(name) => {
                    let next = Plan {
                        name: name.clone(),
                        material: current.material.clone(),
                        ranges: Vec::new(),
                    };
                    plans.push(std::mem::replace(&mut current, next));
                }
                Statement::Material(name) => {
                    if current.material.as_ref() != Some(name) {
                        let next = Plan {
                            name: current.name.clone(),
                            material: Some(name.clone()),
                            ranges: Vec::new(),
                        };
                        plans.push(std::mem::replace(&mut current, next));
                    }
                }
                Statement::Library(name) => libraries.push(name.clone()),
            }
        }
        if chunk.arities.len() > start {
            current.ranges.push((k, start, chunk.arities.len()));
        }
    }
    plans.push(current);
    plans.retain(|p| !p.ranges.is_empty());
    plans
}

/// `bytes` cut into about `parts` pieces, each ending at a line break.
fn split_at_lines(bytes: &[u8], parts: usize) -> Vec<&[u8]> {
    let size = (bytes.len() / parts.max(1)).max(MIN_CHUNK);
    let mut chunks = Vec::new();
    let mut start = 0;
    while start < bytes.len() {
        let mut end = (start + size).min(bytes.len());
        if let Some(nl) = memchr::memchr(b'\n', &bytes[end..]) {
            end += nl + 1;
        } else {
            end = bytes.len();
        }
        chunks.push(&bytes[start..end]);
        start = end;
    }
    chunks
}

/// The lines of a chunk's text (the last one may be empty).
fn lines(text: &[u8]) -> impl Iterator<Item = &[u8]> {
    memchr::memchr_iter(b'\n', text)
        .chain(std::iter::once(text.len()))
        .scan(0, move |start, end| {
            let line = &text[*start..end];
            *start = end + 1;
            Some(line.strip_suffix(b"\r").unwrap_or(line))
        })
}

/// A statement that splits faces into pieces, or names a library.
#[derive(Clone, Debug)]
enum Statement {
    Group(String),
    Material(String),
    Library(String),
}

/// One chunk's contents as read: 12 bytes a corner, the least a big file's
/// faces can be held in (they are most of its memory).
#[derive(Default)]
struct Chunk {
    lines: usize,
    positions: Vec<Vec3>,
    uvs: Vec<Vec2>,
    normals: Vec<Vec3>,
    /// Per corner: v, vt, vn as 0-based indices into the file's lists (NONE
    /// for none, OUT_OF_RANGE), except those `relative` lists, which hold
    /// an index into the chunk's own (as i32 bits; negative reaches back
    /// into earlier chunks) until `resolve` adds the counts before it.
    corners: Vec<[u32; 3]>,
    /// (corner, attribute) written as negative indices.
    relative: Vec<(u32, u8)>,
    arities: Vec<u32>,
    /// Where each face's corners start in `corners` (one more entry than
    /// faces), made by `resolve`.
    face_starts: Vec<u32>,
    /// Before which face each statement came.
    statements: Vec<(usize, Statement)>,
    /// The first error: line within the chunk (1-based) and message.
    error: Option<(usize, String)>,
    /// The warning for the first corner whose normal index is out of range.
    broken_normal: Option<String>,
}

impl Chunk {
    fn read(text: &[u8]) -> Chunk {
        let mut c = Chunk::default();
        for line in lines(text) {
            c.lines += 1;
            if let Err(message) = c.line(line) {
                c.error = Some((c.lines, message));
                break;
            }
        }
        // The text of a chunk ends with its last line's break.
        if text.last() == Some(&b'\n') {
            c.lines -= 1;
        }
        c
    }

    fn line(&mut self, line: &[u8]) -> Result<(), String> {
        let mut words = Words::new(line);
        let Some(keyword) = words.next() else {
            return Ok(());
        };
        match keyword {
            b"v" => {
                let [x, y, z] = floats(&mut words, "v")?;
                // `v x y z w` is homogeneous; `v x y z r g b` has a colour.
                let w = match (words.next(), words.next()) {
                    (Some(w), None) => number(w, "v")?,
                    _ => 1.0,
                };
                if w == 0.0 {
                    return Err("a vertex with weight w = 0".into());
                }
                self.positions.push(Vec3::new(x, y, z) / w);
            }
            b"vt" => {
                let u = words.next_number("vt").ok_or("`vt` needs u")??;
                let v = words.next_number("vt").unwrap_or(Ok(0.0))?;
                self.uvs.push(Vec2::new(u, v));
            }
            b"vn" => {
                let [x, y, z] = floats(&mut words, "vn")?;
                self.normals.push(Vec3::new(x, y, z));
            }
            b"f" => self.face(words)?,
            b"o" | b"g" => {
                let name = rest_of(line, keyword);
                let name = if name.is_empty() {
                    "unnamed_object".to_string()
                } else {
                    name
                };
                self.statements
                    .push((self.arities.len(), Statement::Group(name)));
            }
            b"usemtl" => {
                let name = rest_of(line, keyword);
                if !name.is_empty() {
                    self.statements
                        .push((self.arities.len(), Statement::Material(name)));
                }
            }
            b"mtllib" => {
                let name = rest_of(line, keyword);
                if !name.is_empty() {
                    self.statements
                        .push((self.arities.len(), Statement::Library(name)));
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// An `f` line's corners; faces of fewer than three are skipped.
    fn face(&mut self, mut words: Words) -> Result<(), String> {
        let seen = [self.positions.len(), self.uvs.len(), self.normals.len()];
        let (first, relative) = (self.corners.len(), self.relative.len());
        while let Some(written) = words.next_corner() {
            let written = written?;
            let mut out = [NONE; 3];
            for a in 0..3 {
                out[a] = match written[a] {
                    0 => NONE,
                    i if i > 0 => {
                        u32::try_from(i - 1).map_or(OUT_OF_RANGE, |i| i.min(OUT_OF_RANGE))
                    }
                    i => match i32::try_from(seen[a] as i64 + i) {
                        Ok(local) => {
                            self.relative.push((self.corners.len() as u32, a as u8));
                            local as u32
                        }
                        Err(_) => OUT_OF_RANGE,
                    },
                };
            }
            self.corners.push(out);
        }
        let arity = self.corners.len() - first;
        if arity < 3 {
            // Two corners make no triangle.
            self.corners.truncate(first);
            self.relative.truncate(relative);
        } else {
            self.arities.push(arity as u32);
        }
        Ok(())
    }

    /// Makes every corner index the file's, given the counts of lines and
    /// v, vt, vn before the chunk and in the whole file, and checks them.
    /// Lines are found again in the text, only for a message.
    fn resolve(
        &mut self,
        text: &[u8],
        before: [usize; 4],
        totals: [usize; 4],
    ) -> Result<(), String> {
        for &(c, a) in &self.relative {
            let slot = &mut self.corners[c as usize][a as usize];
            let index = *slot as i32 as i64 + before[a as usize + 1] as i64;
            *slot = u32::try_from(index).map_or(OUT_OF_RANGE, |i| i.min(OUT_OF_RANGE));
        }
        self.relative = Vec::new();
        let mut bad: Option<(usize, usize)> = None;
        for (c, corner) in self.corners.iter_mut().enumerate() {
            for a in 0..3 {
                if corner[a] != NONE && corner[a] as usize >= totals[a + 1] {
                    if a == 2 {
                        // Other loaders accept such files: warn, and
                        // compute the piece's normals.
                        corner[a] = BROKEN;
                        if self.broken_normal.is_none() {
                            let (line, written) = written(text, c, a);
                            self.broken_normal = Some(format!(
                                "line {}: normal index {written} is out of range (the file has {}); \
                                 the normals of the faces that name missing ones are computed",
                                before[0] + line,
                                totals[3]
                            ));
                        }
                    } else {
                        bad = bad.or(Some((c, a)));
                    }
                }
            }
        }
        if let Some((c, a)) = bad {
            let (line, written) = written(text, c, a);
            let what = ["vertex", "texture coordinate", "normal"][a];
            return Err(format!(
                "line {}: {what} index {written} is out of range (the file has {})",
                before[0] + line,
                totals[a + 1]
            ));
        }
        let mut start = 0;
        self.face_starts = Vec::with_capacity(self.arities.len() + 1);
        for &arity in &self.arities {
            self.face_starts.push(start);
            start += arity;
        }
        self.face_starts.push(start);
        Ok(())
    }
}

/// The line (within a chunk's text) of its corner `c`, and that corner's
/// attribute `a` as written: read again, only for a message.
fn written(text: &[u8], c: usize, a: usize) -> (usize, i64) {
    let mut before = 0;
    for (number, line) in lines(text).enumerate() {
        let mut words = Words::new(line);
        if words.next() != Some(b"f") {
            continue;
        }
        let corners: Vec<[i64; 3]> = words.filter_map(|w| corner(w).ok()).collect();
        if corners.len() < 3 {
            continue;
        }
        if c < before + corners.len() {
            return (number + 1, corners[c - before][a]);
        }
        before += corners.len();
    }
    (0, 0)
}

/// Three numbers of a `v` or `vn` line.
fn floats(words: &mut Words, what: &str) -> Result<[f32; 3], String> {
    let mut out = [0.0; 3];
    for v in &mut out {
        *v = words
            .next_number(what)
            .ok_or_else(|| format!("`{what}` needs three numbers"))??;
    }
    Ok(out)
}

/// What follows the keyword on its line, trimmed (names may hold spaces).
fn rest_of(line: &[u8], keyword: &[u8]) -> String {
    let start = line
        .windows(keyword.len())
        .position(|w| w == keyword)
        .map_or(line.len(), |p| p + keyword.len());
    String::from_utf8_lossy(&line[start..]).trim().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_split_by_group_and_material_with_their_own_vertices() {
        let text = b"mtllib a b.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n\
            o first\nusemtl red\nf 1/1/1 2/1/1 3/1/1\nusemtl blue\nf -4/1/1 -2/1/1 -1/1/1\n\
            g second\nf 1 2 3 4\n";
        let g = parse(text).unwrap();
        assert_eq!(g.material_libraries, vec!["a b.mtl"]);
        let summary: Vec<_> = g
            .pieces
            .iter()
            .map(|p| {
                (
                    p.name.as_str(),
                    p.material.as_deref(),
                    p.positions.len(),
                    p.arities.clone(),
                )
            })
            .collect();
        assert_eq!(
            summary,
            vec![
                ("first", Some("red"), 3, vec![3]),
                ("first", Some("blue"), 3, vec![3]),
                ("second", Some("blue"), 4, vec![4]),
            ]
        );
        assert_eq!(g.pieces[1].positions[2], Vec3::new(0.0, 1.0, 0.0));
        assert!(g.pieces[0].uvs.is_some() && g.pieces[0].normals.is_some());
        assert!(g.pieces[2].uvs.is_none() && g.pieces[2].normals.is_none());
    }

    #[test]
    fn a_large_file_reads_the_same_in_chunks() {
        // Vertices and faces interleaved over many chunks, with relative
        // indices reaching back across chunk boundaries.
        let mut text = String::new();
        for i in 0..60_000 {
            text += &format!("v {i} {} 0\nvt 0.5 0.25\nv {i} {} 1\n", i * 2, i * 3);
            if i > 0 {
                text += "f -3/-1 -2/-1 -1/-1\n";
            }
            if i % 20_000 == 0 {
                text += &format!("g part{i}\n");
            }
        }
        assert!(text.len() > 2 * MIN_CHUNK);
        let g = parse(text.as_bytes()).unwrap();
        let faces: usize = g.pieces.iter().map(|p| p.arities.len()).sum();
        assert_eq!(faces, 59_999);
        // The face after vertex pair i uses the second vertex of pair i - 1
        // and both of pair i; the second group starts at i = 20001.
        let p = &g.pieces[1];
        assert_eq!(p.name, "part20000");
        let first = &p.corners[..3];
        let pos: Vec<Vec3> = first.iter().map(|&c| p.positions[c as usize]).collect();
        assert_eq!(
            pos,
            [
                Vec3::new(20000.0, 60000.0, 1.0),
                Vec3::new(20001.0, 40002.0, 0.0),
                Vec3::new(20001.0, 60003.0, 1.0)
            ]
        );
        assert!(p
            .uvs
            .as_ref()
            .unwrap()
            .iter()
            .all(|&t| t == Vec2::new(0.5, 0.25)));
    }

    #[test]
    fn colours_weights_lines_and_comments_are_read_or_skipped() {
        let text = b"# a comment\r\nv 0 0 0 1 0 0\r\nv 2 0 0 2\r\nv 0 1 0\r\ns 1\r\nl 1 2\r\np 3\r\nf 1 2\r\nf 1 2 3\r\n";
        let g = parse(text).unwrap();
        assert_eq!(g.pieces.len(), 1);
        let p = &g.pieces[0];
        assert_eq!(p.arities, vec![3]);
        // `v 2 0 0 2` is (1, 0, 0); the colour after the first is skipped.
        assert_eq!(p.positions[1], Vec3::X);
        assert_eq!(p.name, "unnamed_object");
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse(b"v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap_err();
        assert!(
            e.starts_with("line 3: vertex index 7 is out of range (the file has 2)"),
            "{e}"
        );
        let e = parse(b"v 0 0 0\nv 1 x 0\n").unwrap_err();
        assert!(e.starts_with("line 2: `v`: `x` is not a number"), "{e}");
        let e = parse(b"v 0 0 0\n\nf 1/ 1 1/2/3/4\n").unwrap_err();
        assert!(e.starts_with("line 3: `f`"), "{e}");
        assert!(parse(b"v 0 0 0 0\n").unwrap_err().contains("w = 0"));
        // Relative and huge indices, found again as written.
        let e = parse(b"v 0 0 0\nv 1 0 0\nf -1 -2 -3\n").unwrap_err();
        assert!(
            e.starts_with("line 3: vertex index -3 is out of range"),
            "{e}"
        );
        let e = parse(b"v 0 0 0\nvt 0 0\nf 1/1 1/1 1/99999999999\n").unwrap_err();
        assert!(
            e.starts_with("line 3: texture coordinate index 99999999999 is out of range"),
            "{e}"
        );
    }

    #[test]
    fn errors_and_warnings_in_later_chunks_name_the_files_line() {
        let mut text = String::new();
        for _ in 0..3 * MIN_CHUNK / 16 {
            text += "v 0.5 0.25 1\n";
        }
        text += "vn 0 0 1\nf 1//1 2//1 3//1\nf -1//1 -2//1 -3//-5\nf 1//1 2//1 3//4\n";
        let lines_before = 3 * MIN_CHUNK / 16 + 1;
        let g = parse(text.as_bytes()).unwrap();
        let warning = g.broken_normal.unwrap();
        assert!(
            warning.starts_with(&format!(
                "line {}: normal index -5 is out of range (the file has 1)",
                lines_before + 2
            )),
            "{warning}"
        );
        text += "f 1 2 0x\n";
        let e = parse(text.as_bytes()).unwrap_err();
        assert!(
            e.starts_with(&format!("line {}: `f`", lines_before + 4)),
            "{e}"
        );
        text.truncate(text.len() - 9);
        text += "f 1 2 -99999999\n";
        let e = parse(text.as_bytes()).unwrap_err();
        assert!(
            e.starts_with(&format!(
                "line {}: vertex index -99999999 is out of range",
                lines_before + 4
            )),
            "{e}"
        );
    }
}
