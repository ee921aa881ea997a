//! Every scheme and shape choice has one text form, read and written by `FromStr`, `Display`
//! and serde alike; scene files may also use the table form.

use std::fmt::Display;
use std::str::FromStr;

use serde::{de::DeserializeOwned, Deserialize, Serialize};
use sparse_mpm::mass::{MassScheme, SingularityPolicy, Stabilization};
use sparse_mpm::simulation::{Transfer, UpdateScheme};
use sparse_mpm::step::PositionUpdate;
use sparse_mpm::ShapeFunction;

#[derive(Debug, Serialize, Deserialize)]
struct Holder<T> {
    value: T,
}

/// `value` written as text reads back to itself through `FromStr` and through TOML.
fn round_trips<T>(value: T)
where
    T: Display + FromStr<Err = String> + PartialEq + std::fmt::Debug + Serialize + DeserializeOwned + Copy,
{
    let text = value.to_string();
    assert_eq!(text.parse::<T>().unwrap(), value, "{text}");
    let toml = toml::to_string(&Holder { value }).unwrap();
    assert_eq!(toml.trim(), format!("value = \"{text}\""), "serde writes the text");
    let back: Holder<T> = toml::from_str(&toml).unwrap();
    assert_eq!(back.value, value, "{toml}");
}

fn from_toml<T: DeserializeOwned>(value: &str) -> T {
    let holder: Holder<T> = toml::from_str(&format!("value = {value}")).unwrap();
    holder.value
}

#[test]
fn every_choice_reads_back_from_its_text() {
    for m in [
        MassScheme::Lumped,
        MassScheme::Consistent,
        MassScheme::Blended { gamma: 13.0 / 18.0 },
        MassScheme::TruncatedSeries { k: 8 },
        MassScheme::Iterative {
            tolerance: 1e-10,
            max_iterations: 500,
        },
        MassScheme::Iterative {
            tolerance: 3e-7,
            max_iterations: 25_000_000,
        },
    ] {
        round_trips(m);
    }
    for t in [
        Transfer::Pic,
        Transfer::Flip,
        Transfer::Apic,
        Transfer::Blend { flip: 0.99 },
        Transfer::Xpic { k: 3 },
        Transfer::Fmpm { k: 2 },
    ] {
        round_trips(t);
    }
    for s in [
        ShapeFunction::Linear,
        ShapeFunction::Gimp { half_width: 0.25 },
        ShapeFunction::QuadraticBSpline,
        ShapeFunction::CubicBSpline,
    ] {
        round_trips(s);
    }
    for s in [
        Stabilization::None,
        Stabilization::GhostPenalty { gamma: 0.1 },
        Stabilization::PartialLumping { threshold: 0.5 },
    ] {
        round_trips(s);
    }
    for p in [
        SingularityPolicy::Error,
        SingularityPolicy::FallbackToLumped,
        SingularityPolicy::Regularize { epsilon: 0.01 },
    ] {
        round_trips(p);
    }
    for u in [UpdateScheme::Usf, UpdateScheme::Usl, UpdateScheme::Musl] {
        assert_eq!(u.to_string().parse::<UpdateScheme>().unwrap(), u);
    }
    for p in [PositionUpdate::GridVelocity, PositionUpdate::Trapezoidal] {
        assert_eq!(p.to_string().parse::<PositionUpdate>().unwrap(), p);
    }
}

#[test]
fn the_text_is_the_one_the_command_line_and_the_labels_use() {
    assert_eq!(MassScheme::TruncatedSeries { k: 8 }.to_string(), "series:8");
    assert_eq!(
        MassScheme::Iterative {
            tolerance: 1e-10,
            max_iterations: 500
        }
        .to_string(),
        "cg:1e-10"
    );
    assert_eq!(
        format!("{:#}", MassScheme::Blended { gamma: 13.0 / 18.0 }),
        "blended:0.722222"
    );
    assert_eq!(ShapeFunction::Gimp { half_width: 0.25 }.to_string(), "gimp:0.25");
    assert_eq!(Transfer::Xpic { k: 3 }.to_string(), "xpic:3");
    assert_eq!(format!("{:<12}|", MassScheme::Lumped), "lumped      |");
    // Short and older spellings read as the same choices.
    assert_eq!(
        "quadratic".parse::<ShapeFunction>().unwrap(),
        ShapeFunction::QuadraticBSpline
    );
    assert_eq!("cg".parse::<MassScheme>().unwrap(), "cg:1e-10:500".parse().unwrap());
    assert_eq!(
        "series(3)".parse::<MassScheme>().unwrap(),
        MassScheme::TruncatedSeries { k: 3 }
    );
    assert_eq!(
        "gimp".parse::<ShapeFunction>().unwrap(),
        ShapeFunction::Gimp { half_width: 0.25 }
    );
}

