#!/usr/bin/python3
"""bench/mixed_mode_beam.py against closed forms and its own energy balance: a stiff-in-shear
slab on normal springs is Hetenyi's Winkler beam (tip stress q_n (1 + lambda a)^2 under a
cantilevered overhang), a rigid slab on shear springs is the shear-lag bar (tip shear
tau_g (1 + a / Lambda)), the springs carry the whole weight, the tip's spring energies are the
energy release rate dU/da, and the criterion's bisection finds the cut it was calibrated on."""
import importlib.util
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location(
    'mixed_mode_beam', os.path.join(HERE, '..', '..', 'bench', 'mixed_mode_beam.py'))
beam = importlib.util.module_from_spec(spec)
spec.loader.exec_module(beam)

failures = []


def check(name, value, expected, rel):
    ok = abs(value - expected) <= rel * abs(expected)
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {value:.6g} (expected {expected:.6g}, "
          f"tolerance {rel:.1%})")
    if not ok:
        failures.append(name)


def firn_column(**changes):
    geometry = dict(beam.GEOMETRIES["firn-pst"])
    geometry.update(changes)
    return beam.Column(**geometry)


# Hetenyi's semi-infinite Winkler beam with an end force q_n a and moment q_n a^2 / 2: the tip
# deflects by (q_n / k_n)(1 + lambda a)^2, lambda = (k_n / 4 D)^(1/4). A slab 1000 times stiffer
# in shear (Euler-Bernoulli to ~0.1 %: its shear mode decays over 8 mm, so segments of 5 cm),
# springs 1e9 times softer in shear (no axial coupling), 6 m long (e^(-lambda L) = 2e-7): agreement
# to 0.3 % says the normal and bending equations are right.
column = firn_column(length=6.0)
column.S *= 1e3
column.k_t *= 1e-9
lam = (column.k_n / (4 * column.D))**0.25
q_n, _ = column.loads(0.0)
for cut in (0.0, 0.3, 0.6):
    sigma, _ = beam.Solution(column, 0.0, cut, max_segment=0.05).tip_stresses()
    check(f"Winkler tip stress, cut {cut} m", sigma, q_n * (1 + lam * cut)**2, 3e-3)

# The shear-lag bar: a slab rigid in bending and shear on rigid normal springs on 30 degrees;
# the overhang's down-slope weight q_t a pulls the supported part, tau_tip = tau_g (1 + a mu),
# mu = sqrt(k_t / A). 10 m long (e^(-mu L) = 1e-5). Checks the axial equation and the cut's
# direction (down-slope: the tip's shear grows with the cut).
column = firn_column(length=10.0)
column.D *= 1e6
column.S *= 1e6
column.k_n *= 1e6
mu = math.sqrt(column.k_t / column.A)
_, q_t = column.loads(30.0)
for cut in (0.0, 0.4, 0.8):
    _, tau = beam.Solution(column, 30.0, cut).tip_stresses()
    check(f"shear-lag tip shear, cut {cut} m", tau, q_t * (1 + mu * cut), 2e-3)

# Equilibrium: the springs carry the column's whole weight, normal and along the slope.
column = firn_column()
for slope in (0.0, 30.0):
    solution = beam.Solution(column, slope, 0.5)
    normal = shear = 0.0
    for supported, xs, z in solution.segments():
        if supported:
            sigma, tau = solution.spring_stresses(z)
            normal += beam.simpson(sigma, xs)
            shear += beam.simpson(tau, xs)
    q_n, q_t = column.loads(slope)
    check(f"normal springs carry the weight, {slope:g} deg", normal, q_n * column.length, 1e-6)
    if slope > 0:
        check(f"shear springs carry the weight, {slope:g} deg", shear, q_t * column.length, 1e-6)

# The energy release rate: under dead loads the potential energy is -U, so G = dU/da; the tip's
# spring energies must equal it (central difference, 1 mm), mixed mode on 30 degrees.
for slope, cut in ((0.0, 0.5), (30.0, 0.4)):
    G_I, G_II = beam.Solution(column, slope, cut).energy_release_rates()
    step = 1e-3
    dU = (beam.Solution(column, slope, cut + step).strain_energy() -
          beam.Solution(column, slope, cut - step).strain_energy()) / (2 * step)
    check(f"G_I + G_II = dU/da, {slope:g} deg, cut {cut} m", G_I + G_II, dU, 1e-3)

# The bisection returns the flat cut the toughness was set by, for mixed and single modes.
for ratio, exponent in ((1.0, 1.0), (2.0, 2.0), (math.inf, 1.0)):
    G_Ic, G_IIc = beam.toughness_for_flat_cut(column, 0.5, ratio, exponent)
    check(f"critical cut recovered, G_IIc/G_Ic {ratio}, exponent {exponent}",
          beam.critical_cut(column, 0.0, G_Ic, G_IIc, exponent), 0.5, 1e-3)

# Mode II alone on 30 degrees: the bending's shear and the slope's cancel near the flat a_c, so
# the criterion falls before it rises; a_c must still be the first cut that reaches it (every cut
# on a 1 cm grid below it stays below 1, and it is above the flat one).
G_Ic, G_IIc = beam.toughness_for_flat_cut(column, 0.5, 0.0, 1.0)
cut = beam.critical_cut(column, 30.0, G_Ic, G_IIc, 1.0)
below = [beam.criterion(column, 30.0, 0.01 * i, G_Ic, G_IIc, 1.0) for i in range(int(cut / 0.01))]
print(f"mode II alone on 30 deg: a_c {cut:.4f} m, criterion below it at most {max(below):.3f}")
if not (0.5 < cut < column.length and max(below) < 1.0):
    failures.append("mode II alone: first critical cut")

# The closed form (pst_resolution.py's) given the v8-example column: V8's six example values.
geometry = beam.GEOMETRIES["v8-example"]
for slope, expected in zip((0, 10, 20, 30, 35, 38), (1.129, 0.865, 0.622, 0.401, 0.300, 0.244)):
    check(f"V8 closed form, {slope} deg", beam.closed_form_ac(slope, **geometry), expected, 2e-3)

if failures:
    print(f"{len(failures)} check(s) failed: {', '.join(failures)}")
    sys.exit(1)
print("all checks passed")
