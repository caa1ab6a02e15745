use super::*;
use nalgebra::{Rotation3, Vector3};
use std::path::PathBuf;

mod grids;
mod meshes;
mod placement;
mod shapes;

/// A folder of its own under the system's temporary folder.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("superhelix-bodies-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    dir
}

/// Write an OBJ file of `vertices` and `triangles` (0-based) to `dir/name`.
fn write_obj(
    dir: &std::path::Path,
    name: &str,
    vertices: &[Vector3<f64>],
    triangles: &[[usize; 3]],
) -> PathBuf {
    let mut text = String::from("# written by a test\no body\n");
    for v in vertices {
        text.push_str(&format!("v {:.17e} {:.17e} {:.17e}\n", v.x, v.y, v.z));
    }
    for t in triangles {
        text.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    path
}

/// A mesh body from a file.
fn mesh_setup(path: PathBuf, cell: Option<f64>) -> BodySetup {
    BodySetup {
        name: "mesh".into(),
        attached: Attachment::World,
        shape: ShapeSetup::Mesh {
            path,
            cell,
            scale: 1.0,
            rotation: Rotation3::identity().into_inner(),
            translation: Vector3::zeros(),
        },
    }
}

/// The one body of `setup`, built; panics with the errors otherwise.
fn build_one(setup: BodySetup) -> Body {
    match Bodies::build(&[setup]) {
        Ok(b) => b.as_slice()[0].clone(),
        Err(e) => panic!("{e}"),
    }
}

/// The errors of building `setup`.
fn build_errors(setup: BodySetup) -> Vec<crate::error::FieldError> {
    match Bodies::build(&[setup]) {
        Ok(_) => panic!("should fail"),
        Err(crate::error::Error::Invalid(errors)) => errors,
        Err(e) => panic!("expected Invalid, got {e}"),
    }
}

/// A small deterministic generator of uniform numbers in [0, 1) (xorshift64*).
struct Uniform(u64);

impl Uniform {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// A point with coordinates uniform in [-half, half].
    fn point(&mut self, half: f64) -> Vector3<f64> {
        Vector3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5) * (2.0 * half)
    }
}
