//! Scene loading: Wavefront OBJ (via `tobj`, materials from MTL `Kd`) and PLY (ASCII and
//! binary little/big endian, hand-written reader).
//!
//! Every loader returns a [`Mesh`]: a flat list of triangles whose index is the global
//! primitive id, plus a material table whose entry 0 is always the default grey
//! ([`DEFAULT_MATERIAL`]). Malformed input never panics; it becomes a [`SceneLoadError`]
//! naming the file and the line (text formats) or the element index (binary PLY).
//!
//! Policy for bad geometry:
//! - NaN or infinite vertex coordinates are an error (the device must never see them).
//! - A face index outside the vertex list is an error.
//! - Zero-area triangles (exactly zero cross product in f64, e.g. repeated vertices) are
//!   dropped and counted in [`LoadStats::dropped_degenerate`]; they can never be hit.
//! - A mesh without any remaining triangle is an error.

use std::cell::RefCell;
use std::fmt;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use gridrt_shared::scene::Material;

/// Material 0: what faces without a material (or with an unknown one) use.
pub const DEFAULT_MATERIAL: Material = Material { diffuse: [0.8, 0.8, 0.8], reflect: 0.0 };

/// One triangle of a loaded mesh. Its index in [`Mesh::triangles`] is its primitive id.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangle {
    /// Vertices a, b, c (counter-clockwise as in the file).
    pub v: [[f32; 3]; 3],
    /// Index into [`Mesh::materials`].
    pub material: u32,
}

/// Counters of one load, for the statistics report.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LoadStats {
    /// Triangles read from the file (after triangulating polygons), before dropping.
    pub triangles_read: u64,
    /// Zero-area triangles that were dropped.
    pub dropped_degenerate: u64,
    /// Non-fatal findings (e.g. a referenced MTL file that could not be opened).
    pub warnings: Vec<String>,
}

/// A triangle mesh ready for grid building.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Triangles; the index is the primitive id.
    pub triangles: Vec<Triangle>,
    /// Material table; entry 0 is [`DEFAULT_MATERIAL`].
    pub materials: Vec<Material>,
    /// What happened during loading.
    pub stats: LoadStats,
}

/// Axis-aligned bounds in f32 (the precision of the scene).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl Bounds {
    /// Extent along each axis, in f64.
    pub fn extent(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| self.max[i] as f64 - self.min[i] as f64)
    }
    /// Centre point, in f64.
    pub fn center(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| 0.5 * (self.min[i] as f64 + self.max[i] as f64))
    }
    /// Length of the diagonal, in f64.
    pub fn diagonal_len(&self) -> f64 {
        let e = self.extent();
        (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt()
    }
}

impl Mesh {
    /// Bounding box of all triangle vertices. `None` for an empty mesh.
    pub fn bounds(&self) -> Option<Bounds> {
        let mut it = self.triangles.iter().flat_map(|t| t.v.iter());
        let first = *it.next()?;
        let mut b = Bounds { min: first, max: first };
        for p in it {
            for (i, &c) in p.iter().enumerate() {
                b.min[i] = b.min[i].min(c);
                b.max[i] = b.max[i].max(c);
            }
        }
        Some(b)
    }

    /// Builds a mesh from triangles, dropping zero-area ones. Fails on non-finite
    /// coordinates, a material index outside `materials`, or an empty result.
    /// `materials` must start with the default material.
    pub fn from_triangles(
        name: &Path,
        triangles: impl IntoIterator<Item = Triangle>,
        materials: Vec<Material>,
    ) -> Result<Self, SceneLoadError> {
        let mut stats = LoadStats::default();
        let mut out = Vec::new();
        for (i, t) in triangles.into_iter().enumerate() {
            stats.triangles_read += 1;
            if t.v.iter().flatten().any(|c| !c.is_finite()) {
                return Err(SceneLoadError::NonFinite {
                    path: name.to_path_buf(),
                    at: Location::Element("triangle", i as u64),
                });
            }
            if t.material as usize >= materials.len() {
                return Err(SceneLoadError::Malformed {
                    path: name.to_path_buf(),
                    at: Location::Element("triangle", i as u64),
                    reason: format!("material {} does not exist ({} materials)", t.material, materials.len()),
                });
            }
            if is_degenerate(&t.v) {
                stats.dropped_degenerate += 1;
            } else {
                out.push(t);
            }
        }
        if out.is_empty() {
            return Err(SceneLoadError::EmptyMesh { path: name.to_path_buf(), dropped: stats.dropped_degenerate });
        }
        Ok(Self { triangles: out, materials, stats })
    }
}

