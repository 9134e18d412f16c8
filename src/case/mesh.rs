//! Gmsh meshes (`.msh`, ASCII, format 2.2 or 4.1) as particle sets: one particle at the
//! centroid of every cell of the case's dimension, its volume the cell's measure, so
//! that irregular layouts with their own volumes come from any mesher that writes Gmsh
//! files. Cells of 2D cases are triangles and quadrangles, of 3D cases tetrahedra and
//! hexahedra (Gmsh element types 2, 3, 4 and 5); elements of other dimensions (boundary
//! lines, faces, points) are skipped, and second-order elements are refused.

/// A cell of a mesh: its centroid and its measure (area in 2D, volume in 3D).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    pub centroid: [f64; 3],
    pub measure: f64,
}

/// Gmsh element types: (type, dimension, corner count).
const LINEAR: [(u32, usize, usize); 4] = [(2, 2, 3), (3, 2, 4), (4, 3, 4), (5, 3, 8)];
/// Gmsh element types of higher order (6-node triangles and beyond), named in errors.
const HIGHER_ORDER: [u32; 6] = [9, 10, 11, 12, 16, 17];
/// The corner count of every lower-dimensional Gmsh type a mesh of cells may carry:
/// points, lines, and (in 3D) boundary triangles and quadrangles.
fn skipped_corners(kind: u32) -> Option<usize> {
    match kind {
        15 => Some(1),
        1 => Some(2),
        2 => Some(3),
        3 => Some(4),
        _ => None,
    }
}

/// The cells of dimension `dim` of the Gmsh file `text`. Errors say what is wrong and
/// where (a section or a line), never quote the file.
pub fn cells(text: &str, dim: usize) -> Result<Vec<Cell>, String> {
    Ok(parse(text, dim)?.1.into_iter().map(|c| c.cell).collect())
}

/// The vertices of the cells of dimension `dim` of the Gmsh file `text`, which must all be
/// quadrangles (2D) or hexahedra (3D): the positions of the nodes the cells name, in
/// order of their tags (nodes no cell names are left out), and the corners of every
/// cell, 2^d each in Gmsh's order (the VTK order of quadrilaterals and hexahedra), as
/// indices into the positions, with each cell's measure.
pub fn vertex_cells(text: &str, dim: usize) -> Result<VertexCells, String> {
    let corners = 1usize << dim;
    let (nodes, parsed) = parse(text, dim)?;
    if let Some(c) = parsed.iter().find(|c| c.nodes.len() != corners) {
        return Err(format!(
            "element {} is a {}; nodes = \"vertices\" makes the cells of the Galerkin methods, \
             which are {} only: mesh with them (Gmsh: Recombine{})",
            c.tag,
            if dim == 2 { "triangle" } else { "tetrahedron" },
            if dim == 2 { "quadrangles" } else { "hexahedra" },
            if dim == 2 {
                " on the surface"
            } else {
                " and a transfinite or extruded volume"
            }
        ));
    }
    let mut tags: Vec<u64> = parsed
        .iter()
        .flat_map(|c| c.nodes.iter().copied())
        .collect();
    tags.sort_unstable();
    tags.dedup();
    let index = |tag: u64| {
        tags.binary_search(&tag)
            .expect("every corner tag is listed") as u32
    };
    let position = |tag: u64| {
        let k = nodes.binary_search_by_key(&tag, |n| n.0);
        nodes[k.expect("`parse` found every node a cell names")].1
    };
    Ok(VertexCells {
        points: tags.iter().map(|&t| position(t)).collect(),
        corners: parsed
            .iter()
            .flat_map(|c| c.nodes.iter().map(|&t| index(t)))
            .collect(),
        measures: parsed.iter().map(|c| c.cell.measure).collect(),
    })
}

/// The cells of a mesh by their vertices ([`vertex_cells`]).
#[derive(Clone, Debug, PartialEq)]
pub struct VertexCells {
    pub points: Vec<[f64; 3]>,
    pub corners: Vec<u32>,
    pub measures: Vec<f64>,
}