#[test]
fn scene_tables_read_as_the_same_choices() {
    let m: MassScheme = from_toml("{ truncated_series = { k = 3 } }");
    assert_eq!(m, MassScheme::TruncatedSeries { k: 3 });
    let m: MassScheme = from_toml("{ series = { k = 3 } }");
    assert_eq!(m, MassScheme::TruncatedSeries { k: 3 });
    let m: MassScheme = from_toml("{ iterative = { tolerance = 1e-8, max_iterations = 100 } }");
    assert_eq!(
        m,
        MassScheme::Iterative {
            tolerance: 1e-8,
            max_iterations: 100
        }
    );
    let t: Transfer = from_toml("{ blend = { flip = 0.99 } }");
    assert_eq!(t, Transfer::Blend { flip: 0.99 });
    let s: ShapeFunction = from_toml("{ gimp = { half_width = 0.3 } }");
    assert_eq!(s, ShapeFunction::Gimp { half_width: 0.3 });
    let s: Stabilization = from_toml("{ ghost_penalty = { gamma = 0.2 } }");
    assert_eq!(s, Stabilization::GhostPenalty { gamma: 0.2 });
    let p: SingularityPolicy = from_toml("{ regularize = { epsilon = 0.1 } }");
    assert_eq!(p, SingularityPolicy::Regularize { epsilon: 0.1 });
}

/// The table form is read by each choice's parameter names into its text: parameters may come
/// in any order, an omitted one takes its default (also before one that is given), and a key
/// the choice does not take is an error naming it and the keys it takes.
#[test]
fn table_forms_take_parameters_by_name_with_their_defaults_and_refuse_unknown_keys() {
    let m: MassScheme = from_toml("{ cg = { max_iterations = 300 } }");
    assert_eq!(
        m,
        MassScheme::Iterative {
            tolerance: sparse_mpm::mass::DEFAULT_CG_TOLERANCE,
            max_iterations: 300
        }
    );
    let m: MassScheme = from_toml("{ cg = { max_iterations = 40, tolerance = 1e-6 } }");
    assert_eq!(
        m,
        MassScheme::Iterative {
            tolerance: 1e-6,
            max_iterations: 40
        }
    );
    let m: MassScheme = from_toml("{ lumped = {} }");
    assert_eq!(m, MassScheme::Lumped);
    let s: Stabilization = from_toml("{ linear_extension = { threshold = 0.4 } }");
    assert_eq!(s, "linear_extension::0.4".parse::<Stabilization>().unwrap());
    let s: ShapeFunction = from_toml("{ gimp = {} }");
    assert_eq!(s, ShapeFunction::Gimp { half_width: 0.25 });
    let read = |text: &str| {
        toml::from_str::<Holder<MassScheme>>(&format!("value = {text}"))
            .unwrap_err()
            .to_string()
    };
    let e = read("{ cg = { tol = 1e-6 } }");
    assert!(
        e.contains("unknown key `tol`") && e.contains("tolerance, max_iterations"),
        "{e}"
    );
    let e = read("{ lumped = { gamma = 0.5 } }");
    assert!(e.contains("unknown key `gamma`") && e.contains("no parameters"), "{e}");
    let e = read("{ blended = {} }");
    assert!(e.contains("needs a parameter"), "{e}");
    let e = read("{ blended = { gamma = 0.5 }, series = { k = 2 } }");
    assert!(e.contains("one choice per table"), "{e}");
    let e = read("{ bogus = { k = 2 } }");
    assert!(e.contains("unknown mass scheme"), "{e}");
}

#[test]
fn unknown_names_and_bad_parameters_are_errors_that_quote_the_text() {
    let e = "bogus".parse::<MassScheme>().unwrap_err();
    assert!(e.contains("`bogus`") && e.contains("series:k"), "{e}");
    let e = "blended".parse::<MassScheme>().unwrap_err();
    assert!(e.contains("needs a parameter"), "{e}");
    let e = "series:x".parse::<MassScheme>().unwrap_err();
    assert!(e.contains("`x` is not a valid parameter"), "{e}");
    let e = "lumped:2".parse::<MassScheme>().unwrap_err();
    assert!(e.contains("takes no parameter"), "{e}");
    let e = "cubic:1".parse::<ShapeFunction>().unwrap_err();
    assert!(e.contains("takes no parameter"), "{e}");
    let e = toml::from_str::<Holder<Transfer>>("value = \"flop\"")
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown transfer `flop`"), "{e}");
}
