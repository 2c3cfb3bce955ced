#!/usr/bin/python3
"""The PST as a beam on a weak-layer foundation with a mixed-mode criterion: V8's other model.

validation.md's V8 closed form (Gaume et al. 2017a) is a shear criterion on an elastic interface;
it names "a beam on an elastic foundation with a compressive criterion" as another model. This
script is that family, after Rosendahl & Weissgraeber (2020, The Cryosphere 14:115 and 14:131;
written here from their description, not their code): the slab a Timoshenko beam in plane strain,
the weak layer a bed of normal and shear springs between the slab's lower face and a rigid base,
the column's two ends free, the saw cut an unsupported overhang of length a at the down-slope end.
At the cut's tip the springs that a crack advance releases carry the energy release rates

    G_I = sigma^2 / (2 k_n)  (compression only: an anticrack),   G_II = tau^2 / (2 k_t),

and the cut is critical where (G_I / G_Ic)^p + (G_II / G_IIc)^p = 1. The toughness scale is set by
a flat critical cut (--flat-ac, Firn's measured one by default), so what the model predicts is
the ratio a_c(slope) / a_c(0) for each mode mixity G_IIc / G_Ic: mode I alone is V8's
"compressive criterion"; mode II alone a shear criterion as V8's closed form's, but here the
overhang's bending shears the tip against the slope's pull where the closed form adds the two
(bench/studies.md: "V8's other model").

    /usr/bin/python3 bench/mixed_mode_beam.py [--geometry firn-pst|v8-example] [--flat-ac 0.5125]
                     [--slopes 0 10 20 30 35] [--toughness-ratios 0 0.5 1 2 4 inf]
                     [--exponents 1 2] [--slab-moduli E ...] [--csv FILE] [--plot PNG]
                     [--measured RESULTS_CSV ...]

Equations (x down-slope, z into the snowpack; u, w, psi the mid-plane's axial displacement,
deflection and rotation; the lower face moves by u + h psi / 2): from the potential energy
    A u'^2/2 + D psi'^2/2 + S (w' + psi)^2/2 + k_n w^2/2 + k_t (u + h psi/2)^2/2 - q_t u - q_n w,
A = E' h, D = E' h^3 / 12, S = kappa G h (E' = E / (1 - nu^2), kappa 5/6), q_n = rho g h cos(psi),
q_t = rho g h sin(psi); k_n = E_oed / t (the layer is confined sideways), k_t = G / t.
"""
import argparse
import csv
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pst_resolution  # noqa: E402  (the closed form, one copy)

GRAVITY = 9.81


def plane_strain_modulus(E, nu):
    return E / (1.0 - nu * nu)


def oedometric_modulus(E, nu):
    return E * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))


# Firn's PST (scenes/pst.toml; the 3 m column of bench/pst_resolution.py's bisection) and V8's
# example (validation.md: E 5 MPa, nu 0.2, D 0.5 m, rho 250, D_wl 0.03 m, G_wl 0.1 MPa; its
# weak layer's nu is not given: 0.2, as Firn's).
GEOMETRIES = {
    "firn-pst": dict(E=5e6, nu=0.2, rho=250.0, h=0.5, E_wl=0.48e6, nu_wl=0.2, t=0.06, length=3.0),
    "v8-example": dict(E=5e6, nu=0.2, rho=250.0, h=0.5, E_wl=0.24e6, nu_wl=0.2, t=0.03,
                       length=10.0),
}


class Column:
    """A PST column: slab properties, springs and length (SI units, per unit width)."""

    def __init__(self, E, nu, rho, h, E_wl, nu_wl, t, length, shear_factor=5.0 / 6.0):
        self.h, self.rho, self.length = h, rho, length
        Ep = plane_strain_modulus(E, nu)
        self.A = Ep * h
        self.D = Ep * h**3 / 12.0
        self.S = shear_factor * E / (2.0 * (1.0 + nu)) * h
        self.k_n = oedometric_modulus(E_wl, nu_wl) / t
        self.k_t = E_wl / (2.0 * (1.0 + nu_wl)) / t

    def loads(self, slope_deg):
        s = math.radians(slope_deg)
        weight = self.rho * GRAVITY * self.h
        return weight * math.cos(s), weight * math.sin(s)

    def system(self, supported, slope_deg):
        """z' = M z + b for z = (u, u', w, w', psi, psi') on a supported or free segment."""
        k_n, k_t = (self.k_n, self.k_t) if supported else (0.0, 0.0)
        q_n, q_t = self.loads(slope_deg)
        A, D, S, h = self.A, self.D, self.S, self.h
        M = np.zeros((6, 6))
        b = np.zeros(6)
        M[0, 1] = M[2, 3] = M[4, 5] = 1.0
        # A u'' = k_t (u + h psi/2) - q_t
        M[1, 0], M[1, 4], b[1] = k_t / A, k_t * h / (2 * A), -q_t / A
        # S (w'' + psi') = k_n w - q_n
        M[3, 2], M[3, 5], b[3] = k_n / S, -1.0, -q_n / S
        # D psi'' = S (w' + psi) + (h/2) k_t (u + h psi/2)
        M[5, 3] = S / D
        M[5, 4] = S / D + k_t * h * h / (4 * D)
        M[5, 0] = k_t * h / (2 * D)
        return M, b


