//! Wavefront OBJ: garments in (through `tobj`), baked frames out.
//!
//! Reading keeps what a garment needs: positions, UVs per triangle corner,
//! quads (for shear springs), objects and groups as named parts, and MTL
//! materials (diffuse colour and texture). `tobj` splits vertices between
//! groups and reports errors without a line; here the groups are joined again
//! (welding happens in [`crate::mesh::validate::clean`]) and the line of a
//! parse error is found by a second look at the text.

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use crate::mesh::validate::{MeshError, MeshReport, clean};
use crate::mesh::{Material, Part, Surface, TriMesh};

/// Why an OBJ file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ObjError {
    /// The file could not be read.
    #[error("cannot read OBJ file {path}: {source}")]
    Read {
        /// File path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not valid OBJ.
    #[error("OBJ file {path}{}: {problem}", line.map(|l| format!(", line {l}")).unwrap_or_default())]
    Parse {
        /// File path.
        path: PathBuf,
        /// 1-based line of the problem, when it could be found.
        line: Option<usize>,
        /// What is wrong.
        problem: String,
    },
    /// The geometry cannot be simulated.
    #[error("OBJ file {path}: {source}")]
    Mesh {
        /// File path.
        path: PathBuf,
        /// What is wrong with the mesh.
        source: MeshError,
    },
}

/// A garment read from OBJ: the cleaned mesh, what validation repaired, and
/// non-fatal problems (e.g. an unreadable MTL file).
#[derive(Clone, Debug)]
pub struct ObjGarment {
    /// The mesh, welded and validated, in the file's coordinates.
    pub mesh: TriMesh,
    /// What validation found and repaired.
    pub report: MeshReport,
    /// Problems that did not stop loading.
    pub warnings: Vec<String>,
}

/// Reads and validates a garment OBJ.
pub fn read_obj(path: &Path) -> Result<ObjGarment, ObjError> {
    let bytes = std::fs::read(path).map_err(|source| ObjError::Read { path: path.to_owned(), source })?;
    parse_obj(&bytes, path)
}

/// Parses and validates the bytes of a garment OBJ read from `path` (named
/// in errors; its material library is looked for beside it).
pub fn parse_obj(bytes: &[u8], path: &Path) -> Result<ObjGarment, ObjError> {
    let text = std::str::from_utf8(bytes).map_err(|e| ObjError::Parse {
        path: path.to_owned(),
        line: Some(1 + bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count()),
        problem: "not UTF-8 text (re-save the file as UTF-8)".to_owned(),
    })?;
    // Windows editors start UTF-8 files with a byte-order mark; left in, it
    // would hide the first statement (often `mtllib`) from the parser.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let uncommented = without_trailing_comments(text);
    let text = uncommented.as_ref();
    let folder = path.parent().unwrap_or(Path::new("")).to_owned();
    let options =
        tobj::LoadOptions { triangulate: false, ignore_points: true, ignore_lines: true, ..Default::default() };
    let (models, materials) =
        tobj::load_obj_buf(&mut std::io::Cursor::new(text), &options, |mtl| tobj::load_mtl(folder.join(mtl))).map_err(
            |e| ObjError::Parse { path: path.to_owned(), line: locate_error(text, &e), problem: e.to_string() },
        )?;

    let mut warnings = Vec::new();
    let materials = match materials {
        Ok(m) => m.iter().map(|m| convert_material(m, &folder, &mut warnings)).collect(),
        Err(e) => {
            if text.lines().any(|l| l.trim_start().starts_with("mtllib")) {
                warnings.push(format!("its material library could not be read ({e}); using default colours"));
            }
            Vec::new()
        }
    };
    let mut mesh = assemble(&models, materials);
    mesh.sort_vertices_by(&file_order(text, &mesh.positions));
    let (mesh, mut report) = clean(mesh).map_err(|source| ObjError::Mesh { path: path.to_owned(), source })?;
    // tobj drops vertices no face uses and splits shared ones between groups;
    // count what the file itself declares to report both kinds of defect.
    let (declared, used) = vertex_usage(text);
    report.duplicate_vertices = used.saturating_sub(mesh.vertex_count() + report.isolated_vertices);
    report.isolated_vertices += declared - used;
    Ok(ObjGarment { mesh, report, warnings })
}

