//! Points and mesh files, read within a size cap; and the case file, read under the same guard.

use super::Sampled;
use crate::case::MeshNodes;
use crate::case::expression::COORDINATES;
use crate::core::tensor::Dim;
use std::path::Path;

/// The particles of a Gmsh mesh ([`super::mesh`]): at the centroid of each cell, with
/// the cell's measure as its volume; or at the vertices of its quadrangles (hexahedra),
/// which are the body's cells, each vertex with a 2^-d share of every cell it is a corner
/// of, so that the volumes sum to the mesh's.
pub(super) fn read_mesh<D: Dim>(path: &Path, nodes: MeshNodes) -> Result<Sampled<D>, String> {
    let text = read_points_file(path)?;
    if nodes == MeshNodes::Vertices {
        let mesh = crate::case::mesh::vertex_cells(&text, D::N)?;
        let mut volumes = vec![0.0; mesh.points.len()];
        let share = 1.0 / f64::from(1u32 << D::N);
        for (corners, measure) in mesh.corners.chunks(1 << D::N).zip(&mesh.measures) {
            for &a in corners {
                volumes[a as usize] += share * measure;
            }
        }
        return Ok(Sampled {
            points: mesh
                .points
                .iter()
                .map(|x| D::from_slice(&x[..D::N]))
                .collect(),
            volumes,
            corners: mesh.corners,
            velocities: None,
        });
    }
    let cells = crate::case::mesh::cells(&text, D::N)?;
    Ok(cells
        .iter()
        .map(|c| (D::from_slice(&c.centroid[..D::N]), c.measure))
        .unzip::<_, _, Vec<D::V>, Vec<f64>>()
        .into())
}

/// A file that may be read: a regular file (not a device, pipe or folder) of at most
/// `cap` bytes, `what` it is named in the error.
fn open_capped(path: &Path, cap: u64, what: &str) -> std::io::Result<std::fs::File> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "it is not a regular file; give the path of a file",
        ));
    }
    if meta.len() > cap {
        return Err(too_large(cap, what));
    }
    std::fs::File::open(path)
}

fn too_large(cap: u64, what: &str) -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::InvalidInput,
        format!("it is larger than {cap} bytes, the most {what} may hold"),
    )
}

/// A file as UTF-8 text (see [`open_capped`]); at most the cap is read, should the file
/// grow after its size was checked.
pub(crate) fn read_capped(path: &Path, cap: u64, what: &str) -> std::io::Result<String> {
    use std::io::Read;
    let mut text = String::new();
    open_capped(path, cap, what)?
        .take(cap + 1)
        .read_to_string(&mut text)?;
    if text.len() as u64 > cap {
        return Err(too_large(cap, what));
    }
    Ok(text)
}

/// The largest points or mesh file read [bytes]: 1 GiB, about 15 million rows of x, y, z
/// and a volume.
const POINTS_FILE_CAP: u64 = 1 << 30;
const POINTS_FILE: &str = "a points or mesh file";

/// A points or mesh file as text.
fn read_points_file(path: &Path) -> Result<String, String> {
    read_capped(path, POINTS_FILE_CAP, POINTS_FILE).map_err(|e| format!("cannot read: {e}"))
}

/// Reads `x,y[,z][,volume][,vx,vy[,vz]]` rows (header required, any column order).
/// Without a volume column every point gets Δx^d; the velocity columns, all or none,
/// give the points' initial velocities. Errors name lines and columns, never the file's text.
pub(super) fn read_points<D: Dim>(path: &Path, cell: f64) -> Result<Sampled<D>, String> {
    let text = read_points_file(path)?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines
        .next()
        .ok_or("empty file; expected a header line x,y[,z][,volume][,vx,vy[,vz]]")?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let column = |name: &str| names.iter().position(|&c| c == name);
    let axes: Vec<usize> = COORDINATES[..D::N]
        .iter()
        .map(|a| {
            column(a).ok_or(format!(
                "the header (its first non-empty line) has no column `{a}` (needed in {}D); a \
                 points file starts with a header such as `x,y,volume`",
                D::N
            ))
        })
        .collect::<Result<_, _>>()?;
    let volume = column("volume");
    let speeds: Vec<Option<usize>> = ["vx", "vy", "vz"][..D::N]
        .iter()
        .map(|&c| column(c))
        .collect();
    let velocity_columns: Option<Vec<usize>> = speeds.iter().copied().collect();
    if velocity_columns.is_none() && speeds.iter().any(Option::is_some) {
        return Err(format!(
            "the header has some velocity columns but not all of {}; give every component \
             or none",
            ["vx", "vy", "vz"][..D::N].join(", ")
        ));
    }
    let known: Vec<&str> = COORDINATES[..D::N]
        .iter()
        .copied()
        .chain(["volume"])
        .chain(["vx", "vy", "vz"][..D::N].iter().copied())
        .collect();
    if let Some(k) = names.iter().position(|c| !known.contains(c)) {
        return Err(format!(
            "the header's column {} is not one a {}D points file takes ({}); remove it",
            k + 1,
            D::N,
            known.join(", ")
        ));
    }
    let (mut points, mut vols, mut velocities) = (Vec::new(), Vec::new(), Vec::new());
    for (line_no, line) in lines {
        let fields: Vec<f64> = line
            .split(',')
            .map(|f| f.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("line {}: {e}", line_no + 1))?;
        if fields.len() != names.len() || fields.iter().any(|v| !v.is_finite()) {
            return Err(format!(
                "line {}: expected {} finite numbers separated by commas, one per header column",
                line_no + 1,
                names.len()
            ));
        }
        let p: Vec<f64> = axes.iter().map(|&c| fields[c]).collect();
        points.push(D::from_slice(&p));
        let v = volume.map_or(cell, |c| fields[c]);
        if v <= 0.0 {
            return Err(format!(
                "line {}: volume must be positive, found {v}",
                line_no + 1
            ));
        }
        vols.push(v);
        if let Some(columns) = &velocity_columns {
            let v: Vec<f64> = columns.iter().map(|&c| fields[c]).collect();
            velocities.push(D::from_slice(&v));
        }
    }
    Ok(Sampled {
        points,
        volumes: vols,
        corners: Vec::new(),
        velocities: velocity_columns.map(|_| velocities),
    })
}
