//! Reading a triangle mesh from an OBJ file with the `tobj` crate: every object of the
//! file in one mesh, polygons split into triangle fans, points and lines left out,
//! materials not read.

use nalgebra::Vector3;
use std::io::Cursor;
use std::path::Path;

/// Vertex positions and triangles (three indices into the positions each).
pub type Triangles = (Vec<Vector3<f64>>, Vec<[usize; 3]>);

/// The vertex positions and triangles (indices into the positions) of the OBJ file at
/// `path`. The error says what went wrong (the file cannot be read, or where parsing
/// stopped).
pub fn read_obj(path: &Path) -> Result<Triangles, String> {
    let bytes = crate::input::read_bounded(path, crate::input::MESH_FILE_LIMIT, "OBJ mesh")?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) = tobj::load_obj_buf(&mut Cursor::new(bytes), &options, |_| {
        Err(tobj::LoadError::GenericFailure)
    })
    .map_err(|e| format!("'{}' is not a readable OBJ file: {e}", path.display()))?;
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let offset = positions.len();
        positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| Vector3::new(p[0], p[1], p[2])),
        );
        triangles.extend(
            mesh.indices
                .chunks_exact(3)
                .map(|t| [0, 1, 2].map(|k| offset + t[k] as usize)),
        );
    }
    Ok((positions, triangles))
}
