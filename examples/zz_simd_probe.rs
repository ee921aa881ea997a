use sparse_mpm::bench::{problem, BenchSpec};
use std::time::Instant;

#[inline(always)]
fn body<const S: usize>(ops: &sparse_mpm::Operators, p: &sparse_mpm::Particles, acc: &mut [Vec<f64>; 5], lo: usize) {
    for k in 0..p.len() {
        let m = p.mass[k];
        let (mvx, mvy) = (m * p.vx[k], m * p.vy[k]);
        let (mbx, mby) = (m * p.bx[k], m * p.by[k]);
        let v = p.volume[k];
        let (vsxx, vsyy, vsxy) = (v * p.sxx[k], v * p.syy[k], v * p.sxy[k]);
        let c = [
            p.affine_xx[k] / 0.25e-6,
            p.affine_xy[k] / 0.25e-6,
            p.affine_yx[k] / 0.25e-6,
            p.affine_yy[k] / 0.25e-6,
        ];
        let st = ops.stencil::<S>(k);
        let (dxs, dys) = st.offsets(p.x[k], p.y[k]);
        for b in 0..S {
            let (start, n, gx, gy) = st.row(b);
            let s0 = start - lo;
            let dy = dys[b];
            let [a0, a1, a2, a3, a4] = acc;
            let (r0, r1, r2, r3, r4) = (
                &mut a0[s0..s0 + S],
                &mut a1[s0..s0 + S],
                &mut a2[s0..s0 + S],
                &mut a3[s0..s0 + S],
                &mut a4[s0..s0 + S],
            );
            for a in 0..S {
                let (ax, ay) = (n[a] * (c[0] * dxs[a] + c[1] * dy), n[a] * (c[2] * dxs[a] + c[3] * dy));
                r0[a] += n[a] * m;
                r1[a] += n[a] * mvx + m * ax;
                r2[a] += n[a] * mvy + m * ay;
                r3[a] += n[a] * mbx - (gx[a] * vsxx + gy[a] * vsxy);
                r4[a] += n[a] * mby - (gx[a] * vsxy + gy[a] * vsyy);
            }
        }
    }
}

#[inline(always)]
fn body_aos<const S: usize>(ops: &sparse_mpm::Operators, p: &sparse_mpm::Particles, acc: &mut [[f64; 5]], lo: usize) {
    for k in 0..p.len() {
        let m = p.mass[k];
        let (mvx, mvy) = (m * p.vx[k], m * p.vy[k]);
        let (mbx, mby) = (m * p.bx[k], m * p.by[k]);
        let v = p.volume[k];
        let (vsxx, vsyy, vsxy) = (v * p.sxx[k], v * p.syy[k], v * p.sxy[k]);
        let c = [
            p.affine_xx[k] / 0.25e-6,
            p.affine_xy[k] / 0.25e-6,
            p.affine_yx[k] / 0.25e-6,
            p.affine_yy[k] / 0.25e-6,
        ];
        let st = ops.stencil::<S>(k);
        let (dxs, dys) = st.offsets(p.x[k], p.y[k]);
        for b in 0..S {
            let (start, n, gx, gy) = st.row(b);
            let s0 = start - lo;
            let dy = dys[b];
            let r = &mut acc[s0..s0 + S];
            for a in 0..S {
                let (ax, ay) = (n[a] * (c[0] * dxs[a] + c[1] * dy), n[a] * (c[2] * dxs[a] + c[3] * dy));
                let r = &mut r[a];
                r[0] += n[a] * m;
                r[1] += n[a] * mvx + m * ax;
                r[2] += n[a] * mvy + m * ay;
                r[3] += n[a] * mbx - (gx[a] * vsxx + gy[a] * vsxy);
                r[4] += n[a] * mby - (gx[a] * vsxy + gy[a] * vsyy);
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn body_avx2(ops: &sparse_mpm::Operators, p: &sparse_mpm::Particles, acc: &mut [Vec<f64>; 5], lo: usize) {
    body::<3>(ops, p, acc, lo)
}
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn body_aos_avx2(ops: &sparse_mpm::Operators, p: &sparse_mpm::Particles, acc: &mut [[f64; 5]], lo: usize) {
    body_aos::<3>(ops, p, acc, lo)
}
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
unsafe fn body_aos_avx512(ops: &sparse_mpm::Operators, p: &sparse_mpm::Particles, acc: &mut [[f64; 5]], lo: usize) {
    body_aos::<3>(ops, p, acc, lo)
}

fn main() {
    let n: usize = 1048576;
    let spec = BenchSpec::default();
    let mut sim = problem(n, &spec).unwrap();
    sim.step().unwrap();
    sim.step().unwrap();
    let ops = sim.operators().clone();
    let p = sim.particles().clone();
    let span = ops.node_span();
    let mut soa: [Vec<f64>; 5] = std::array::from_fn(|_| vec![0.0; span.len() + 8]);
    let mut aos = vec![[0.0f64; 5]; span.len() + 8];
    let time = |name: &str, f: &mut dyn FnMut()| {
        for _ in 0..2 {
            let t = Instant::now();
            for _ in 0..10 {
                f();
            }
            println!(
                "{name} {:.2} ns/particle",
                t.elapsed().as_secs_f64() / 10.0 / n as f64 * 1e9
            );
        }
    };
    time("soa", &mut || {
        for a in soa.iter_mut() {
            a.fill(0.0);
        }
        body::<3>(&ops, &p, &mut soa, span.start)
    });
    time("aos", &mut || {
        aos.fill([0.0; 5]);
        body_aos::<3>(&ops, &p, &mut aos, span.start)
    });
    time("soa avx2", &mut || {
        for a in soa.iter_mut() {
            a.fill(0.0);
        }
        unsafe { body_avx2(&ops, &p, &mut soa, span.start) }
    });
    time("aos avx2", &mut || {
        aos.fill([0.0; 5]);
        unsafe { body_aos_avx2(&ops, &p, &mut aos, span.start) }
    });
    time("aos avx512", &mut || {
        aos.fill([0.0; 5]);
        unsafe { body_aos_avx512(&ops, &p, &mut aos, span.start) }
    });
}
