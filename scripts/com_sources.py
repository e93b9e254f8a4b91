#!/usr/bin/env python3
"""What the controller's CoM misses, and what the force plates give it (docs/wearer.md "The CoM from the plates").

Reads one run log of `exoid experiment` (controller status, ground truth, both plates) and prints, over the moves
(after the first --skip seconds), against the true CoM (simulator's world = the plates'):
  - the controller's CoM (status `com`: the model's, or blended with the estimate): its mean offset (the model's
    bias plus the offset of the controller's world, summary.json frame_offset_m) and the RMS about it, and that
    error's spectrum by frequency band;
  - offline fusions of the horizontal CoM, each the same 4th-order complementary pair (a Butterworth
    denominator at the crossover, the plates' acceleration f / m twice integrated above it):
      model + acc:        the controller's CoM below the crossover;
      balance + acc:      the plates' own CoM by the moment balance about the CoM, c_x = (c_z F_x - M_y) / F_z,
                          c_y = (M_x + c_z F_y) / F_z (the centre of pressure corrected by the ground force's lean),
                          below it;
      balance+dL + acc:   the same with the model's rate of angular momentum about the CoM (+dL_y/dt, -dL_x/dt over
                          F_z; the status `momentum`, differenced through a 20 ms low-pass as the controller's CoM
                          observer does, docs/controller.md "The CoM observer").
No model, no controller: the log alone. Needs lcm-gen (to decode the messages) and numpy.

    python3 scripts/com_sources.py out/run/run.lcmlog --crossovers 0.05 0.1 0.2 0.3
"""
import argparse
import os
import struct
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def lcm_types(tmp):
    """Python classes for the messages (lcm-gen -p into tmp)."""
    names = ["controller_status_t", "ground_truth_t", "force_plate_t"]
    subprocess.run(["lcm-gen", "-p", "--ppath", tmp] + [os.path.join(ROOT, "lcmtypes", n + ".lcm") for n in names],
                   check=True, stdout=subprocess.DEVNULL)
    sys.path.insert(0, tmp)
    import exoid_lcm  # noqa: E402 (generated above)
    return exoid_lcm