def expm(matrix):
    """Matrix exponential by scaling and squaring of a Taylor series (numpy has none, and the
    project's Python has no scipy)."""
    norm = np.linalg.norm(matrix, 1)
    squarings = max(0, int(math.ceil(math.log2(norm))) + 1) if norm > 0.5 else 0
    scaled = matrix / 2.0**squarings
    result = np.eye(len(matrix))
    term = np.eye(len(matrix))
    for k in range(1, 20):
        term = term @ scaled / k
        result = result + term
    for _ in range(squarings):
        result = result @ result
    return result


def transfer(M, b, length):
    """(Phi, p) with z(x + length) = Phi z(x) + p for z' = M z + b."""
    augmented = np.zeros((7, 7))
    augmented[:6, :6], augmented[:6, 6] = M * length, b * length
    E = expm(augmented)
    return E[:6, :6], E[:6, 6]


# A free end carries no axial force, shear force or moment: u' = 0, w' + psi = 0, psi' = 0.
FREE_END = np.array([[0, 1, 0, 0, 0, 0], [0, 0, 0, 1, 1, 0], [0, 0, 0, 0, 0, 1]], float)


class Solution:
    """The column's state at the nodes of its segments (multiple shooting keeps the long
    supported part well conditioned)."""

    def __init__(self, column, slope_deg, cut, max_segment=0.25):
        if not 0.0 <= cut < column.length:
            raise ValueError(f"cut {cut} m outside [0, {column.length}) m")
        self.column = column
        tip = column.length - cut
        nodes = list(np.linspace(0.0, tip, max(1, math.ceil(tip / max_segment)) + 1))
        self.tip_index = len(nodes) - 1
        if cut > 0.0:
            nodes += list(np.linspace(tip, column.length,
                                      max(1, math.ceil(cut / max_segment)) + 1)[1:])
        self.nodes, self.tip = np.array(nodes), tip
        segments = len(nodes) - 1
        n = 6 * (segments + 1)
        K, r = np.zeros((n, n)), np.zeros(n)
        K[0:3, 0:6] = FREE_END
        K[n - 3:n, n - 6:n] = FREE_END
        self.systems = []
        for i in range(segments):
            supported = nodes[i + 1] <= tip + 1e-12
            M, b = column.system(supported, slope_deg)
            self.systems.append((M, b))
            Phi, p = transfer(M, b, nodes[i + 1] - nodes[i])
            rows = slice(3 + 6 * i, 9 + 6 * i)
            K[rows, 6 * i:6 * i + 6] = Phi
            K[rows, 6 * i + 6:6 * i + 12] = -np.eye(6)
            r[rows] = -p
        self.states = np.linalg.solve(K, r).reshape(segments + 1, 6)

    def segments(self, per_segment=40):
        """Per segment: whether it rests on the springs, and x and z at points along it (both
        ends included), for energies and equilibrium checks."""
        for i, (M, b) in enumerate(self.systems):
            x0, x1 = self.nodes[i], self.nodes[i + 1]
            Phi, p = transfer(M, b, (x1 - x0) / per_segment)  # one step, applied per_segment times
            zs = [self.states[i]]
            for _ in range(per_segment):
                zs.append(Phi @ zs[-1] + p)
            yield x1 <= self.tip + 1e-12, np.linspace(x0, x1, per_segment + 1), np.array(zs)

    def spring_stresses(self, z):
        """Normal (compression > 0) and shear stress in the springs under states z."""
        c = self.column
        return c.k_n * z[..., 2], c.k_t * (z[..., 0] + 0.5 * c.h * z[..., 4])

    def tip_stresses(self):
        """Weak-layer normal and shear stress at the cut's tip."""
        return self.spring_stresses(self.states[self.tip_index])

    def energy_release_rates(self):
        sigma, tau = self.tip_stresses()
        c = self.column
        return max(sigma, 0.0)**2 / (2 * c.k_n), tau**2 / (2 * c.k_t)

    def strain_energy(self, per_segment=40):
        """Elastic energy of slab and springs (Simpson's rule on each segment)."""
        c = self.column
        total = 0.0
        for supported, xs, z in self.segments(per_segment):
            density = (0.5 * c.A * z[:, 1]**2 + 0.5 * c.D * z[:, 5]**2 +
                       0.5 * c.S * (z[:, 3] + z[:, 4])**2)
            if supported:
                sigma, tau = self.spring_stresses(z)
                density += 0.5 * sigma**2 / c.k_n + 0.5 * tau**2 / c.k_t
            total += simpson(density, xs)
        return total


