use sparse_mpm::shape::ShapeFunction;
use sparse_mpm_study::verification::column::Column;
use sparse_mpm_study::verification::Choices;
fn main() {
    let column = Column::SMALL_STRAIN;
    let cells: usize = std::env::args().nth(1).unwrap().parse().unwrap();
    let shape: ShapeFunction = std::env::args().nth(2).unwrap().parse().unwrap();
    let choices = Choices { shape, ..Choices::default() };
    let mut sim = column.simulation(cells, &choices).unwrap();
    let initial = sparse_mpm_study::verification::column::initial_heights(sim.particles());
    for _ in 0..column.load_steps { sim.step().unwrap(); }
    let p = sim.particles();
    let mut rows: Vec<(f64, f64, f64, f64)> = (0..p.len()).map(|k| (initial[p.id[k]], p.x[k], p.syy[k], column.stress_exact(initial[p.id[k]]))).collect();
    rows.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    for r in rows { println!("{:.4} {:.4} {:.2} {:.2} {:.3e}", r.0, r.1, r.2, r.3, (r.2 - r.3) / 40000.0); }
}
