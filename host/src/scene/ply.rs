//! PLY loading: ASCII and binary little/big endian, `vertex` and `face` elements, properties
//! by name. Malformed input never panics; errors name the element index or the line.

use std::path::Path;

use super::error::{read_file, Location, SceneLoadError};
use super::mesh::{Mesh, Triangle, DEFAULT_MATERIAL};

/// Loads a PLY file: `vertex` elements with `x y z` properties and `face` elements with a
/// `vertex_indices` (or `vertex_index`) list; other elements and properties are skipped.
/// Faces with more than three vertices are fan-triangulated. Formats: `ascii`,
/// `binary_little_endian`, `binary_big_endian`.
pub fn load_ply(path: &Path) -> Result<Mesh, SceneLoadError> {
    let bytes = read_file(path)?;
    load_ply_bytes(path, &bytes)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }
    fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }
    /// The value that means "full" for a colour of this type (1 for floats).
    fn full_scale(self) -> f64 {
        match self {
            Self::U8 => 255.0,
            Self::I8 => 127.0,
            Self::U16 => 65535.0,
            Self::I16 => 32767.0,
            Self::U32 => u32::MAX as f64,
            Self::I32 => i32::MAX as f64,
            Self::F32 | Self::F64 => 1.0,
        }
    }
}

#[derive(Debug, Clone)]
enum PropKind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug, Clone)]
struct Property {
    name: String,
    kind: PropKind,
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PlyFormat {
    Ascii,
    BinaryLe,
    BinaryBe,
}

/// Longest list a face may declare; anything longer is treated as corruption.
const MAX_FACE_VERTICES: u64 = 1024;

/// Loads PLY data already in memory; `name` labels errors.
pub fn load_ply_bytes(name: &Path, bytes: &[u8]) -> Result<Mesh, SceneLoadError> {
    let parsed = parse(name, bytes)?;
    Mesh::from_triangles(name, parsed.tris, vec![DEFAULT_MATERIAL])
}

/// The vertices of a PLY file with their optional per-vertex attributes (found by property
/// name): what a point cloud is made of.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlyVertices {
    /// `x y z`.
    pub pos: Vec<[f32; 3]>,
    /// `nx ny nz` (or `normal_x normal_y normal_z`), when the file has all three.
    pub normal: Option<Vec<[f32; 3]>>,
    /// `radius`, when present.
    pub radius: Option<Vec<f32>>,
    /// `red green blue` (or `r g b`, `diffuse_red …`) in [0, 1]: integer types are divided by
    /// their largest value (255 for `uchar`), floats clamped.
    pub colour: Option<Vec<[f32; 3]>>,
    /// Faces the file declares (0 for a point cloud).
    pub faces: u64,
}

/// Loads a PLY file's vertices and their attributes; faces are counted, not kept.
pub fn load_ply_vertices(path: &Path) -> Result<PlyVertices, SceneLoadError> {
    let bytes = read_file(path)?;
    load_ply_vertices_bytes(path, &bytes)
}

/// [`load_ply_vertices`] of data already in memory; `name` labels errors.
pub fn load_ply_vertices_bytes(name: &Path, bytes: &[u8]) -> Result<PlyVertices, SceneLoadError> {
    let p = parse(name, bytes)?;
    Ok(PlyVertices { pos: p.vertices, normal: p.normal, radius: p.radius, colour: p.colour, faces: p.faces })
}

/// Everything `parse` reads.
struct Parsed {
    vertices: Vec<[f32; 3]>,
    normal: Option<Vec<[f32; 3]>>,
    radius: Option<Vec<f32>>,
    colour: Option<Vec<[f32; 3]>>,
    tris: Vec<Triangle>,
    faces: u64,
}

/// Index of the first scalar property named one of `names`.
fn scalar_index(el: &Element, names: &[&str]) -> Option<usize> {
    names.iter().find_map(|n| el.props.iter().position(|p| p.name == *n && matches!(p.kind, PropKind::Scalar(_))))
}

/// Indices of three scalar properties, if all are present under one of the name sets.
fn triple_index(el: &Element, sets: &[[&str; 3]]) -> Option<[usize; 3]> {
    sets.iter().find_map(|set| {
        let [a, b, c] = set.map(|n| scalar_index(el, &[n]));
        Some([a?, b?, c?])
    })
}

