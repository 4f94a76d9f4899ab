//! USD as a `.usda` text layer: one stage, Y up, metres, a time code per
//! bake frame; every mesh a `UsdGeomMesh` with its topology and UVs once
//! and its points, normals and extent as time samples; looks as
//! `UsdPreviewSurface` materials (with the cloth's sheen kept as inputs of
//! the material). Written mesh by mesh and frame by frame: linear in the
//! frames, one frame in memory.

use std::fmt::Write as _;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::Work;
use super::content::{Content, ExportMesh, Look, Role};

/// Writes `content` as a `.usda` layer into `w`; `out` is where the layer
/// goes (textures are referred to relative to it when they are beside it).
pub fn write(content: &Content<'_>, out: &Path, w: &mut impl Write, work: &Work<'_>) -> io::Result<()> {
    let root = identifier(&content_name(out));
    header(content, &root, w)?;
    writeln!(w, "def Xform \"{root}\" (\n    kind = \"component\"\n)\n{{")?;
    let looks = look_paths(content, &root);
    write_looks(content, &looks, out, w)?;
    let mut done = 0;
    for (role, group) in [(Role::Garment, "garments"), (Role::Body, "body"), (Role::Collider, "colliders")] {
        let meshes: Vec<usize> = (0..content.meshes.len()).filter(|&m| content.meshes[m].role == role).collect();
        if meshes.is_empty() {
            continue;
        }
        writeln!(w, "    def Xform \"{group}\"\n    {{")?;
        let mut names = Vec::new();
        for m in meshes {
            let name = unique(identifier(&content.meshes[m].name), &mut names);
            write_mesh(content, m, &name, &looks, w, &mut |frames| {
                done += frames;
                work.done(done)
            })?;
        }
        writeln!(w, "    }}")?;
    }
    writeln!(w, "}}")
}

/// The stage's name: the file's stem.
fn content_name(out: &Path) -> String {
    out.file_stem().map_or("drape".into(), |s| s.to_string_lossy().into_owned())
}

fn header(content: &Content<'_>, root: &str, w: &mut impl Write) -> io::Result<()> {
    let (first, last) = (content.frame_numbers[0], content.frame_numbers[content.frame_numbers.len() - 1]);
    let fps = content.fps;
    writeln!(
        w,
        "#usda 1.0\n(\n    defaultPrim = \"{root}\"\n    doc = \"drape bake: garments, bodies and colliders, a time code per frame\"\n    \
         endTimeCode = {last}\n    framesPerSecond = {fps}\n    metersPerUnit = 1\n    startTimeCode = {first}\n    \
         timeCodesPerSecond = {fps}\n    upAxis = \"Y\"\n)\n"
    )
}

/// A name USD accepts for a prim: letters, digits and `_`, not starting with a digit.
pub fn identifier(name: &str) -> String {
    let mut out: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, '_');
    }
    out
}

/// `name`, or `name_2`, `name_3`... when taken; remembered in `taken`.
fn unique(name: String, taken: &mut Vec<String>) -> String {
    let mut candidate = name.clone();
    let mut n = 1;
    while taken.contains(&candidate) {
        n += 1;
        candidate = format!("{name}_{n}");
    }
    taken.push(candidate.clone());
    candidate
}

/// Each look's material path.
fn look_paths(content: &Content<'_>, root: &str) -> Vec<String> {
    let mut taken = Vec::new();
    content.looks.iter().map(|l| format!("/{root}/Looks/{}", unique(identifier(&l.name), &mut taken))).collect()
}

fn write_looks(content: &Content<'_>, paths: &[String], out: &Path, w: &mut impl Write) -> io::Result<()> {
    writeln!(w, "    def Scope \"Looks\"\n    {{")?;
    for (look, path) in content.looks.iter().zip(paths) {
        write_material(look, path, out, w)?;
    }
    writeln!(w, "    }}")
}

