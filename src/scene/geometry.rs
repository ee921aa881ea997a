//! A body's shape: rectangles, disks, annuli and polygons, their unions and differences,
//! rotated and translated; or a particle file.
//!
//! ```toml
//! geometry = { annulus = { center = [0.0, 0.0], inner_radius = 0.3, outer_radius = 0.4 } }
//! geometry = { polygon = { vertices = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]] } }
//! geometry = { union = [{ rectangle = { min = [0, 0], max = [1, 0.2] } }, { disk = { center = [1, 0.1], radius = 0.2 } }] }
//! geometry = { difference = { base = { rectangle = { min = [0, 0], max = [1, 1] } }, minus = [{ disk = { center = [0.5, 0.5], radius = 0.2 } }] } }
//! geometry = { transformed = { shape = { rectangle = { min = [0, 0], max = [1, 0.2] } }, angle = 30.0, about = [0, 0], translate = [0.5, 0] } }
//! ```
//!
//! A point belongs to a shape when it lies strictly inside it (a polygon by the even–odd rule,
//! so a self-crossing outline alternates in and out). `transformed` maps the shape by
//! `x ↦ R(angle) (x − about) + about + translate` (`angle` in degrees, counter-clockwise;
//! `about` defaults to the centre of the shape's bounding box).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

/// The deepest nesting of unions, differences and transforms a scene may write.
pub const MAX_GEOMETRY_DEPTH: usize = 16;

/// The most shapes one body's geometry may hold, a polygon's vertices counted as shapes: each
/// particle's test visits every one of them.
pub const MAX_GEOMETRY_PARTS: usize = 4096;

/// Where a body's particles are.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Geometry {
    /// The axis-aligned rectangle `[min, max]`.
    Rectangle {
        /// Lower-left corner.
        #[serde(deserialize_with = "crate::pairs::exactly_two")]
        min: [f64; 2],
        /// Upper-right corner.
        #[serde(deserialize_with = "crate::pairs::exactly_two")]
        max: [f64; 2],
    },
    /// The disk `|x − center| < radius`.
    Disk {
        /// Centre.
        #[serde(deserialize_with = "crate::pairs::exactly_two")]
        center: [f64; 2],
        /// Radius.
        radius: f64,
    },
    /// The ring `inner_radius < |x − center| < outer_radius`.
    Annulus {
        /// Centre.
        #[serde(deserialize_with = "crate::pairs::exactly_two")]
        center: [f64; 2],
        /// Radius of the hole (0: a disk).
        inner_radius: f64,
        /// Outer radius.
        outer_radius: f64,
    },
    /// The polygon with these vertices in order (either orientation), closed from the last
    /// back to the first.
    Polygon {
        /// At least three vertices `[x, y]`.
        #[serde(deserialize_with = "crate::pairs::list_of_pairs")]
        vertices: Vec<[f64; 2]>,
    },
    /// The points inside any of the shapes.
    Union(Vec<Geometry>),
    /// The points of `base` inside none of `minus`.
    Difference {
        /// The shape cut from.
        base: Box<Geometry>,
        /// The shapes cut out.
        minus: Vec<Geometry>,
    },
    /// `shape` rotated by `angle` degrees (counter-clockwise) about `about`, then translated by
    /// `translate`.
    Transformed {
        /// The shape moved.
        shape: Box<Geometry>,
        /// Rotation in degrees, counter-clockwise.
        #[serde(default)]
        angle: f64,
        /// The centre of the rotation (default: the centre of the shape's bounding box).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        #[serde(deserialize_with = "crate::pairs::optional_pair")]
        about: Option<[f64; 2]>,
        /// Translation after the rotation.
        #[serde(default)]
        #[serde(deserialize_with = "crate::pairs::exactly_two")]
        translate: [f64; 2],
    },
    /// Particles listed in a CSV file (columns `x`, `y`, `volume`, optionally `vx`, `vy`, `mass`,
    /// `sxx`, `syy`, `sxy`).
    File(PathBuf),
}

