//! Every numeric key of every shipped scene and of the scenes in `tests/data/schema/` (which
//! write every optional key of docs/simulation.md's table, and each parameterised choice as a
//! table), given a value no key has a meaning for (NaN, ±∞, a string), is refused by what
//! `mpm check` runs ([`sparse_mpm::limits::prepare_run`]), and the message names the key. The
//! keys are found by walking the scenes, not listed here, so a key added to a scene is checked
//! without touching this test.
//!
//! The same walk gives every number values a key may or may not have a meaning for (0, its
//! negative, and its value times 10^±6, 10^±12, 10^±30, and ±10³⁰⁰): each is refused naming the
//! key, or accepted and then runs its first steps without a panic and with finite energies,
//! speeds and step (the ranges are in docs/simulation.md's key table).

use std::path::{Path, PathBuf};

use sparse_mpm::limits::{prepare_run, Limits};
use sparse_mpm::scene::Scene;

/// A step of a path into a TOML document.
#[derive(Clone, Debug)]
enum Step {
    Key(String),
    Index(usize),
}

/// The path as a scene key is written in messages: `bodies[0].geometry.disk.radius`.
fn shown(path: &[Step]) -> String {
    let mut s = String::new();
    for step in path {
        match step {
            Step::Key(k) if s.is_empty() => s.push_str(k),
            Step::Key(k) => {
                s.push('.');
                s.push_str(k);
            }
            Step::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// Values no numeric key has a meaning for: NaN, ±∞, and a number written as a string.
fn meaningless() -> [toml::Value; 4] {
    [
        toml::Value::Float(f64::NAN),
        toml::Value::Float(f64::INFINITY),
        toml::Value::Float(f64::NEG_INFINITY),
        toml::Value::String("1.0".into()),
    ]
}

/// Values a key may or may not have a meaning for, from its value `v` in the scene: 0, `−v`,
/// `v · 10^±6`, `v · 10^±12`, `v · 10^±30`, `±10³⁰⁰`; for an integer 0, −1, `−v`, 2⁴⁰ and the
/// largest.
fn extremes(v: &toml::Value) -> Vec<toml::Value> {
    use toml::Value::{Float, Integer};
    match *v {
        Integer(i) => vec![
            Integer(0),
            Integer(-1),
            Integer(-i),
            Integer(1 << 40),
            Integer(i64::MAX),
        ],
        Float(x) => {
            let x = if x == 0.0 { 1.0 } else { x };
            let mut out = vec![Float(0.0), Float(-x), Float(1e300), Float(-1e300)];
            out.extend([1e6, 1e-6, 1e12, 1e-12, 1e30, 1e-30].map(|f| Float(x * f)));
            out
        }
        _ => Vec::new(),
    }
}

/// The last key of a path (what a message names at least).
fn last_key(path: &[Step]) -> String {
    path.iter()
        .rev()
        .find_map(|s| match s {
            Step::Key(k) => Some(k.clone()),
            Step::Index(_) => None,
        })
        .unwrap_or_default()
}

/// Every path to a number (integer or float) in `value`.
fn numbers(value: &toml::Value, path: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
    match value {
        toml::Value::Integer(_) | toml::Value::Float(_) => out.push(path.clone()),
        toml::Value::Table(t) => {
            for (k, v) in t {
                path.push(Step::Key(k.clone()));
                numbers(v, path, out);
                path.pop();
            }
        }
        toml::Value::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                path.push(Step::Index(i));
                numbers(v, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

fn at<'a>(value: &'a mut toml::Value, path: &[Step]) -> &'a mut toml::Value {
    path.iter().fold(value, |v, step| match step {
        Step::Key(k) => v.get_mut(k.as_str()).expect("a path found by the walk"),
        Step::Index(i) => v.get_mut(*i).expect("a path found by the walk"),
    })
}

/// The shipped scenes, and the scenes of `tests/data/schema/` that write every optional key and
/// every parameterised choice as a table.
fn scenes() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<PathBuf> = ["scenes", "tests/data/schema"]
        .iter()
        .flat_map(|d| std::fs::read_dir(root.join(d)).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

/// What `mpm check` says of the scene `text` read from `dir`: `Ok` when it accepts it.
fn check(text: &str, dir: &Path) -> Result<(), String> {
    accept(text, dir).map(|_| ())
}

/// The simulation `mpm check` builds from the scene `text` read from `dir`, or its message.
fn accept(text: &str, dir: &Path) -> Result<sparse_mpm::simulation::Simulation, String> {
    let mut scene = Scene::from_toml_str(text).map_err(|e| e.to_string())?;
    scene.base_dir = Some(dir.to_path_buf());
    prepare_run(&scene, &Limits::default())
        .map(|(sim, _)| sim)
        .map_err(|e| e.to_string())
}

/// Whether a refusal names the key `last`, another key (in backquotes, as
/// [`Scene::locate`] writes it) or a particle.
fn names_what_is_wrong(message: &str, last: &str) -> bool {
    message.contains(last) || message.matches('`').count() >= 2 || message.contains("particle ")
}

/// What is wrong with an accepted scene's first `steps` steps: an error, or a step, energy or
/// speed that is not finite (`None`: nothing). A quasi-static increment whose load the bodies
/// cannot carry (no equilibrium exists) is refused by a Newton error naming the key to change,
/// and that is what it should do.
fn first_steps(sim: &mut sparse_mpm::simulation::Simulation, steps: usize) -> Option<String> {
    for _ in 0..steps {
        match sim.step() {
            Err(e @ sparse_mpm::MpmError::NewtonFailed { .. }) if e.to_string().contains("quasi_static.load_steps") => {
                return None
            }
            Err(e) => return Some(format!("step {} failed: {e}", sim.steps())),
            Ok(r) => {
                let values = [r.dt, r.total_energy, r.kinetic_energy, r.strain_energy, r.max_speed];
                if !values.iter().all(|v| v.is_finite()) || r.dt <= 0.0 {
                    return Some(format!(
                        "step {}: dt {}, energies {} {} {}, speed {}",
                        r.step, r.dt, r.total_energy, r.kinetic_energy, r.strain_energy, r.max_speed
                    ));
                }
            }
        }
    }
    None
}

#[test]
fn no_numeric_key_accepts_nan_infinity_or_a_string() {
    let mut failures = Vec::new();
    let mut cases = 0;
    for file in scenes() {
        let dir = file.parent().unwrap().to_path_buf();
        let original: toml::Value = toml::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        let mut paths = Vec::new();
        numbers(&original, &mut Vec::new(), &mut paths);
        assert!(!paths.is_empty(), "{}: no number to mutate", file.display());
        for path in &paths {
            let key = shown(path);
            for bad in meaningless() {
                let mut mutated = original.clone();
                *at(&mut mutated, path) = bad.clone();
                let text = toml::to_string(&mutated).unwrap();
                cases += 1;
                match check(&text, &dir) {
                    Ok(()) => failures.push(format!("{}: `{key}` = {bad} accepted", file.display())),
                    Err(message) => {
                        // The message names the key (or the last part of it, where the parser
                        // names the table it stopped in).
                        let last = last_key(path);
                        if !message.contains(&last) {
                            failures.push(format!(
                                "{}: `{key}` = {bad}: the message does not name `{last}`: {message}",
                                file.display()
                            ));
                        }
                    }
                }
            }
        }
    }
    assert!(cases > 100, "only {cases} cases");
    assert!(
        failures.is_empty(),
        "{} of {cases}:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn every_numeric_key_refuses_an_extreme_value_by_name_or_runs_with_it() {
    let mut failures = Vec::new();
    let (mut cases, mut accepted) = (0, 0);
    for file in scenes() {
        let dir = file.parent().unwrap().to_path_buf();
        let original: toml::Value = toml::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        let mut paths = Vec::new();
        numbers(&original, &mut Vec::new(), &mut paths);
        for path in &paths {
            let key = shown(path);
            let last = last_key(path);
            for value in extremes(at(&mut original.clone(), path)) {
                let mut mutated = original.clone();
                *at(&mut mutated, path) = value.clone();
                let text = toml::to_string(&mutated).unwrap();
                cases += 1;
                let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match accept(&text, &dir) {
                    // Refused naming the key, or the key the value makes wrong beside it (a
                    // cell size that leaves a body outside the grid names the body's geometry,
                    // a time step too short names `time.end`), or the particle it makes wrong.
                    Err(message) => (!names_what_is_wrong(&message, &last))
                        .then(|| format!("refused without naming `{last}` or what it makes wrong: {message}")),
                    Ok(mut sim) => {
                        accepted += 1;
                        first_steps(&mut sim, 3).map(|what| format!("accepted, then {what}"))
                    }
                }));
                match outcome {
                    Err(_) => failures.push(format!("{}: `{key}` = {value}: panicked", file.display())),
                    Ok(Some(what)) => failures.push(format!("{}: `{key}` = {value}: {what}", file.display())),
                    Ok(None) => {}
                }
            }
        }
    }
    eprintln!("{cases} cases, {accepted} accepted");
    assert!(cases > 1000 && accepted > 100, "{cases} cases, {accepted} accepted");
    assert!(
        failures.is_empty(),
        "{} of {cases}:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn no_numeric_key_of_a_study_spec_accepts_nan_infinity_or_a_string() {
    use sparse_mpm_study::StudySpec;
    // The default spec written out in full: every key a spec has, each list with its values.
    let text = toml::to_string(&StudySpec::default()).unwrap();
    let original: toml::Value = toml::from_str(&text).unwrap();
    assert!(StudySpec::from_toml_str(&text).is_ok(), "the default spec reads back");
    let mut paths = Vec::new();
    numbers(&original, &mut Vec::new(), &mut paths);
    assert!(paths.len() > 20, "only {} numbers in the default spec", paths.len());
    let mut failures = Vec::new();
    for path in &paths {
        let key = shown(path);
        let last = last_key(path);
        for bad in meaningless() {
            let mut mutated = original.clone();
            *at(&mut mutated, path) = bad.clone();
            match StudySpec::from_toml_str(&toml::to_string(&mutated).unwrap()) {
                Ok(_) => failures.push(format!("`{key}` = {bad} accepted")),
                Err(e) if !e.to_string().contains(&last) => {
                    failures.push(format!("`{key}` = {bad}: the message does not name `{last}`: {e}"))
                }
                Err(_) => {}
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {}:\n{}",
        failures.len(),
        4 * paths.len(),
        failures.join("\n")
    );
}

/// The extremes of [`extremes`] for every number of the study spec: refused naming the key, or
/// accepted with a meaning docs/verification.md gives (a mass tolerance of 0 or a tiny one);
/// never a Courant number whose runs would not end (10⁻³⁰ was accepted), never a panic.
#[test]
fn every_number_of_a_study_spec_refuses_an_extreme_value_by_name_or_has_a_meaning() {
    use sparse_mpm_study::StudySpec;
    let text = toml::to_string(&StudySpec::default()).unwrap();
    let original: toml::Value = toml::from_str(&text).unwrap();
    let mut paths = Vec::new();
    numbers(&original, &mut Vec::new(), &mut paths);
    let (mut failures, mut cases, mut accepted) = (Vec::new(), 0, 0);
    for path in &paths {
        let (key, last) = (shown(path), last_key(path));
        for value in extremes(at(&mut original.clone(), path)) {
            let mut mutated = original.clone();
            *at(&mut mutated, path) = value.clone();
            cases += 1;
            let outcome = std::panic::catch_unwind(|| {
                match StudySpec::from_toml_str(&toml::to_string(&mutated).unwrap()) {
                    Err(e) if !e.to_string().contains(&last) => Some(format!("refused without naming `{last}`: {e}")),
                    Err(_) => None,
                    Ok(spec) => {
                        // The runs' count grows as 1/cfl and the cell counts: an accepted value
                        // leaves the spec at most what the default's bounds allow.
                        (spec.cfl < sparse_mpm_study::MIN_STUDY_CFL).then(|| format!("cfl {} accepted", spec.cfl))
                    }
                }
            });
            match outcome {
                Err(_) => failures.push(format!("`{key}` = {value}: panicked")),
                Ok(Some(what)) => failures.push(format!("`{key}` = {value}: {what}")),
                Ok(None) => {
                    accepted += usize::from(StudySpec::from_toml_str(&toml::to_string(&mutated).unwrap()).is_ok())
                }
            }
        }
    }
    assert!(cases > 100, "only {cases} cases");
    assert!(
        failures.is_empty(),
        "{} of {cases} ({accepted} accepted):\n{}",
        failures.len(),
        failures.join("\n")
    );
}