def simpson(values, xs):
    """Simpson's rule on an even number of equal intervals."""
    h = (xs[-1] - xs[0]) / (len(xs) - 1)
    return float(h / 3 * (values[0] + values[-1] + 4 * values[1:-1:2].sum() +
                          2 * values[2:-1:2].sum()))


def criterion(column, slope, cut, G_Ic, G_IIc, exponent):
    """(G_I/G_Ic)^p + (G_II/G_IIc)^p: >= 1 where the cut is critical. A toughness of inf leaves
    that mode out."""
    G_I, G_II = Solution(column, slope, cut).energy_release_rates()
    return (G_I / G_Ic)**exponent + (G_II / G_IIc)**exponent


def critical_cut(column, slope, G_Ic, G_IIc, exponent, scan=0.05, tolerance=1e-4):
    """Smallest cut at which the criterion reaches 1: the first scan step that reaches it, then
    bisection (the criterion need not grow with the cut: in mode II the bending's shear and the
    slope's can cancel). 0 if the uncut column is critical, nan if no cut below 0.9 L is."""
    def critical(cut):
        return criterion(column, slope, cut, G_Ic, G_IIc, exponent) >= 1.0

    if critical(0.0):
        return 0.0
    lo = 0.0
    for hi in np.arange(scan, 0.9 * column.length + 1e-9, scan):
        if critical(hi):
            break
        lo = hi
    else:
        return math.nan
    while hi - lo > tolerance:
        mid = 0.5 * (lo + hi)
        if critical(mid):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def toughness_for_flat_cut(column, flat_ac, ratio, exponent):
    """(G_Ic, G_IIc) with G_IIc = ratio G_Ic (ratio 0: mode II alone, inf: mode I alone) that
    make flat_ac the flat critical cut."""
    G_I, G_II = Solution(column, 0.0, flat_ac).energy_release_rates()
    if ratio == 0.0:
        return math.inf, G_II
    if math.isinf(ratio):
        return G_I, math.inf
    # (G_I/G)^p + (G_II/(ratio G))^p = 1  =>  G = ((G_I^p + (G_II/ratio)^p))^(1/p)
    G = (G_I**exponent + (G_II / ratio)**exponent)**(1.0 / exponent)
    return G, ratio * G