fn parse(name: &Path, bytes: &[u8]) -> Result<Parsed, SceneLoadError> {
    let path = name.to_path_buf();
    let malformed = |at: Location, reason: String| SceneLoadError::Malformed { path: path.clone(), at, reason };

    // Parse the header line by line.
    let mut pos = 0usize;
    let mut line_no = 0u64;
    let mut next_line = |pos: &mut usize| -> Option<(u64, String)> {
        if *pos >= bytes.len() {
            return None;
        }
        let rest = &bytes[*pos..];
        let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        *pos += (end + 1).min(rest.len());
        line_no += 1;
        Some((line_no, String::from_utf8_lossy(&rest[..end]).trim_end_matches('\r').to_string()))
    };
    match next_line(&mut pos) {
        Some((_, l)) if l.trim() == "ply" => {}
        _ => return Err(malformed(Location::Line(1), "missing `ply` magic".into())),
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut header_lines;
    loop {
        let Some((ln, line)) = next_line(&mut pos) else {
            return Err(malformed(Location::Line(line_no), "header ends without `end_header`".into()));
        };
        header_lines = ln;
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["end_header"] => break,
            ["format", f, _version] => {
                format = Some(match *f {
                    "ascii" => PlyFormat::Ascii,
                    "binary_little_endian" => PlyFormat::BinaryLe,
                    "binary_big_endian" => PlyFormat::BinaryBe,
                    other => return Err(malformed(Location::Line(ln), format!("unknown format `{other}`"))),
                })
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["element", name, count] => {
                let count = count
                    .parse::<u64>()
                    .map_err(|_| malformed(Location::Line(ln), format!("bad element count `{count}`")))?;
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            ["property", "list", c, i, name] => {
                let (Some(count), Some(item)) = (Scalar::parse(c), Scalar::parse(i)) else {
                    return Err(malformed(Location::Line(ln), format!("unknown list types `{c} {i}`")));
                };
                if !count.is_integer() {
                    return Err(malformed(Location::Line(ln), "list count type must be an integer".into()));
                }
                let el = elements
                    .last_mut()
                    .ok_or_else(|| malformed(Location::Line(ln), "property before any element".into()))?;
                el.props.push(Property { name: name.to_string(), kind: PropKind::List { count, item } });
            }
            ["property", ty, name] => {
                let ty = Scalar::parse(ty)
                    .ok_or_else(|| malformed(Location::Line(ln), format!("unknown property type `{ty}`")))?;
                let el = elements
                    .last_mut()
                    .ok_or_else(|| malformed(Location::Line(ln), "property before any element".into()))?;
                el.props.push(Property { name: name.to_string(), kind: PropKind::Scalar(ty) });
            }
            _ => return Err(malformed(Location::Line(ln), format!("unrecognised header line `{line}`"))),
        }
    }
    let format = format.ok_or_else(|| malformed(Location::Line(header_lines), "header has no `format` line".into()))?;

    // Locate the properties we need.
    let vertex_el = elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| malformed(Location::File, "no `vertex` element".into()))?;
    let xyz_idx: Vec<usize> = ["x", "y", "z"]
        .iter()
        .map(|n| elements[vertex_el].props.iter().position(|p| p.name == *n && matches!(p.kind, PropKind::Scalar(_))))
        .collect::<Option<_>>()
        .ok_or_else(|| malformed(Location::File, "vertex element lacks scalar x, y and z".into()))?;
    let vel = &elements[vertex_el];
    let normal_idx = triple_index(vel, &[["nx", "ny", "nz"], ["normal_x", "normal_y", "normal_z"]]);
    let radius_idx = scalar_index(vel, &["radius"]);
    let colour_idx = triple_index(
        vel,
        &[["red", "green", "blue"], ["r", "g", "b"], ["diffuse_red", "diffuse_green", "diffuse_blue"]],
    );
    let colour_scale: [f64; 3] = colour_idx.map_or([1.0; 3], |ix| {
        ix.map(|i| match vel.props[i].kind {
            PropKind::Scalar(t) => t.full_scale(),
            PropKind::List { .. } => 1.0,
        })
    });
    let face_el = elements.iter().position(|e| e.name == "face");
    let face_idx = match face_el {
        Some(f) => Some(
            elements[f]
                .props
                .iter()
                .position(|p| {
                    (p.name == "vertex_indices" || p.name == "vertex_index") && matches!(p.kind, PropKind::List { .. })
                })
                .ok_or_else(|| malformed(Location::File, "face element lacks a vertex_indices list".into()))?,
        ),
        None => None,
    };

    // Read the body.
    let mut src: Box<dyn ValueSource + '_> = match format {
        PlyFormat::Ascii => Box::new(AsciiSource { bytes, pos, line: header_lines + 1 }),
        PlyFormat::BinaryLe => Box::new(BinarySource { bytes, pos, big_endian: false }),
        PlyFormat::BinaryBe => Box::new(BinarySource { bytes, pos, big_endian: true }),
    };
    let mut vertices: Vec<[f32; 3]> = Vec::new();
    let mut normals: Vec<[f32; 3]> = Vec::new();
    let mut radii: Vec<f32> = Vec::new();
    let mut colours: Vec<[f32; 3]> = Vec::new();
    let mut tris: Vec<Triangle> = Vec::new();
    let mut faces = 0u64;
    for (ei, el) in elements.iter().enumerate() {
        for k in 0..el.count {
            let loc = |src: &dyn ValueSource| {
                src.location(
                    if ei == vertex_el {
                        "vertex"
                    } else if Some(ei) == face_el {
                        "face"
                    } else {
                        "element"
                    },
                    k,
                )
            };
            let mut xyz = [0.0f32; 3];
            let (mut nrm, mut rad, mut rgb) = ([0.0f32; 3], 0.0f32, [0.0f32; 3]);
            let mut face: Vec<i64> = Vec::new();
            src.begin_record();
            let record_at = loc(src.as_ref());
            for (pi, prop) in el.props.iter().enumerate() {
                match prop.kind {
                    PropKind::Scalar(t) => {
                        let v = src
                            .value(t)
                            .map_err(|r| malformed(loc(src.as_ref()), format!("property `{}`: {r}", prop.name)))?;
                        if ei == vertex_el {
                            if let Some(axis) = xyz_idx.iter().position(|&x| x == pi) {
                                xyz[axis] = v as f32;
                            }
                            if let Some(axis) = normal_idx.and_then(|ix| ix.iter().position(|&x| x == pi)) {
                                nrm[axis] = v as f32;
                            }
                            if radius_idx == Some(pi) {
                                rad = v as f32;
                            }
                            if let Some(axis) = colour_idx.and_then(|ix| ix.iter().position(|&x| x == pi)) {
                                rgb[axis] = (v / colour_scale[axis]).clamp(0.0, 1.0) as f32;
                            }
                        }
                    }
                    PropKind::List { count, item } => {
                        let n = src
                            .value(count)
                            .map_err(|r| malformed(loc(src.as_ref()), format!("list `{}` length: {r}", prop.name)))?;
                        if !(0.0..=MAX_FACE_VERTICES as f64).contains(&n) || n.fract() != 0.0 {
                            return Err(malformed(
                                loc(src.as_ref()),
                                format!("list `{}` has invalid length {n}", prop.name),
                            ));
                        }
                        let want = Some(ei) == face_el && Some(pi) == face_idx;
                        for _ in 0..n as u64 {
                            let v = src
                                .value(item)
                                .map_err(|r| malformed(loc(src.as_ref()), format!("list `{}`: {r}", prop.name)))?;
                            if want {
                                if !item.is_integer() && v.fract() != 0.0 {
                                    return Err(malformed(
                                        loc(src.as_ref()),
                                        format!("vertex index {v} is not an integer"),
                                    ));
                                }
                                face.push(v as i64);
                            }
                        }
                    }
                }
            }
            src.end_record().map_err(|r| malformed(loc(src.as_ref()), r))?;
            if ei == vertex_el {
                if xyz.iter().chain(nrm.iter()).any(|c| !c.is_finite())
                    || !rad.is_finite()
                    || rgb.iter().any(|c| c.is_nan())
                {
                    return Err(SceneLoadError::NonFinite { path: path.clone(), at: record_at });
                }
                vertices.push(xyz);
                if normal_idx.is_some() {
                    normals.push(nrm);
                }
                if radius_idx.is_some() {
                    radii.push(rad);
                }
                if colour_idx.is_some() {
                    colours.push(rgb);
                }
            } else if Some(ei) == face_el {
                faces += 1;
                if face.len() < 3 {
                    // Points and lines have no area: count them as dropped triangles.
                    tris.push(Triangle { v: [[0.0; 3]; 3], material: 0 });
                    continue;
                }
                for &ix in &face {
                    if ix < 0 || ix as u64 >= vertices.len() as u64 {
                        return Err(SceneLoadError::IndexOutOfRange {
                            path: path.clone(),
                            at: record_at,
                            index: ix,
                            vertex_count: vertices.len() as u64,
                        });
                    }
                }
                for j in 1..face.len() - 1 {
                    let v = [vertices[face[0] as usize], vertices[face[j] as usize], vertices[face[j + 1] as usize]];
                    tris.push(Triangle { v, material: 0 });
                }
            }
        }
    }
    Ok(Parsed {
        vertices,
        normal: normal_idx.map(|_| normals),
        radius: radius_idx.map(|_| radii),
        colour: colour_idx.map(|_| colours),
        tris,
        faces,
    })
}