/// A parsed cell: its element tag, corner node tags, centroid and measure.
struct Parsed {
    tag: u64,
    nodes: Vec<u64>,
    cell: Cell,
}

/// The nodes (tag, position; sorted by tag) and the cells of dimension `dim` of the Gmsh
/// file `text`, each cell's nodes in $Nodes and its measure positive.
type Mesh = (Vec<(u64, [f64; 3])>, Vec<Parsed>);

fn parse(text: &str, dim: usize) -> Result<Mesh, String> {
    let format = section(text, "MeshFormat")?;
    let mut header = format.split_whitespace();
    let version = header.next().ok_or("$MeshFormat is empty")?;
    let binary = header.next().ok_or("$MeshFormat has no file type")?;
    if binary != "0" {
        return Err(
            "is a binary Gmsh file; write it as ASCII (Gmsh: File > Export, or -format msh41 \
             without -bin)"
                .into(),
        );
    }
    let major = version.split('.').next().unwrap_or("");
    let (nodes, elements) = match major {
        "2" => (
            nodes_v2(&section(text, "Nodes")?)?,
            section(text, "Elements")?,
        ),
        "4" => (
            nodes_v4(&section(text, "Nodes")?)?,
            section(text, "Elements")?,
        ),
        _ => {
            return Err(format!(
                "has format version {version}; this reader takes Gmsh's ASCII formats 2.2 and \
                 4.1"
            ));
        }
    };
    let corners = match major {
        "2" => elements_v2(&elements, dim)?,
        _ => elements_v4(&elements, dim)?,
    };
    let point = |tag: u64| {
        nodes
            .binary_search_by_key(&tag, |n| n.0)
            .map(|k| nodes[k].1)
            .map_err(|_| format!("an element names node {tag}, which $Nodes does not hold"))
    };
    let mut out = Vec::with_capacity(corners.len());
    for (tag, tags) in corners {
        let x: Vec<[f64; 3]> = tags.iter().map(|&t| point(t)).collect::<Result<_, _>>()?;
        let cell = measure(&x, dim);
        let what = if dim == 2 { "area" } else { "volume" };
        if cell.measure.is_nan() || cell.measure <= 0.0 {
            return Err(format!(
                "element {tag} has {what} {:e}; cells must not be degenerate (check its \
                 corner order and that the mesh is {dim}D)",
                cell.measure
            ));
        }
        if !(cell.measure.is_finite() && cell.centroid.iter().all(|c| c.is_finite())) {
            return Err(format!(
                "element {tag} has {what} {:e} and centroid {:?}, past the range of f64; \
                 give the mesh in units that keep its coordinates within about 1e100",
                cell.measure, cell.centroid
            ));
        }
        out.push(Parsed {
            tag,
            nodes: tags,
            cell,
        });
    }
    if out.is_empty() {
        return Err(format!(
            "holds no {dim}D cells (Gmsh types {}); mesh the {}",
            if dim == 2 {
                "2: triangles, 3: quadrangles"
            } else {
                "4: tetrahedra, 5: hexahedra"
            },
            if dim == 2 { "surface" } else { "volume" }
        ));
    }
    Ok((nodes, out))
}

/// The text between `$name` and `$Endname`.
fn section(text: &str, name: &str) -> Result<String, String> {
    let start = format!("${name}");
    let end = format!("$End{name}");
    let mut lines = text.lines().map(str::trim);
    lines
        .by_ref()
        .find(|l| *l == start)
        .ok_or(format!("has no ${name} section; is it a Gmsh .msh file?"))?;
    let mut body = String::new();
    for line in lines {
        if line == end {
            return Ok(body);
        }
        body.push_str(line);
        body.push('\n');
    }
    Err(format!("its ${name} section has no {end}"))
}

/// Numbers of a section, in order, with the position of each for errors.
struct Numbers<'a> {
    words: std::iter::Peekable<std::str::SplitWhitespace<'a>>,
    section: &'static str,
    read: usize,
}

