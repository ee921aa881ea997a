//! Reading `[x, y]` pairs from scene files strictly (serde's fixed-size arrays take the first
//! two elements of a longer array and drop the rest).

use serde::Deserialize;

/// A two-element array read strictly: exactly two elements of the element type (serde's
/// fixed-size arrays take the first two of a longer TOML array and drop the rest). Every
/// `[x, y]` pair of a scene goes through it; `Scene::validate` then checks that numbers are
/// finite, naming the element (`grid.origin[0]`).
pub(crate) fn exactly_two<'de, D, T>(d: D) -> std::result::Result<[T; 2], D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct Two<T>(std::marker::PhantomData<T>);
    impl<'de, T: Deserialize<'de>> serde::de::Visitor<'de> for Two<T> {
        type Value = [T; 2];
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("an array of length 2")
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> std::result::Result<[T; 2], A::Error> {
            let mut values = Vec::with_capacity(2);
            while let Some(v) = seq.next_element::<T>()? {
                values.push(v);
                if values.len() > 2 {
                    // Count the rest for the message without keeping them.
                    let mut n = values.len();
                    while seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
                        n += 1;
                    }
                    return Err(serde::de::Error::custom(format!(
                        "expected exactly 2 elements `[x, y]`, found {n}"
                    )));
                }
            }
            let n = values.len();
            <[T; 2]>::try_from(values)
                .map_err(|_| serde::de::Error::custom(format!("expected exactly 2 elements `[x, y]`, found {n}")))
        }
    }
    d.deserialize_seq(Two(std::marker::PhantomData))
}

/// [`exactly_two`] of pairs (`[[x0, y0], [x1, y1]]`), optional.
pub(crate) fn optional_two_pairs<'de, D>(d: D) -> std::result::Result<Option<[[f64; 2]; 2]>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    #[derive(Deserialize)]
    struct Pair(#[serde(deserialize_with = "exactly_two")] [f64; 2]);
    let [a, b]: [Pair; 2] = exactly_two(d)?;
    Ok(Some([a.0, b.0]))
}

/// A list of [`exactly_two`] pairs (`[[x0, y0], [x1, y1], …]`), each read strictly.
pub(crate) fn list_of_pairs<'de, D>(d: D) -> std::result::Result<Vec<[f64; 2]>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    #[derive(Deserialize)]
    struct Pair(#[serde(deserialize_with = "exactly_two")] [f64; 2]);
    let v: Vec<Pair> = Vec::deserialize(d)?;
    Ok(v.into_iter().map(|p| p.0).collect())
}

/// [`exactly_two`], optional (`None` when the key is absent, with `#[serde(default)]`).
pub(crate) fn optional_pair<'de, D>(d: D) -> std::result::Result<Option<[f64; 2]>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    exactly_two(d).map(Some)
}
