//! Hair curves from an OBJ file: its polylines, `v x y z [w]` vertices and `l i j k …`
//! line records (1-based vertex indices, negative ones counted back from the last
//! vertex read, `i/t` pairs taking the vertex index). Each `l` record is a curve, its
//! first vertex the root; a record that starts where the previous one ended continues
//! it (exporters that write a polyline as one record per segment), unless another
//! record comes between them. Faces, normals,
//! texture coordinates, groups and every other record are ignored; so is a `#` comment.
//! A line ending in `\` continues on the next.

use super::curves::Curve;
use nalgebra::Vector3;
use std::path::Path;

/// The curves of the OBJ text `text`; `name` (the file) goes into the messages and the
/// curves' origins. An error names the file and the line.
pub fn parse_obj_curves(text: &str, name: &str) -> Result<Vec<Curve>, String> {
    let mut vertices: Vec<Vector3<f64>> = Vec::new();
    let mut curves: Vec<Curve> = Vec::new();
    // the vertex indices of the last record, to join records that continue it
    let mut last_indices: Option<(usize, usize)> = None;
    let mut pending = String::new();
    let mut pending_line = 0;
    for (k, raw) in text.lines().enumerate() {
        let line_no = k + 1;
        let raw = raw.split('#').next().unwrap_or("");
        if pending.is_empty() {
            pending_line = line_no;
        }
        if let Some(body) = raw.trim_end().strip_suffix('\\') {
            pending.push_str(body);
            pending.push(' ');
            continue;
        }
        pending.push_str(raw);
        let line = std::mem::take(&mut pending);
        let at = |message: String| format!("'{name}' line {pending_line}: {message}");
        let mut fields = line.split_whitespace();
        match fields.next() {
            Some("v") => {
                let values: Vec<&str> = fields.collect();
                if values.len() < 3 || values.len() > 4 {
                    return Err(at(format!(
                        "a vertex needs 3 coordinates (and an optional weight), got {}",
                        values.len()
                    )));
                }
                let mut p = [0.0; 3];
                for (c, v) in values.iter().take(3).enumerate() {
                    p[c] = v
                        .parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| at(format!("'{v}' is not a finite number")))?;
                }
                vertices.push(Vector3::from(p));
            }
            Some("l") => {
                let mut indices = Vec::new();
                for item in fields {
                    let first = item.split('/').next().unwrap_or("");
                    let index: i64 = first
                        .parse()
                        .map_err(|_| at(format!("'{item}' is not a vertex index")))?;
                    let resolved = if index > 0 {
                        Some(index as usize - 1)
                    } else if index < 0 {
                        vertices.len().checked_sub(index.unsigned_abs() as usize)
                    } else {
                        None
                    };
                    match resolved.filter(|&i| i < vertices.len()) {
                        Some(i) => indices.push(i),
                        None => {
                            return Err(at(format!(
                                "vertex index {index} is out of range ({} vertices read so far)",
                                vertices.len()
                            )))
                        }
                    }
                }
                if indices.len() < 2 {
                    return Err(at(format!(
                        "a line record needs at least two vertices, got {}",
                        indices.len()
                    )));
                }
                let (first, last) = (indices[0], indices[indices.len() - 1]);
                let continues = last_indices.is_some_and(|(_, end)| end == first);
                match curves.last_mut() {
                    Some(curve) if continues => {
                        curve
                            .points
                            .extend(indices[1..].iter().map(|&i| vertices[i]));
                    }
                    _ => curves.push(Curve {
                        points: indices.iter().map(|&i| vertices[i]).collect(),
                        origin: format!("'{name}' line {pending_line}"),
                    }),
                }
                last_indices = Some((first, last));
            }
            Some(_) => last_indices = None,
            None => {}
        }
    }
    if curves.is_empty() {
        return Err(format!(
            "'{name}' has no line records (l): no curve to read"
        ));
    }
    Ok(curves)
}

/// The curves of the OBJ file at `path` ([`parse_obj_curves`]).
pub fn read_obj_curves(path: &Path) -> Result<Vec<Curve>, String> {
    let text = crate::input::read_text_bounded(path, crate::input::TEXT_FILE_LIMIT, "OBJ file")?;
    parse_obj_curves(&text, &path.display().to_string())
}