/// A `UsdPreviewSurface` material (base colour or texture, roughness), the
/// cloth's sheen as inputs of the material.
fn write_material(look: &Look, path: &str, out: &Path, w: &mut impl Write) -> io::Result<()> {
    let name = path.rsplit('/').next().unwrap_or("look");
    let mut text = format!("        def Material \"{name}\"\n        {{\n");
    if let Some((color, roughness)) = look.sheen {
        let _ = writeln!(text, "            color3f inputs:sheenColor = {}", tuple(&color));
        let _ = writeln!(text, "            float inputs:sheenRoughness = {}", number(roughness));
    }
    let _ = writeln!(text, "            token outputs:surface.connect = <{path}/PreviewSurface.outputs:surface>");
    text += "\n            def Shader \"PreviewSurface\"\n            {\n";
    text += "                uniform token info:id = \"UsdPreviewSurface\"\n";
    match &look.texture {
        Some(_) => {
            let _ =
                writeln!(text, "                color3f inputs:diffuseColor.connect = <{path}/Texture.outputs:rgb>");
        }
        None => {
            let _ = writeln!(text, "                color3f inputs:diffuseColor = {}", tuple(&look.base_color));
        }
    }
    text += "                float inputs:metallic = 0\n";
    let _ = writeln!(text, "                float inputs:roughness = {}", number(look.roughness));
    text +=
        "                int inputs:useSpecularWorkflow = 0\n                token outputs:surface\n            }\n";
    if let Some(texture) = &look.texture {
        text += &texture_shaders(path, &texture_path(texture, out));
    }
    text += "        }\n";
    w.write_all(text.as_bytes())
}

/// A texture's path as the layer refers to it: the bake's own copy beside
/// the layer (`textures/NAME`) when there is one, else the file itself.
fn texture_path(texture: &Path, out: &Path) -> String {
    let folder = out.parent().unwrap_or(Path::new("."));
    let name = texture.file_name().map(PathBuf::from).unwrap_or_default();
    let beside = Path::new("textures").join(&name);
    match folder.join(&beside).is_file() {
        true => beside.display().to_string(),
        false => std::path::absolute(texture).unwrap_or_else(|_| texture.to_owned()).display().to_string(),
    }
}

fn texture_shaders(path: &str, file: &str) -> String {
    format!(
        "\n            def Shader \"Texture\"\n            {{\n                uniform token info:id = \"UsdUVTexture\"\n                \
         asset inputs:file = @{file}@\n                token inputs:sourceColorSpace = \"sRGB\"\n                \
         float2 inputs:st.connect = <{path}/StReader.outputs:result>\n                token inputs:wrapS = \"repeat\"\n                \
         token inputs:wrapT = \"repeat\"\n                float3 outputs:rgb\n            }}\n\n            \
         def Shader \"StReader\"\n            {{\n                uniform token info:id = \"UsdPrimvarReader_float2\"\n                \
         string inputs:varname = \"st\"\n                float2 outputs:result\n            }}\n"
    )
}