/// The triangles of one exported frame, from any program: every object and
/// group of the file joined, polygons fanned, and vertices with identical
/// coordinates (split by groups or UV seams) merged, so that triangles sharing
/// a corner share its index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameMesh {
    /// Vertex positions, m.
    pub positions: Vec<Vector3<f64>>,
    /// Triangles, indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
}

/// Reads one frame of an OBJ sequence (positions and faces only).
pub fn read_frame(path: &Path) -> Result<FrameMesh, ObjError> {
    let bytes = std::fs::read(path).map_err(|source| ObjError::Read { path: path.to_owned(), source })?;
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(&bytes);
    let options =
        tobj::LoadOptions { triangulate: true, ignore_points: true, ignore_lines: true, ..Default::default() };
    let (models, _) =
        tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &options, |_| Err(tobj::LoadError::OpenFileFailed))
            .map_err(|e| {
                let line = std::str::from_utf8(bytes).ok().and_then(|text| locate_error(text, &e));
                ObjError::Parse { path: path.to_owned(), line, problem: e.to_string() }
            })?;
    let mut frame = FrameMesh::default();
    let mut index_of = std::collections::HashMap::new();
    for model in &models {
        let m = &model.mesh;
        let ids: Vec<u32> = m
            .positions
            .chunks_exact(3)
            .map(|p| {
                let next = index_of.len() as u32;
                *index_of.entry([p[0], p[1], p[2]].map(|c| (c + 0.0).to_bits())).or_insert_with(|| {
                    frame.positions.push(Vector3::new(p[0], p[1], p[2]));
                    next
                })
            })
            .collect();
        frame.triangles.extend(m.indices.chunks_exact(3).map(|t| [0, 1, 2].map(|k| ids[t[k] as usize])));
    }
    if let Some(bad) = frame.positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(ObjError::Parse {
            path: path.to_owned(),
            line: None,
            problem: format!("vertex {} is not finite", bad + 1),
        });
    }
    Ok(frame)
}

fn convert_material(m: &tobj::Material, folder: &Path, warnings: &mut Vec<String>) -> Material {
    let texture = m.diffuse_texture.as_ref().map(|t| folder.join(t));
    let found = texture.filter(|t| t.is_file());
    if let (Some(named), None) = (&m.diffuse_texture, &found) {
        warnings.push(format!("material '{}': its texture {named} is not there; using its colour", m.name));
    }
    Material {
        name: m.name.clone(),
        diffuse: m.diffuse.map_or([0.8; 3], |c| c.map(|x| x as f32)),
        diffuse_texture: found,
    }
}

/// Joins tobj's models into one mesh: quads kept, n-gons fanned, one part per
/// model. Corners without UVs point at an appended (0, 0).
fn assemble(models: &[tobj::Model], materials: Vec<Material>) -> TriMesh {
    let mut mesh = TriMesh { surface: Surface { materials, ..Default::default() }, ..Default::default() };
    let any_uvs = models.iter().any(|m| !m.mesh.texcoord_indices.is_empty());
    let mut missing_uv = None;
    for model in models {
        let m = &model.mesh;
        let vertex_offset = mesh.positions.len() as u32;
        let uv_offset = mesh.surface.uvs.len() as u32;
        mesh.positions.extend(m.positions.chunks_exact(3).map(|p| Vector3::new(p[0], p[1], p[2])));
        mesh.surface.uvs.extend(m.texcoords.chunks_exact(2).map(|t| [t[0] as f32, t[1] as f32]));
        if any_uvs && m.texcoord_indices.is_empty() && missing_uv.is_none() {
            missing_uv = Some(mesh.surface.uvs.len() as u32);
            mesh.surface.uvs.push([0.0, 0.0]);
        }
        let first_triangle = mesh.triangles.len();
        let arities: Vec<u32> =
            if m.face_arities.is_empty() { vec![3; m.indices.len() / 3] } else { m.face_arities.clone() };
        let mut start = 0;
        for arity in arities {
            let range = start..start + arity as usize;
            start = range.end;
            let corners: Vec<u32> = m.indices[range.clone()].iter().map(|i| i + vertex_offset).collect();
            let uvs: Vec<u32> = match m.texcoord_indices.get(range) {
                Some(t) => t.iter().map(|i| i + uv_offset).collect(),
                None => vec![missing_uv.unwrap_or(0); corners.len()],
            };
            if let [a, b, c, d] = corners[..] {
                mesh.quads.push([a, b, c, d]);
            }
            for k in 1..corners.len().saturating_sub(1) {
                mesh.triangles.push([corners[0], corners[k], corners[k + 1]]);
                if any_uvs {
                    mesh.surface.triangle_uvs.push([uvs[0], uvs[k], uvs[k + 1]]);
                }
            }
        }
        mesh.surface.parts.push(Part {
            name: model.name.clone(),
            material: m.material_id,
            first_triangle,
            triangle_count: mesh.triangles.len() - first_triangle,
        });
    }
    mesh
}