/// The affine map `x ↦ A x + b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine {
    /// The linear part, row by row.
    pub a: [[f64; 2]; 2],
    /// The translation.
    pub b: [f64; 2],
}

impl Affine {
    /// The identity.
    pub const IDENTITY: Affine = Affine {
        a: [[1.0, 0.0], [0.0, 1.0]],
        b: [0.0, 0.0],
    };

    /// `x ↦ R(θ)(x − c) + c + t`, θ in degrees. Multiples of 90° are exact.
    pub fn rotation(angle_degrees: f64, about: [f64; 2], translate: [f64; 2]) -> Affine {
        let (s, c) = exact_sin_cos(angle_degrees);
        let a = [[c, -s], [s, c]];
        // b = c + t − R c
        let b = [
            about[0] + translate[0] - (a[0][0] * about[0] + a[0][1] * about[1]),
            about[1] + translate[1] - (a[1][0] * about[0] + a[1][1] * about[1]),
        ];
        Affine { a, b }
    }

    /// `A x + b`.
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        [
            self.a[0][0] * p[0] + self.a[0][1] * p[1] + self.b[0],
            self.a[1][0] * p[0] + self.a[1][1] * p[1] + self.b[1],
        ]
    }

    /// `self ∘ inner`: `x ↦ self(inner(x))`.
    pub fn after(&self, inner: &Affine) -> Affine {
        let (p, q) = (&self.a, &inner.a);
        let a = [
            [
                p[0][0] * q[0][0] + p[0][1] * q[1][0],
                p[0][0] * q[0][1] + p[0][1] * q[1][1],
            ],
            [
                p[1][0] * q[0][0] + p[1][1] * q[1][0],
                p[1][0] * q[0][1] + p[1][1] * q[1][1],
            ],
        ];
        let pb = self.apply(inner.b);
        Affine { a, b: pb }
    }

    /// The inverse of a rotation and translation (`Aᵀ (x − b)`; `A` orthogonal).
    fn inverse_rigid(&self, p: [f64; 2]) -> [f64; 2] {
        let d = [p[0] - self.b[0], p[1] - self.b[1]];
        [
            self.a[0][0] * d[0] + self.a[1][0] * d[1],
            self.a[0][1] * d[0] + self.a[1][1] * d[1],
        ]
    }
}

/// `(sin θ, cos θ)` of `θ` in degrees, exact at multiples of 90°.
fn exact_sin_cos(degrees: f64) -> (f64, f64) {
    let turns = degrees.rem_euclid(360.0);
    if turns % 90.0 == 0.0 {
        match (turns / 90.0) as u8 {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            _ => (-1.0, 0.0),
        }
    } else {
        turns.to_radians().sin_cos()
    }
}

/// A bounding box `(lo, hi)`.
pub type BoundingBox = ([f64; 2], [f64; 2]);

fn join(a: Option<BoundingBox>, b: Option<BoundingBox>) -> Option<BoundingBox> {
    match (a, b) {
        (Some(a), Some(b)) => Some((
            [a.0[0].min(b.0[0]), a.0[1].min(b.0[1])],
            [a.1[0].max(b.1[0]), a.1[1].max(b.1[1])],
        )),
        (a, None) => a,
        (None, b) => b,
    }
}

fn box_of(points: impl IntoIterator<Item = [f64; 2]>) -> Option<BoundingBox> {
    points.into_iter().fold(None, |acc, p| join(acc, Some((p, p))))
}

