use super::*;
use crate::output::scratch::scratch;
use std::fs;

/// The values of the Float64 or Int32 `DataArray` named `name` of a frame, as f64.
pub(crate) fn read_field(path: &Path, name: &str) -> Vec<f64> {
    let (_, tags, raw) = read_vtu(path);
    let tag = tags
        .iter()
        .find(|t| t.name == name)
        .unwrap_or_else(|| panic!("no field {name}"));
    let bytes = block(&raw, tag.offset);
    match tag.vtk_type.as_str() {
        "Float64" => decode_f64(bytes).into_iter().map(f64::from_bits).collect(),
        "Int32" => decode_i32(bytes).into_iter().map(f64::from).collect(),
        other => panic!("{name}: type {other}"),
    }
}

/// A `DataArray` tag as read back from a frame header.
#[derive(Debug)]
struct Tag {
    name: String,
    vtk_type: String,
    components: usize,
    offset: usize,
}

/// Value of attribute `key` in a single XML tag.
fn attr<'t>(tag: &'t str, key: &str) -> Option<&'t str> {
    let start = tag.find(&format!(" {key}=\""))? + key.len() + 3;
    let len = tag[start..].find('"')?;
    Some(&tag[start..start + len])
}

/// Minimal reader of the frames written by [`write_vtu`]: returns the XML
/// header, the `DataArray` tags and the bytes after the `_` marker.
fn read_vtu(path: &Path) -> (String, Vec<Tag>, Vec<u8>) {
    let bytes = fs::read(path).unwrap();
    let opening = b"<AppendedData encoding=\"raw\">";
    let at = bytes
        .windows(opening.len())
        .position(|w| w == opening)
        .expect("no AppendedData element");
    let marker = at + bytes[at..].iter().position(|&b| b == b'_').unwrap();
    let header = String::from_utf8(bytes[..marker].to_vec()).unwrap();
    let raw = bytes[marker + 1..].to_vec();
    let tags = header
        .split("<DataArray")
        .skip(1)
        .map(|rest| {
            let tag = &rest[..rest.find("/>").expect("unclosed DataArray")];
            Tag {
                name: attr(tag, "Name").unwrap().to_owned(),
                vtk_type: attr(tag, "type").unwrap().to_owned(),
                components: attr(tag, "NumberOfComponents").unwrap().parse().unwrap(),
                offset: attr(tag, "offset").unwrap().parse().unwrap(),
            }
        })
        .collect();
    (header, tags, raw)
}

/// Payload of the block at `offset`, checked against its UInt64 header.
fn block(raw: &[u8], offset: usize) -> &[u8] {
    let len = u64::from_le_bytes(raw[offset..offset + 8].try_into().unwrap()) as usize;
    &raw[offset + 8..offset + 8 + len]
}

/// Little-endian words of N bytes each (the f64s as their bits).
fn decode<const N: usize, T>(bytes: &[u8], from_le_bytes: fn([u8; N]) -> T) -> Vec<T> {
    assert_eq!(bytes.len() % N, 0);
    bytes
        .chunks_exact(N)
        .map(|c| from_le_bytes(c.try_into().unwrap()))
        .collect()
}

fn decode_f64(bytes: &[u8]) -> Vec<u64> {
    decode(bytes, u64::from_le_bytes)
}

fn decode_i32(bytes: &[u8]) -> Vec<i32> {
    decode(bytes, i32::from_le_bytes)
}

