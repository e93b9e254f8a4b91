#!/usr/bin/env python3
"""Generates config/exo.urdf and config/exo.xml (MJCF, MuJoCo 2.2) from one kinematic table and
config/exo_true_parameters.csv (seed thesis Appendix D, standard parameters about each link origin).

One source for both files; tests/test_model_files.cpp proves the two parsed robots agree to 1e-9.
Frames (docs/conventions.md): world x forward, y left, z up. Every link frame has its origin on the
link's own joint axis and z along that axis (thesis beta_r = [0 0 1 0 0 0]); leg link frames have x
pointing down the leg in the standing pose. Left-leg frames are the mirrored right-leg frames with z
flipped, which is the mirror symmetry of the parameter table (left mcz, Ixz, Iyz = -right).
Run: python3 tools/model/gen_exo_model.py   (no third-party packages needed)
"""
import csv, math, os, sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
CSV = os.path.join(ROOT, "config", "exo_true_parameters.csv")

# Orientation of each link frame in the standing pose, world coordinates: columns x, y, z.
DOWN, UP, FWD, BACK, LEFT, RIGHT = (0, 0, -1), (0, 0, 1), (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0)
FRAMES = {
    "body": (FWD, LEFT, UP),
    "right_hip_abduction": (DOWN, LEFT, FWD),   # z forward: + = adduction
    "right_thigh": (DOWN, FWD, RIGHT),          # z right: + = flexion
    "right_shank": (DOWN, BACK, LEFT),          # z left: + = knee flexion
    "right_ankle": (DOWN, FWD, RIGHT),          # z right: + = dorsiflexion
    "right_foot": (DOWN, LEFT, FWD),            # z forward: + = inversion (sole turns inward)
    "left_hip_abduction": (DOWN, RIGHT, BACK),
    "left_thigh": (DOWN, FWD, RIGHT),
    "left_shank": (DOWN, BACK, LEFT),
    "left_ankle": (DOWN, FWD, RIGHT),
    "left_foot": (DOWN, RIGHT, BACK),
}
HIP_HALF_WIDTH = 0.11   # m, lateral distance of each hip ab/adduction axis from the body origin
HIP_AA_TO_FE = 0.10     # m, hip flexion axis below the ab/adduction axis
THIGH = 0.43            # m, hip flexion to knee
SHANK = 0.42            # m, knee to ankle plantar/dorsiflexion
ANKLE_PD_TO_IE = 0.03   # m, in/eversion axis below the plantar/dorsiflexion axis
SOLE_DEPTH = 0.06       # m, sole below the in/eversion axis
FOOT_HEEL, FOOT_TOE, FOOT_HALF_WIDTH = -0.11, 0.17, 0.06   # m, sole outline about the ankle, world x / y
SOLE_THICKNESS = 0.02
# MJCF only (the URDF has no ground): force plates, 60 x 20 cm top, 2 cm apart, tops at z = 0.
PLATE_HALF = (0.3, 0.1, 0.025)   # m
PLATE_MASS = 20.0                # kg, lab plate class (tared away by the sim)
CONTACT_FRICTION = "1 0.005 0.0001"
CONTACT_SOLREF = "0.005 1"       # timeconst (>= 2 timesteps), damping ratio
CONTACT_SOLIMP = "0.95 0.99 0.001"
STAND_HEIGHT = HIP_AA_TO_FE + THIGH + SHANK + ANKLE_PD_TO_IE + SOLE_DEPTH  # body origin above ground

# (joint, parent link, child link, joint origin in world coordinates at standing, torque limit N m or None)
def leg(side, s):
    y = s * HIP_HALF_WIDTH
    return [
        (f"{side}_hip_aa", "body", f"{side}_hip_abduction", (0, y, 0), 150.0),
        (f"{side}_hip_fe", f"{side}_hip_abduction", f"{side}_thigh", (0, y, -HIP_AA_TO_FE), 150.0),
        (f"{side}_knee", f"{side}_thigh", f"{side}_shank", (0, y, -HIP_AA_TO_FE - THIGH), 150.0),
        (f"{side}_ankle_pd", f"{side}_shank", f"{side}_ankle", (0, y, -HIP_AA_TO_FE - THIGH - SHANK), 100.0),
        (f"{side}_ankle_ie", f"{side}_ankle", f"{side}_foot",
         (0, y, -HIP_AA_TO_FE - THIGH - SHANK - ANKLE_PD_TO_IE), None),  # unactuated
    ]
