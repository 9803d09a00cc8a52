"""Linear stability (section 5) against the nonlinear solver.

    python examples/growth_rate.py [--cells 64]

Runs the verification problem ``growth`` (tiseg/data/problems/growth.toml, the one `tiseg bench
accuracy` scores): the steady uniform flow h0 = 2 mm, phi0 = 0.8, nu = 0.01 perturbed with its
most unstable normal mode (5.19) at k = 0.2399, whose measured growth rate is compared with
sigma_R from (5.20)-(5.21).
"""

import argparse

import tiseg
from tiseg.post.problems import load_problem
from tiseg.run.simulation import Simulation


GALLERY = ["--cells", "32"]  # the docs gallery run


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=64, help="cells per wavelength")
    a = ap.parse_args(argv)
    tiseg.init("cpu", "f64")
    problem = load_problem("growth")
    sim = Simulation(problem.build(a.cells))
    # the amplitude of the mode over 12 h0/u0, and an exponential fitted to its later part
    rate, _ = problem.score(problem.run(sim), sim.scene)
    theory = problem.solution(sim.scene)
    print(
        f"growth rate: simulation {rate:.4f} 1/s, linear theory {theory:.4f} 1/s "
        f"(relative difference {abs(rate - theory) / theory:.1e})"
    )
    return rate, theory


if __name__ == "__main__":
    main()