/// `text` with the comments after data statements (`v 0 1 0 # corner`,
/// written by hand or by some exporters) cut off, which tobj would read as
/// data; lines stay where they were, so errors keep their line numbers.
fn without_trailing_comments(text: &str) -> std::borrow::Cow<'_, str> {
    const DATA: [&str; 7] = ["v", "vt", "vn", "f", "l", "p", "s"];
    let commented =
        |line: &str| line.contains('#') && line.split_whitespace().next().is_some_and(|t| DATA.contains(&t));
    if !text.lines().any(commented) {
        return text.into();
    }
    let mut kept = String::with_capacity(text.len());
    for line in text.split_inclusive('\n') {
        match line.find('#').filter(|_| commented(line)) {
            Some(at) => kept.extend([&line[..at], if line.ends_with('\n') { "\n" } else { "" }]),
            None => kept.push_str(line),
        }
    }
    kept.into()
}

/// For each vertex, the index of the first `v` line with its exact
/// coordinates: tobj numbers vertices by first use in a face, this restores
/// the file's order (so vertex indices in scene files mean what the modelling
/// tool shows).
fn file_order(text: &str, positions: &[Vector3<f64>]) -> Vec<usize> {
    let mut first_line = std::collections::HashMap::new();
    let vertex_lines = text.lines().map(str::split_whitespace).filter_map(|mut tokens| match tokens.next() {
        Some("v") => Some(tokens),
        _ => None,
    });
    for (index, tokens) in vertex_lines.enumerate() {
        let mut numbers = tokens.map(str::parse::<f64>);
        if let (Some(Ok(x)), Some(Ok(y)), Some(Ok(z))) = (numbers.next(), numbers.next(), numbers.next()) {
            first_line.entry([x, y, z].map(f64::to_bits)).or_insert(index);
        }
    }
    positions
        .iter()
        .map(|p| first_line.get(&[p.x, p.y, p.z].map(f64::to_bits)).copied().unwrap_or(usize::MAX))
        .collect()
}

/// Number of `v` lines, and of distinct vertices that faces refer to.
fn vertex_usage(text: &str) -> (usize, usize) {
    let mut declared = 0;
    let mut used = std::collections::HashSet::new();
    for line in text.lines() {
        let mut tokens = line.split_whitespace();
        match tokens.next() {
            Some("v") => declared += 1,
            Some("f") => {
                for corner in tokens {
                    if let Some(Ok(i)) = corner.split('/').next().map(str::parse::<i64>) {
                        used.insert(if i < 0 { declared as i64 + i } else { i - 1 });
                    }
                }
            }
            _ => {}
        }
    }
    (declared, used.len().min(declared))
}

/// Whether a line's whitespace-separated tokens are the kind a tobj error
/// complains about.
type LineTest<'a> = Box<dyn Fn(&[&str]) -> bool + 'a>;

/// Finds the line a tobj error most likely comes from.
fn locate_error(text: &str, error: &tobj::LoadError) -> Option<usize> {
    use tobj::LoadError as E;
    let numbers = |tokens: &[&str]| tokens.iter().all(|t| t.parse::<f64>().is_ok());
    let bad_numbers = |tag: &'static str, counts: &'static [usize]| {
        move |tokens: &[&str]| {
            tokens.first() == Some(&tag) && !(numbers(&tokens[1..]) && counts.contains(&(tokens.len() - 1)))
        }
    };
    let counts = ["v", "vt", "vn"].map(|tag| text.lines().filter(|l| l.split_whitespace().next() == Some(tag)).count());
    let bad_face = |tokens: &[&str]| {
        tokens.first() == Some(&"f")
            && (tokens.len() < 4
                || tokens[1..].iter().any(|corner| {
                    corner.split('/').zip(counts).any(|(index, count)| {
                        !index.is_empty()
                            && index.parse::<i64>().map_or(true, |i| i == 0 || i.unsigned_abs() as usize > count)
                    })
                }))
    };
    let predicate: LineTest<'_> = match error {
        E::PositionParseError | E::ColorParseError => Box::new(bad_numbers("v", &[3, 4, 6, 7])),
        E::TexcoordParseError => Box::new(bad_numbers("vt", &[1, 2, 3])),
        E::NormalParseError => Box::new(bad_numbers("vn", &[3])),
        E::FaceParseError
        | E::InvalidPolygon
        | E::FaceVertexOutOfBounds
        | E::FaceTexCoordOutOfBounds
        | E::FaceNormalOutOfBounds => Box::new(bad_face),
        _ => return None,
    };
    text.lines().position(|line| predicate(&line.split_whitespace().collect::<Vec<_>>())).map(|i| i + 1)
}

