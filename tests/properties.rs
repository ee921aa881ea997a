//! Property tests: no input panics. Scene files with their values replaced by arbitrary numbers
//! (NaN, infinities, huge, tiny, negative, zero) and their text cut or spliced, and the library's
//! constructors fed arbitrary arrays, give either a value or an error, never a panic; and a scene
//! that passes the checks of `mpm check` ([`limits::prepare_run`]) also takes a step without
//! panicking.
//!
//! The number of cases per property is proptest's `PROPTEST_CASES` (default here: 48, to keep
//! the suite quick). docs/reliability.md gives the command for a longer search:
//!
//! ```text
//! PROPTEST_CASES=2000 cargo test --release --test properties
//! ```

use proptest::prelude::*;

use sparse_mpm::limits::{self, Limits};
use sparse_mpm::scene::Scene;
use sparse_mpm::{Grid, Operators, Particles, ShapeFunction};

const SCENES: [&str; 5] = [
    include_str!("../scenes/two_disks.toml"),
    include_str!("../scenes/block_in_box.toml"),
    include_str!("../scenes/vibrating_bar.toml"),
    include_str!("../scenes/cantilever.toml"),
    include_str!("../scenes/seed_problem.toml"),
];

/// Small limits, so that a mutated scene that passes them runs in milliseconds.
fn small() -> Limits {
    Limits {
        memory_bytes: 64.0 * 1024.0 * 1024.0,
        output_bytes: 64.0 * 1024.0 * 1024.0,
        snapshots: 200.0,
        steps: 1e5,
    }
}

/// Numbers a hostile scene might hold.
fn hostile_number() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("0".to_string()),
        Just("-0.0".to_string()),
        Just("1e308".to_string()),
        Just("-1e308".to_string()),
        Just("1e-320".to_string()),
        Just("18446744073709551615".to_string()),
        Just("-1".to_string()),
        (-1e6f64..1e6).prop_map(|v| format!("{v:e}")),
        (0u64..100_000).prop_map(|v| v.to_string()),
    ]
}

/// The scene `k` with its `n`-th number (counting digits runs) replaced by `value`.
fn replace_number(text: &str, n: usize, value: &str) -> String {
    let bytes = text.as_bytes();
    let mut starts = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        let starts_number = (c.is_ascii_digit() || c == b'-') && (i == 0 || !bytes[i - 1].is_ascii_alphanumeric());
        if starts_number && bytes[i..].iter().take(2).any(|b| b.is_ascii_digit()) {
            let mut j = i + 1;
            while j < bytes.len() && (bytes[j].is_ascii_digit() || matches!(bytes[j], b'.' | b'e' | b'E' | b'-' | b'+'))
            {
                j += 1;
            }
            starts.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    if starts.is_empty() {
        return text.to_string();
    }
    let (a, b) = starts[n % starts.len()];
    format!("{}{}{}", &text[..a], value, &text[b..])
}

/// Whatever the scene, reading and checking it gives a value or an error; when the checks pass
/// with small limits, building and two steps do not panic either.
fn exercise(text: &str) {
    let Ok(scene) = Scene::from_toml_str(text) else {
        return;
    };
    let Ok((mut sim, _)) = limits::prepare_run(&scene, &small()) else {
        return;
    };
    for _ in 0..2 {
        if sim.step().is_err() {
            break;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(
        std::env::var("PROPTEST_CASES").ok().and_then(|c| c.parse().ok()).unwrap_or(48)
    ))]

    #[test]
    fn scenes_with_hostile_numbers_never_panic(
        k in 0..SCENES.len(),
        edits in proptest::collection::vec((0usize..200, hostile_number()), 1..4),
    ) {
        let mut text = SCENES[k].to_string();
        for (n, value) in &edits {
            text = replace_number(&text, *n, value);
        }
        exercise(&text);
    }

    #[test]
    fn cut_and_spliced_scenes_never_panic(
        k in 0..SCENES.len(),
        cut in 0usize..4000,
        splice in "[a-z_=\\[\\]{}\" .,0-9\n-]{0,40}",
    ) {
        let text = SCENES[k];
        let mut at = cut.min(text.len());
        while !text.is_char_boundary(at) {
            at -= 1;
        }
        exercise(&format!("{}{}{}", &text[..at], splice, &text[at..]));
        exercise(&text[..at]);
    }

    #[test]
    fn particles_and_operators_from_arbitrary_arrays_never_panic(
        n in 0usize..12,
        values in proptest::collection::vec(
            prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(-1.0), Just(0.0), -2.0f64..12.0],
            0..60,
        ),
        cells in (0usize..6, 0usize..6),
        h in prop_oneof![Just(0.0), Just(-1.0), Just(f64::NAN), 0.01f64..3.0],
        shape in 0usize..4,
    ) {
        let take = |k: usize| -> Vec<f64> { values.iter().cycle().skip(k).take(n).copied().collect() };
        let (x, y, m, v) = if values.is_empty() {
            (vec![], vec![], vec![], vec![])
        } else {
            (take(0), take(1), take(2), take(3))
        };
        let shape = [
            ShapeFunction::Linear,
            ShapeFunction::Gimp { half_width: 0.25 },
            ShapeFunction::QuadraticBSpline,
            ShapeFunction::CubicBSpline,
        ][shape];
        if let (Ok(grid), Ok(p)) = (Grid::new([0.0, 0.0], [h, h], [cells.0, cells.1]), Particles::new(x, y, m, v)) {
            if let Ok(ops) = Operators::assemble(&grid, shape, &p) {
                let _ = sparse_mpm::mass::lumped_mass(&ops, &p.mass);
                let _ = sparse_mpm::mass::consistent_mass(&ops, &p.mass);
            }
        }
    }
}