impl<'a> Numbers<'a> {
    fn new(text: &'a str, section: &'static str) -> Self {
        Self {
            words: text.split_whitespace().peekable(),
            section,
            read: 0,
        }
    }

    fn next<T: std::str::FromStr>(&mut self, what: &str) -> Result<T, String> {
        self.read += 1;
        let word = self.words.next().ok_or(format!(
            "${} ends before its {what} (number {})",
            self.section, self.read
        ))?;
        word.parse().map_err(|_| {
            format!(
                "${}: number {} ({what}) is not a valid number",
                self.section, self.read
            )
        })
    }

    fn coordinate(&mut self) -> Result<f64, String> {
        let x: f64 = self.next("a coordinate")?;
        if x.is_finite() {
            Ok(x)
        } else {
            Err(format!(
                "${}: number {} is a coordinate that is not finite",
                self.section, self.read
            ))
        }
    }
}

/// (tag, position) of every node, sorted by tag; MSH 2.2: `n`, then `tag x y z` lines.
fn nodes_v2(text: &str) -> Result<Vec<(u64, [f64; 3])>, String> {
    let mut words = Numbers::new(text, "Nodes");
    let n: usize = words.next("node count")?;
    let mut nodes = Vec::with_capacity(n.min(text.len()));
    for _ in 0..n {
        let tag = words.next("node tag")?;
        nodes.push((
            tag,
            [
                words.coordinate()?,
                words.coordinate()?,
                words.coordinate()?,
            ],
        ));
    }
    sorted(nodes)
}

/// MSH 4.1: blocks of `dim tag parametric count`, `count` tags, then `count` coordinate
/// rows (x y z, and the parametric coordinates when `parametric` is 1).
fn nodes_v4(text: &str) -> Result<Vec<(u64, [f64; 3])>, String> {
    let mut words = Numbers::new(text, "Nodes");
    let blocks: usize = words.next("block count")?;
    let n: usize = words.next("node count")?;
    let _: u64 = words.next("smallest node tag")?;
    let _: u64 = words.next("largest node tag")?;
    let mut nodes = Vec::with_capacity(n.min(text.len()));
    for _ in 0..blocks {
        let entity_dim: usize = words.next("entity dimension")?;
        let _: i64 = words.next("entity tag")?;
        let parametric: u32 = words.next("parametric flag")?;
        let count: usize = words.next("block's node count")?;
        let tags: Vec<u64> = (0..count.min(text.len()))
            .map(|_| words.next("node tag"))
            .collect::<Result<_, _>>()?;
        for tag in tags {
            let x = [
                words.coordinate()?,
                words.coordinate()?,
                words.coordinate()?,
            ];
            if parametric == 1 {
                for _ in 0..entity_dim.min(3) {
                    words.coordinate()?;
                }
            }
            nodes.push((tag, x));
        }
    }
    sorted(nodes)
}

fn sorted(mut nodes: Vec<(u64, [f64; 3])>) -> Result<Vec<(u64, [f64; 3])>, String> {
    nodes.sort_by_key(|n| n.0);
    if let Some(w) = nodes.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(format!("$Nodes holds node {} twice", w[0].0));
    }
    Ok(nodes)
}

/// The corner count of a cell type of dimension `dim`; None for a type to skip; Err for a
/// type this reader does not take.
fn corners_of(kind: u32, dim: usize, tag: u64) -> Result<Option<usize>, String> {
    if let Some(&(_, _, n)) = LINEAR.iter().find(|&&(t, d, _)| t == kind && d == dim) {
        return Ok(Some(n));
    }
    if HIGHER_ORDER.contains(&kind) {
        return Err(format!(
            "element {tag} has Gmsh type {kind}, a second-order element; mesh with order 1 \
             (Gmsh: -order 1)"
        ));
    }
    match skipped_corners(kind) {
        Some(_) => Ok(None),
        None => Err(format!(
            "element {tag} has Gmsh type {kind}, which this reader does not take (cells: 2 \
             triangle, 3 quadrangle, 4 tetrahedron, 5 hexahedron; skipped: 1 line, 15 point)"
        )),
    }
}

