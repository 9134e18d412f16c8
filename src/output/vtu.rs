//! VTK XML UnstructuredGrid (`.vtu`) frames for particle clouds and the
//! ParaView collection (`.pvd`) that indexes them in time; a frame written in pieces
//! (one a rank) has a parallel index (`.pvtu`) that ParaView reads as one grid.
//!
//! Frames use binary appended raw encoding with UInt64 block headers in
//! little-endian byte order. Every particle is one `VTK_VERTEX` cell so that
//! ParaView renders the cloud without a Glyph filter; a method with elements adds them
//! as `VTK_QUAD` (2D) or `VTK_HEXAHEDRON` (3D) cells on the same points ([`Mesh`]). The
//! frame time is stored as the `TimeValue` field-data array.

use std::collections::HashSet;
use std::fmt::Write as _;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use super::{format_f64, invalid_input, write_atomically};

/// VTK cell type of a single point.
const VTK_VERTEX: u8 = 1;
/// VTK cell types of the 4-node quadrilateral and the 8-node hexahedron.
const VTK_QUAD: u8 = 9;
const VTK_HEXAHEDRON: u8 = 12;
/// The `vtkGhostType` flag of a point that another piece owns.
const DUPLICATE_POINT: u8 = 1;
/// The name VTK gives the ghost flags of the points.
const GHOST_ARRAY: &str = "vtkGhostType";

/// Elements on the points of a frame: 2^dim corner indices per cell, in VTK order.
#[derive(Debug, Clone, Copy)]
pub struct Mesh<'a> {
    pub corners: &'a [u32],
    /// 2 (quadrilaterals) or 3 (hexahedra).
    pub dim: usize,
    /// In a piece of a frame: how many of the points, the last ones, are another piece's,
    /// there as corners of this piece's elements. They get no vertex cell, and the
    /// `vtkGhostType` array flags them as duplicates. None for a frame written whole.
    pub ghosts: Option<usize>,
}

impl Mesh<'_> {
    /// No elements: the points alone.
    pub const NONE: Mesh<'static> = Mesh {
        corners: &[],
        dim: 2,
        ghosts: None,
    };

    fn per_cell(&self) -> usize {
        1 << self.dim
    }
}

