//! A reader of the frames `meshless` writes, whole (`.vtu`) or in pieces (`.pvtu` and
//! one `.vtu` a rank), into one frame in particle order: what a distributed run's frame
//! is compared with the one-rank run's by. It reads the appended raw blocks the writer
//! makes (UInt64 headers, little endian), no other VTK file.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A frame's values, each f64 as its bits.
#[derive(Clone, Debug, PartialEq)]
pub enum Values {
    F64(Vec<u64>),
    I32(Vec<i32>),
    I64(Vec<i64>),
    U8(Vec<u8>),
}

impl Values {
    fn vtk_type(&self) -> &'static str {
        match self {
            Values::F64(_) => "Float64",
            Values::I32(_) => "Int32",
            Values::I64(_) => "Int64",
            Values::U8(_) => "UInt8",
        }
    }

    fn as_i64(&self) -> Vec<i64> {
        match self {
            Values::I32(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Values::I64(v) => v.clone(),
            Values::U8(v) => v.iter().map(|&x| i64::from(x)).collect(),
            Values::F64(_) => panic!("not an integer array"),
        }
    }

    /// The components `comp` values of each point `which` (by index).
    fn pick(&self, comp: usize, which: &[usize]) -> Values {
        fn rows<T: Copy>(v: &[T], comp: usize, which: &[usize]) -> Vec<T> {
            which
                .iter()
                .flat_map(|&i| v[i * comp..(i + 1) * comp].iter().copied())
                .collect()
        }
        match self {
            Values::F64(v) => Values::F64(rows(v, comp, which)),
            Values::I32(v) => Values::I32(rows(v, comp, which)),
            Values::I64(v) => Values::I64(rows(v, comp, which)),
            Values::U8(v) => Values::U8(rows(v, comp, which)),
        }
    }
}

/// One frame in particle order: its time, the points' arrays (the positions under
/// `Points`) with their components, and the element cells as the ids of their corners,
/// sorted (a frame in pieces lists each rank's cells).
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub time: Vec<u64>,
    pub points: BTreeMap<String, (usize, Values)>,
    pub cells: Vec<Vec<i64>>,
}

/// One `.vtu` file as written: its time, point arrays, the points of its vertex cells
/// and its other cells, the corners as indices of its points.
struct Piece {
    time: Vec<u64>,
    points: BTreeMap<String, (usize, Values)>,
    vertices: Vec<i64>,
    cells: Vec<Vec<i64>>,
}

fn attribute<'t>(tag: &'t str, key: &str) -> &'t str {
    let start = tag
        .find(&format!(" {key}=\""))
        .unwrap_or_else(|| panic!("no {key} in {tag}"))
        + key.len()
        + 3;
    let len = tag[start..].find('"').unwrap();
    &tag[start..start + len]
}

fn decode<const N: usize, T>(bytes: &[u8], f: fn([u8; N]) -> T) -> Vec<T> {
    assert_eq!(bytes.len() % N, 0);
    bytes
        .chunks_exact(N)
        .map(|c| f(c.try_into().unwrap()))
        .collect()
}

fn read_piece(path: &Path) -> Piece {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let opening = b"<AppendedData encoding=\"raw\">";
    let at = (bytes.windows(opening.len()))
        .position(|w| w == opening)
        .expect("appended data");
    let marker = at + bytes[at..].iter().position(|&b| b == b'_').unwrap();
    let header = String::from_utf8(bytes[..marker].to_vec()).unwrap();
    let raw = &bytes[marker + 1..];
    let mut arrays = BTreeMap::new();
    for rest in header.split("<DataArray").skip(1) {
        let tag = &rest[..rest.find("/>").unwrap()];
        let offset: usize = attribute(tag, "offset").parse().unwrap();
        let len = u64::from_le_bytes(raw[offset..offset + 8].try_into().unwrap()) as usize;
        let block = &raw[offset + 8..offset + 8 + len];
        let values = match attribute(tag, "type") {
            "Float64" => Values::F64(decode(block, u64::from_le_bytes)),
            "Int32" => Values::I32(decode(block, i32::from_le_bytes)),
            "Int64" => Values::I64(decode(block, i64::from_le_bytes)),
            "UInt8" => Values::U8(block.to_vec()),
            other => panic!("type {other}"),
        };
        let components: usize = attribute(tag, "NumberOfComponents").parse().unwrap();
        arrays.insert(attribute(tag, "Name").to_string(), (components, values));
    }
    let mut take = |name: &str| arrays.remove(name).unwrap().1;
    let time = match take("TimeValue") {
        Values::F64(t) => t,
        _ => panic!("TimeValue"),
    };
    let (connectivity, offsets, types) = (
        take("connectivity").as_i64(),
        take("offsets").as_i64(),
        take("types").as_i64(),
    );
    let (mut vertices, mut cells) = (Vec::new(), Vec::new());
    let mut start = 0;
    for (&end, &kind) in offsets.iter().zip(&types) {
        let corners = connectivity[start as usize..end as usize].to_vec();
        match kind {
            1 => vertices.extend(corners),
            _ => cells.push(corners),
        }
        start = end;
    }
    Piece {
        time,
        points: arrays,
        vertices,
        cells,
    }
}