/// (element tag, corner node tags) of every cell; MSH 2.2: `n`, then
/// `tag type ntags tags… nodes…` lines.
fn elements_v2(text: &str, dim: usize) -> Result<Vec<(u64, Vec<u64>)>, String> {
    let mut words = Numbers::new(text, "Elements");
    let n: usize = words.next("element count")?;
    let mut cells = Vec::new();
    for _ in 0..n {
        let tag: u64 = words.next("element tag")?;
        let kind: u32 = words.next("element type")?;
        let ntags: usize = words.next("tag count")?;
        for _ in 0..ntags {
            let _: i64 = words.next("element's tag")?;
        }
        let corners = match corners_of(kind, dim, tag)? {
            Some(n) => n,
            None => skipped_corners(kind).expect("a skipped type has a corner count"),
        };
        let nodes: Vec<u64> = (0..corners)
            .map(|_| words.next("node tag"))
            .collect::<Result<_, _>>()?;
        if corners_of(kind, dim, tag)?.is_some() {
            cells.push((tag, nodes));
        }
    }
    Ok(cells)
}

/// MSH 4.1: blocks of `dim tag type count`, then `count` lines of `tag nodes…`.
fn elements_v4(text: &str, dim: usize) -> Result<Vec<(u64, Vec<u64>)>, String> {
    let mut words = Numbers::new(text, "Elements");
    let blocks: usize = words.next("block count")?;
    let _: usize = words.next("element count")?;
    let _: u64 = words.next("smallest element tag")?;
    let _: u64 = words.next("largest element tag")?;
    let mut cells = Vec::new();
    for _ in 0..blocks {
        let _: usize = words.next("entity dimension")?;
        let _: i64 = words.next("entity tag")?;
        let kind: u32 = words.next("element type")?;
        let count: usize = words.next("block's element count")?;
        for _ in 0..count {
            let tag: u64 = words.next("element tag")?;
            let keep = corners_of(kind, dim, tag)?;
            let corners = keep.or(skipped_corners(kind)).expect("a known type");
            let nodes: Vec<u64> = (0..corners)
                .map(|_| words.next("node tag"))
                .collect::<Result<_, _>>()?;
            if keep.is_some() {
                cells.push((tag, nodes));
            }
        }
    }
    Ok(cells)
}

