"""The spatial circular restricted three-body problem in velocity form (x, y, z, vx, vy, vz), the
rotating frame with the primaries at (-mu, 0, 0) and (1 - mu, 0, 0): the equations of motion and the
energy written here from the textbook (Szebehely 1967, ch. 10), independent of the program's model,
for the tests' scipy correctors (tests/test_halo.py, tests/test_axial.py). Earth–Moon mu."""
import numpy as np
from scipy.integrate import solve_ivp

MU = 0.01215058560962404
TOL = dict(method="DOP853", rtol=1e-13, atol=1e-13)


def rhs(t, s):
    x, y, z, vx, vy, vz = s
    r1 = np.sqrt((x + MU) ** 2 + y * y + z * z)
    r2 = np.sqrt((x - 1 + MU) ** 2 + y * y + z * z)
    a1, a2 = (1 - MU) / r1**3, MU / r2**3
    return [vx, vy, vz, x - a1 * (x + MU) - a2 * (x - 1 + MU) + 2 * vy, y - (a1 + a2) * y - 2 * vx,
            -(a1 + a2) * z]


def energy(s):
    """H = |v|^2/2 - (x^2 + y^2)/2 - (1 - mu)/r1 - mu/r2 (the program's energy, -C/2)."""
    x, y, z, vx, vy, vz = s
    r1 = np.sqrt((x + MU) ** 2 + y * y + z * z)
    r2 = np.sqrt((x - 1 + MU) ** 2 + y * y + z * z)
    return (vx * vx + vy * vy + vz * vz) / 2 - (x * x + y * y) / 2 - (1 - MU) / r1 - MU / r2


def flow(s0, t):
    """The state at time t from s0."""
    return solve_ivp(rhs, (0, t), s0, **TOL).y[:, -1]
