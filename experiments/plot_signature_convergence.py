"""Convergence plots of the signature measures on straight paths in R^4 (reference secs. 8.2, 8.4).

    .venv/bin/python experiments/plot_signature_convergence.py [--out docs/img]

x(t) = a t and x_eps(t) = (a + eps 1) t on [0, 1]. Writes

* ``signature_group_rate.png``: rho^n(x, x_eps) for a = (0.1, 0.5, 0.0, -0.2), n = 1..8 (Proposition 1:
  O(eps^(1/n))), with the fitted exponents in the legend (cf. the thesis' fig. 8.2);
* ``signature_group_equal.png``: the same with equal slopes a = (0.1, 0.1, 0.1, 0.1): rho^n = 4 eps for every
  n (fig. 8.1); below eps ~ 1e-3 the higher levels hit the rounding floor (n! u |a|^n)^(1/n) of the
  cancelling Chen product (u = 2.2e-16), as the thesis noticed;
* ``signature_log_rate.png``: sigma_*^n and sigma_L^n (Lyndon basis), n = 1..4: O(eps) (figs. 8.3, 8.4).

and prints the fitted log-log slopes (least squares over eps in [1e-6, 1e-3]; [1e-3, 1e-1] for equal slopes).
"""

import argparse
import math
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from blender_shapesig.core.signatures import signatures as sg  # noqa: E402

A_UNEQUAL = np.array([0.1, 0.5, 0.0, -0.2])
A_EQUAL = np.full(4, 0.1)


def line(a):
    return np.vstack([np.zeros(a.size), a])


def curve_of(fn, a, eps, n):
    return np.array([fn(line(a), line(a + e), n) for e in eps])


def slope(eps, values, lo=1e-6, hi=1e-3):
    sel = (eps >= lo) & (eps <= hi)
    return float(np.polyfit(np.log(eps[sel]), np.log(values[sel]), 1)[0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "docs" / "img")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    eps = np.logspace(-7, -0.5, 27)

    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    print("rho^n, a = (0.1, 0.5, 0.0, -0.2): fitted exponent (expected 1/n)")
    for n in range(1, 9):
        v = curve_of(sg.path_group_distance, A_UNEQUAL, eps, n)
        s = slope(eps, v)
        print(f"  n={n}: {s:.4f} (1/n = {1 / n:.4f})")
        ax.loglog(eps, v, marker=".", label=f"n={n}: slope {s:.3f}")
    ax.set_xlabel("eps")
    ax.set_ylabel("rho^n(x, x_eps)")
    ax.set_title("Group metric, a = (0.1, 0.5, 0.0, -0.2): O(eps^(1/n))")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(args.out / "signature_group_rate.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    print("rho^n, a = (0.1, 0.1, 0.1, 0.1): fitted exponent (expected 1)")
    for n in range(1, 9):
        v = curve_of(sg.path_group_distance, A_EQUAL, eps, n)
        s = slope(eps, v, 1e-3, 1e-1)
        ok = eps >= 1e-3
        err = np.max(np.abs(v[ok] - 4 * eps[ok]) / (4 * eps[ok]))
        floor = (math.factorial(n) * np.finfo(float).eps * 0.1 ** n * 2 ** n) ** (1 / n)
        print(f"  n={n}: {s:.4f} over eps in [1e-3, 1e-1]; max |rho - 4 eps| / (4 eps) there = {err:.1e}; "
              f"rounding floor ~ {floor:.1e}")
        # shift each line a little so that they can be told apart (they coincide: rho^n = 4 eps)
        ax.loglog(eps, v * 1.15 ** (n - 1), marker=".", label=f"n={n} (x1.15^{n - 1}): slope {s:.3f}")
    ax.set_xlabel("eps")
    ax.set_ylabel("rho^n(x, x_eps), shifted")
    ax.set_title("Group metric, equal slopes: rho^n = 4 eps")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(args.out / "signature_group_equal.png", dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), sharey=True)
    for ax, fn, name in ((axes[0], sg.path_concat_distance, "sigma_*^n"),
                         (axes[1], sg.path_linear_distance, "sigma_L^n")):
        print(f"{name}, a = (0.1, 0.5, 0.0, -0.2): fitted exponent (expected 1)")
        for n in range(1, 5):
            v = curve_of(fn, A_UNEQUAL, eps, n)
            s = slope(eps, v)
            print(f"  n={n}: {s:.4f}")
            ax.loglog(eps, v * 1.15 ** (n - 1), marker=".", label=f"n={n} (x1.15^{n - 1}): slope {s:.3f}")
        ax.set_xlabel("eps")
        ax.set_title(f"{name}(x, x_eps): O(eps)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("distance (shifted)")
    fig.tight_layout()
    fig.savefig(args.out / "signature_log_rate.png", dpi=110)
    plt.close(fig)
    print(f"figures written to {args.out}")


if __name__ == "__main__":
    main()
