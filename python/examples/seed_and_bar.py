"""The worked problem's matrices, and consistent against lumped mass on the vibrating bar.

Run from the repository root after `pip install ./python`:

    python python/examples/seed_and_bar.py [--out bar_mass.png]

Part 1 builds the seed problem's grid from its node coordinates (y-fastest node order, as
the assignment numbers them), assembles N = [S_I(x_p)] and prints N, the consistent mass
M = N diag(m) N^T and the lumped mass m_L = N m (the row sums of M).

Part 2 runs scenes/vibrating_bar.toml with the lumped and with the consistent mass and
compares the centre-of-mass velocity with the exact (0.2/pi) cos(pi t / 5). The plot is
saved to --out if Matplotlib is installed (pip install './python[plot]'): the velocities
against time, where the three curves lie on top of each other at this scale, and below them
the error |v - v_exact| against time on a log scale, where the two mass schemes separate.
"""

import argparse
import pathlib

import numpy as np

import sparse_mpm as mpm

ROOT = pathlib.Path(__file__).resolve().parents[2]


def seed_problem():
    x_g = [0.0, 0.0, 1.0, 1.0, 2.0, 2.0]
    y_g = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0]
    grid = mpm.Grid.from_node_coordinates(x_g, y_g)
    particles = mpm.Particles([1.2, 1.7, 1.3, 1.8], [0.75, 0.81, 0.26, 0.24], mass=[1.0] * 4, volume=[2.0] * 4)
    ops = mpm.Operators.assemble(grid, particles, shape="linear")
    m = particles.mass
    N = ops.N
    M = mpm.consistent_mass(ops, m)
    m_l = mpm.lumped_mass(ops, m)
    np.set_printoptions(precision=4, suppress=True)
    print(f"{grid}  (node order {grid.node_order})")
    print("N (nodes x particles):\n", N.toarray())
    print("Gx:\n", ops.Gx.toarray())
    print("M = N diag(m) N^T:\n", M.toarray())
    print("m_L = N m:", m_l)
    print("row sums of M - m_L:", np.asarray(M.sum(axis=1)) - m_l)


def bar(scheme):
    text = (ROOT / "scenes" / "vibrating_bar.toml").read_text()
    lumped = 'mass = { velocity = "lumped", acceleration = "lumped" }'
    assert lumped in text
    text = text.replace(lumped, f'mass = {{ velocity = "{scheme}", acceleration = "{scheme}" }}')
    sim = mpm.Simulation.from_toml(text, base_dir=ROOT / "scenes")
    report = sim.run()
    return report["time"], report["momentum_x"] / report["mass"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bar_mass.png", help="where to save the plot")
    args = parser.parse_args()

    seed_problem()

    curves = {scheme: bar(scheme) for scheme in ("lumped", "consistent")}
    exact = lambda t: 0.2 / np.pi * np.cos(np.pi * t / 5.0)  # noqa: E731
    print("\nvibrating bar, centre-of-mass velocity against (0.2/pi) cos(pi t/5):")
    for scheme, (t, v) in curves.items():
        print(f"  {scheme:10s} {len(t):4d} steps, largest error {np.abs(v - exact(t)).max():.3e}")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("Matplotlib is not installed: no plot")
        return
    fig, (ax, err) = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    t = np.linspace(0.0, 20.0, 400)
    ax.plot(t, exact(t), "k-", lw=1, label="exact")
    styles = {"lumped": "--", "consistent": ":"}
    for scheme, (t_s, v) in curves.items():
        ax.plot(t_s, v, styles[scheme], lw=1.5, label=f"{scheme} mass")
        # The error against the exact solution, floored so that an exact zero stays on the plot.
        err.semilogy(t_s, np.maximum(np.abs(v - exact(t_s)), 1e-16), styles[scheme], lw=1.5, label=f"{scheme} mass")
    ax.set_ylabel("centre-of-mass velocity")
    ax.set_title("Vibrating bar: consistent against lumped mass")
    ax.legend()
    err.set_xlabel("time")
    err.set_ylabel("|v - v_exact|")
    err.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"plot saved to {args.out}")


if __name__ == "__main__":
    main()