/// True when the triangle has exactly zero area (cross product computed in f64, which is
/// exact for the products of f32 differences up to rounding of the sum; a triangle this
/// test keeps has a non-zero f64 normal).
pub fn is_degenerate(v: &[[f32; 3]; 3]) -> bool {
    let d = |a: [f32; 3], b: [f32; 3]| [0, 1, 2].map(|i| b[i] as f64 - a[i] as f64);
    let (e1, e2) = (d(v[0], v[1]), d(v[0], v[2]));
    let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    n[0] == 0.0 && n[1] == 0.0 && n[2] == 0.0
}

/// Where in a file a problem was found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// 1-based line of a text file.
    Line(u64),
    /// 0-based index of an element (`"vertex"`, `"face"`, …) of a binary file.
    Element(&'static str, u64),
    /// No finer location is known.
    File,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Line(l) => write!(f, "line {l}"),
            Self::Element(kind, i) => write!(f, "{kind} {i}"),
            Self::File => f.write_str("file"),
        }
    }
}

/// Why a scene file could not be loaded.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SceneLoadError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The extension is neither `.obj` nor `.ply`.
    #[error("{}: unsupported scene format (expected .obj or .ply)", path.display())]
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
    },
    /// The file is syntactically malformed.
    #[error("{}:{at}: {reason}", path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// Where.
        at: Location,
        /// What is wrong.
        reason: String,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("{}:{at}: vertex coordinate is NaN or infinite", path.display())]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// Where.
        at: Location,
    },
    /// A face names a vertex that does not exist.
    #[error("{}:{at}: face vertex index {index} out of range (the file has {vertex_count} vertices so far)", path.display())]
    IndexOutOfRange {
        /// The file.
        path: PathBuf,
        /// Where.
        at: Location,
        /// The index as written in the file.
        index: i64,
        /// Vertices available.
        vertex_count: u64,
    },
    /// No triangle with non-zero area remains.
    #[error("{}: mesh is empty ({dropped} zero-area triangles dropped)", path.display())]
    EmptyMesh {
        /// The file.
        path: PathBuf,
        /// Zero-area triangles that were dropped.
        dropped: u64,
    },
    /// `tobj` rejected the file for a reason the pre-scan did not locate.
    #[error("{}: OBJ load failed: {source}", path.display())]
    Obj {
        /// The file.
        path: PathBuf,
        /// The tobj error.
        #[source]
        source: tobj::LoadError,
    },
}

/// Loads a scene by extension (`.obj` or `.ply`, case-insensitive).
pub fn load(path: &Path) -> Result<Mesh, SceneLoadError> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("obj") => load_obj(path),
        Some("ply") => load_ply(path),
        _ => Err(SceneLoadError::UnsupportedFormat { path: path.to_path_buf() }),
    }
}

fn read_file(path: &Path) -> Result<Vec<u8>, SceneLoadError> {
    std::fs::read(path).map_err(|source| SceneLoadError::Io { path: path.to_path_buf(), source })
}

// ---------------------------------------------------------------------------------------------
// OBJ
// ---------------------------------------------------------------------------------------------

/// Loads an OBJ file (polygons are fan-triangulated by tobj; points and lines are ignored).
///
/// MTL files named by `mtllib` are looked up next to the OBJ. A missing MTL file is a warning
/// (faces fall back to material 0); a malformed one is an error. Material `i` of the MTL
/// becomes material `i + 1`; its `Kd` (clamped to `[0, 1]`) is the diffuse colour.
pub fn load_obj(path: &Path) -> Result<Mesh, SceneLoadError> {
    let bytes = read_file(path)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    load_obj_bytes(path, &bytes, &|name| std::fs::read(dir.join(name)))
}