def events(path):
    """(channel, payload) of every event of an LCM log; stops with a message at the first damaged event."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        sys.exit(f"{path}: cannot read: {e.strerror}")
    i = 0
    while i + 28 <= len(data):
        sync, _, _, cl, dl = struct.unpack(">IqqII", data[i:i + 28])
        if sync != 0xEDA1DA01 or i + 28 + cl + dl > len(data):
            sys.exit(f"{path}: damaged event at byte {i}")
        yield data[i + 28:i + 28 + cl].decode(), data[i + 28 + cl:i + 28 + cl + dl]
        i += 28 + cl + dl


def rotation(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def fuse(u, acc, crossover_hz, dt):
    """c_hat = L u + H acc / s^2 per column, L = (a2 s^2 + a1 s + a0) / D, H = s^3 (s + a3) / D, D the 4th-order
    Butterworth polynomial; forward Euler, started at rest on u[0]."""
    w = 2 * np.pi * crossover_hz
    p, q = 2 * np.sin(np.pi / 8), 2 * np.cos(np.pi / 8)
    a3, a2, a1, a0 = (p + q) * w, (2 + p * q) * w * w, (p + q) * w ** 3, w ** 4
    x = np.zeros((4, u.shape[1]))
    x[0], x[1] = u[0], a3 * u[0]
    out = np.empty_like(u)
    for k in range(len(u)):
        a = acc[k - 1] if k else 0.0 * u[0]  # the plates of the previous tick, as a controller would have them
        x1, x2, x3, x4 = x
        x = np.array([x1 + dt * (-a3 * x1 + x2), x2 + dt * (-a2 * x1 + x3 + a2 * u[k] + a),
                      x3 + dt * (-a1 * x1 + x4 + a1 * u[k] + a3 * a), x4 + dt * (-a0 * x1 + a0 * u[k])])
        out[k] = x[0]
    return out


def error_figures(true_xy, est_xy):
    """(mean offset mm [2], RMS about it mm) of true - estimate."""
    e = true_xy - est_xy
    m = e.mean(0)
    return 1e3 * m, 1e3 * np.sqrt(((e - m) ** 2).sum(1).mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("log", help="run.lcmlog of exoid experiment (a scenario whose truth carries the CoM)")
    ap.add_argument("--crossovers", type=float, nargs="+", default=[0.05, 0.1, 0.2, 0.3], metavar="HZ",
                    help="crossover frequencies of the offline fusions (default 0.05 0.1 0.2 0.3)")
    ap.add_argument("--skip", type=float, default=5.0, metavar="S",
                    help="seconds of the moves left out of the figures (the fusions' start; default 5)")
    ap.add_argument("--period", type=float, default=1e-3, metavar="S", help="tick period (default 0.001)")
    args = ap.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        msg = lcm_types(tmp)
        status, truth, plates = {}, {}, {}
        for ch, data in events(args.log):
            if ch == "EXO_CONTROLLER_STATUS":
                m = msg.controller_status_t.decode(data)
                status[m.tick] = m
            elif ch == "EXO_TRUTH":
                m = msg.ground_truth_t.decode(data)
                truth[m.tick] = m
            elif ch in ("EXO_PLATE_RIGHT", "EXO_PLATE_LEFT"):
                m = msg.force_plate_t.decode(data)
                plates.setdefault(m.tick, {})[ch] = m
    ticks = sorted(t for t in status if status[t].move_index >= 0 and t in truth and len(plates.get(t, {})) == 2)
    if len(ticks) < 2 * int(args.skip / args.period):
        sys.exit(f"{args.log}: {len(ticks)} ticks with status, truth and both plates during the moves: too few")
    ctrl = np.array([status[t].com for t in ticks])
    momentum = np.array([status[t].momentum[3:] for t in ticks])
    rate = np.zeros_like(momentum)  # dL/dt, low-passed (20 ms) as the controller's observer does
    k_rate = min(1.0, args.period / 0.02)
    for k in range(1, len(ticks)):
        rate[k] = rate[k - 1] + k_rate * ((momentum[k] - momentum[k - 1]) / args.period - rate[k - 1])
    true = np.array([truth[t].com for t in ticks])
    force = np.zeros((len(ticks), 3))   # ON the robot, world
    moment = np.zeros((len(ticks), 3))  # ON the robot about the world origin
    for k, t in enumerate(ticks):
        for p in plates[t].values():
            R = rotation(p.plate_orientation)
            f = R @ np.array(p.force)
            force[k] -= f
            moment[k] -= R @ np.array(p.moment) + np.cross(np.array(p.plate_position), f)
    mass = force[:, 2].mean() / 9.81
    acc = force[:, :2] / mass
    fz = force[:, 2]
    cop_com = np.stack([-moment[:, 1] / fz, moment[:, 0] / fz], 1) + ctrl[:, 2:3] * force[:, :2] / fz[:, None]
    cop_com_dl = cop_com + np.stack([rate[:, 1], -rate[:, 0]], 1) / fz[:, None]
    s = int(args.skip / args.period)
    true_xy = true[s:, :2]
    print(f"{args.log}: {len(ticks)} ticks of moves, mass from the plates {mass:.2f} kg, figures after {args.skip} s")
    m, r = error_figures(true_xy, ctrl[s:, :2])
    print(f"controller's CoM: mean offset ({m[0]:+.2f}, {m[1]:+.2f}) mm, RMS about it {r:.2f} mm")
    e = true_xy - ctrl[s:, :2]
    e = e - e.mean(0)
    freq = np.fft.rfftfreq(len(e), args.period)
    power = (np.abs(np.fft.rfft(e, axis=0)) ** 2).sum(1)
    bands = [(0, 0.05), (0.05, 0.1), (0.1, 0.2), (0.2, 0.35), (0.35, 0.5), (0.5, 0.8), (0.8, 1.2), (1.2, 2), (2, 1e9)]
    print("  its spectrum, share of the RMS^2 by band (Hz): " + ", ".join(
        f"{lo:g}-{hi:g} {power[(freq >= lo) & (freq < hi)].sum() / power.sum():.2f}" if hi < 1e9 else
        f">{lo:g} {power[freq >= lo].sum() / power.sum():.2f}" for lo, hi in bands))
    m, r = error_figures(true_xy, cop_com[s:])
    print(f"moment balance's CoM (no fusion): mean offset ({m[0]:+.2f}, {m[1]:+.2f}) mm, RMS about it {r:.2f} mm")
    m, r = error_figures(true_xy, cop_com_dl[s:])
    print(f"  with the model's dL/dt: mean offset ({m[0]:+.2f}, {m[1]:+.2f}) mm, RMS about it {r:.2f} mm")
    for fc in args.crossovers:
        a = error_figures(true_xy, fuse(ctrl[:, :2], acc, fc, args.period)[s:])
        b = error_figures(true_xy, fuse(cop_com, acc, fc, args.period)[s:])
        c = error_figures(true_xy, fuse(cop_com_dl, acc, fc, args.period)[s:])
        print(f"crossover {fc:g} Hz, RMS about the mean (mean x, y), mm: model + acc {a[1]:.2f} ({a[0][0]:+.2f}, "
              f"{a[0][1]:+.2f}); balance + acc {b[1]:.2f} ({b[0][0]:+.2f}, {b[0][1]:+.2f}); balance+dL + acc "
              f"{c[1]:.2f} ({c[0][0]:+.2f}, {c[0][1]:+.2f})")


if __name__ == "__main__":
    main()