/// Reads typed values from the PLY body in either encoding.
trait ValueSource {
    /// Next value converted to f64 (exact for every PLY integer type).
    fn value(&mut self, t: Scalar) -> Result<f64, String>;
    /// Called before each element record (ASCII: skips blank and `comment` lines, which some
    /// files, like the bundled bun_zipper_res4.ply, carry in their body).
    fn begin_record(&mut self) {}
    /// Called after each element record (ASCII: the rest of the line must be empty).
    fn end_record(&mut self) -> Result<(), String>;
    /// Location for error messages.
    fn location(&self, kind: &'static str, index: u64) -> Location;
}

struct AsciiSource<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: u64,
}

impl AsciiSource<'_> {
    fn token(&mut self) -> Option<&str> {
        while let Some(&b) = self.bytes.get(self.pos) {
            if b == b'\n' {
                return None; // records end at the end of their line
            }
            if !b.is_ascii_whitespace() {
                break;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while self.bytes.get(self.pos).is_some_and(|b| !b.is_ascii_whitespace()) {
            self.pos += 1;
        }
        if start == self.pos {
            return None;
        }
        std::str::from_utf8(&self.bytes[start..self.pos]).ok()
    }
}

impl ValueSource for AsciiSource<'_> {
    fn begin_record(&mut self) {
        loop {
            let rest = &self.bytes[self.pos.min(self.bytes.len())..];
            let end = rest.iter().position(|&b| b == b'\n');
            let line = &rest[..end.unwrap_or(rest.len())];
            let text = String::from_utf8_lossy(line);
            let t = text.trim();
            let skip = t.is_empty() || t == "comment" || t.starts_with("comment ") || t.starts_with("comment\t");
            match end {
                Some(e) if skip => {
                    self.pos += e + 1;
                    self.line += 1;
                }
                _ => return,
            }
        }
    }
    fn value(&mut self, t: Scalar) -> Result<f64, String> {
        let tok = self.token().ok_or_else(|| "missing value (record ends early)".to_string())?.to_string();
        if t.is_integer() {
            tok.parse::<i64>().map(|v| v as f64).map_err(|_| format!("`{tok}` is not an integer"))
        } else {
            tok.parse::<f64>().map_err(|_| format!("`{tok}` is not a number"))
        }
    }
    fn end_record(&mut self) -> Result<(), String> {
        if let Some(extra) = self.token() {
            return Err(format!("unexpected extra value `{extra}`"));
        }
        match self.bytes.get(self.pos) {
            Some(b'\n') => {
                self.pos += 1;
                self.line += 1;
                Ok(())
            }
            None => Ok(()),
            Some(_) => Err("unexpected data".into()),
        }
    }
    fn location(&self, _kind: &'static str, _index: u64) -> Location {
        Location::Line(self.line)
    }
}

struct BinarySource<'a> {
    bytes: &'a [u8],
    pos: usize,
    big_endian: bool,
}

impl ValueSource for BinarySource<'_> {
    fn value(&mut self, t: Scalar) -> Result<f64, String> {
        let n = t.size();
        let raw = self.bytes.get(self.pos..self.pos + n).ok_or_else(|| "file ends inside the element".to_string())?;
        self.pos += n;
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(raw);
        if self.big_endian {
            b[..n].reverse();
        }
        Ok(match t {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(b),
        })
    }
    fn end_record(&mut self) -> Result<(), String> {
        Ok(())
    }
    fn location(&self, kind: &'static str, index: u64) -> Location {
        Location::Element(kind, index)
    }
}
