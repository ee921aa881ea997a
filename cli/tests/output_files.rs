//! Snapshot (`.vtp`, `.pvd`) and CSV output: snapshots read back through an independent VTK
//! reader (the `vtkio` crate, in `common/vtk_read.rs`), CSV files through the crate's reader.

#[path = "../../tests/common/scratch.rs"]
mod scratch;
use std::fs;
use std::io::ErrorKind;
use std::path::{Path, PathBuf};

use sparse_mpm::io::csv::{read_csv, CsvWriter};
use sparse_mpm::MpmError;
use sparse_mpm_cli::vtk::{write_vtp, Field, PvdWriter};

#[path = "common/vtk_read.rs"]
mod vtk_read;

use vtk_read::{f64_values, read_pvd, read_vtp, VtpData};

/// A fresh, empty directory for one test.
fn scratch_dir(test: &str) -> scratch::Scratch {
    scratch::Scratch::new("output_files", test)
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Deterministic values with varied signs, exponents and bit patterns (plus special values).
fn values(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|i| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            match i {
                0 => -0.0,
                1 => 1e-300,
                2 => f64::MIN_POSITIVE / 4.0, // subnormal
                _ => {
                    let mantissa = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                    mantissa * 10f64.powi((state % 40) as i32 - 20)
                }
            }
        })
        .collect()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

struct Snapshot {
    x: Vec<f64>,
    y: Vec<f64>,
    mass: Vec<f64>,
    pressure: Vec<f64>,
    vx: Vec<f64>,
    vy: Vec<f64>,
    sxx: Vec<f64>,
    sxy: Vec<f64>,
    syx: Vec<f64>,
    syy: Vec<f64>,
}

impl Snapshot {
    fn new(n: usize) -> Self {
        let mut pressure = values(n, 2);
        for (i, special) in [(5, f64::NAN), (6, f64::INFINITY), (7, f64::NEG_INFINITY)] {
            if i < n {
                pressure[i] = special;
            }
        }
        Snapshot {
            x: values(n, 10),
            y: values(n, 11),
            mass: values(n, 1),
            pressure,
            vx: values(n, 3),
            vy: values(n, 4),
            sxx: values(n, 5),
            sxy: values(n, 6),
            syx: values(n, 7),
            syy: values(n, 8),
        }
    }

    fn fields(&self) -> Vec<Field<'_>> {
        vec![
            Field::Scalar {
                name: "mass",
                values: &self.mass,
            },
            Field::Vector {
                name: "velocity",
                x: &self.vx,
                y: &self.vy,
            },
            Field::Tensor {
                name: "stress",
                xx: &self.sxx,
                xy: &self.sxy,
                yx: &self.syx,
                yy: &self.syy,
            },
            Field::Scalar {
                name: "pressure <p> & \"q\"",
                values: &self.pressure,
            },
        ]
    }

    fn write(&self, path: &Path) {
        write_vtp(path, &self.x, &self.y, &self.fields()).unwrap();
    }

    /// The expected arrays: (name, components, values point after point).
    fn expected_arrays(&self) -> Vec<(&'static str, usize, Vec<f64>)> {
        let n = self.x.len();
        let vector: Vec<f64> = (0..n).flat_map(|i| [self.vx[i], self.vy[i], 0.0]).collect();
        let tensor: Vec<f64> = (0..n)
            .flat_map(|i| {
                [
                    self.sxx[i],
                    self.sxy[i],
                    0.0,
                    self.syx[i],
                    self.syy[i],
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                ]
            })
            .collect();
        vec![
            ("mass", 1, self.mass.clone()),
            ("velocity", 3, vector),
            ("stress", 9, tensor),
            ("pressure <p> & \"q\"", 1, self.pressure.clone()),
        ]
    }

    fn expected_points(&self) -> Vec<f64> {
        (0..self.x.len()).flat_map(|i| [self.x[i], self.y[i], 0.0]).collect()
    }
}