JOINTS = leg("right", -1) + leg("left", +1)
LIMITS = {"hip_aa": (-0.5, 0.5), "hip_fe": (-0.6, 1.6), "knee": (-0.1, 2.0), "ankle_pd": (-0.6, 0.6), "ankle_ie": (-0.4, 0.4)}

def T(m): return [[m[j][i] for j in range(3)] for i in range(3)]
def mat(frame): return [[frame[c][r] for c in range(3)] for r in range(3)]   # columns -> matrix
def mul(a, b): return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
def mv(a, v): return [sum(a[i][k] * v[k] for k in range(3)) for i in range(3)]
def sub(a, b): return [a[i] - b[i] for i in range(3)]
def fmt(x):
    r = repr(float(x))
    return "0" if r in ("0.0", "-0.0") else r
def vec(v): return " ".join(fmt(x) for x in v)

def box_inertia(m, half):
    a, b, c = (2 * h for h in half)
    return (m * (b * b + c * c) / 12, m * (a * a + c * c) / 12, m * (a * a + b * b) / 12)

def rpy_of(R):
    """URDF rpy (fixed-axis roll about x, pitch about y, yaw about z: R = Rz(y) Ry(p) Rx(r))."""
    pitch = math.atan2(-R[2][0], math.hypot(R[0][0], R[1][0]))
    if abs(math.cos(pitch)) < 1e-12:   # gimbal lock: only yaw - roll is defined; choose roll = 0
        pitch = math.copysign(math.pi / 2, -R[2][0])
        return 0.0, pitch, math.atan2(-R[0][1], R[1][1])
    roll = math.atan2(R[2][1], R[2][2]); yaw = math.atan2(R[1][0], R[0][0])
    return roll, pitch, yaw

def quat_of(R):
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    tr = R[0][0] + R[1][1] + R[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2; w = 0.25 * s
        x = (R[2][1] - R[1][2]) / s; y = (R[0][2] - R[2][0]) / s; z = (R[1][0] - R[0][1]) / s
    elif R[0][0] > R[1][1] and R[0][0] > R[2][2]:
        s = math.sqrt(1.0 + R[0][0] - R[1][1] - R[2][2]) * 2
        w = (R[2][1] - R[1][2]) / s; x = 0.25 * s; y = (R[0][1] + R[1][0]) / s; z = (R[0][2] + R[2][0]) / s
    elif R[1][1] > R[2][2]:
        s = math.sqrt(1.0 + R[1][1] - R[0][0] - R[2][2]) * 2
        w = (R[0][2] - R[2][0]) / s; x = (R[0][1] + R[1][0]) / s; y = 0.25 * s; z = (R[1][2] + R[2][1]) / s
    else:
        s = math.sqrt(1.0 + R[2][2] - R[0][0] - R[1][1]) * 2
        w = (R[1][0] - R[0][1]) / s; x = (R[0][2] + R[2][0]) / s; y = (R[1][2] + R[2][1]) / s; z = 0.25 * s
    if w < 0: w, x, y, z = -w, -x, -y, -z
    return w, x, y, z

def principal_axes(I):
    """Eigen-decomposition of a symmetric 3x3 by cyclic Jacobi rotations to machine precision.
    Returns (moments, R) with I = R diag(moments) R^T, det R = +1. MuJoCo's own fullinertia
    decomposition stops near 1e-8, so the MJCF gets exact principal axes instead."""
    A = [row[:] for row in I]
    V = [[1.0 if i == j else 0.0 for j in range(3)] for i in range(3)]
    for _ in range(100):
        off = sum(A[i][j] ** 2 for i in range(3) for j in range(3) if i != j)
        if off < 1e-40:
            break
        for p_ in range(3):
            for q in range(p_ + 1, 3):
                if abs(A[p_][q]) < 1e-300:
                    continue
                theta = (A[q][q] - A[p_][p_]) / (2.0 * A[p_][q])
                t = math.copysign(1.0, theta) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0); s_ = t * c
                for k in range(3):  # A <- J^T A J
                    akp, akq = A[k][p_], A[k][q]
                    A[k][p_], A[k][q] = c * akp - s_ * akq, s_ * akp + c * akq
                for k in range(3):
                    apk, aqk = A[p_][k], A[q][k]
                    A[p_][k], A[q][k] = c * apk - s_ * aqk, s_ * apk + c * aqk
                for k in range(3):
                    vkp, vkq = V[k][p_], V[k][q]
                    V[k][p_], V[k][q] = c * vkp - s_ * vkq, s_ * vkp + c * vkq
    moments = [A[i][i] for i in range(3)]
    det = (V[0][0] * (V[1][1] * V[2][2] - V[1][2] * V[2][1]) - V[0][1] * (V[1][0] * V[2][2] - V[1][2] * V[2][0])
           + V[0][2] * (V[1][0] * V[2][1] - V[1][1] * V[2][0]))
    if det < 0:
        for k in range(3):
            V[k][2] = -V[k][2]
    return moments, V