/// One mesh: topology, UVs and material bindings once, then its extent,
/// normals and points per frame (time samples when it moves).
fn write_mesh(
    content: &Content<'_>,
    m: usize,
    name: &str,
    looks: &[String],
    w: &mut impl Write,
    done: &mut dyn FnMut(usize) -> io::Result<()>,
) -> io::Result<()> {
    let mesh = &content.meshes[m];
    writeln!(
        w,
        "        def Mesh \"{name}\" (\n            prepend apiSchemas = [\"MaterialBindingAPI\"]\n        )\n        {{"
    )?;
    writeln!(w, "            uniform bool doubleSided = 1")?;
    let moves = content.moves(m);
    let frames: &[usize] = if moves { &content.frame_numbers } else { &content.frame_numbers[..1] };
    samples(w, "float3[] extent", moves, frames, |frame, text| {
        let points = positions(content, m, frame)?;
        let (low, high) = bounds(&points);
        text.push('[');
        push_vector(text, &low);
        text.push_str(", ");
        push_vector(text, &high);
        text.push(']');
        Ok(())
    })?;
    topology(mesh, w)?;
    if let [part] = mesh.parts.as_slice() {
        writeln!(w, "            rel material:binding = <{}>", looks[part.look])?;
    }
    writeln!(w, "            normal3f[] normals (\n                interpolation = \"vertex\"\n            )")?;
    samples(w, "normal3f[] normals", moves, frames, |frame, text| {
        let points = positions(content, m, frame)?;
        push_vectors(text, &content.normals(m, &points));
        Ok(())
    })?;
    writeln!(w, "            uniform token orientation = \"rightHanded\"")?;
    samples(w, "point3f[] points", moves, frames, |frame, text| {
        push_vectors(text, &positions(content, m, frame)?);
        done(1)
    })?;
    uvs(mesh, w)?;
    writeln!(w, "            uniform token subdivisionScheme = \"none\"")?;
    subsets(mesh, looks, w)?;
    writeln!(w, "        }}")?;
    match moves {
        true => Ok(()),
        false => done(content.frame_numbers.len() - 1),
    }
}

/// Mesh `m`'s positions at `frame`; an error naming it if one is not a finite number.
fn positions(content: &Content<'_>, m: usize, frame: usize) -> io::Result<Vec<Vector3<f64>>> {
    let mut points = Vec::new();
    content.positions(m, frame, &mut points);
    if let Some(bad) = points.iter().position(|p| !p.iter().all(|c| (*c as f32).is_finite())) {
        let name = &content.meshes[m].name;
        let why = format!("{name}: vertex {bad} at frame {frame} is not a finite number: USD cannot hold it");
        return Err(io::Error::new(io::ErrorKind::InvalidData, why));
    }
    Ok(points)
}

/// An attribute `declaration` with one value (`moves` false: the first
/// frame's) or a time sample per frame, each value written by `value`.
fn samples(
    w: &mut impl Write,
    declaration: &str,
    moves: bool,
    frames: &[usize],
    mut value: impl FnMut(usize, &mut String) -> io::Result<()>,
) -> io::Result<()> {
    let mut text = String::new();
    if !moves {
        let _ = write!(text, "            {declaration} = ");
        value(frames[0], &mut text)?;
        text.push('\n');
        return w.write_all(text.as_bytes());
    }
    writeln!(w, "            {declaration}.timeSamples = {{")?;
    for &frame in frames {
        text.clear();
        let _ = write!(text, "                {frame}: ");
        value(frame, &mut text)?;
        text.push_str(",\n");
        w.write_all(text.as_bytes())?;
    }
    writeln!(w, "            }}")
}

fn topology(mesh: &ExportMesh, w: &mut impl Write) -> io::Result<()> {
    let counts = vec!["3"; mesh.triangles.len()].join(", ");
    writeln!(w, "            int[] faceVertexCounts = [{counts}]")?;
    let indices: Vec<String> = mesh.triangles.iter().flatten().map(u32::to_string).collect();
    writeln!(w, "            int[] faceVertexIndices = [{}]", indices.join(", "))
}

/// Face-varying UVs as the OBJ has them: its UV list and each corner's index.
fn uvs(mesh: &ExportMesh, w: &mut impl Write) -> io::Result<()> {
    let surface = &mesh.surface;
    if surface.triangle_uvs.len() != mesh.triangles.len() || surface.uvs.is_empty() {
        return Ok(());
    }
    let mut text = String::from("            texCoord2f[] primvars:st = [");
    for (k, uv) in surface.uvs.iter().enumerate() {
        if k > 0 {
            text.push_str(", ");
        }
        text.push('(');
        push_number(&mut text, uv[0]);
        text.push_str(", ");
        push_number(&mut text, uv[1]);
        text.push(')');
    }
    text.push_str("] (\n                interpolation = \"faceVarying\"\n            )\n");
    let indices: Vec<String> = surface.triangle_uvs.iter().flatten().map(u32::to_string).collect();
    let _ = writeln!(text, "            int[] primvars:st:indices = [{}]", indices.join(", "));
    w.write_all(text.as_bytes())
}