def closed_form_ac(slope, E, nu, rho, h, E_wl, nu_wl, t, **_):
    """validation.md V8's closed form (Gaume et al. 2017a; bench/pst_resolution.py's) for the
    same column, its shear strength tau_p 1 kPa."""
    return pst_resolution.closed_form_ac(slope, E=E, nu=nu, rho=rho, D=h, D_wl=t,
                                         G_wl=E_wl / (2.0 * (1.0 + nu_wl)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--geometry", choices=list(GEOMETRIES), default="firn-pst")
    parser.add_argument("--flat-ac", type=float, default=0.5125,
                        help="flat critical cut that sets the toughness (m; default Firn's "
                             "0.50-0.525 at dx 0.03)")
    parser.add_argument("--slopes", type=float, nargs="+", default=[0, 10, 20, 30, 35])
    parser.add_argument("--toughness-ratios", type=float, nargs="+",
                        default=[0.0, 0.25, 0.5, 1.0, 2.0, 4.0, math.inf],
                        help="G_IIc / G_Ic (0: mode II alone, inf: mode I alone)")
    parser.add_argument("--exponents", type=float, nargs="+", default=[1.0, 2.0])
    parser.add_argument("--csv", help="write the table here as well")
    parser.add_argument("--slab-moduli", type=float, nargs="+", default=[],
                        help="also give a_c for these slab E (Pa), the toughness kept from the "
                             "geometry's own E: what one calibration predicts for other slabs")
    parser.add_argument("--plot", help="draw a_c against slope into this image (matplotlib)")
    parser.add_argument("--measured", nargs="+", default=[],
                        help="bench/pst_resolution.py results.csv files whose rows without "
                             "overrides the plot draws beside the model (Firn's a_c brackets)")
    args = parser.parse_args()

    geometry = GEOMETRIES[args.geometry]
    column = Column(**geometry)
    print(f"# {args.geometry}: {geometry}; flat a_c {args.flat_ac} m sets the toughness")
    G_I, G_II = Solution(column, 0.0, args.flat_ac).energy_release_rates()
    print(f"# at the flat critical cut: G_I {G_I:.3f} J/m^2, G_II {G_II:.3f} J/m^2 "
          f"(mode mixity G_II/(G_I+G_II) {G_II / (G_I + G_II):.2f})")
    closed = [closed_form_ac(s, **geometry) for s in args.slopes]
    print("closed form (tau_p 1 kPa): " + ", ".join(
        f"{s:g} deg {a:.3f} m" for s, a in zip(args.slopes, closed)))
    rows = []
    header = ["G_IIc/G_Ic", "exponent", "G_Ic", "G_IIc"] + [f"a_c {s:g}" for s in args.slopes] \
        + ["ratio 30/0" if 30.0 in args.slopes and 0.0 in args.slopes else "ratio"]
    print(" | ".join(header))
    for exponent in args.exponents:
        for ratio in args.toughness_ratios:
            if (ratio == 0.0 or math.isinf(ratio)) and exponent != args.exponents[0]:
                continue  # one mode alone does not depend on the interaction's exponent
            G_Ic, G_IIc = toughness_for_flat_cut(column, args.flat_ac, ratio, exponent)
            cuts = [critical_cut(column, s, G_Ic, G_IIc, exponent) for s in args.slopes]
            by_slope = dict(zip(args.slopes, cuts))
            ratio30 = by_slope.get(30.0, math.nan) / by_slope.get(0.0, math.nan)
            row = [ratio, exponent, G_Ic, G_IIc] + cuts + [ratio30]
            rows.append(row)
            print(" | ".join(f"{v:.4g}" for v in row))
            for E in args.slab_moduli:
                slab = Column(**dict(geometry, E=E))
                print(f"    slab E {E:.3g} Pa: " + ", ".join(
                    f"{s:g} deg {critical_cut(slab, s, G_Ic, G_IIc, exponent):.4g}"
                    for s in args.slopes))
    closed_ratio = closed_form_ac(30, **geometry) / closed_form_ac(0, **geometry)
    print(f"closed form's ratio a_c(30)/a_c(0): {closed_ratio:.3f}")
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(header)
            writer.writerows([[f"{v:.6g}" for v in row] for row in rows])
    if args.plot:
        plot(args.plot, args.slopes, rows, closed, measured_brackets(args.measured),
             f"{args.geometry}, toughness set by a flat a_c of {args.flat_ac} m")
    return 0


def measured_brackets(paths):
    """(slope, a_c low, a_c high) of the rows without overrides in pst_resolution.py CSVs."""
    brackets = []
    for path in paths:
        with open(path) as f:
            brackets += [(float(r["slope"]), float(r["a_c_low"]), float(r["a_c_high"]))
                         for r in csv.DictReader(f) if not r["overrides"]]
    return sorted(brackets)


def plot(path, slopes, rows, closed, measured, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    for ratio, exponent, _, _, *cuts_and_ratio in rows:
        cuts = cuts_and_ratio[:-1]
        if ratio == 0.0:
            style, label = dict(color="tab:red", lw=2), "beam model, mode II alone"
        elif math.isinf(ratio):
            style, label = dict(color="tab:blue", lw=2), "beam model, mode I alone"
        else:
            style = dict(color="tab:gray", lw=0.8, alpha=0.7)
            label = "beam model, mixed (G_IIc/G_Ic 0.25-4, p 1, 2)"
        ax.plot(slopes, cuts, label=label, **style)
    ax.plot(slopes, closed, "k--", label="closed form (V8, Gaume et al. 2017a)")
    if 0.0 in slopes:  # V8's gate asks for this trend: the closed form through the flat a_c
        flat = rows[0][4 + slopes.index(0.0)] / closed[slopes.index(0.0)]
        ax.plot(slopes, [flat * a for a in closed], "k:",
                label="closed form scaled to the flat a_c (V8's trend)")
    if measured:
        s, lo, hi = np.array(measured).T
        ax.errorbar(s, 0.5 * (lo + hi), yerr=0.5 * (hi - lo), fmt="o", color="tab:green",
                    capsize=4, label="Firn, dx 0.03 (bisection bracket)")
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles))
    ax.legend(unique.values(), unique.keys(), fontsize=8)
    ax.set_xlabel("slope (deg); negative: the cut at the up-slope end")
    ax.set_ylabel("critical cut length a_c (m)")
    ax.set_ylim(0, 1.5)
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