def read_params():
    rows = {}
    with open(CSV) as f:
        for r in csv.DictReader(l for l in f if not l.startswith("#")):
            rows[r["name"]] = {k: float(v) for k, v in r.items() if k not in ("link", "name")}
    return rows

def com_inertia(p):
    """Standard parameters about the link origin -> (mass, CoM, inertia tensor about the CoM), link frame."""
    m = p["m"]; c = [p["mcx"] / m, p["mcy"] / m, p["mcz"] / m]
    Io = [[p["Ixx"], p["Ixy"], p["Ixz"]], [p["Ixy"], p["Iyy"], p["Iyz"]], [p["Ixz"], p["Iyz"], p["Izz"]]]
    cc = sum(x * x for x in c)
    Ic = [[Io[i][j] - m * ((cc if i == j else 0.0) - c[i] * c[j]) for j in range(3)] for i in range(3)]
    return m, c, Ic

def placements():
    """Joint placement in the parent frame: (position, rotation parent<-child) for every joint."""
    out = {}
    world_pos = {"body": (0, 0, 0)}
    for name, parent, child, pos, _ in JOINTS:
        Rp, Rc = mat(FRAMES[parent]), mat(FRAMES[child])
        out[name] = (mv(T(Rp), sub(pos, world_pos[parent])), mul(T(Rp), Rc))
        world_pos[child] = pos
    return out, world_pos

def sole_in_foot(side):
    """Sole box centre and half sizes in the foot frame (x down, z along +-world x)."""
    zsign = 1.0 if side == "right" else -1.0
    centre = (SOLE_DEPTH - SOLE_THICKNESS / 2, 0.0, zsign * (FOOT_HEEL + FOOT_TOE) / 2)
    half = (SOLE_THICKNESS / 2, FOOT_HALF_WIDTH, (FOOT_TOE - FOOT_HEEL) / 2)
    return centre, half

