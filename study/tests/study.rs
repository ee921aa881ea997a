//! `mpm study` end to end at a small size: every part runs, the report embeds only plots that
//! exist, the CSV has a row per run, and a spec file is read strictly.

use sparse_mpm_study::{run_study, Part, StudySpec};

#[path = "../../tests/common/scratch.rs"]
mod scratch;

#[test]
fn a_quick_study_writes_its_report_csv_and_every_embedded_plot() {
    let out = scratch::unique_temp_dir("study");
    let mut seen = Vec::new();
    let summary = run_study(&StudySpec::quick(), &out, |p| seen.push((p.done, p.total))).unwrap();
    assert_eq!(
        seen.last().map(|&(d, t)| d == t),
        Some(true),
        "progress ends at the total"
    );
    assert!(
        summary.runs.iter().all(|r| r.outcome.is_ok()),
        "{:?}",
        summary.runs.iter().find(|r| r.outcome.is_err())
    );
    let report = std::fs::read_to_string(&summary.report).unwrap();
    for part in Part::ALL {
        assert!(summary.runs.iter().any(|r| r.part == part), "{} ran", part.name());
    }
    // Every image the report embeds exists, and every plot written is embedded.
    let embedded: Vec<&str> = report
        .split("](")
        .skip(1)
        .filter_map(|s| s.split(')').next())
        .filter(|s| s.ends_with(".png"))
        .collect();
    assert!(embedded.len() >= 8, "{embedded:?}");
    for name in &embedded {
        let bytes = std::fs::read(out.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{name}");
    }
    assert_eq!(summary.plots.len(), embedded.len());
    // The report states fitted orders and energy losses.
    assert!(report.contains("fitted order") && report.contains("Energy lost by the end"));
    assert!(report.contains("Stabilising the consistent mass") && report.contains("strip projection error"));
    // One CSV row per run.
    let csv = std::fs::read_to_string(&summary.csv).unwrap();
    assert_eq!(csv.lines().count(), 1 + summary.runs.len());
    assert!(csv.lines().next().unwrap().contains("period_error"));
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn a_study_spec_is_read_strictly_and_defaults_what_it_omits() {
    let spec =
        StudySpec::from_toml_str("parts = [\"frequency\", \"time_step\"]\nbar_cells = [4, 8]\ncfl = 0.3\n").unwrap();
    assert_eq!(spec.parts, vec![Part::Frequency, Part::TimeStep]);
    assert_eq!(spec.bar_cells, vec![4, 8]);
    assert_eq!(spec.masses, StudySpec::default().masses);
    let err = StudySpec::from_toml_str("bar_cels = [4]").unwrap_err().to_string();
    assert!(err.contains("bar_cels"), "{err}");
    let err = StudySpec::from_toml_str("cfl = 2.0").unwrap_err().to_string();
    assert!(err.contains("cfl"), "{err}");
    let err = StudySpec::from_toml_str("parts = [\"nonsense\"]")
        .unwrap_err()
        .to_string();
    assert!(err.contains("nonsense"), "{err}");
}

/// docs/verification.md, "Study spec keys": its example spec reads, and its table has a row
/// for every key of a spec and for no other.
#[test]
fn the_documented_spec_keys_are_the_spec_keys() {
    let docs = include_str!("../../docs/verification.md");
    let section = docs
        .split("## Study spec keys")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("the section");
    let example = section
        .split("```toml\n")
        .nth(1)
        .and_then(|s| s.split("```").next())
        .expect("an example spec");
    let spec = StudySpec::from_toml_str(example).unwrap_or_else(|e| panic!("{e}\n{example}"));
    assert_ne!(spec, StudySpec::default());
    let mut documented: Vec<&str> = section
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split('`').next())
        .collect();
    let toml::Value::Table(keys) = toml::Value::try_from(StudySpec::default()).unwrap() else {
        panic!("a spec is a table")
    };
    let mut keys: Vec<&str> = keys.keys().map(String::as_str).collect();
    documented.sort_unstable();
    keys.sort_unstable();
    assert_eq!(documented, keys);
}
