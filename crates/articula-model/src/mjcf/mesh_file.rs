//! Triangle meshes from files: STL (binary and ASCII) and MuJoCo's binary `.msh`.
//!
//! Sizes are checked against the file's length before anything is allocated, so a header
//! claiming 10⁹ triangles is an error, not an allocation. Errors are sentences about the file;
//! the caller names the `<mesh>` element and its attribute.

use crate::urdf::read_limited;
use std::collections::HashMap;
use std::path::Path;

/// The largest mesh file read (a binary STL of this size holds 5.4 million triangles; MuJoCo
/// itself reads at most 200,000).
pub(crate) const MAX_MESH_BYTES: u64 = 256 << 20;

/// Vertices (single precision, as the files and MuJoCo store them) and triangles indexing them.
#[derive(Clone, Debug, Default)]
pub(crate) struct TriangleMesh {
    /// Vertex positions in the file's units.
    pub vertices: Vec<[f32; 3]>,
    /// Triangles, counter-clockwise seen from outside, as indices into `vertices`.
    pub faces: Vec<[u32; 3]>,
}

/// The file formats read, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MeshFormat {
    /// `.stl`, binary or ASCII.
    Stl,
    /// MuJoCo's `.msh`.
    Msh,
}

impl MeshFormat {
    /// The format a file name's extension says, or an error naming the extensions read.
    pub fn of(path: &Path) -> Result<MeshFormat, String> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        match ext.as_str() {
            "stl" => Ok(MeshFormat::Stl),
            "msh" => Ok(MeshFormat::Msh),
            other => Err(format!(
                "articula reads STL and MuJoCo .msh mesh files, not '.{other}' \
                 (convert the mesh to STL)"
            )),
        }
    }
}

/// Reads a mesh file (format by extension).
pub(crate) fn read(path: &Path) -> Result<(TriangleMesh, MeshFormat), String> {
    let format = MeshFormat::of(path)?;
    let bytes = read_limited(path, MAX_MESH_BYTES).map_err(|e| e.to_string())?;
    let mesh = match format {
        MeshFormat::Stl => stl(&bytes)?,
        MeshFormat::Msh => msh(&bytes)?,
    };
    Ok((mesh, format))
}

/// An STL file: binary when its length is the header's triangle count's (84 + 50 n bytes),
/// else ASCII when it begins with `solid`.
pub(crate) fn stl(bytes: &[u8]) -> Result<TriangleMesh, String> {
    if bytes.is_empty() {
        return Err("the STL file is empty".into());
    }
    let ascii = bytes.trim_ascii_start().starts_with(b"solid");
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        if 84 + 50 * n == bytes.len() as u64 {
            return stl_binary(&bytes[84..], n as usize);
        }
        if !ascii {
            return Err(format!(
                "binary STL whose header counts {n} triangles ({} bytes) has {} bytes \
                 (truncated or not an STL file)",
                84 + 50 * n,
                bytes.len()
            ));
        }
    }
    if !ascii {
        return Err(format!(
            "{} bytes: shorter than a binary STL header (84 bytes) and not ASCII STL",
            bytes.len()
        ));
    }
    let text = std::str::from_utf8(bytes)
        .map_err(|e| format!("ASCII STL with invalid UTF-8 at byte {}", e.valid_up_to()))?;
    stl_ascii(text)
}

/// Binary STL triangles (50 bytes each: normal, three vertices, attribute), vertices merged
/// by their bits as MuJoCo's decoder does.
fn stl_binary(data: &[u8], n: usize) -> Result<TriangleMesh, String> {
    if n == 0 {
        return Err("the STL file has no triangles".into());
    }
    let mut mesh = Merger::default();
    for t in data.chunks_exact(50) {
        let mut face = [0u32; 3];
        for (j, slot) in face.iter_mut().enumerate() {
            let at = |k: usize| {
                let o = 12 * (j + 1) + 4 * k;
                f32::from_le_bytes([t[o], t[o + 1], t[o + 2], t[o + 3]])
            };
            *slot = mesh.vertex([at(0), at(1), at(2)])?;
        }
        mesh.out.faces.push(face);
    }
    Ok(mesh.out)
}

/// ASCII STL: `facet … outer loop vertex x y z (×3) endloop endfacet`, repeated.
fn stl_ascii(text: &str) -> Result<TriangleMesh, String> {
    let mut mesh = Merger::default();
    let mut corners: Vec<u32> = Vec::with_capacity(3);
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_ascii_whitespace();
        match words.next() {
            Some("vertex") => {
                let mut v = [0f32; 3];
                for x in &mut v {
                    *x = words
                        .next()
                        .and_then(|w| w.parse::<f32>().ok())
                        .ok_or_else(|| {
                            format!("ASCII STL line {}: a vertex needs three numbers", i + 1)
                        })?;
                }
                corners.push(mesh.vertex(v)?);
            }
            Some("endloop") => {
                if corners.len() != 3 {
                    return Err(format!(
                        "ASCII STL line {}: a facet has {} vertices, not 3",
                        i + 1,
                        corners.len()
                    ));
                }
                mesh.out.faces.push([corners[0], corners[1], corners[2]]);
                corners.clear();
            }
            _ => {}
        }
    }
    if mesh.out.faces.is_empty() {
        return Err("the ASCII STL file has no facets".into());
    }
    Ok(mesh.out)
}

/// Collects vertices, merging repeats (equal bits), and checks MuJoCo's bound on them.
#[derive(Default)]
struct Merger {
    out: TriangleMesh,
    seen: HashMap<[u32; 3], u32>,
}