/// One `GeomSubset` per part with its material, when a mesh has several.
fn subsets(mesh: &ExportMesh, looks: &[String], w: &mut impl Write) -> io::Result<()> {
    if mesh.parts.len() < 2 {
        return Ok(());
    }
    writeln!(w, "            uniform token subsetFamily:materialBind:familyType = \"nonOverlapping\"")?;
    let mut taken = Vec::new();
    for part in &mesh.parts {
        let name = unique(identifier(&part.name), &mut taken);
        let faces: Vec<String> = part.triangles.iter().map(usize::to_string).collect();
        writeln!(
            w,
            "\n            def GeomSubset \"{name}\" (\n                prepend apiSchemas = [\"MaterialBindingAPI\"]\n            )\n            \
             {{\n                uniform token elementType = \"face\"\n                uniform token familyName = \"materialBind\"\n                \
             int[] indices = [{}]\n                rel material:binding = <{}>\n            }}",
            faces.join(", "),
            looks[part.look]
        )?;
    }
    Ok(())
}

/// The lowest and highest corner of `points`.
fn bounds(points: &[Vector3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    let first = points.first().copied().unwrap_or_else(Vector3::zeros);
    points.iter().fold((first, first), |(low, high), p| (low.inf(p), high.sup(p)))
}

fn push_vectors(text: &mut String, vectors: &[Vector3<f64>]) {
    text.push('[');
    for (k, v) in vectors.iter().enumerate() {
        if k > 0 {
            text.push_str(", ");
        }
        push_vector(text, v);
    }
    text.push(']');
}

fn push_vector(text: &mut String, v: &Vector3<f64>) {
    text.push('(');
    push_number(text, v.x as f32);
    text.push_str(", ");
    push_number(text, v.y as f32);
    text.push_str(", ");
    push_number(text, v.z as f32);
    text.push(')');
}

fn tuple(rgb: &[f32; 3]) -> String {
    format!("({}, {}, {})", number(rgb[0]), number(rgb[1]), number(rgb[2]))
}

fn number(x: f32) -> String {
    let mut text = String::new();
    push_number(&mut text, x);
    text
}

/// An f32 as text USD reads back to the same bits: the shortest form
/// (with an exponent when very small or large), or the exact double of it
/// for the one pair of values (±7.038531e-26) whose shortest form USD's
/// reading through a double rounds to another float.
pub fn push_number(text: &mut String, x: f32) {
    let start = text.len();
    let _ = write!(text, "{x:?}");
    let exact = text[start..].parse::<f64>().is_ok_and(|d| (d as f32).to_bits() == x.to_bits());
    if !exact {
        text.truncate(start);
        let _ = write!(text, "{:?}", f64::from(x));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_back_to_the_same_bits_through_a_double() {
        for x in [0.1f32, -0.0, 1e-7, 3.402_823_5e38, 7.038_531e-26, -7.038_531e-26, 1.0, 123_456.79] {
            let mut text = String::new();
            push_number(&mut text, x);
            let back = text.parse::<f64>().unwrap() as f32;
            assert_eq!(back.to_bits(), x.to_bits(), "{x:e} written as {text}");
        }
        assert_eq!(number(1.0), "1.0");
    }

    #[test]
    fn prim_names_are_identifiers_and_unique() {
        assert_eq!(identifier("skirt.front-2"), "skirt_front_2");
        assert_eq!(identifier("3d"), "_3d");
        let mut taken = Vec::new();
        assert_eq!(unique("a".into(), &mut taken), "a");
        assert_eq!(unique("a".into(), &mut taken), "a_2");
    }
}