/// One object of exported frames: what stays the same from frame to frame.
pub struct ObjSurface<'a> {
    /// Object name (`o`).
    pub name: &'a str,
    /// Number of vertices; every frame gives this many positions.
    pub vertex_count: usize,
    /// Triangles (indices into the object's positions).
    pub triangles: &'a [[u32; 3]],
    /// UVs, materials and parts.
    pub surface: &'a Surface,
    /// Prefix of material names in the library: a part's material is written as
    /// `namespace.name`, a part without one as `namespace`.
    pub material_namespace: &'a str,
}

/// Decimals of a written position, m: 1 nm, a thousandth of the gap within
/// which the collision pipeline counts features as crossing (1 µm), so that
/// the independent checker finds in the files what the bake's own check
/// found in memory. At 6 decimals (1 µm) the rounding alone made 20
/// intersecting pairs in 9 frames of the wrung `twist`, which in memory had
/// none.
const POSITION_DECIMALS: usize = 9;

/// Writes frames of objects whose surfaces stay the same: every object with
/// positions, UVs, area-weighted normals, and parts as groups with their
/// materials. The UV and face lines are formatted once, when made, so a frame
/// formats only its positions and normals. Vertex order is the simulation's,
/// the same in every frame.
pub struct ObjFrames<'a> {
    mtllib: Option<String>,
    objects: Vec<FormattedObject<'a>>,
}

/// An object's name, triangles, and its UV and face lines, ready to write.
struct FormattedObject<'a> {
    name: &'a str,
    vertex_count: usize,
    triangles: &'a [[u32; 3]],
    uv_lines: String,
    face_lines: String,
}

impl<'a> ObjFrames<'a> {
    /// Formats the unchanging lines of `objects`, whose frames refer to the
    /// material library `mtllib`.
    pub fn new(mtllib: Option<&str>, objects: &[ObjSurface<'a>]) -> Self {
        let (mut v_base, mut vt_base) = (1usize, 1usize);
        let formatted = objects
            .iter()
            .map(|object| {
                let formatted = FormattedObject {
                    name: object.name,
                    vertex_count: object.vertex_count,
                    triangles: object.triangles,
                    uv_lines: uv_lines(object.surface),
                    face_lines: face_lines(object, v_base, vt_base),
                };
                v_base += object.vertex_count;
                vt_base += object.surface.uvs.len();
                formatted
            })
            .collect();
        ObjFrames { mtllib: mtllib.map(str::to_owned), objects: formatted }
    }

    /// Number of positions a frame gives: every object's, in order.
    pub fn vertex_count(&self) -> usize {
        self.objects.iter().map(|o| o.vertex_count).sum()
    }

    /// Writes one frame under the comment `header`, from `positions`, m: the
    /// objects' vertices one after the other ([`Self::vertex_count`] of them).
    pub fn write(&self, out: &mut impl Write, header: &str, positions: &[Vector3<f64>]) -> std::io::Result<()> {
        if positions.len() != self.vertex_count() {
            let problem = format!("{} positions for {} vertices", positions.len(), self.vertex_count());
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, problem));
        }
        writeln!(out, "# {header}")?;
        if let Some(lib) = &self.mtllib {
            writeln!(out, "mtllib {lib}")?;
        }
        let mut rest = positions;
        for object in &self.objects {
            let (own, others) = rest.split_at(object.vertex_count);
            rest = others;
            writeln!(out, "o {}", object.name)?;
            for p in own {
                let d = POSITION_DECIMALS;
                writeln!(out, "v {:.d$} {:.d$} {:.d$}", p.x, p.y, p.z)?;
            }
            out.write_all(object.uv_lines.as_bytes())?;
            for n in crate::mesh::normals::vertex_normals(own, object.triangles) {
                writeln!(out, "vn {:.5} {:.5} {:.5}", n.x, n.y, n.z)?;
            }
            out.write_all(object.face_lines.as_bytes())?;
        }
        Ok(())
    }
}

