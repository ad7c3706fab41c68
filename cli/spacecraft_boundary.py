#!/usr/bin/python3
"""Boundary values of the spacecraft scenes: a geosynchronous orbit to the Earth-Moon L5 point.

Usage: spacecraft_boundary.py [--days 8] [--phi0 DEG] [--th-M0 RAD] [--sundman]

Frame and units are those of lagrangians/spacecraft.lag: the Sun-Earth rotating frame, Earth at the
origin, length in AU, time in (sidereal year)/2pi, G (M_S + M_E + M_M) = 1, the Moon on the circle
x_M = r_M cos(w_M t + th_M0), y_M = r_M sin(w_M t + th_M0).

- Start: on the geosynchronous circle, radius 42164.17 km, at the angle phi0 from the +x axis,
  moving prograde with the circular speed sqrt(m_E / r_GEO) of the Earth's inertial frame, written
  in the rotating frame (minus the frame's rotation, rate 1, times r_GEO).
- End, after T days: the Earth-Moon L5 point, 60 degrees behind the Moon on its circle, moving
  with it (angular rate w_M in the rotating frame).
- With --sundman the velocities are derivatives with respect to the model's Sundman parameter s
  (dt/ds = G), i.e. multiplied by the model's clock G at the boundary point and time.

Prints the grid.T and [boundary] lines of a scene.
"""
import argparse
import math

AU_KM = 149597870.7
R_GEO_KM = 42164.17
SIDEREAL_YEAR_DAYS = 365.25636


def lag_params(path):
    params = {}
    with open(path, encoding="utf-8") as f:
        for raw in f:
            line = raw.split("#", 1)[0].strip()
            if line.startswith("param ") and "=" in line:
                name, value = line[len("param "):].split("=", 1)
                params[name.strip()] = float(value)
    return params


def clock_G(p, x, y, t):
    """The model's clock: G = k_clock d_E d_M / ((d_E + d_M) r_M)."""
    th = p["w_M"] * t + p["th_M0"]
    xm, ym = p["r_M"] * math.cos(th), p["r_M"] * math.sin(th)
    d_e = math.hypot(x, y)
    d_m = math.hypot(x - xm, y - ym)
    return p["k_clock"] * d_e * d_m / ((d_e + d_m) * p["r_M"])


def main():
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("--lag", default="lagrangians/spacecraft.lag")
    parser.add_argument("--days", type=float, default=8.0)
    parser.add_argument("--phi0", type=float, default=180.0, help="start angle on GEO, degrees")
    parser.add_argument("--th-M0", type=float, default=None, help="override the Moon's initial angle (rad)")
    parser.add_argument("--sundman", action="store_true", help="velocities as d/ds with dt/ds = G")
    args = parser.parse_args()
    p = lag_params(args.lag)
    if args.th_M0 is not None:
        p["th_M0"] = args.th_M0
    T = args.days / SIDEREAL_YEAR_DAYS * 2 * math.pi
    r_geo = R_GEO_KM / AU_KM
    phi = math.radians(args.phi0)
    v_rot = math.sqrt(p["m_E"] / r_geo) - r_geo  # prograde speed in the rotating frame
    q0 = (r_geo * math.cos(phi), r_geo * math.sin(phi))
    v0 = (-v_rot * math.sin(phi), v_rot * math.cos(phi))
    th_end = p["w_M"] * T + p["th_M0"] - math.pi / 3
    qN = (p["r_M"] * math.cos(th_end), p["r_M"] * math.sin(th_end))
    vN = (-p["w_M"] * p["r_M"] * math.sin(th_end), p["w_M"] * p["r_M"] * math.cos(th_end))
    if args.sundman:
        g0, gN = clock_G(p, *q0, 0.0), clock_G(p, *qN, T)
        v0 = (v0[0] * g0, v0[1] * g0)
        vN = (vN[0] * gN, vN[1] * gN)
    fmt = lambda v: "[%.17g, %.17g]" % v  # noqa: E731
    print("# %g days = %.17g time units (sidereal year / 2pi); th_M0 = %g; GEO angle %g deg%s"
          % (args.days, T, p["th_M0"], args.phi0, "; velocities d/ds (Sundman)" if args.sundman else ""))
    print("T = %.17g" % T)
    print("q0 = %s\nv0 = %s\nqN = %s\nvN = %s" % (fmt(q0), fmt(v0), fmt(qN), fmt(vN)))


if __name__ == "__main__":
    main()