/// Loads OBJ text already in memory. `read_mtl` opens an MTL file named by `mtllib`
/// (relative name as written in the OBJ). `name` labels errors.
pub fn load_obj_bytes(
    name: &Path,
    bytes: &[u8],
    read_mtl: &dyn Fn(&Path) -> std::io::Result<Vec<u8>>,
) -> Result<Mesh, SceneLoadError> {
    let text = std::str::from_utf8(bytes).map_err(|e| SceneLoadError::Malformed {
        path: name.to_path_buf(),
        at: Location::Line(line_of_offset(bytes, e.valid_up_to())),
        reason: "not UTF-8 text".into(),
    })?;
    // Locate errors ourselves first: tobj's errors carry no line number, and a few malformed
    // inputs would make it panic (e.g. `Kd` with two values in an MTL file).
    prescan_obj(name, text)?;

    let mtl_problem: RefCell<Option<SceneLoadError>> = RefCell::new(None);
    let warnings: RefCell<Vec<String>> = RefCell::new(Vec::new());
    let loader = |p: &Path| -> tobj::MTLLoadResult {
        let mtl_name = name.parent().map(|d| d.join(p)).unwrap_or_else(|| p.to_path_buf());
        let data = match read_mtl(p) {
            Ok(d) => d,
            Err(e) => {
                warnings
                    .borrow_mut()
                    .push(format!("{}: cannot read MTL ({e}); using the default material", mtl_name.display()));
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        let checked = std::str::from_utf8(&data)
            .map_err(|e| SceneLoadError::Malformed {
                path: mtl_name.clone(),
                at: Location::Line(line_of_offset(&data, e.valid_up_to())),
                reason: "not UTF-8 text".into(),
            })
            .and_then(|t| prescan_mtl(&mtl_name, t));
        if let Err(e) = checked {
            mtl_problem.borrow_mut().get_or_insert(e);
            return Err(tobj::LoadError::MaterialParseError);
        }
        tobj::load_mtl_buf(&mut Cursor::new(data))
    };
    // `..Default::default()` is needed when tobj's optional `merging`/`reordering` features
    // are unified in by another crate; they add fields we want off.
    #[allow(clippy::needless_update)]
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let result = tobj::load_obj_buf(&mut Cursor::new(bytes), &opts, loader);
    if let Some(e) = mtl_problem.into_inner() {
        return Err(e);
    }
    let (models, mtl) = result.map_err(|source| SceneLoadError::Obj { path: name.to_path_buf(), source })?;
    let mut stats_warnings = warnings.into_inner();

    let mut materials = vec![DEFAULT_MATERIAL];
    match mtl {
        Ok(ms) => {
            for m in ms {
                let kd = m.diffuse.unwrap_or(DEFAULT_MATERIAL.diffuse);
                if kd.iter().any(|c| !c.is_finite()) {
                    return Err(SceneLoadError::Malformed {
                        path: name.to_path_buf(),
                        at: Location::File,
                        reason: format!("material `{}` has a non-finite Kd", m.name),
                    });
                }
                materials.push(Material { diffuse: kd.map(|c| c.clamp(0.0, 1.0)), reflect: 0.0 });
            }
        }
        Err(e) => {
            if stats_warnings.is_empty() {
                stats_warnings
                    .push(format!("{}: materials not loaded ({e}); using the default material", name.display()));
            }
        }
    }

    let mut tris = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let material = match mesh.material_id {
            Some(id) if id + 1 < materials.len() => (id + 1) as u32,
            _ => 0,
        };
        for face in mesh.indices.chunks_exact(3) {
            let mut v = [[0.0f32; 3]; 3];
            for (k, &idx) in face.iter().enumerate() {
                let base = idx as usize * 3;
                let p = mesh.positions.get(base..base + 3).ok_or_else(|| SceneLoadError::Malformed {
                    path: name.to_path_buf(),
                    at: Location::File,
                    reason: format!("object `{}`: index {idx} outside its vertex list", model.name),
                })?;
                v[k] = [p[0], p[1], p[2]];
            }
            tris.push(Triangle { v, material });
        }
    }
    let mut mesh = Mesh::from_triangles(name, tris, materials)?;
    mesh.stats.warnings = stats_warnings;
    Ok(mesh)
}

fn line_of_offset(bytes: &[u8], offset: usize) -> u64 {
    bytes.get(..offset).map_or(0, |b| b.iter().filter(|&&c| c == b'\n').count() as u64) + 1
}

/// Checks the parts of an OBJ file that tobj reports without a location: vertex coordinates
/// (count, syntax, finiteness, `w` scaling) and face indices (syntax, range, relative indices).
fn prescan_obj(name: &Path, text: &str) -> Result<(), SceneLoadError> {
    let mut vertices: u64 = 0;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i as u64 + 1;
        let at = || Location::Line(line_no);
        let line = raw.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let vals: Vec<&str> = words.collect();
                let malformed =
                    |reason: String| SceneLoadError::Malformed { path: name.to_path_buf(), at: at(), reason };
                if vals.len() < 3 {
                    return Err(malformed(format!("vertex needs 3 coordinates, found {}", vals.len())));
                }
                let mut xyz = [0.0f32; 3];
                for (k, s) in vals.iter().take(3).enumerate() {
                    xyz[k] = s.parse::<f32>().map_err(|_| malformed(format!("`{s}` is not a number")))?;
                }
                if vals.len() == 4 {
                    let w = vals[3].parse::<f32>().map_err(|_| malformed(format!("`{}` is not a number", vals[3])))?;
                    if w == 0.0 {
                        return Err(malformed("vertex w is zero".into()));
                    }
                    xyz = xyz.map(|c| c / w);
                }
                if xyz.iter().any(|c| !c.is_finite()) {
                    return Err(SceneLoadError::NonFinite { path: name.to_path_buf(), at: at() });
                }
                vertices += 1;
            }
            Some("f") => {
                let mut count = 0;
                for w in words {
                    count += 1;
                    let first = w.split('/').next().unwrap_or("");
                    let index: i64 = first.parse().map_err(|_| SceneLoadError::Malformed {
                        path: name.to_path_buf(),
                        at: at(),
                        reason: format!("`{w}` is not a face vertex index"),
                    })?;
                    let ok = if index < 0 {
                        index.unsigned_abs() <= vertices
                    } else {
                        index >= 1 && index as u64 <= vertices
                    };
                    if !ok {
                        return Err(SceneLoadError::IndexOutOfRange {
                            path: name.to_path_buf(),
                            at: at(),
                            index,
                            vertex_count: vertices,
                        });
                    }
                }
                if count == 0 {
                    return Err(SceneLoadError::Malformed {
                        path: name.to_path_buf(),
                        at: at(),
                        reason: "face without vertices".into(),
                    });
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Checks colour statements of an MTL file (tobj panics on fewer than three values).
fn prescan_mtl(name: &Path, text: &str) -> Result<(), SceneLoadError> {
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() {
            let vals: Vec<&str> = words.collect();
            let ok = vals.len() >= 3 && vals.iter().take(3).all(|s| s.parse::<f32>().is_ok_and(f32::is_finite));
            if !ok {
                return Err(SceneLoadError::Malformed {
                    path: name.to_path_buf(),
                    at: Location::Line(i as u64 + 1),
                    reason: format!("`{key}` needs three finite numbers"),
                });
            }
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// PLY
// ---------------------------------------------------------------------------------------------

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
    let mut tris: Vec<Triangle> = Vec::new();
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
                if xyz.iter().any(|c| !c.is_finite()) {
                    return Err(SceneLoadError::NonFinite { path: path.clone(), at: record_at });
                }
                vertices.push(xyz);
            } else if Some(ei) == face_el {
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
    Mesh::from_triangles(name, tris, vec![DEFAULT_MATERIAL])
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

#[cfg(test)]
mod tests {
    use super::*;

    fn scenes() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes")
    }

    fn obj(text: &str) -> Result<Mesh, SceneLoadError> {
        load_obj_bytes(Path::new("test.obj"), text.as_bytes(), &|_| Err(std::io::ErrorKind::NotFound.into()))
    }

    const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";

    #[test]
    fn obj_quad_is_triangulated() {
        let m = obj(QUAD).unwrap();
        assert_eq!(m.triangles.len(), 2);
        assert_eq!(m.materials, vec![DEFAULT_MATERIAL]);
        assert_eq!(m.stats.dropped_degenerate, 0);
    }

    #[test]
    fn obj_nan_vertex_names_its_line() {
        let err = obj("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n").unwrap_err();
        assert!(matches!(err, SceneLoadError::NonFinite { at: Location::Line(3), .. }), "{err}");
        assert!(err.to_string().contains("test.obj:line 3"), "{err}");
        let err = obj("v 0 0 0\nv 1 0 0\nv inf 1 0\nf 1 2 3\n").unwrap_err();
        assert!(matches!(err, SceneLoadError::NonFinite { at: Location::Line(3), .. }), "{err}");
    }

    #[test]
    fn obj_out_of_range_index_names_its_line() {
        let err = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
        assert!(
            matches!(err, SceneLoadError::IndexOutOfRange { at: Location::Line(4), index: 4, vertex_count: 3, .. }),
            "{err}"
        );
        let err = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").unwrap_err();
        assert!(matches!(err, SceneLoadError::IndexOutOfRange { index: 0, .. }), "{err}");
        let err = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n").unwrap_err();
        assert!(matches!(err, SceneLoadError::IndexOutOfRange { index: -4, .. }), "{err}");
        // Relative indices in range are fine.
        assert_eq!(obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").unwrap().triangles.len(), 1);
    }

    #[test]
    fn obj_garbage_is_malformed_not_panic() {
        for text in ["v 1 2\nf 1 1 1\n", "v a b c\n", "v 0 0 0\nf x y z\n", "f\n", "v 1 1 1 0\n", "\u{0}\u{1}junk"] {
            assert!(obj(text).is_err(), "{text:?} should fail");
        }
        let err = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n").unwrap_err();
        assert!(matches!(err, SceneLoadError::Malformed { at: Location::Line(4), .. }), "{err}");
        assert!(obj("").is_err());
    }

    #[test]
    fn obj_degenerate_triangles_are_dropped_and_counted() {
        let m = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 2\n").unwrap();
        assert_eq!(m.triangles.len(), 1);
        assert_eq!(m.stats.dropped_degenerate, 2);
        assert_eq!(m.stats.triangles_read, 3);
    }

    #[test]
    fn obj_only_degenerate_is_empty_mesh_error() {
        let err = obj("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap_err();
        assert!(matches!(err, SceneLoadError::EmptyMesh { dropped: 1, .. }), "{err}");
        assert!(matches!(obj("v 0 0 0\n").unwrap_err(), SceneLoadError::EmptyMesh { dropped: 0, .. }));
    }

    #[test]
    fn obj_missing_mtl_is_a_warning() {
        let m = obj(&format!("mtllib nope.mtl\nusemtl red\n{QUAD}")).unwrap();
        assert_eq!(m.materials.len(), 1);
        assert!(m.triangles.iter().all(|t| t.material == 0));
        assert!(!m.stats.warnings.is_empty());
    }

    #[test]
    fn obj_malformed_mtl_names_mtl_line() {
        let mtl = b"newmtl red\nKd 1 0\n".to_vec();
        let err =
            load_obj_bytes(Path::new("dir/a.obj"), format!("mtllib m.mtl\nusemtl red\n{QUAD}").as_bytes(), &|_| {
                Ok(mtl.clone())
            })
            .unwrap_err();
        assert!(
            matches!(&err, SceneLoadError::Malformed { at: Location::Line(2), path, .. } if path.ends_with("m.mtl")),
            "{err}"
        );
    }

    #[test]
    fn cornell_box_keeps_mtl_diffuse_colours() {
        let m = load(&scenes().join("cornell_box.obj")).unwrap();
        // white, red, green, blue, light after the default.
        assert_eq!(m.materials.len(), 6);
        assert!(m.materials.contains(&Material { diffuse: [1.0, 0.0, 0.0], reflect: 0.0 }));
        assert!(m.triangles.iter().any(|t| m.materials[t.material as usize].diffuse == [0.0, 1.0, 0.0]));
        assert!(m.triangles.iter().all(|t| t.material != 0));
        assert!(m.triangles.len() >= 30, "{}", m.triangles.len());
    }

    #[test]
    fn bunny_res4_ply_and_obj_agree() {
        let ply = load(&scenes().join("bun_zipper_res4.ply")).unwrap();
        let obj = load(&scenes().join("bun_zipper_res4.obj")).unwrap();
        assert_eq!(ply.stats.triangles_read, 946);
        assert_eq!(ply.triangles.len(), obj.triangles.len());
        assert_eq!(ply.triangles[0].v, obj.triangles[0].v);
        assert_eq!(ply.bounds(), obj.bounds());
    }

    #[test]
    fn suzanne_quads_are_triangulated() {
        let m = load(&scenes().join("suzanne.obj")).unwrap();
        assert!(m.triangles.len() > 500);
    }

    fn ply_header(format: &str, nv: usize, nf: usize) -> String {
        format!(
            "ply\nformat {format} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n\
             element face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
        )
    }

    #[test]
    fn ply_binary_little_endian_loads() {
        let mut b = ply_header("binary_little_endian", 3, 1).into_bytes();
        for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in v {
                b.extend_from_slice(&c.to_le_bytes());
            }
        }
        b.push(3);
        for i in [0i32, 1, 2] {
            b.extend_from_slice(&i.to_le_bytes());
        }
        let m = load_ply_bytes(Path::new("t.ply"), &b).unwrap();
        assert_eq!(m.triangles.len(), 1);
        assert_eq!(m.triangles[0].v[1], [1.0, 0.0, 0.0]);
        // Truncated: names the element.
        let err = load_ply_bytes(Path::new("t.ply"), &b[..b.len() - 2]).unwrap_err();
        assert!(matches!(err, SceneLoadError::Malformed { at: Location::Element("face", 0), .. }), "{err}");
    }

    #[test]
    fn ply_ascii_errors_name_the_line() {
        let h = ply_header("ascii", 3, 1);
        let ok = format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
        assert_eq!(load_ply_bytes(Path::new("t.ply"), ok.as_bytes()).unwrap().triangles.len(), 1);
        // The header has 9 lines; vertex 2 is on line 12.
        let nan = format!("{h}0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n");
        let err = load_ply_bytes(Path::new("t.ply"), nan.as_bytes()).unwrap_err();
        assert!(matches!(err, SceneLoadError::NonFinite { at: Location::Line(12), .. }), "{err}");
        let oob = format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
        let err = load_ply_bytes(Path::new("t.ply"), oob.as_bytes()).unwrap_err();
        assert!(matches!(err, SceneLoadError::IndexOutOfRange { at: Location::Line(13), index: 7, .. }), "{err}");
        let short = format!("{h}0 0 0\n1 0\n0 1 0\n3 0 1 2\n");
        let err = load_ply_bytes(Path::new("t.ply"), short.as_bytes()).unwrap_err();
        assert!(matches!(err, SceneLoadError::Malformed { at: Location::Line(11), .. }), "{err}");
    }

    #[test]
    fn ply_garbage_never_panics() {
        let cases: [&[u8]; 6] = [
            b"",
            b"ply\n",
            b"ply\nformat ascii 1.0\nelement vertex 1\nend_header\n0 0 0\n",
            b"ply\nformat binary_little_endian 1.0\nelement vertex 99999999999\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n200 0 1 2\n",
            b"ply\nformat weird 1.0\nend_header\n",
        ];
        for c in cases {
            assert!(load_ply_bytes(Path::new("t.ply"), c).is_err());
        }
    }

    #[test]
    fn unknown_extension_is_rejected() {
        assert!(matches!(load(Path::new("x.stl")), Err(SceneLoadError::UnsupportedFormat { .. })));
        assert!(matches!(load(Path::new("/nonexistent/x.obj")), Err(SceneLoadError::Io { .. })));
    }
}