/// The `vt` lines of `surface`.
fn uv_lines(surface: &Surface) -> String {
    let mut lines = String::new();
    for uv in &surface.uvs {
        let _ = writeln!(lines, "vt {:.6} {:.6}", uv[0], uv[1]);
    }
    lines
}

/// The group, material and face lines of `object`, whose first vertex is
/// number `v_base` of the file and first UV number `vt_base` (each vertex's
/// normal has the vertex's number).
fn face_lines(object: &ObjSurface, v_base: usize, vt_base: usize) -> String {
    let surface = object.surface;
    let has_uvs = !surface.triangle_uvs.is_empty();
    let ns = object.material_namespace;
    let mut lines = String::new();
    for part in &surface.parts {
        let _ = writeln!(lines, "g {}", part.name);
        let _ = match part.material.and_then(|m| surface.materials.get(m)) {
            Some(m) => writeln!(lines, "usemtl {ns}.{}", m.name),
            None => writeln!(lines, "usemtl {ns}"),
        };
        for t in part.first_triangle..part.first_triangle + part.triangle_count {
            lines.push('f');
            for k in 0..3 {
                let v = object.triangles[t][k] as usize + v_base;
                let _ = match has_uvs {
                    true => write!(lines, " {v}/{}/{v}", surface.triangle_uvs[t][k] as usize + vt_base),
                    false => write!(lines, " {v}//{v}"),
                };
            }
            lines.push('\n');
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    fn write_temp(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn quads_groups_and_uv_seams_are_kept_and_groups_are_welded() {
        let dir = tempfile::tempdir().unwrap();
        // Two groups sharing the edge 2-3; each has its own UV island (a seam).
        let text = "mtllib cloth.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 2 0 0\nv 2 0 1\n\
                    vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
                    g front\nusemtl red\nf 1/1 4/4 3/3 2/2\ng back\nf 2/5 3/8 6/7 5/6\n";
        write_temp(&dir, "cloth.mtl", "newmtl red\nKd 0.8 0.1 0.1\nmap_Kd red.png\n");
        write_temp(&dir, "red.png", "");
        let garment = read_obj(&write_temp(&dir, "cloth.obj", text)).unwrap();
        let mesh = &garment.mesh;
        assert_eq!(mesh.vertex_count(), 6, "the shared edge is one edge");
        assert_eq!(mesh.triangles.len(), 4);
        assert_eq!(mesh.quads.len(), 2);
        assert_eq!(mesh.surface.uvs.len(), 8, "each corner keeps its own UV");
        assert_eq!(mesh.surface.parts.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["front", "back"]);
        let red = &mesh.surface.materials[mesh.surface.parts[0].material.unwrap()];
        assert_eq!((red.name.as_str(), red.diffuse), ("red", [0.8, 0.1, 0.1]));
        assert_eq!(red.diffuse_texture.as_deref(), Some(dir.path().join("red.png").as_path()));
        assert!(garment.warnings.is_empty() && garment.report.is_clean(), "{:?}", garment.report);
    }

    #[test]
    fn negative_indices_ngons_and_missing_mtl_load_with_a_warning() {
        let dir = tempfile::tempdir().unwrap();
        let text =
            "mtllib missing.mtl\r\nv 0 0 0\r\nv 1 0 0\r\nv 1.5 0 0.5\r\nv 1 0 1\r\nv 0 0 1\r\nf -5 -1 -2 -3 -4\r\n";
        let garment = read_obj(&write_temp(&dir, "pentagon.obj", text)).unwrap();
        assert_eq!(garment.mesh.triangles.len(), 3, "a pentagon fans into three triangles");
        assert_eq!(garment.warnings.len(), 1, "{:?}", garment.warnings);
    }

    #[test]
    fn bad_files_name_the_file_the_line_and_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            ("range.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\nf 1 2 9\n", Some(5)),
            ("number.obj", "v 0 0 0\nv 1 zero 0\nv 0 0 1\nf 1 2 3\n", Some(2)),
            ("empty.obj", "# nothing here\n", None),
        ];
        for (name, text, line) in cases {
            let err = read_obj(&write_temp(&dir, name, text)).unwrap_err();
            let message = err.to_string();
            assert!(message.contains(name), "{message}");
            if let Some(line) = line {
                assert!(message.contains(&format!("line {line}")), "{message}");
            }
        }
        let err = read_obj(&dir.path().join("absent.obj")).unwrap_err();
        assert!(matches!(err, ObjError::Read { .. }), "{err}");
        let latin1 = dir.path().join("latin1.obj");
        std::fs::write(&latin1, b"v 0 0 0\n# caf\xe9\n").unwrap();
        assert!(read_obj(&latin1).unwrap_err().to_string().contains("line 2"));
    }

    /// `frames` of two tubes written as one file each; the second tube is
    /// the first 2 m away along every axis and moved by `shift` along x per
    /// frame, with its own namespace.
    fn two_tube_frames(frames: usize, shift: f64) -> (TriMesh, Vec<Vec<u8>>) {
        let mesh = generate::tube(0.2, 1.0, 8, 4);
        let surface = |name, material_namespace| ObjSurface {
            name,
            vertex_count: mesh.vertex_count(),
            triangles: &mesh.triangles,
            surface: &mesh.surface,
            material_namespace,
        };
        let writer = ObjFrames::new(Some("cloth.mtl"), &[surface("near", "cloth"), surface("far", "lining")]);
        let files = (0..frames)
            .map(|frame| {
                let offset = Vector3::repeat(2.0) + Vector3::x() * (shift * frame as f64);
                let positions: Vec<_> =
                    mesh.positions.iter().copied().chain(mesh.positions.iter().map(|p| p + offset)).collect();
                let mut bytes = Vec::new();
                writer.write(&mut bytes, &format!("frame {frame}"), &positions).unwrap();
                bytes
            })
            .collect();
        (mesh, files)
    }

    #[test]
    fn written_frames_read_back_with_the_same_vertices_and_uvs() {
        let (mesh, files) = two_tube_frames(1, 0.0);
        let dir = tempfile::tempdir().unwrap();
        let back = read_obj(&write_temp(&dir, "frame.obj", std::str::from_utf8(&files[0]).unwrap())).unwrap();
        let n = mesh.vertex_count();
        assert_eq!(back.mesh.vertex_count(), 2 * n, "the two tubes are apart: nothing welds");
        let far: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| t.map(|v| v + n as u32)).collect();
        assert_eq!(back.mesh.triangles, [mesh.triangles.clone(), far].concat(), "the far tube's faces count on");
        for (a, b) in back.mesh.positions.iter().zip(mesh.positions.iter().chain(&mesh.positions)).skip(n) {
            assert!((a - b - Vector3::repeat(2.0)).norm() < 1e-9, "positions are written to the nanometre");
        }
        assert_eq!(back.mesh.surface.uvs.len(), 2 * mesh.surface.uvs.len());
        let text = std::str::from_utf8(&files[0]).unwrap();
        assert!(text.starts_with("# frame 0\nmtllib cloth.mtl\no near\n"), "{}", &text[..40]);
        assert!(text.contains("usemtl cloth\n") && text.contains("usemtl lining\n"));
    }

    #[test]
    fn frames_differ_only_in_their_positions_and_normals() {
        let (_, files) = two_tube_frames(2, 0.25);
        let lines = |bytes: &[u8]| String::from_utf8(bytes.to_vec()).unwrap();
        let (first, second) = (lines(&files[0]), lines(&files[1]));
        let mut differing = first.lines().zip(second.lines()).filter(|(a, b)| a != b).map(|(a, _)| a);
        assert!(differing.all(|line| line.starts_with("v ") || line.starts_with("# frame")));
        assert_eq!(first.lines().count(), second.lines().count());
        assert_ne!(first, second, "the far tube moved");
    }

    #[test]
    fn a_frame_of_the_wrong_size_is_an_error() {
        let mesh = generate::tube(0.2, 1.0, 8, 4);
        let surface = ObjSurface {
            name: "tube",
            vertex_count: mesh.vertex_count(),
            triangles: &mesh.triangles,
            surface: &mesh.surface,
            material_namespace: "cloth",
        };
        let err = ObjFrames::new(None, &[surface]).write(&mut Vec::new(), "short", &mesh.positions[1..]).unwrap_err();
        assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput);
    }
}