/// The arrays of a piece's points: name, VTK type and components.
type Declared = Vec<(String, String, usize)>;

/// The pieces a `.pvtu` index lists, beside it, and the point arrays it declares.
fn read_index(index: &Path) -> (Vec<PathBuf>, Declared) {
    let text = std::fs::read_to_string(index).unwrap();
    let dir = index.parent().unwrap();
    let sources = (text.split("<Piece Source=\"").skip(1))
        .map(|s| dir.join(&s[..s.find('"').unwrap()]))
        .collect();
    let mut declared: Declared = (text.split("<PDataArray").skip(1))
        .map(|rest| {
            let tag = &rest[..rest.find("/>").unwrap()];
            let components = attribute(tag, "NumberOfComponents").parse().unwrap();
            let (name, vtk_type) = (attribute(tag, "Name"), attribute(tag, "type"));
            (name.to_string(), vtk_type.to_string(), components)
        })
        .collect();
    declared.sort();
    (sources, declared)
}

/// The frame at `path` (`.vtu` whole, or `.pvtu` in pieces) in particle order: a piece's
/// own points (those that are no ghost) placed by their `id`, its cells' corners named by
/// id. The read fails unless the ids found are 0..m once each, the index declares the
/// arrays every piece holds, each own point has one vertex cell and a ghost none (a
/// ghost flagged 1, a duplicate point), and a ghost point's values are those of its
/// particle in the piece that owns it. A missing particle past the highest id found
/// shows only against another frame.
pub fn read_frame(path: &Path) -> Frame {
    let pieces: Vec<Piece> = match path.extension().and_then(|e| e.to_str()) {
        Some("pvtu") => {
            let (sources, declared) = read_index(path);
            let pieces: Vec<Piece> = sources.iter().map(|p| read_piece(p)).collect();
            for (p, source) in pieces.iter().zip(&sources) {
                let mut held: Declared = (p.points.iter())
                    .map(|(name, (c, v))| (name.clone(), v.vtk_type().to_string(), *c))
                    .collect();
                held.sort();
                assert_eq!(held, declared, "{} against its index", source.display());
            }
            pieces
        }
        _ => vec![read_piece(path)],
    };
    let time = pieces[0].time.clone();
    // Each piece's own points (no ghosts), piece after piece, and their ids.
    let (mut own, mut ids, mut cells) = (Vec::new(), Vec::new(), Vec::new());
    for p in &pieces {
        assert_eq!(p.time, time, "the pieces' times");
        let id = p.points["id"].1.as_i64();
        let ghost = p.points.get("vtkGhostType").map(|g| g.1.as_i64());
        if let Some(flags) = &ghost {
            assert!(
                flags.iter().all(|&g| g == 0 || g == 1),
                "ghost flags {flags:?}"
            );
        }
        let mine: Vec<usize> = (0..id.len())
            .filter(|&i| ghost.as_ref().is_none_or(|f| f[i] == 0))
            .collect();
        let vertices: Vec<usize> = p.vertices.iter().map(|&v| v as usize).collect();
        assert_eq!(vertices, mine, "one vertex cell an own point, none a ghost");
        ids.extend(mine.iter().map(|&i| id[i]));
        own.push(mine);
        let corners = |c: &Vec<i64>| c.iter().map(|&i| id[i as usize]).collect::<Vec<_>>();
        cells.extend(p.cells.iter().map(corners));
    }
    cells.sort_unstable();
    // The order of the particles by id, which must be 0..n once each.
    let mut by_id: Vec<usize> = (0..ids.len()).collect();
    by_id.sort_by_key(|&r| ids[r]);
    let sorted: Vec<i64> = by_id.iter().map(|&r| ids[r]).collect();
    assert_eq!(
        sorted,
        (0..ids.len() as i64).collect::<Vec<_>>(),
        "one point a particle"
    );
    let mut points = BTreeMap::new();
    for (name, (comp, _)) in &pieces[0].points {
        if name == "vtkGhostType" {
            continue;
        }
        let parts = pieces
            .iter()
            .zip(&own)
            .map(|(p, mine)| p.points[name].1.pick(*comp, mine));
        let joined = parts
            .reduce(|a, b| match (a, b) {
                (Values::F64(mut a), Values::F64(b)) => {
                    a.extend(b);
                    Values::F64(a)
                }
                (Values::I32(mut a), Values::I32(b)) => {
                    a.extend(b);
                    Values::I32(a)
                }
                (a, b) => panic!("array {name}: {a:?} and {b:?}"),
            })
            .unwrap();
        points.insert(name.clone(), (*comp, joined.pick(*comp, &by_id)));
    }
    for p in &pieces {
        let (id, Some((_, ghost))) = (p.points["id"].1.as_i64(), p.points.get("vtkGhostType"))
        else {
            continue;
        };
        for (i, _) in ghost.as_i64().iter().enumerate().filter(|g| *g.1 != 0) {
            for (name, (comp, values)) in &points {
                let at = id[i] as usize;
                assert_eq!(
                    p.points[name].1.pick(*comp, &[i]),
                    values.pick(*comp, &[at]),
                    "{name} of ghost {} differs from its owner's",
                    id[i]
                );
            }
        }
    }
    Frame {
        time,
        points,
        cells,
    }
}