impl Geometry {
    /// The shape's name as a scene writes it (`rectangle`, `union`, …).
    pub fn kind(&self) -> &'static str {
        match self {
            Geometry::Rectangle { .. } => "rectangle",
            Geometry::Disk { .. } => "disk",
            Geometry::Annulus { .. } => "annulus",
            Geometry::Polygon { .. } => "polygon",
            Geometry::Union(_) => "union",
            Geometry::Difference { .. } => "difference",
            Geometry::Transformed { .. } => "transformed",
            Geometry::File(_) => "file",
        }
    }

    /// Whether `(x, y)` lies strictly inside the shape (a particle file contains nothing).
    pub fn contains(&self, x: f64, y: f64) -> bool {
        match self {
            Geometry::Rectangle { min, max } => x > min[0] && x < max[0] && y > min[1] && y < max[1],
            Geometry::Disk { center, radius } => (x - center[0]).hypot(y - center[1]) < *radius,
            Geometry::Annulus {
                center,
                inner_radius,
                outer_radius,
            } => {
                let r = (x - center[0]).hypot(y - center[1]);
                r > *inner_radius && r < *outer_radius
            }
            Geometry::Polygon { vertices } => polygon_contains(vertices, x, y),
            Geometry::Union(parts) => parts.iter().any(|g| g.contains(x, y)),
            Geometry::Difference { base, minus } => base.contains(x, y) && !minus.iter().any(|g| g.contains(x, y)),
            Geometry::Transformed { shape, .. } => {
                let map = self.own_map().unwrap_or(Affine::IDENTITY);
                let [u, v] = map.inverse_rigid([x, y]);
                shape.contains(u, v)
            }
            Geometry::File(_) => false,
        }
    }

    /// The map of a `transformed` shape (with `about` defaulted to its shape's box centre);
    /// `None` for other shapes.
    pub fn own_map(&self) -> Option<Affine> {
        let Geometry::Transformed {
            shape,
            angle,
            about,
            translate,
        } = self
        else {
            return None;
        };
        let centre = about.or_else(|| {
            shape
                .bounding_box()
                .map(|(lo, hi)| [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])])
        })?;
        Some(Affine::rotation(*angle, centre, *translate))
    }

    /// The smallest axis-aligned box holding the shape; `None` for a particle file.
    pub fn bounding_box(&self) -> Option<BoundingBox> {
        self.mapped_box(&Affine::IDENTITY)
    }

    /// The box of the shape mapped by `map` (rotation and translation).
    fn mapped_box(&self, map: &Affine) -> Option<BoundingBox> {
        let round = |center: &[f64; 2], r: f64| {
            let c = map.apply(*center);
            Some(([c[0] - r, c[1] - r], [c[0] + r, c[1] + r]))
        };
        match self {
            Geometry::Rectangle { min, max } => {
                box_of([[min[0], min[1]], [max[0], min[1]], [max[0], max[1]], [min[0], max[1]]].map(|p| map.apply(p)))
            }
            Geometry::Disk { center, radius } => round(center, *radius),
            Geometry::Annulus {
                center, outer_radius, ..
            } => round(center, *outer_radius),
            Geometry::Polygon { vertices } => box_of(vertices.iter().map(|&p| map.apply(p))),
            Geometry::Union(parts) => parts.iter().fold(None, |acc, g| join(acc, g.mapped_box(map))),
            Geometry::Difference { base, .. } => base.mapped_box(map),
            Geometry::Transformed { shape, .. } => {
                let own = self.own_map()?;
                shape.mapped_box(&map.after(&own))
            }
            Geometry::File(_) => None,
        }
    }

    /// The exact area of a rectangle, disk, annulus or polygon (the shoelace formula's
    /// `½ |Σ (x_i y_{i+1} − x_{i+1} y_i)|`, which for a self-crossing outline is not the area
    /// the even–odd rule fills), and of a transformed one; `None` for unions, differences and
    /// particle files.
    pub fn area(&self) -> Option<f64> {
        use std::f64::consts::PI;
        match self {
            Geometry::Rectangle { min, max } => Some((max[0] - min[0]) * (max[1] - min[1])),
            Geometry::Disk { radius, .. } => Some(PI * radius * radius),
            Geometry::Annulus {
                inner_radius,
                outer_radius,
                ..
            } => Some(PI * (outer_radius * outer_radius - inner_radius * inner_radius)),
            Geometry::Polygon { vertices } => Some(shoelace(vertices).abs()),
            Geometry::Transformed { shape, .. } => shape.area(),
            Geometry::Union(_) | Geometry::Difference { .. } | Geometry::File(_) => None,
        }
    }

    /// The highest point of the shape along `up` (a unit vector), from its outline; `None` for
    /// a particle file.
    pub fn highest(&self, up: [f64; 2]) -> Option<f64> {
        self.highest_mapped(up, &Affine::IDENTITY)
    }

    fn highest_mapped(&self, up: [f64; 2], map: &Affine) -> Option<f64> {
        let h = |p: [f64; 2]| {
            let q = map.apply(p);
            up[0] * q[0] + up[1] * q[1]
        };
        let max =
            |it: &mut dyn Iterator<Item = f64>| it.fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
        match self {
            Geometry::Rectangle { min, max: hi } => {
                max(
                    &mut [[min[0], min[1]], [hi[0], min[1]], [hi[0], hi[1]], [min[0], hi[1]]]
                        .into_iter()
                        .map(h),
                )
            }
            Geometry::Disk { center, radius } => Some(h(*center) + radius),
            Geometry::Annulus {
                center, outer_radius, ..
            } => Some(h(*center) + outer_radius),
            Geometry::Polygon { vertices } => max(&mut vertices.iter().map(|&p| h(p))),
            Geometry::Union(parts) => max(&mut parts.iter().filter_map(|g| g.highest_mapped(up, map))),
            Geometry::Difference { base, .. } => base.highest_mapped(up, map),
            Geometry::Transformed { shape, .. } => {
                let own = self.own_map()?;
                shape.highest_mapped(up, &map.after(&own))
            }
            Geometry::File(_) => None,
        }
    }

    /// The shapes inside this one with their keys below `key` (`key.union[1].disk`), this one
    /// first; stops at [`MAX_GEOMETRY_DEPTH`].
    pub fn parts(&self, key: &str) -> Vec<(String, &Geometry)> {
        let mut out = Vec::new();
        self.collect(key, 0, &mut out);
        out
    }

    fn collect<'a>(&'a self, key: &str, depth: usize, out: &mut Vec<(String, &'a Geometry)>) {
        let here = format!("{key}.{}", self.kind());
        out.push((here.clone(), self));
        if depth >= MAX_GEOMETRY_DEPTH {
            return;
        }
        match self {
            Geometry::Union(parts) => {
                for (i, g) in parts.iter().enumerate() {
                    g.collect(&format!("{here}[{i}]"), depth + 1, out);
                }
            }
            Geometry::Difference { base, minus } => {
                base.collect(&format!("{here}.base"), depth + 1, out);
                for (i, g) in minus.iter().enumerate() {
                    g.collect(&format!("{here}.minus[{i}]"), depth + 1, out);
                }
            }
            Geometry::Transformed { shape, .. } => shape.collect(&format!("{here}.shape"), depth + 1, out),
            _ => {}
        }
    }

    /// The first part (a rectangle, disk, annulus or polygon, or a difference's base) whose box,
    /// where the whole shape puts it, is `outside`: its key below `key`
    /// (`key.union[1].disk`) and that box.
    pub fn first_outside(&self, key: &str, outside: &dyn Fn(BoundingBox) -> bool) -> Option<(String, BoundingBox)> {
        self.outside_mapped(key, &Affine::IDENTITY, outside, 0)
    }

    fn outside_mapped(
        &self,
        key: &str,
        map: &Affine,
        outside: &dyn Fn(BoundingBox) -> bool,
        depth: usize,
    ) -> Option<(String, BoundingBox)> {
        let here = format!("{key}.{}", self.kind());
        if depth > MAX_GEOMETRY_DEPTH {
            return None;
        }
        match self {
            Geometry::Union(parts) => parts
                .iter()
                .enumerate()
                .find_map(|(i, g)| g.outside_mapped(&format!("{here}[{i}]"), map, outside, depth + 1)),
            Geometry::Difference { base, .. } => base.outside_mapped(&format!("{here}.base"), map, outside, depth + 1),
            Geometry::Transformed { shape, .. } => {
                let own = self.own_map()?;
                shape.outside_mapped(&format!("{here}.shape"), &map.after(&own), outside, depth + 1)
            }
            Geometry::File(_) => None,
            leaf => leaf.mapped_box(map).filter(|b| outside(*b)).map(|b| (here, b)),
        }
    }

    /// The shapes the geometry holds, this one included, a polygon's vertices counted too:
    /// the work of one [`Geometry::contains`].
    pub fn size(&self) -> usize {
        match self {
            Geometry::Polygon { vertices } => 1 + vertices.len(),
            Geometry::Union(parts) => 1 + parts.iter().map(Geometry::size).sum::<usize>(),
            Geometry::Difference { base, minus } => 1 + base.size() + minus.iter().map(Geometry::size).sum::<usize>(),
            Geometry::Transformed { shape, .. } => 1 + shape.size(),
            _ => 1,
        }
    }

    /// How deeply unions, differences and transforms nest (0 for a plain shape).
    pub fn depth(&self) -> usize {
        match self {
            Geometry::Union(parts) => 1 + parts.iter().map(Geometry::depth).max().unwrap_or(0),
            Geometry::Difference { base, minus } => {
                1 + minus.iter().map(Geometry::depth).max().unwrap_or(0).max(base.depth())
            }
            Geometry::Transformed { shape, .. } => 1 + shape.depth(),
            _ => 0,
        }
    }
}