impl Merger {
    fn vertex(&mut self, v: [f32; 3]) -> Result<u32, String> {
        if v.iter()
            .any(|x| !x.is_finite() || x.abs() > (1u32 << 30) as f32)
        {
            return Err(format!(
                "vertex {v:?} is not finite or exceeds 2^30 in magnitude"
            ));
        }
        let key = v.map(f32::to_bits);
        let next = self.out.vertices.len() as u32;
        let id = *self.seen.entry(key).or_insert(next);
        if id == next {
            self.out.vertices.push(v);
        }
        Ok(id)
    }
}

/// MuJoCo's `.msh`: four little-endian `i32` counts (vertices, normals, texture coordinates,
/// faces), then the vertices (3 `f32` each), normals (3 `f32`), texture coordinates (2 `f32`)
/// and faces (3 `i32`).
pub(crate) fn msh(bytes: &[u8]) -> Result<TriangleMesh, String> {
    if bytes.len() < 16 {
        return Err(format!(
            "{} bytes: shorter than the .msh header (16)",
            bytes.len()
        ));
    }
    let int = |o: usize| i32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    let (nv, nn, nt, nf) = (int(0), int(4), int(8), int(12));
    if nv < 4 || nf < 0 || nn < 0 || nt < 0 || (nn > 0 && nn != nv) || (nt > 0 && nt != nv) {
        return Err(format!(
            "invalid .msh header: {nv} vertices, {nn} normals, {nt} texture coordinates, \
             {nf} faces (at least 4 vertices; normals and texture coordinates none or one \
             per vertex)"
        ));
    }
    let [nv, nn, nt, nf] = [nv, nn, nt, nf].map(|x| x as u64);
    let expected = 16 + 4 * (3 * nv + 3 * nn + 2 * nt + 3 * nf);
    if expected != bytes.len() as u64 {
        return Err(format!(
            ".msh header counts {nv} vertices and {nf} faces ({expected} bytes) but the file \
             has {} bytes (truncated or not a .msh file)",
            bytes.len()
        ));
    }
    if nf == 0 {
        return Err(
            ".msh file without faces: MuJoCo would take its convex hull, \
                    which articula does not compute"
                .into(),
        );
    }
    let float = |o: usize| f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    let mut out = TriangleMesh::default();
    for i in 0..nv as usize {
        let o = 16 + 12 * i;
        let v = [float(o), float(o + 4), float(o + 8)];
        if v.iter().any(|x| !x.is_finite()) {
            return Err(format!("vertex {i} is not finite"));
        }
        out.vertices.push(v);
    }
    let faces_at = 16 + 4 * (3 * nv + 3 * nn + 2 * nt) as usize;
    for i in 0..nf as usize {
        let o = faces_at + 12 * i;
        let mut face = [0u32; 3];
        for (k, slot) in face.iter_mut().enumerate() {
            let id = int(o + 4 * k);
            if id < 0 || id as u64 >= nv {
                return Err(format!("face {i} names vertex {id}, which does not exist"));
            }
            *slot = id as u32;
        }
        out.faces.push(face);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary_stl(tris: &[[[f32; 3]; 3]], claimed: u32) -> Vec<u8> {
        let mut b = vec![0u8; 80];
        b.extend_from_slice(&claimed.to_le_bytes());
        for t in tris {
            b.extend_from_slice(&[0u8; 12]);
            for v in t {
                for x in v {
                    b.extend_from_slice(&x.to_le_bytes());
                }
            }
            b.extend_from_slice(&[0u8; 2]);
        }
        b
    }

    const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    #[test]
    fn binary_stl_merges_repeated_vertices() {
        let other = [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let m = stl(&binary_stl(&[TRI, other], 2)).unwrap();
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn binary_stl_header_must_match_length() {
        let e = stl(&binary_stl(&[TRI], 1_000_000_000)).unwrap_err();
        assert!(e.contains("1000000000 triangles"), "{e}");
        let mut b = binary_stl(&[TRI, TRI], 2);
        b.truncate(120);
        let e = stl(&b).unwrap_err();
        assert!(e.contains("truncated"), "{e}");
    }

    #[test]
    fn ascii_stl_reads_facets() {
        let text = "solid t\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  \
                    vertex 0 1 0\n endloop\nendfacet\nendsolid t\n";
        let m = stl(text.as_bytes()).unwrap();
        assert_eq!(m.vertices.len(), 3);
        assert_eq!(m.faces, vec![[0, 1, 2]]);
        let bad = "solid t\nfacet normal 0 0 1\n outer loop\n  vertex 0 0\n endloop\nendfacet\n";
        assert!(stl(bad.as_bytes()).unwrap_err().contains("three numbers"));
    }

    #[test]
    fn msh_sizes_are_checked() {
        let mut b = Vec::new();
        for x in [4i32, 0, 0, 1] {
            b.extend_from_slice(&x.to_le_bytes());
        }
        for v in [
            [0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ] {
            for x in v {
                b.extend_from_slice(&x.to_le_bytes());
            }
        }
        for i in [0i32, 2, 1] {
            b.extend_from_slice(&i.to_le_bytes());
        }
        let m = msh(&b).unwrap();
        assert_eq!((m.vertices.len(), m.faces.len()), (4, 1));
        assert!(msh(&b[..b.len() - 1]).unwrap_err().contains("truncated"));
        let mut bad = b.clone();
        let n = bad.len();
        bad[n - 4..].copy_from_slice(&7i32.to_le_bytes());
        assert!(msh(&bad).unwrap_err().contains("vertex 7"));
    }
}