def urdf(params, place):
    L = ['<?xml version="1.0"?>', "<!-- Generated by tools/model/gen_exo_model.py; do not edit by hand. -->",
         '<robot name="exoid_exo">']
    def link(name, p):
        m, c, I = com_inertia(p)
        L.append(f'  <link name="{name}">')
        L.append("    <inertial>")
        L.append(f'      <origin xyz="{vec(c)}" rpy="0 0 0"/>')
        L.append(f'      <mass value="{fmt(m)}"/>')
        L.append(f'      <inertia ixx="{fmt(I[0][0])}" ixy="{fmt(I[0][1])}" ixz="{fmt(I[0][2])}" '
                 f'iyy="{fmt(I[1][1])}" iyz="{fmt(I[1][2])}" izz="{fmt(I[2][2])}"/>')
        L.append("    </inertial>")
        L.append("  </link>")
    link("body", params["body"])
    for name, parent, child, _, lim in JOINTS:
        link(child, params[child])
        pos, R = place[name]
        lo, hi = LIMITS[name.split("_", 1)[1]]
        L.append(f'  <joint name="{name}" type="revolute">')
        L.append(f'    <parent link="{parent}"/>')
        L.append(f'    <child link="{child}"/>')
        L.append(f'    <origin xyz="{vec(pos)}" rpy="{vec(rpy_of(R))}"/>')
        L.append('    <axis xyz="0 0 1"/>')
        L.append(f'    <limit lower="{fmt(lo)}" upper="{fmt(hi)}" effort="{fmt(lim if lim else 0.0)}" velocity="6"/>')
        L.append("  </joint>")
    # Massless frames on fixed joints (lumped into their parent by the loader): IMU and soles.
    L.append('  <link name="imu"/>')
    L.append('  <joint name="imu_mount" type="fixed"><parent link="body"/><child link="imu"/>'
             '<origin xyz="0 0 0" rpy="0 0 0"/></joint>')
    for side in ("right", "left"):
        centre, _ = sole_in_foot(side)
        sole = (SOLE_DEPTH, 0.0, centre[2])
        L.append(f'  <link name="{side}_sole"/>')
        # Sole frame: origin at the sole centre on the ground plane, axes aligned with the world in standing.
        R = T(mat(FRAMES[f"{side}_foot"]))
        L.append(f'  <joint name="{side}_sole_mount" type="fixed"><parent link="{side}_foot"/>'
                 f'<child link="{side}_sole"/><origin xyz="{vec(sole)}" rpy="{vec(rpy_of(R))}"/></joint>')
    L.append("</robot>")
    return "\n".join(L) + "\n"

