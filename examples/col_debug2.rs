use sparse_mpm::shape::ShapeFunction;
use sparse_mpm_study::verification::column::Column;
use sparse_mpm_study::verification::Choices;
fn main() {
    let shape: ShapeFunction = std::env::args().nth(1).unwrap().parse().unwrap();
    let ls: usize = std::env::args().nth(2).unwrap().parse().unwrap();
    let ppc: usize = std::env::args().nth(3).unwrap().parse().unwrap();
    let e: f64 = std::env::args().nth(4).unwrap().parse().unwrap();
    let column = Column {
        load_steps: ls,
        youngs_modulus: e,
        ..Column::SMALL_STRAIN
    };
    for cells in [16, 32, 64, 128, 256] {
        let choices = Choices {
            shape,
            particles_per_cell: ppc,
            ..Choices::default()
        };
        let o = column.run(cells, &choices).unwrap();
        println!("{cells} {:.3e}", o.metric("stress_error").unwrap());
    }
}