#[test]
fn a_vtp_snapshot_reads_back_bit_for_bit() {
    let dir = scratch_dir("vtp-roundtrip");
    let path = dir.join("particles.vtp");
    let snap = Snapshot::new(357);
    snap.write(&path);

    let data: VtpData = read_vtp(&path).unwrap();
    assert_eq!(data.len(), 357);
    let points: Vec<f64> = data.points.iter().flatten().copied().collect();
    assert_eq!(bits(&points), bits(&snap.expected_points()));
    assert_eq!(data.arrays.len(), 4);
    for (array, (name, components, values)) in data.arrays.iter().zip(snap.expected_arrays()) {
        assert_eq!(array.name, name);
        assert_eq!(array.components, components, "{name}");
        assert_eq!(bits(&array.values), bits(&values), "{name}");
    }
    let velocity = data.array("velocity").unwrap();
    assert_eq!(bits(&velocity.component(1)), bits(&snap.vy));
    assert_eq!(bits(velocity.point(10)), bits(&[snap.vx[10], snap.vy[10], 0.0]));
    assert!(data.array("pressure <p> & \"q\"").unwrap().values[5].is_nan());
    assert_eq!(files_in(&dir), ["particles.vtp"], "no .tmp file is left behind");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_vtp_snapshot_has_one_vertex_cell_per_point_and_arrays_of_the_vtk_attribute_types() {
    use vtkio::model::{Attribute, DataSet, ElementType, Piece, VertexNumbers};

    let dir = scratch_dir("vtp-vtkio");
    let path = dir.join("particles.vtp");
    let snap = Snapshot::new(311);
    snap.write(&path);

    let vtk = vtkio::Vtk::import(&path).unwrap_or_else(|e| panic!("vtkio cannot read the file: {e:?}"));
    let DataSet::PolyData { pieces, .. } = vtk.data else {
        panic!("vtkio read another data set type: {:?}", vtk.data);
    };
    assert_eq!(pieces.len(), 1);
    let Piece::Inline(piece) = &pieces[0] else {
        panic!("the piece is not inline");
    };
    assert_eq!(f64_values(&piece.points, "Points").unwrap().len(), 3 * 311);

    let Some(VertexNumbers::XML { connectivity, offsets }) = &piece.verts else {
        panic!("no vertex cells: {:?}", piece.verts);
    };
    assert_eq!(*connectivity, (0..311).collect::<Vec<u64>>());
    assert_eq!(*offsets, (1..=311).collect::<Vec<u64>>());
    assert!(piece.lines.is_none() && piece.polys.is_none() && piece.strips.is_none());

    // Scalars, vectors and tensors as ParaView shows them (the values are checked above).
    let expected = snap.expected_arrays();
    assert_eq!(piece.data.point.len(), expected.len());
    for (attribute, (name, components, _)) in piece.data.point.iter().zip(expected) {
        let Attribute::DataArray(array) = attribute else {
            panic!("`{name}` was read as a field");
        };
        assert_eq!(array.name, name);
        match (components, &array.elem) {
            (c, ElementType::Generic(k)) if *k as usize == c => {}
            (1, ElementType::Scalars { num_comp: 1, .. }) | (3, ElementType::Vectors) | (9, ElementType::Tensors) => {}
            (_, elem) => panic!("`{name}` read as {elem:?}"),
        }
    }
    assert!(piece.data.cell.is_empty());
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_empty_snapshot_reads_back() {
    let dir = scratch_dir("vtp-empty");
    let path = dir.join("empty.vtp");
    write_vtp(
        &path,
        &[],
        &[],
        &[Field::Scalar {
            name: "mass",
            values: &[],
        }],
    )
    .unwrap();
    let data = read_vtp(&path).unwrap();
    assert!(data.is_empty());
    assert_eq!(data.arrays.len(), 1);
    assert!(data.arrays[0].values.is_empty());
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn rewriting_a_snapshot_replaces_it_whole() {
    let dir = scratch_dir("vtp-rewrite");
    let path = dir.join("p.vtp");
    Snapshot::new(300).write(&path);
    let small = Snapshot::new(20);
    small.write(&path);
    let data = read_vtp(&path).unwrap();
    assert_eq!(data.len(), 20);
    assert_eq!(bits(&data.arrays[0].values), bits(&small.mass));
    assert_eq!(files_in(&dir), ["p.vtp"]);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn length_mismatches_name_the_field_and_write_nothing() {
    let dir = scratch_dir("vtp-lengths");
    let path = dir.join("p.vtp");
    let x = [0.0, 1.0, 2.0];
    let short = [1.0, 2.0];
    let err = write_vtp(&path, &x, &short, &[]).unwrap_err();
    assert!(
        matches!(
            err,
            MpmError::LengthMismatch {
                field: "y",
                expected: 3,
                found: 2
            }
        ),
        "{err:?}"
    );
    let cases: [(Field<'_>, &str); 3] = [
        (
            Field::Scalar {
                name: "mass",
                values: &short,
            },
            "mass",
        ),
        (
            Field::Vector {
                name: "velocity",
                x: &x,
                y: &short,
            },
            "velocity",
        ),
        (
            Field::Tensor {
                name: "stress",
                xx: &x,
                xy: &x,
                yx: &short,
                yy: &x,
            },
            "stress",
        ),
    ];
    for (field, name) in cases {
        let err = write_vtp(&path, &x, &x, &[Field::Scalar { name: "ok", values: &x }, field]).unwrap_err();
        match &err {
            MpmError::LengthMismatch {
                field,
                expected: 3,
                found: 2,
            } => assert_eq!(*field, name),
            other => panic!("{other:?}"),
        }
        assert!(err.to_string().contains(name), "{err}");
    }
    assert!(files_in(&dir).is_empty(), "{:?}", files_in(&dir));
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn writing_into_a_missing_directory_is_an_io_error_naming_the_path() {
    let dir = scratch_dir("missing-dir");
    let missing = dir.join("no-such-dir");
    let vtp = missing.join("p.vtp");
    let pvd = missing.join("run.pvd");
    let csv = missing.join("h.csv");
    let errors = [
        (write_vtp(&vtp, &[1.0], &[2.0], &[]).unwrap_err(), &vtp),
        (PvdWriter::create(&pvd).unwrap_err(), &pvd),
        (CsvWriter::create(&csv, &["t"]).unwrap_err(), &csv),
    ];
    for (err, expected) in errors {
        match &err {
            MpmError::Io { path, source } => {
                assert_eq!(path, expected);
                assert_eq!(source.kind(), ErrorKind::NotFound);
            }
            other => panic!("{other:?}"),
        }
        assert!(err.to_string().contains(&*expected.to_string_lossy()), "{err}");
    }
    assert!(!missing.exists());
    fs::remove_dir_all(&dir).unwrap();
}

/// A minimal well-formedness check: every tag closes in order, attributes are quoted, nothing
/// but whitespace between elements, and exactly one root.
fn assert_well_formed_xml(text: &str) {
    let mut rest = text.trim();
    let mut open: Vec<&str> = Vec::new();
    let mut roots = 0;
    if let Some(after) = rest.strip_prefix("<?xml") {
        rest = after[after.find("?>").expect("unterminated declaration") + 2..].trim_start();
    }
    while !rest.is_empty() {
        assert!(rest.starts_with('<'), "text outside tags: {rest:.40}");
        let end = rest.find('>').expect("unterminated tag");
        let tag = &rest[1..end];
        assert_eq!(tag.matches('"').count() % 2, 0, "unbalanced quotes in <{tag}>");
        assert!(!tag.contains('<'), "`<` inside <{tag}>");
        for (i, _) in tag.match_indices('&') {
            let entity = &tag[i..];
            assert!(
                ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;"]
                    .iter()
                    .any(|e| entity.starts_with(e)),
                "a bare `&` in <{tag}>"
            );
        }
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(open.pop(), Some(name), "mismatched </{name}>");
        } else {
            let name = tag.split_whitespace().next().unwrap().trim_end_matches('/');
            if open.is_empty() {
                roots += 1;
            }
            if !tag.ends_with('/') {
                open.push(name);
            }
        }
        rest = rest[end + 1..].trim_start();
    }
    assert!(open.is_empty(), "unclosed {open:?}");
    assert_eq!(roots, 1);
}

#[test]
fn the_pvd_is_a_valid_collection_after_every_push_and_reads_back_exactly() {
    let dir = scratch_dir("pvd");
    let pvd = dir.join("run.pvd");
    let mut series = PvdWriter::create(&pvd).unwrap();
    let text = fs::read_to_string(&pvd).unwrap();
    assert_well_formed_xml(&text);
    assert!(text.contains("<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">"));
    assert!(read_pvd(&pvd).unwrap().is_empty());

    let times = [0.0, 1e-3, 0.1 + 0.2, 2.5e-9, 1e300, 123456.789];
    let names = [
        "p_0.vtp",
        "p_1.vtp",
        "sub/p_2.vtp",
        "a&b <c>.vtp",
        "q\"uote'.vtp",
        "p_5.vtp",
    ];
    let snap = Snapshot::new(5);
    let mut expected = Vec::new();
    for (&t, &name) in times.iter().zip(&names) {
        let file = dir.join(name);
        fs::create_dir_all(file.parent().unwrap()).unwrap();
        snap.write(&file);
        series.push(t, Path::new(name)).unwrap();
        expected.push((t, PathBuf::from(name)));

        let text = fs::read_to_string(&pvd).unwrap();
        assert_well_formed_xml(&text);
        let read = read_pvd(&pvd).unwrap();
        assert_eq!(read, expected);
        assert_eq!(
            bits(&read.iter().map(|e| e.0).collect::<Vec<_>>()),
            bits(&times[..read.len()])
        );
        // Every listed file is a readable snapshot, relative to the .pvd's directory.
        for (_, f) in &read {
            assert_eq!(read_vtp(&dir.join(f)).unwrap().len(), 5);
        }
    }
    assert_eq!(series.entries(), expected.as_slice());
    assert_eq!(series.path(), pvd);
    let text = fs::read_to_string(&pvd).unwrap();
    assert!(
        text.contains("<DataSet timestep=\"0.001\" group=\"\" part=\"0\" file=\"p_1.vtp\"/>"),
        "{text}"
    );
    assert!(text.contains("file=\"a&amp;b &lt;c&gt;.vtp\""), "{text}");
    assert!(
        !files_in(&dir).iter().any(|f| f.ends_with(".tmp")),
        "{:?}",
        files_in(&dir)
    );

    let err = series.push(f64::NAN, Path::new("x.vtp")).unwrap_err();
    assert!(
        matches!(err, MpmError::InvalidParameter { name: "time", .. }),
        "{err:?}"
    );
    assert_eq!(
        read_pvd(&pvd).unwrap(),
        expected,
        "a rejected push leaves the collection unchanged"
    );
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn csv_rows_read_back_bit_for_bit_including_negative_zero_tiny_huge_and_non_finite_values() {
    let dir = scratch_dir("csv");
    let path = dir.join("history.csv");
    let header = ["time", "kinetic energy", "odd, \"name\""];
    let special = [
        -0.0,
        0.0,
        1e-300,
        -1e-300,
        f64::MIN_POSITIVE / 8.0,
        f64::MAX,
        f64::MIN,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        0.1 + 0.2,
        1e-5,
        1e16 - 2.0, // the largest f64 below 1e16, written with `{}`
        1e16,
        -123456.789,
    ];
    let mut rows: Vec<Vec<f64>> = special.chunks(3).map(|c| c.to_vec()).collect();
    rows.extend(values(300, 42).chunks(3).map(|c| c.to_vec()));

    let mut csv = CsvWriter::create(&path, &header).unwrap();
    assert_eq!(csv.columns(), 3);
    for row in &rows[..2] {
        csv.write_row(row).unwrap();
    }
    csv.flush().unwrap();
    let (_, flushed) = read_csv(&path).unwrap();
    assert_eq!(flushed.len(), 2, "both rows are in the file after flush()");
    for row in &rows[2..] {
        csv.write_row(row).unwrap();
    }
    let err = csv.write_row(&[1.0, 2.0]).unwrap_err();
    assert!(
        matches!(
            err,
            MpmError::LengthMismatch {
                field: "row",
                expected: 3,
                found: 2
            }
        ),
        "{err:?}"
    );
    csv.flush().unwrap();
    drop(csv);

    let (read_header, read_rows) = read_csv(&path).unwrap();
    assert_eq!(read_header, header);
    assert_eq!(read_rows.len(), rows.len());
    for (read, written) in read_rows.iter().zip(&rows) {
        assert_eq!(bits(read), bits(written));
    }
    let text = fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("time,kinetic energy,\"odd, \"\"name\"\"\""));
    assert_eq!(lines.next(), Some("-0,0,1e-300"));
    assert_eq!(lines.nth(2), Some("-inf,0.30000000000000004,0.00001"));
    assert!(text.contains("NaN,inf"), "{text:.300}");
    assert_eq!(files_in(&dir), ["history.csv"]);
    fs::remove_dir_all(&dir).unwrap();
}