def mjcf(params, place, world_pos):
    children = {}
    for name, parent, child, _, _ in JOINTS:
        children.setdefault(parent, []).append((name, child))
    L = ['<!-- Generated by tools/model/gen_exo_model.py; do not edit by hand. -->',
         '<mujoco model="exoid_exo">',
         '  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>',
         # Newton solver to a tight tolerance: the constraint forces then satisfy the equations of motion to
         # ~1e-12, which the sim tests (and the estimator's EoM checks) rely on.
         '  <option timestep="0.001" gravity="0 0 -9.81" integrator="Euler" cone="elliptic" impratio="10" '
         'solver="Newton" iterations="100" tolerance="1e-12"/>',
         '  <default>',
         '    <joint armature="0" damping="0" frictionloss="0" limited="false"/>',
         '    <geom contype="0" conaffinity="0" density="0" rgba="0.6 0.6 0.7 1"/>',
         # Sole/plate contact: stiff (timeconst 5 ms >= 2 timesteps, critically damped) so the robot sinks
         # < 1 mm; friction 1 with elliptic cones and impratio 10 keeps the feet from creeping.
         f'    <default class="contact"><geom contype="1" conaffinity="1" condim="3" friction="{CONTACT_FRICTION}" '
         f'solref="{CONTACT_SOLREF}" solimp="{CONTACT_SOLIMP}"/></default>',
         '  </default>',
         '  <worldbody>',
         '    <light pos="0 0 3" dir="0 0 -1"/>',
         '    <geom name="floor" type="plane" size="3 3 0.1" pos="0 0 -0.05" rgba="0.8 0.8 0.8 1"/>']
    for side, s in (("right", -1), ("left", 1)):
        y = s * HIP_HALF_WIDTH
        # Static plate (welded to the world): its <force>/<torque> sensors read the world-plate interaction,
        # i.e. the plate's own load cell. The plate has mass so that the sim's taring is exercised.
        hx, hy, hz = PLATE_HALF
        L.append(f'    <body name="{side}_plate" pos="{vec(((FOOT_HEEL + FOOT_TOE) / 2, y, -hz))}">')
        L.append(f'      <inertial pos="0 0 0" mass="{fmt(PLATE_MASS)}" diaginertia="'
                 f'{vec(box_inertia(PLATE_MASS, PLATE_HALF))}"/>')
        L.append(f'      <geom name="{side}_plate_top" class="contact" type="box" size="{vec(PLATE_HALF)}" '
                 f'rgba="0.3 0.3 0.3 1"/>')
        L.append(f'      <site name="{side}_plate_sensor" pos="0 0 {fmt(hz)}" size="0.01"/>')
        L.append("    </body>")
    def body(name, pos, R, indent, joint):
        sp = " " * indent
        q = quat_of(R)
        L.append(f'{sp}<body name="{name}" pos="{vec(pos)}" quat="{vec(q)}">')
        if joint is None:
            L.append(f'{sp}  <freejoint name="base"/>')
        else:
            L.append(f'{sp}  <joint name="{joint}" type="hinge" axis="0 0 1" pos="0 0 0"/>')
        m, c, I = com_inertia(params[name])
        moments, axes = principal_axes(I)
        L.append(f'{sp}  <inertial pos="{vec(c)}" mass="{fmt(m)}" quat="{vec(quat_of(axes))}" '
                 f'diaginertia="{vec(moments)}"/>')
        if name == "body":
            L.append(f'{sp}  <site name="imu" pos="0 0 0" size="0.01"/>')
            L.append(f'{sp}  <geom type="box" size="0.08 0.15 0.25" pos="-0.05 0 0.35" rgba="0.5 0.5 0.6 0.5"/>')
        if name.endswith("_foot"):
            side = name.split("_")[0]
            centre, half = sole_in_foot(side)
            L.append(f'{sp}  <geom name="{side}_sole" class="contact" type="box" size="{vec(half)}" '
                     f'pos="{vec(centre)}"/>')
            L.append(f'{sp}  <site name="{side}_sole" pos="{vec((SOLE_DEPTH, 0, centre[2]))}" size="0.01"/>')
        for jname, child in children.get(name, []):
            jpos, jR = place[jname]
            body(child, jpos, jR, indent + 2, jname)
        L.append(f"{sp}</body>")
    body("body", (0, 0, STAND_HEIGHT), mat(FRAMES["body"]), 4, None)
    L.append("  </worldbody>")
    L.append("  <actuator>")
    for name, _, _, _, lim in JOINTS:
        if lim is not None:
            L.append(f'    <motor name="{name}" joint="{name}" gear="1" ctrllimited="true" ctrlrange="{fmt(-lim)} {fmt(lim)}"/>')
    L.append("  </actuator>")
    # Sensors read by the sim (sim/src): joint torque sensors of the motors, IMU at the body origin, and the
    # 6-axis load cell of each plate. Encoders are read from qpos. Noise is added by the sim, not here.
    L.append("  <sensor>")
    for name, _, _, _, lim in JOINTS:
        if lim is not None:
            L.append(f'    <actuatorfrc name="{name}_tau" actuator="{name}"/>')
    L.append('    <framequat name="imu_quat" objtype="site" objname="imu"/>')
    L.append('    <gyro name="imu_gyro" site="imu"/>')
    L.append('    <accelerometer name="imu_accel" site="imu"/>')
    for side in ("right", "left"):
        L.append(f'    <force name="{side}_plate_force" site="{side}_plate_sensor"/>')
        L.append(f'    <torque name="{side}_plate_torque" site="{side}_plate_sensor"/>')
    L.append("  </sensor>")
    L.append("</mujoco>")
    return "\n".join(L) + "\n"

def main():
    params = read_params()
    place, world_pos = placements()
    with open(os.path.join(ROOT, "config", "exo.urdf"), "w") as f:
        f.write(urdf(params, place))
    with open(os.path.join(ROOT, "config", "exo.xml"), "w") as f:
        f.write(mjcf(params, place, world_pos))
    print(f"wrote config/exo.urdf and config/exo.xml (standing height {STAND_HEIGHT:.3f} m)")

if __name__ == "__main__":
    main()