/// Values of one per-point field.
#[derive(Debug, Clone, Copy)]
pub enum FieldData<'a> {
    /// One `Float64` per point.
    Scalar(&'a [f64]),
    /// Three `Float64` components per point.
    Vector(&'a [[f64; 3]]),
    /// A 3x3 tensor per point, row-major (`xx, xy, xz, yx, ..., zz`).
    Tensor(&'a [[f64; 9]]),
    /// One `Int32` per point (ids, flags, material indices).
    Int(&'a [i32]),
}

impl FieldData<'_> {
    /// Number of points the field covers.
    pub fn len(&self) -> usize {
        match self {
            FieldData::Scalar(v) => v.len(),
            FieldData::Vector(v) => v.len(),
            FieldData::Tensor(v) => v.len(),
            FieldData::Int(v) => v.len(),
        }
    }

    /// Whether the field has no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of components per point.
    pub fn components(&self) -> usize {
        match self {
            FieldData::Scalar(_) | FieldData::Int(_) => 1,
            FieldData::Vector(_) => 3,
            FieldData::Tensor(_) => 9,
        }
    }
}

/// A named per-point field of a frame.
#[derive(Debug, Clone, Copy)]
pub struct Field<'a> {
    /// Array name shown in ParaView.
    pub name: &'a str,
    /// The values, one entry per point.
    pub data: FieldData<'a>,
}

/// Writes one frame: `points` with per-point `fields` at simulation `time`, and the
/// elements of `mesh` besides the points' vertex cells.
///
/// Two-dimensional data passes `z = 0`. Fails with
/// [`io::ErrorKind::InvalidInput`] if a field's length differs from the point
/// count, if field names are empty or repeated, if a cell names a point that is not
/// there, or if there are more ghosts than points; the file at `path` is then left
/// untouched. The frame is written to a fresh temporary sibling and renamed into
/// place ([`super::write_atomically`]).
pub fn write_vtu(
    path: &Path,
    points: &[[f64; 3]],
    fields: &[Field],
    time: f64,
    mesh: Mesh,
) -> io::Result<()> {
    let n = points.len();
    if let Some(&c) = mesh.corners.iter().find(|&&c| c as usize >= n) {
        return Err(invalid_input(format!(
            "a VTU cell names point {c} but there are {n} points"
        )));
    }
    let ghosts = mesh.ghosts.unwrap_or(0);
    if ghosts > n {
        return Err(invalid_input(format!(
            "a VTU piece has {ghosts} ghosts but {n} points"
        )));
    }
    let mut names = HashSet::from([GHOST_ARRAY]);
    for field in fields {
        if field.name.is_empty() {
            return Err(invalid_input("a VTU field has an empty name".into()));
        }
        if !names.insert(field.name) {
            return Err(invalid_input(format!(
                "VTU field `{}` is given twice",
                field.name
            )));
        }
        if field.data.len() != n {
            return Err(invalid_input(format!(
                "VTU field `{}` has {} values but there are {n} points",
                field.name,
                field.data.len()
            )));
        }
    }

    let time = [time];
    let time_array = Array::new("TimeValue", 1, Payload::F64(&time));
    let flags: Vec<u8> = mesh.ghosts.map_or_else(Vec::new, |_| {
        let own = std::iter::repeat_n(0, n - ghosts);
        own.chain(std::iter::repeat_n(DUPLICATE_POINT, ghosts))
            .collect()
    });
    let mut point_arrays: Vec<Array> = fields.iter().map(Array::from_field).collect();
    if mesh.ghosts.is_some() {
        point_arrays.push(Array::new(GHOST_ARRAY, 1, Payload::U8(&flags)));
    }
    let points_array = Array::new("Points", 3, Payload::F64(points.as_flattened()));
    // The vertex cells of the points but the ghosts, then the elements.
    let vertices = n - ghosts;
    let count =
        i64::try_from(vertices).map_err(|_| invalid_input(format!("{n} points is too many")))?;
    let elements = mesh.corners.len() / mesh.per_cell();
    let connectivity: Vec<i64> = (0..count)
        .chain(mesh.corners.iter().map(|&c| i64::from(c)))
        .collect();
    let per_cell = mesh.per_cell() as i64;
    let offsets: Vec<i64> = (1..=count)
        .chain((1..=elements as i64).map(|k| count + k * per_cell))
        .collect();
    let element_type = if mesh.dim == 3 {
        VTK_HEXAHEDRON
    } else {
        VTK_QUAD
    };
    let types: Vec<u8> = std::iter::repeat_n(VTK_VERTEX, vertices)
        .chain(std::iter::repeat_n(element_type, elements))
        .collect();
    let cells = vertices + elements;
    let cell_arrays = [
        Array::new("connectivity", 1, Payload::I64(&connectivity)),
        Array::new("offsets", 1, Payload::I64(&offsets)),
        Array::new("types", 1, Payload::U8(&types)),
    ];

    // The header lists the arrays in the order their blocks are appended.
    let mut header = String::new();
    let mut offset = 0;
    header.push_str("<?xml version=\"1.0\"?>\n");
    header.push_str(
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" \
         byte_order=\"LittleEndian\" header_type=\"UInt64\">\n",
    );
    header.push_str("  <UnstructuredGrid>\n");
    header.push_str("    <FieldData>\n");
    time_array.write_tag(&mut header, 6, true, &mut offset);
    header.push_str("    </FieldData>\n");
    let _ = writeln!(
        header,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{cells}\">"
    );
    header.push_str("      <PointData>\n");
    for array in &point_arrays {
        array.write_tag(&mut header, 8, false, &mut offset);
    }
    header.push_str("      </PointData>\n");
    header.push_str("      <Points>\n");
    points_array.write_tag(&mut header, 8, false, &mut offset);
    header.push_str("      </Points>\n");
    header.push_str("      <Cells>\n");
    for array in &cell_arrays {
        array.write_tag(&mut header, 8, false, &mut offset);
    }
    header.push_str("      </Cells>\n");
    header.push_str("    </Piece>\n");
    header.push_str("  </UnstructuredGrid>\n");
    header.push_str("  <AppendedData encoding=\"raw\">\n   _");

    let blocks = std::iter::once(&time_array)
        .chain(&point_arrays)
        .chain(std::iter::once(&points_array))
        .chain(&cell_arrays);

    write_atomically(path, |w| {
        w.write_all(header.as_bytes())?;
        for array in blocks {
            array.payload.write_block(w)?;
        }
        w.write_all(b"\n  </AppendedData>\n</VTKFile>\n")
    })
}

/// The point arrays every piece of a frame holds (a piece's fields and its ghost
/// flags), which the frame's parallel index declares.
#[derive(Clone, Debug, PartialEq)]
pub struct PieceArrays(Vec<(String, &'static str, usize)>);

impl PieceArrays {
    /// The arrays of a piece written with `fields` and a [`Mesh`] with ghosts.
    pub fn of(fields: &[Field]) -> Self {
        let mut arrays: Vec<_> = (fields.iter())
            .map(|f| {
                let array = Array::from_field(f);
                (
                    f.name.to_owned(),
                    array.payload.vtk_type(),
                    array.components,
                )
            })
            .collect();
        arrays.push((GHOST_ARRAY.to_owned(), "UInt8", 1));
        Self(arrays)
    }
}

/// Writes the parallel index (`.pvtu`) of a frame written in pieces: the point arrays
/// each piece holds and the pieces' files, relative to the index's folder. Written
/// through a temporary sibling, as a frame is.
pub fn write_pvtu(path: &Path, arrays: &PieceArrays, pieces: &[String]) -> io::Result<()> {
    if let Some(p) = (pieces.iter()).find(|p| p.is_empty() || Path::new(p).is_absolute()) {
        return Err(invalid_input(format!(
            "piece `{p}` must be a path relative to the index"
        )));
    }
    let mut xml = String::new();
    xml.push_str("<?xml version=\"1.0\"?>\n");
    xml.push_str(
        "<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" \
         byte_order=\"LittleEndian\" header_type=\"UInt64\">\n",
    );
    xml.push_str("  <PUnstructuredGrid GhostLevel=\"0\">\n");
    xml.push_str("    <PPointData>\n");
    let array = |xml: &mut String, (name, vtk_type, components): &(String, &str, usize)| {
        let _ = writeln!(
            xml,
            "      <PDataArray type=\"{vtk_type}\" Name=\"{}\" NumberOfComponents=\"{components}\"/>",
            escape_xml(name)
        );
    };
    for a in &arrays.0 {
        array(&mut xml, a);
    }
    xml.push_str("    </PPointData>\n");
    xml.push_str("    <PPoints>\n");
    array(&mut xml, &("Points".to_owned(), "Float64", 3));
    xml.push_str("    </PPoints>\n");
    for piece in pieces {
        let _ = writeln!(xml, "    <Piece Source=\"{}\"/>", escape_xml(piece));
    }
    xml.push_str("  </PUnstructuredGrid>\n");
    xml.push_str("</VTKFile>\n");
    write_atomically(path, |w| w.write_all(xml.as_bytes()))
}

/// Raw values of one appended block.
enum Payload<'a> {
    F64(&'a [f64]),
    I32(&'a [i32]),
    I64(&'a [i64]),
    U8(&'a [u8]),
}

impl Payload<'_> {
    fn vtk_type(&self) -> &'static str {
        match self {
            Payload::F64(_) => "Float64",
            Payload::I32(_) => "Int32",
            Payload::I64(_) => "Int64",
            Payload::U8(_) => "UInt8",
        }
    }

    /// Size of the data in bytes, excluding the block header.
    fn byte_len(&self) -> u64 {
        let bytes = match self {
            Payload::F64(v) => v.len() * 8,
            Payload::I32(v) => v.len() * 4,
            Payload::I64(v) => v.len() * 8,
            Payload::U8(v) => v.len(),
        };
        bytes as u64
    }

    /// Writes the UInt64 byte count followed by the little-endian values.
    fn write_block(&self, w: &mut impl Write) -> io::Result<()> {
        w.write_all(&self.byte_len().to_le_bytes())?;
        match self {
            Payload::F64(v) => write_le(w, v.iter().map(|x| x.to_le_bytes())),
            Payload::I32(v) => write_le(w, v.iter().map(|x| x.to_le_bytes())),
            Payload::I64(v) => write_le(w, v.iter().map(|x| x.to_le_bytes())),
            Payload::U8(v) => write_le(w, v.iter().map(|&x| [x])),
        }
    }
}

/// Writes fixed-size little-endian encodings through a small staging buffer.
fn write_le<const N: usize>(
    w: &mut impl Write,
    values: impl Iterator<Item = [u8; N]>,
) -> io::Result<()> {
    const CHUNK_BYTES: usize = 64 * 1024;
    let mut buf = Vec::with_capacity(CHUNK_BYTES);
    for bytes in values {
        buf.extend_from_slice(&bytes);
        if buf.len() >= CHUNK_BYTES {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    w.write_all(&buf)
}

/// One `DataArray`: its header attributes and its appended payload.
struct Array<'a> {
    name: &'a str,
    components: usize,
    payload: Payload<'a>,
}

impl<'a> Array<'a> {
    fn new(name: &'a str, components: usize, payload: Payload<'a>) -> Self {
        Self {
            name,
            components,
            payload,
        }
    }

    fn from_field(field: &Field<'a>) -> Self {
        let payload = match field.data {
            FieldData::Scalar(v) => Payload::F64(v),
            FieldData::Vector(v) => Payload::F64(v.as_flattened()),
            FieldData::Tensor(v) => Payload::F64(v.as_flattened()),
            FieldData::Int(v) => Payload::I32(v),
        };
        Self::new(field.name, field.data.components(), payload)
    }

    /// Appends the `DataArray` tag at `offset` and advances `offset` past
    /// this array's block. Field-data arrays declare their tuple count.
    fn write_tag(&self, out: &mut String, indent: usize, field_data: bool, offset: &mut u64) {
        let _ = write!(
            out,
            "{:indent$}<DataArray type=\"{}\" Name=\"{}\" ",
            "",
            self.payload.vtk_type(),
            escape_xml(self.name)
        );
        if field_data {
            let tuples = self.payload.byte_len() / 8 / self.components as u64;
            let _ = write!(out, "NumberOfTuples=\"{tuples}\" ");
        }
        let _ = writeln!(
            out,
            "NumberOfComponents=\"{}\" format=\"appended\" offset=\"{offset}\"/>",
            self.components
        );
        *offset += 8 + self.payload.byte_len();
    }
}

/// Escapes text for use inside a double-quoted XML attribute.
fn escape_xml(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(c),
        }
    }
    out
}

/// A ParaView collection (`<base>.pvd`) listing the frames written so far.
///
/// The index is rewritten atomically after every [`push`](Self::push), so the
/// file on disk is always complete and lists only frames that exist.
#[derive(Debug, Clone)]
pub struct PvdIndex {
    dir: PathBuf,
    path: PathBuf,
    frames: Vec<(f64, String)>,
}

impl PvdIndex {
    /// Starts an empty index at `dir/<base>.pvd`, replacing any existing one.
    pub fn create(dir: &Path, base: &str) -> io::Result<Self> {
        if base.is_empty() {
            return Err(invalid_input("PVD base name is empty".into()));
        }
        let index = Self {
            dir: dir.to_path_buf(),
            path: dir.join(format!("{base}.pvd")),
            frames: Vec::new(),
        };
        index.write()?;
        Ok(index)
    }

    /// Adds the frame `file_name` (relative to the index's directory, already
    /// written) at `time` and rewrites the index.
    pub fn push(&mut self, time: f64, file_name: &str) -> io::Result<()> {
        if !time.is_finite() {
            return Err(invalid_input(format!(
                "PVD frame `{file_name}` has non-finite time {time}"
            )));
        }
        if file_name.is_empty() || Path::new(file_name).is_absolute() {
            return Err(invalid_input(format!(
                "PVD frame `{file_name}` must be a path relative to the index"
            )));
        }
        if !self.dir.join(file_name).is_file() {
            return Err(io::Error::new(
                io::ErrorKind::NotFound,
                format!(
                    "PVD frame `{file_name}` does not exist in `{}`",
                    self.dir.display()
                ),
            ));
        }
        self.frames.push((time, file_name.to_owned()));
        let result = self.write();
        if result.is_err() {
            self.frames.pop();
        }
        result
    }

    /// Path of the `.pvd` file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Times of the frames listed, in order.
    pub fn times(&self) -> Vec<f64> {
        self.frames.iter().map(|(t, _)| *t).collect()
    }

    /// Number of frames listed.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether no frame has been listed yet.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    fn write(&self) -> io::Result<()> {
        let mut xml = String::new();
        xml.push_str("<?xml version=\"1.0\"?>\n");
        xml.push_str("<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n");
        xml.push_str("  <Collection>\n");
        for (time, file) in &self.frames {
            let _ = writeln!(
                xml,
                "    <DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{}\"/>",
                format_f64(*time),
                escape_xml(file)
            );
        }
        xml.push_str("  </Collection>\n");
        xml.push_str("</VTKFile>\n");
        write_atomically(&self.path, |w| w.write_all(xml.as_bytes()))
    }
}

#[cfg(test)]
pub(crate) mod tests;