/// The centroid and measure of a cell with corners `x` in Gmsh's order: a polygon's by
/// the shoelace formula (in the x–y plane), a tetrahedron's exactly, a hexahedron's as
/// the six tetrahedra about its diagonal from corner 0 to corner 6 (exact for cells with
/// planar faces).
fn measure(x: &[[f64; 3]], dim: usize) -> Cell {
    if dim == 2 {
        let (mut area, mut cx, mut cy) = (0.0, 0.0, 0.0);
        for k in 0..x.len() {
            let (a, b) = (x[k], x[(k + 1) % x.len()]);
            let cross = a[0] * b[1] - b[0] * a[1];
            area += cross;
            cx += (a[0] + b[0]) * cross;
            cy += (a[1] + b[1]) * cross;
        }
        let area = 0.5 * area;
        return Cell {
            centroid: [cx / (6.0 * area), cy / (6.0 * area), 0.0],
            measure: area,
        };
    }
    let tets: &[[usize; 4]] = if x.len() == 4 {
        &[[0, 1, 2, 3]]
    } else {
        &[
            [0, 1, 2, 6],
            [0, 2, 3, 6],
            [0, 3, 7, 6],
            [0, 7, 4, 6],
            [0, 4, 5, 6],
            [0, 5, 1, 6],
        ]
    };
    let (mut volume, mut centroid) = (0.0, [0.0; 3]);
    for t in tets {
        let [a, b, c, d] = t.map(|k| x[k]);
        let e = |p: [f64; 3]| [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
        let (u, v, w) = (e(b), e(c), e(d));
        let v6 = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0]);
        let vol = v6 / 6.0;
        volume += vol;
        for k in 0..3 {
            centroid[k] += vol * (a[k] + b[k] + c[k] + d[k]) / 4.0;
        }
    }
    Cell {
        centroid: centroid.map(|c| c / volume),
        measure: volume,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square as two triangles and a quadrangle beside it, with boundary lines and a
    /// point element that are skipped, in format 2.2.
    const V2: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n6\n1 0 0 0\n2 1 0 0\n3 1 1 0\n4 0 1 0\n5 2 0 0\n6 2 1 0\n$EndNodes\n$Elements\n5\n1 15 2 0 1 1\n2 1 2 0 1 1 2\n3 2 2 0 1 1 2 3\n4 2 2 0 1 1 3 4\n5 3 2 0 1 2 5 6 3\n$EndElements\n";

    /// The same in format 4.1.
    const V4: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 1 0\n1 0 0 0 2 1 0 0\n$EndEntities\n$Nodes\n1 6 1 6\n2 1 0 6\n1\n2\n3\n4\n5\n6\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0\n2 1 0\n$EndNodes\n$Elements\n3 4 1 5\n1 1 1 1\n2 1 2\n2 1 2 2\n3 1 2 3\n4 1 3 4\n2 1 3 1\n5 2 5 6 3\n$EndElements\n";

    #[test]
    fn both_formats_give_the_cells_centroids_and_areas() {
        for text in [V2, V4] {
            let cells = cells(text, 2).unwrap();
            assert_eq!(cells.len(), 3);
            let total: f64 = cells.iter().map(|c| c.measure).sum();
            assert!((total - 2.0).abs() < 1e-15, "{total}");
            assert_eq!(cells[0].centroid, [2.0 / 3.0, 1.0 / 3.0, 0.0]);
            assert!((cells[2].centroid[0] - 1.5).abs() < 1e-15);
            assert!((cells[2].centroid[1] - 0.5).abs() < 1e-15);
        }
    }

    #[test]
    fn a_hexahedron_and_a_tetrahedron_have_their_exact_volumes() {
        // A box 2 × 1 × 0.5 sheared in x by z (planar faces): volume 1, centroid at the
        // mean of the corners; the tetrahedron of the unit axes: 1/6 at (1/4, 1/4, 1/4).
        let hex: Vec<[f64; 3]> = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.3, 0.0, 0.5],
            [2.3, 0.0, 0.5],
            [2.3, 1.0, 0.5],
            [0.3, 1.0, 0.5],
        ]
        .to_vec();
        let cell = measure(&hex, 3);
        assert!((cell.measure - 1.0).abs() < 1e-15, "{cell:?}");
        assert!((cell.centroid[0] - 1.15).abs() < 1e-15, "{cell:?}");
        let tet = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let cell = measure(&tet, 3);
        assert!((cell.measure - 1.0 / 6.0).abs() < 1e-16);
        assert_eq!(cell.centroid, [0.25; 3]);
    }

    #[test]
    fn bad_meshes_are_named() {
        let err = |text: &str, dim: usize| cells(text, dim).unwrap_err();
        assert!(err("x", 2).contains("$MeshFormat"));
        assert!(err(&V2.replace("2.2 0 8", "2.2 1 8"), 2).contains("binary"));
        assert!(err(&V2.replace("2.2 0 8", "3.0 0 8"), 2).contains("2.2 and 4.1"));
        // Clockwise corners: a negative area.
        assert!(err(&V2.replace("3 2 2 0 1 1 2 3", "3 2 2 0 1 1 3 2"), 2).contains("element 3"));
        // A node no element may name, a cut-off section, a 2D mesh read as 3D.
        assert!(err(&V2.replace("1 2 3\n4", "1 2 9\n4"), 2).contains("node 9"));
        assert!(err(&V2.replace("$EndElements\n", ""), 2).contains("$EndElements"));
        assert!(err(V2, 3).contains("no 3D cells"));
        // A second-order triangle.
        assert!(
            err(&V2.replace("3 2 2 0 1 1 2 3", "3 9 2 0 1 1 2 3 4 5 6"), 2)
                .contains("second-order")
        );
    }
}