/// Twice the signed area over two: `½ Σ (x_i y_{i+1} − x_{i+1} y_i)`.
fn shoelace(v: &[[f64; 2]]) -> f64 {
    let n = v.len();
    0.5 * (0..n)
        .map(|i| {
            let (p, q) = (v[i], v[(i + 1) % n]);
            p[0] * q[1] - q[0] * p[1]
        })
        .sum::<f64>()
}

/// The even–odd rule: a ray to +x crosses the outline an odd number of times.
fn polygon_contains(v: &[[f64; 2]], x: f64, y: f64) -> bool {
    let n = v.len();
    let mut inside = false;
    for i in 0..n {
        let (p, q) = (v[i], v[(i + n - 1) % n]);
        if (p[1] > y) != (q[1] > y) {
            let cross = p[0] + (y - p[1]) * (q[0] - p[0]) / (q[1] - p[1]);
            if x < cross {
                inside = !inside;
            }
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quarter_turn_is_exact_and_maps_the_box() {
        let g = Geometry::Transformed {
            shape: Box::new(Geometry::Rectangle {
                min: [0.0, 0.0],
                max: [2.0, 1.0],
            }),
            angle: 90.0,
            about: Some([0.0, 0.0]),
            translate: [1.0, 0.0],
        };
        assert_eq!(g.bounding_box(), Some(([0.0, 0.0], [1.0, 2.0])));
        assert!(g.contains(0.5, 1.5) && !g.contains(1.5, 0.5));
        assert_eq!(g.area(), Some(2.0));
    }

    #[test]
    fn a_polygon_holds_its_interior_in_either_orientation() {
        let tri = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let rev: Vec<_> = tri.iter().rev().copied().collect();
        for v in [tri, rev] {
            let g = Geometry::Polygon { vertices: v };
            assert!(g.contains(0.2, 0.2) && !g.contains(0.6, 0.6) && !g.contains(-0.1, 0.1));
            assert!((g.area().unwrap() - 0.5).abs() < 1e-15);
        }
    }
}