fn decode_i64(bytes: &[u8]) -> Vec<i64> {
    decode(bytes, i64::from_le_bytes)
}

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn vtu_round_trips_all_field_kinds_bit_exact() {
    let (dir, path) = scratch("frame_0003.vtu");
    let points = [
        [0.0, 0.0, 0.0],
        [0.1, -0.0, 1e-300],
        [1.0 / 3.0, 2.5, -7.25],
        [f64::MAX, f64::MIN_POSITIVE, 5e-324],
        [-1.5e10, 3.0e-8, 42.0],
    ];
    let pressure = [1.0, -2.0, f64::NAN, f64::INFINITY, 0.1 + 0.2];
    let velocity = [
        [1.0, 2.0, 3.0],
        [-1.0, -2.0, -3.0],
        [0.5, 0.25, 0.125],
        [1e-12, 1e12, 0.0],
        [9.0, 8.0, 7.0],
    ];
    let stress: Vec<[f64; 9]> = (0..5)
        .map(|p| std::array::from_fn(|k| (10 * p + k) as f64 + 1.0 / 7.0))
        .collect();
    let ids = [0, -1, i32::MAX, i32::MIN, 7];
    let fields = [
        Field {
            name: "pressure",
            data: FieldData::Scalar(&pressure),
        },
        Field {
            name: "velocity",
            data: FieldData::Vector(&velocity),
        },
        Field {
            name: "stress",
            data: FieldData::Tensor(&stress),
        },
        Field {
            name: "id",
            data: FieldData::Int(&ids),
        },
    ];
    let time = 0.123_456_789_012_345_67;

    write_vtu(&path, &points, &fields, time, Mesh::NONE).unwrap();
    let (header, tags, raw) = read_vtu(&path);

    assert!(header.starts_with("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\""));
    assert!(header.contains("header_type=\"UInt64\""));
    assert!(header.contains("byte_order=\"LittleEndian\""));
    assert!(header.contains("<Piece NumberOfPoints=\"5\" NumberOfCells=\"5\">"));
    assert!(header.contains("NumberOfTuples=\"1\""));

    let expected = [
        ("TimeValue", "Float64", 1, 8),
        ("pressure", "Float64", 1, 5 * 8),
        ("velocity", "Float64", 3, 15 * 8),
        ("stress", "Float64", 9, 45 * 8),
        ("id", "Int32", 1, 5 * 4),
        ("Points", "Float64", 3, 15 * 8),
        ("connectivity", "Int64", 1, 5 * 8),
        ("offsets", "Int64", 1, 5 * 8),
        ("types", "UInt8", 1, 5),
    ];
    assert_eq!(tags.len(), expected.len());
    let mut offset = 0;
    for (tag, (name, vtk_type, components, len)) in tags.iter().zip(expected) {
        assert_eq!((tag.name.as_str(), tag.vtk_type.as_str()), (name, vtk_type));
        assert_eq!(tag.components, components, "{name}");
        assert_eq!(tag.offset, offset, "offset of {name}");
        assert_eq!(block(&raw, offset).len(), len, "length of {name}");
        offset += 8 + len;
    }
    assert_eq!(&raw[offset..], b"\n  </AppendedData>\n</VTKFile>\n");

    let data = |i: usize| block(&raw, tags[i].offset);
    assert_eq!(decode_f64(data(0)), bits(&[time]));
    assert_eq!(decode_f64(data(1)), bits(&pressure));
    assert_eq!(decode_f64(data(2)), bits(velocity.as_flattened()));
    assert_eq!(decode_f64(data(3)), bits(stress.as_flattened()));
    assert_eq!(decode_i32(data(4)), ids);
    assert_eq!(decode_f64(data(5)), bits(points.as_flattened()));
    assert_eq!(decode_i64(data(6)), [0, 1, 2, 3, 4]);
    assert_eq!(decode_i64(data(7)), [1, 2, 3, 4, 5]);
    assert_eq!(data(8), [VTK_VERTEX; 5]);

    assert!(!dir.path().join("frame_0003.vtu.tmp").exists());
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn elements_follow_the_vertex_cells() {
    // Four points and one quadrilateral on them: five cells, the quad's corners after
    // the vertices, its offset four past theirs, its type VTK_QUAD; a cell naming a
    // fifth point is refused and nothing is written.
    let (dir, path) = scratch("mesh.vtu");
    let points = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let mesh = Mesh {
        corners: &[0, 1, 2, 3],
        dim: 2,
        ghosts: None,
    };
    write_vtu(&path, &points, &[], 0.0, mesh).unwrap();
    let (header, tags, raw) = read_vtu(&path);
    assert!(header.contains("NumberOfPoints=\"4\" NumberOfCells=\"5\""));
    let data = |name: &str| {
        let tag = tags.iter().find(|t| t.name == name).unwrap();
        block(&raw, tag.offset).to_vec()
    };
    assert_eq!(decode_i64(&data("connectivity")), [0, 1, 2, 3, 0, 1, 2, 3]);
    assert_eq!(decode_i64(&data("offsets")), [1, 2, 3, 4, 8]);
    assert_eq!(
        data("types"),
        [VTK_VERTEX, VTK_VERTEX, VTK_VERTEX, VTK_VERTEX, VTK_QUAD]
    );
    let bad = Mesh {
        corners: &[0, 1, 2, 4],
        dim: 2,
        ghosts: None,
    };
    let other = dir.path().join("bad.vtu");
    let err = write_vtu(&other, &points, &[], 0.0, bad).unwrap_err();
    assert!(err.to_string().contains("point 4"), "{err}");
    assert!(!other.exists());
}

#[test]
fn a_piece_flags_its_ghosts_and_gives_them_no_vertex_cell() {
    // Four points, the last two another piece's corners of this piece's quadrilateral:
    // two vertex cells and the quad (three cells), vtkGhostType 0, 0, 1, 1 after the
    // fields; the parallel index declares the same arrays and lists the pieces.
    let (dir, path) = scratch("piece.vtu");
    let points = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let ids = [4, 5, 9, 8];
    let fields = [Field {
        name: "id",
        data: FieldData::Int(&ids),
    }];
    let mesh = Mesh {
        corners: &[0, 1, 2, 3],
        dim: 2,
        ghosts: Some(2),
    };
    write_vtu(&path, &points, &fields, 0.5, mesh).unwrap();
    let (header, tags, raw) = read_vtu(&path);
    assert!(header.contains("NumberOfPoints=\"4\" NumberOfCells=\"3\""));
    let data = |name: &str| {
        let tag = tags.iter().find(|t| t.name == name).unwrap();
        block(&raw, tag.offset).to_vec()
    };
    assert_eq!(data("vtkGhostType"), [0, 0, 1, 1]);
    assert_eq!(decode_i64(&data("connectivity")), [0, 1, 0, 1, 2, 3]);
    assert_eq!(decode_i64(&data("offsets")), [1, 2, 6]);
    assert_eq!(data("types"), [VTK_VERTEX, VTK_VERTEX, VTK_QUAD]);
    let index = dir.path().join("frame.pvtu");
    let pieces = [
        "frame/rank-00000.vtu".to_owned(),
        "frame/rank-00001.vtu".to_owned(),
    ];
    super::write_pvtu(&index, &super::PieceArrays::of(&fields), &pieces).unwrap();
    let xml = fs::read_to_string(&index).unwrap();
    assert!(xml.contains("type=\"PUnstructuredGrid\""), "{xml}");
    for line in [
        "<PDataArray type=\"Int32\" Name=\"id\" NumberOfComponents=\"1\"/>",
        "<PDataArray type=\"UInt8\" Name=\"vtkGhostType\" NumberOfComponents=\"1\"/>",
        "<PDataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"/>",
        "<Piece Source=\"frame/rank-00001.vtu\"/>",
    ] {
        assert!(xml.contains(line), "{line} in {xml}");
    }
    // More ghosts than points, and a piece outside the index's folder, are refused.
    let too_many = Mesh {
        ghosts: Some(5),
        ..mesh
    };
    assert!(write_vtu(&path, &points, &[], 0.0, too_many).is_err());
    let absolute = ["/tmp/piece.vtu".to_owned()];
    assert!(super::write_pvtu(&index, &super::PieceArrays::of(&[]), &absolute).is_err());
}

#[test]
fn vtu_without_points_or_fields_is_well_formed() {
    let (_dir, path) = scratch("empty.vtu");

    write_vtu(&path, &[], &[], 2.0, Mesh::NONE).unwrap();
    let (header, tags, raw) = read_vtu(&path);

    assert!(header.contains("<Piece NumberOfPoints=\"0\" NumberOfCells=\"0\">"));
    assert!(header.contains("<PointData>\n      </PointData>"));
    let names: Vec<&str> = tags.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(
        names,
        ["TimeValue", "Points", "connectivity", "offsets", "types"]
    );
    assert_eq!(decode_f64(block(&raw, 0)), bits(&[2.0]));
    for tag in &tags[1..] {
        assert!(block(&raw, tag.offset).is_empty(), "{}", tag.name);
    }
    assert_eq!(&raw[8 + 8 + 4 * 8..], b"\n  </AppendedData>\n</VTKFile>\n");
}

#[test]
fn vtu_rejects_field_length_mismatch_naming_field() {
    let (dir, path) = scratch("bad.vtu");
    let points = [[0.0; 3]; 3];
    let good = [1.0, 2.0, 3.0];
    let short = [[0.0; 9]; 2];
    let fields = [
        Field {
            name: "density",
            data: FieldData::Scalar(&good),
        },
        Field {
            name: "cauchy_stress",
            data: FieldData::Tensor(&short),
        },
    ];

    let err = write_vtu(&path, &points, &fields, 0.0, Mesh::NONE).unwrap_err();

    assert_eq!(err.kind(), io::ErrorKind::InvalidInput);
    assert!(err.to_string().contains("cauchy_stress"), "{err}");
    assert!(!err.to_string().contains("density"), "{err}");
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn vtu_rejects_empty_and_repeated_field_names() {
    let (_dir, path) = scratch("bad.vtu");
    let points = [[0.0; 3]];
    let v = [1.0];
    let empty = [Field {
        name: "",
        data: FieldData::Scalar(&v),
    }];
    let twice = [
        Field {
            name: "rho",
            data: FieldData::Scalar(&v),
        },
        Field {
            name: "rho",
            data: FieldData::Scalar(&v),
        },
    ];

    for fields in [&empty[..], &twice[..]] {
        let err = write_vtu(&path, &points, fields, 0.0, Mesh::NONE).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidInput);
    }
    assert!(!path.exists());
}

#[test]
fn vtu_escapes_field_names() {
    let (_dir, path) = scratch("names.vtu");
    let v = [1.0];

    let fields = [Field {
        name: "a<b & \"c\"",
        data: FieldData::Scalar(&v),
    }];
    write_vtu(&path, &[[0.0; 3]], &fields, 0.0, Mesh::NONE).unwrap();
    let (header, _, _) = read_vtu(&path);

    assert!(
        header.contains("Name=\"a&lt;b &amp; &quot;c&quot;\""),
        "{header}"
    );
}

#[test]
fn pvd_lists_every_pushed_frame() {
    let dir = tempfile::tempdir().unwrap();
    let mut index = PvdIndex::create(dir.path(), "run").unwrap();
    let pvd = dir.path().join("run.pvd");
    assert_eq!(index.path(), pvd);
    let empty = fs::read_to_string(&pvd).unwrap();
    assert!(empty.contains("<Collection>\n  </Collection>"), "{empty}");

    let times = [0.0, 2.5e-4, 1.0 / 3.0];
    for (i, &t) in times.iter().enumerate() {
        let name = format!("run_{i:04}.vtu");
        write_vtu(&dir.path().join(&name), &[[0.0; 3]], &[], t, Mesh::NONE).unwrap();
        index.push(t, &name).unwrap();
    }
    assert_eq!(index.len(), 3);

    let xml = fs::read_to_string(&pvd).unwrap();
    assert!(xml.starts_with("<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\""));
    assert!(xml.ends_with("  </Collection>\n</VTKFile>\n"), "{xml}");
    assert_eq!(xml.matches("<Collection>").count(), 1);
    let datasets: Vec<&str> = xml.lines().filter(|l| l.contains("<DataSet")).collect();
    assert_eq!(datasets.len(), 3);
    for (i, (line, &t)) in datasets.iter().zip(&times).enumerate() {
        assert!(line.trim_end().ends_with("/>"), "{line}");
        let timestep: f64 = attr(line, "timestep").unwrap().parse().unwrap();
        assert_eq!(timestep.to_bits(), t.to_bits());
        assert_eq!(attr(line, "part"), Some("0"));
        assert_eq!(attr(line, "file"), Some(format!("run_{i:04}.vtu").as_str()));
    }
    assert!(!dir.path().join("run.pvd.tmp").exists());
}

#[test]
fn pvd_rejects_missing_frames_and_keeps_index() {
    let dir = tempfile::tempdir().unwrap();
    let mut index = PvdIndex::create(dir.path(), "run").unwrap();
    write_vtu(&dir.path().join("a.vtu"), &[], &[], 0.0, Mesh::NONE).unwrap();
    index.push(0.0, "a.vtu").unwrap();
    let before = fs::read_to_string(index.path()).unwrap();

    let missing = index.push(1.0, "b.vtu").unwrap_err();
    assert_eq!(missing.kind(), io::ErrorKind::NotFound);
    assert!(missing.to_string().contains("b.vtu"), "{missing}");
    let nan = index.push(f64::NAN, "a.vtu").unwrap_err();
    assert_eq!(nan.kind(), io::ErrorKind::InvalidInput);
    let absolute = dir.path().join("a.vtu");
    let absolute = index.push(1.0, absolute.to_str().unwrap()).unwrap_err();
    assert_eq!(absolute.kind(), io::ErrorKind::InvalidInput);

    assert_eq!(index.len(), 1);
    assert_eq!(fs::read_to_string(index.path()).unwrap(), before);
}
